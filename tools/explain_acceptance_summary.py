#!/usr/bin/env python3
"""Scores the JSON lines of examples/explain_acceptance.rs against issue 7's acceptance.

Usage: tools/explain_acceptance_summary.py RESULTS.jsonl [...]
"""
import json
import sys

LIB = {"gravity", "young", "leg_stiffness", "point_load", "actuator_offset",
       "camera_pose", "depth", "poisson"}


def main(paths):
    rows = {}
    for p in paths:
        for line in open(p):
            line = line.strip()
            if line.startswith("{"):
                d = json.loads(line)
                rows[d["dataset"]] = d
    rows = [rows[k] for k in sorted(rows)]
    single = [d for d in rows if len(d["effects"]) == 1 and d["effects"][0] in LIB]
    big = [d for d in single if d.get("size_over_noise", 0) > 3]
    right = [d for d in big if d["status"] == "explained" and all(d["named"])]
    named = [d for d in single if d["status"] == "explained" and all(d["named"])]
    params = [d for d in named if all(e is not None and e < 0.1 for e in d["param_rel_err"])]
    reduced = [d for d in big if d["reduced"]]
    null = [d for d in rows if not d["effects"]]
    none = [d for d in null if d["status"] == "none"]
    ool = [d for d in rows if len(d["effects"]) == 1 and d["effects"][0] not in LIB]
    unexpl = [d for d in ool if d["status"] == "unexplained"]
    pairs = [d for d in rows if len(d["effects"]) == 2]
    both = [d for d in pairs if d["status"] == "explained" and all(d["named"])]
    secs = [d["seconds"] for d in rows if "seconds" in d]
    print(f"datasets: {len(rows)} (single library {len(single)}, of which > 3x noise {len(big)}; "
          f"null {len(null)}; out-of-library {len(ool)}; pairs {len(pairs)})")
    print(f"effect types covered: {sorted({d['effects'][0] for d in single})}")
    print(f"right effect named (> 3x noise): {len(right)}/{len(big)}")
    print(f"parameters within 10% (named right): {len(params)}/{len(named)}")
    print(f"held-out RMS down >= 80% or <= 1.2x noise (> 3x noise): {len(reduced)}/{len(big)}")
    print(f"null: no missing effect: {len(none)}/{len(null)}")
    print(f"out-of-library: unexplained residual: {len(unexpl)}/{len(ool)}")
    print(f"two effects both named: {len(both)}/{len(pairs)}")
    if secs:
        print(f"explain seconds per dataset: mean {sum(secs)/len(secs):.1f}, max {max(secs):.1f}")
    bad = [d for d in big if d not in right] + [d for d in null if d not in none] \
        + [d for d in ool if d not in unexpl] + [d for d in pairs if d not in both] \
        + [d for d in named if d not in params]
    for d in bad:
        print(f"  miss ds{d['dataset']:03} {d['effects']} m={d['magnitude']} status={d['status']} "
              f"named={d['named']} err={d['param_rel_err']} size={d.get('size_over_noise', 0):.1f} "
              f"claimed={[c['kind'] for c in d['claimed']]}")


if __name__ == "__main__":
    main(sys.argv[1:])
