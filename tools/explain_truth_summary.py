#!/usr/bin/env python3
"""Tables the JSON lines of examples/explain_truth.rs (explain when the truth is not the
model; protocol in docs/discrepancy.md): one Markdown row per dataset, then the counts
per verdict. A "WRONG NAME" is an explained verdict naming an effect neither hidden nor
able to represent the truth.

Usage: tools/explain_truth_summary.py RESULTS.jsonl [...]
"""
import collections
import json
import sys


def short(name):
    """An effect's name as the table shows it."""
    return (name.replace("global compliance (1/Young) scale", "young")
            .replace("gravity (density scale)", "gravity")
            .replace(" compliance scale", " leg"))


def main(paths):
    rows = sorted((json.loads(l) for p in paths for l in open(p) if l.strip()),
                  key=lambda d: d["dataset"])
    print("| ds | seed | truth | hidden | verdict | claimed (fitted) | young: fitted / wanted |"
          " held-out RMS before → after (mm) | noise (mm) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for d in rows:
        claimed = ", ".join(short(c["name"]) for c in d["claimed"]) or "-"
        if d["status"] == "unexplained residual" and d["kept"]:
            claimed = "(kept, not claimed: " + ", ".join(short(k) for k in d["kept"]) + ")"
        y = "-"
        if d["young_fit"] or d["young_want"]:
            fit = "-" if not d["young_fit"] else f"{d['young_fit'][0]:+.4f}"
            want = "-" if d["young_want"] is None else f"{d['young_want']:+.4f}"
            y = f"{fit} / {want}"
        print(f"| {d['dataset']} | {d['seed']} | {d['truth']} | {', '.join(d['hidden']) or 'none'} | "
              f"{d['verdict']} | {claimed} | {y} | {d['rms_before_mm']:.3f} → "
              f"{d['rms_after_mm']:.3f} | {d['noise_mm']:.3f} |")
    print()
    by = collections.defaultdict(collections.Counter)
    for d in rows:
        by[d["truth"]][d["verdict"]] += 1
    for t, c in by.items():
        print(f"- {t}: " + ", ".join(f"{v} {n}" for v, n in sorted(c.items())))
    wrong = sum(c["WRONG NAME"] for c in by.values())
    print(f"- confident wrong names: {wrong}/{len(rows)}")


if __name__ == "__main__":
    main(sys.argv[1:])
