#!/usr/bin/env python3
"""Scores the JSON lines of examples/explain_acceptance.rs against issue 7's acceptance.

Usage: tools/explain_acceptance_summary.py [--table] RESULTS.jsonl [...]
(--table adds a Markdown table with one row per dataset).
"""
import json
import sys

LIB = {"gravity", "young", "leg_stiffness", "point_load", "actuator_offset",
       "camera_pose", "depth", "poisson"}


def table(rows):
    print("\n| ds | hidden | magnitude | size/noise | status | claimed | named | param err | "
          "held-out RMS before → after (mm) | noise (mm) | CPU s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for d in rows:
        errs = ", ".join("-" if e is None else f"{e:.3f}" for e in d["param_rel_err"])
        claimed = ", ".join(c["kind"] for c in d["claimed"]) or "-"
        print(f"| {d['dataset']} | {', '.join(d['effects']) or 'none'} | {d['magnitude']} | "
              f"{d.get('size_over_noise', 0):.1f} | {d['status']} | {claimed} | "
              f"{'/'.join('y' if n else 'n' for n in d['named']) or '-'} | {errs or '-'} | "
              f"{d['rms_before_mm']:.3f} → {d['rms_after_mm']:.3f} | {d['noise_mm']:.3f} | "
              f"{d.get('cpu_seconds', float('nan')):.1f} |")


def main(paths):
    want_table = "--table" in paths
    paths = [p for p in paths if p != "--table"]
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
    def close(d):
        return all(e is not None and e < 0.1 for e in d["param_rel_err"])
    params = [d for d in right if close(d)]
    params_all = [d for d in named if close(d)]
    reduced = [d for d in big if d["reduced"]]
    null = [d for d in rows if not d["effects"]]
    none = [d for d in null if d["status"] == "none"]
    ool = [d for d in rows if len(d["effects"]) == 1 and d["effects"][0] not in LIB]
    unexpl = [d for d in ool if d["status"] == "unexplained"]
    pairs = [d for d in rows if len(d["effects"]) == 2]
    both = [d for d in pairs if d["status"] == "explained" and all(d["named"])]
    secs = [d["seconds"] for d in rows if "seconds" in d]
    cpu = [d["cpu_seconds"] for d in rows if "cpu_seconds" in d]
    print(f"datasets: {len(rows)} (single library {len(single)}, of which > 3x noise {len(big)}; "
          f"null {len(null)}; out-of-library {len(ool)}; pairs {len(pairs)})")
    print(f"effect types covered: {sorted({d['effects'][0] for d in single})}")
    print(f"right effect named (> 3x noise): {len(right)}/{len(big)}")
    print(f"parameters within 10% (named right, > 3x noise): {len(params)}/{len(right)}; "
          f"all sizes: {len(params_all)}/{len(named)}")
    print(f"held-out RMS down >= 80% or <= 1.2x noise (> 3x noise): {len(reduced)}/{len(big)}")
    print(f"null: no missing effect: {len(none)}/{len(null)}")
    print(f"out-of-library: unexplained residual: {len(unexpl)}/{len(ool)}")
    print(f"two effects both named: {len(both)}/{len(pairs)}")
    if secs:
        print(f"explain wall seconds per dataset: mean {sum(secs)/len(secs):.1f}, max {max(secs):.1f}")
    if cpu:
        print(f"explain CPU seconds per dataset: mean {sum(cpu)/len(cpu):.1f}, max {max(cpu):.1f}")
    bad = [d for d in big if d not in right] + [d for d in null if d not in none] \
        + [d for d in ool if d not in unexpl] + [d for d in pairs if d not in both] \
        + [d for d in named if d not in params_all]
    for d in bad:
        print(f"  miss ds{d['dataset']:03} {d['effects']} m={d['magnitude']} status={d['status']} "
              f"named={d['named']} err={d['param_rel_err']} "
              f"1sigma={d.get('param_rel_sigma', '-')} size={d.get('size_over_noise', 0):.1f} "
              f"claimed={[c['kind'] for c in d['claimed']]}")
    if want_table:
        table(rows)


if __name__ == "__main__":
    main(sys.argv[1:])
