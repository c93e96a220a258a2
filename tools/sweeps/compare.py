#!/usr/bin/env python3
"""One table row per way of sensing the same drawn sweep: accuracy, sigma and time.

    tools/sweeps/compare.py OUT_DIR NAME...

OUT_DIR is a sweep drawn and sensed by `tools/sweeps/run.sh` (NAME `default` is its plain
run, any other NAME a run re-sensed as `run.sh ... NAME -- ARGS`). Per NAME: loads within
5% (3-D force, located within 5 mm), located, silent misses, magnitude within 2 sigma,
inside the 95% ellipsoid (from score_NAME.json), and over the sensed forces the median
force error, the median sigma and the median ms per frame without the free FE solve (the
one-time cost a stream pays at its first frame) from each scene's sense_NAME.json.
"""
import glob
import json
import os
import statistics
import sys


def rows(out, name):
    suffix = "" if name == "default" else f"_{name}"
    with open(os.path.join(out, f"score{suffix}.json")) as f:
        score = json.load(f)["all"]
    errors, sigmas, ms = [], [], []
    for path in sorted(glob.glob(os.path.join(out, "scene_*", f"sense{suffix}.json"))):
        with open(path) as f:
            for line in f:
                frame = json.loads(line)
                if frame.get("status") != "sensed":
                    continue
                t = frame["timings"]
                ms.append(t["total"] - t.get("free_solve", 0.0))
                sigmas += [force["sigma"] for force in frame["forces"]]
                errors += [e["force_error"] for e in frame.get("errors") or []]
    med = lambda v: statistics.median(v) if v else float("nan")
    return (f"| {name} | {score['within']}/{score['loads']} | {score['located']} "
            f"| {score['silent']} | {100 * score['sigma_coverage'][1]:.1f}% "
            f"| {100 * score['within_ellipsoid95']:.1f}% | {100 * med(errors):.2f}% "
            f"| {1000 * med(sigmas):.1f} | {med(ms):.0f} |")


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    print("| run | within 5% | located | silent | within 2σ | 95% ellipsoid "
          "| median force error | median σ (mN) | median ms |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name in sys.argv[2:]:
        print(rows(sys.argv[1], name))


if __name__ == "__main__":
    main()
