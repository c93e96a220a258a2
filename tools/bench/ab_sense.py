#!/usr/bin/env python3
"""The bench's sense row for two builds, in alternating rounds: did a change make it slower?

    tools/bench/ab_sense.py OLD_BENCH_STAGES NEW_BENCH_STAGES [ROUNDS] [DIR]...

A build may carry sense parameters as BINARY@JSON, e.g. the same binary twice as
`B@{}` and `B@{"dense_points":1000}`: the default against fewer dense rows.

Each argument is a release `examples/bench_stages` binary (e.g. one built from a clone at
the old commit with `cargo build --release --example bench_stages`). Each round runs every
bundled scene (and each extra DIR, e.g. a generated two-camera scene) 3 times per build,
the builds' order swapped every round so a slow minute of a busy machine falls on both;
prints per scene the median ms per frame one at a time and new/old, and the stream's
frames/s (`Sensor::sense_frames`, as many frames at a time as threads) of each build.
Run from the repository's root.
"""
import json
import statistics
import subprocess
import sys

SCENES = ["clouds/scenes/tip_weight", "clouds/scenes/probe_side",
          "clouds/scenes/two_probes", "clouds/scenes/probe_press"]


def split_params(arg):
    """BINARY or BINARY@JSON -> (binary, params JSON)."""
    binary, _, params = arg.partition("@")
    return binary, params or "{}"


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    builds = {b: split_params(a) for b, a in (("old", sys.argv[1]), ("new", sys.argv[2]))}
    rounds = int(sys.argv[3]) if len(sys.argv) >= 4 else 4
    scenes = SCENES + sys.argv[4:]
    times = {(b, s): [] for b in builds for s in scenes}
    stream = {(b, s): [] for b in builds for s in scenes}
    for rnd in range(rounds):
        order = ["old", "new"] if rnd % 2 == 0 else ["new", "old"]
        for scene in scenes:
            for b in order:
                p = subprocess.run([builds[b][0], "sense", scene, "3", builds[b][1]],
                                   capture_output=True, text=True, check=True)
                r = json.loads(p.stdout.strip().splitlines()[-1])
                if not r["ok"]:
                    sys.exit(f"{b} {scene}: {r['error']}")
                times[(b, scene)] += r["timings_ms"]
                stream[(b, scene)] += [v for k, v in r["stage_ms"] if k == "stream"]
    print(f"median ms per frame, {rounds} alternating rounds of 3 passes")
    for scene in scenes:
        old = statistics.median(times[("old", scene)])
        new = statistics.median(times[("new", scene)])
        fps = {b: 1000 / statistics.median(stream[(b, scene)]) for b in builds}
        print(f"{scene}: old {old:.0f}, new {new:.0f}, new/old {new / old:.2f}; "
              f"stream frames/s old {fps['old']:.1f}, new {fps['new']:.1f}")


if __name__ == "__main__":
    main()
