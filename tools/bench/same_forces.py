#!/usr/bin/env python3
"""Are two builds' forces the same within a fraction of sigma on every bundled frame?

    tools/bench/same_forces.py OLD_SOFTSENSE NEW_SOFTSENSE [--tol SIGMAS] [DIR]...

Runs `softsense sense DIR --json` with both binaries on every bundled recording and on
each extra DIR (e.g. the two-camera scene, `softsense scene generate
clouds/scenes/two_cameras.toml DIR`) and compares,
frame by frame, each force's vector: the difference's length over the old force's sigma
(its 1-sigma magnitude uncertainty). Fails (exit 1) when a frame's status or number of
forces differs, or when a difference exceeds SIGMAS (default 0.1), the line
issue 56 gives for a speed change. Run from the repository's root.
"""
import json
import math
import subprocess
import sys
from pathlib import Path

SCENES = ["tip_weight", "probe_side", "two_probes", "probe_press"]


def frames(binary, scene):
    out = subprocess.run([binary, "sense", str(scene), "--json"], capture_output=True,
                         text=True, check=True).stdout
    return [json.loads(line) for line in out.splitlines() if line.startswith("{")]


def main():
    args = sys.argv[1:]
    tol = 0.1
    if "--tol" in args:
        i = args.index("--tol")
        tol = float(args[i + 1])
        del args[i:i + 2]
    if len(args) < 2:
        sys.exit(__doc__)
    old_bin, new_bin = args[0], args[1]
    scenes = [Path("clouds/scenes") / s for s in SCENES] + [Path(d) for d in args[2:]]
    worst, bad = 0.0, []
    for scene in scenes:
        old, new = frames(old_bin, scene), frames(new_bin, scene)
        if len(old) != len(new):
            bad.append(f"{scene}: {len(old)} frames against {len(new)}")
            continue
        for a, b in zip(old, new):
            fa, fb = a.get("forces", []), b.get("forces", [])
            if a["status"] != b["status"] or len(fa) != len(fb):
                bad.append(f"{scene} frame {a['frame']}: {a['status']}/{len(fa)} forces "
                           f"against {b['status']}/{len(fb)}")
                continue
            for k, (x, y) in enumerate(zip(fa, fb)):
                d = math.dist(x["force"], y["force"]) / max(x["sigma"], 1e-12)
                worst = max(worst, d)
                if d > tol:
                    bad.append(f"{scene} frame {a['frame']} force {k}: off by {d:.3f} sigma")
        print(f"{scene}: {len(old)} frames compared")
    print(f"largest difference: {worst:.4f} sigma (tolerance {tol})")
    for line in bad:
        print("DIFFERS:", line)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
