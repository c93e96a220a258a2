#!/usr/bin/env bash
# The Punyo protocol (issue 53, docs/real-data.md): TRI's soft bubble pressed by a robot
# arm, sensed by softsense from its inside camera and compared with the wrist's measured
# force. Reads $SOFTSENSE_DATA/punyo in place (default ../shared/data/punyo).
#
# Fixed before the result was looked at (the reference, tools/real/punyo_reference.py):
# - frames 0-4 are the rest reference, frames 5-60 the still frames (each node's noise
#   and the sigma's floor);
# - the stiffness is fitted only on frames 0, 5, ..., 55 and 60-70 against the measured
#   magnitude, and the loaded ones among them set the sigma's model error;
# - every frame is then sensed.
# The measured magnitude is |wrench force - bias|, the bias the mean force of frames 0-60
# (a vector), as the issue defines it.
#
# Writes OUT/forces.jsonl (`sense --json`, one line per frame), OUT/summary.json
# ({"stiffness", "frames": [{frame, net_force, magnitude, sigma, measured}]}),
# OUT/timeline.png, OUT/fit.json, and prints the acceptance numbers.
#
# Usage: tools/real/punyo.sh OUT
# Env:   SOFTSENSE_DATA (the data folder), SOFTSENSE_BIN (a softsense binary; default: built
#        here with cargo build --release).
set -euo pipefail

if [ $# -ne 1 ]; then
    sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
fi
out="$1"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
data="${SOFTSENSE_DATA:-$root/../shared/data}/punyo"
if [ ! -f "$data/frames.json" ]; then
    echo "punyo.sh: $data/frames.json not found (set SOFTSENSE_DATA)" >&2
    exit 1
fi
data="$(cd "$data" && pwd)"
if [ -z "${SOFTSENSE_BIN:-}" ]; then
    cargo build --release --quiet --manifest-path "$root/Cargo.toml"
fi
bin="${SOFTSENSE_BIN:-${CARGO_TARGET_DIR:-$root/target}/release/softsense}"
mkdir -p "$out"

# The recording's own files in softsense's formats: its camera (the ray table, read in
# place), the pose the data's README states, the pressures, and the measured magnitudes.
python3 - "$data" "$out" <<'EOF'
import json, math, sys
data, out = sys.argv[1], sys.argv[2]
frames = json.load(open(f"{data}/frames.json"))["frames"]
def dump(name, value):
    with open(f"{out}/{name}", "w") as f:
        json.dump(value, f, indent=1)
# The README's pinhole fit for pinhole consumers; the ray table is what the lens uses.
dump("camera.json", {"width": 640, "height": 480,
                     "intrinsic_matrix": [434.3, 0, 0, 0, 433.3, 0, 313.7, 247.5, 1],
                     "depth_scale": 10000, "rays": f"{data}/rays.npy"})
# mesh_from_camera: 25 degrees about the camera's y axis, camera at the mesh origin.
c, s = math.cos(math.radians(25)), math.sin(math.radians(25))
dump("pose.json", {"robot_from_camera": [[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1]]})
def pressure(f):
    p = f.get("pressure_hpa")
    return p * 100 if isinstance(p, (int, float)) and math.isfinite(p) else float("nan")
dump("inputs.json", [{"cavities": [{"name": "bubble", "pressure": pressure(f)}]} for f in frames])
force = [f["wrench"][:3] for f in frames]
bias = [sum(v[k] for v in force[:61]) / 61 for k in range(3)]
measured = [math.dist(v, bias) for v in force]
dump("measured.json", [{"frame": i, "magnitude": m} for i, m in enumerate(measured)])
fit = list(range(0, 60, 5)) + list(range(60, 71))
dump("fit_loads.json", [{"frame": i, "magnitude": measured[i]} for i in fit if i < len(measured)])
EOF

start=$(date +%s.%N)
"$bin" sense "$data" --membrane --model "$root/meshes/models/punyo.toml" \
    --camera "$out/camera.json" --pose "$out/pose.json" --inputs "$out/inputs.json" \
    --reference-frames 5 --still-frames 5-60 \
    --fit-stiffness "$out/fit_loads.json" --fit-out "$out/fit.json" \
    --measured "$out/measured.json" --timeline "$out/timeline.png" \
    --json > "$out/forces.jsonl" 2> "$out/sense.log" || {
    cat "$out/sense.log" >&2
    exit 1
}
end=$(date +%s.%N)
cat "$out/sense.log" >&2

python3 - "$out" "$start" "$end" <<'EOF'
import json, math, sys
out, start, end = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
fit = json.load(open(f"{out}/fit.json"))
rows = [json.loads(l) for l in open(f"{out}/forces.jsonl")]
frames = []
for r in rows:
    row = {"frame": r["frame"], "status": r["status"], "measured": r.get("measured")}
    if r["status"] == "ok":
        row.update(net_force=r["net_force"], magnitude=r["magnitude"], sigma=r["sigma"])
    frames.append(row)
stiffness = {k: fit[k] for k in ("scale", "tension_n_per_m", "young_pa", "thickness_m",
                                 "sigma_floor_n", "model_error")}
stiffness["et_n_per_m"] = fit["young_pa"] * fit["thickness_m"]
seconds = end - start
json.dump({"stiffness": stiffness, "seconds": seconds, "frames": frames},
          open(f"{out}/summary.json", "w"), indent=1)
by = {r["frame"]: r for r in frames if r["status"] == "ok"}
plateau = [by[f] for f in range(76, 101) if f in by]
rest = [by[f]["magnitude"] for f in list(range(61)) + list(range(115, 150)) if f in by]
cover = [abs(by[f]["magnitude"] - by[f]["measured"]) <= 2 * by[f]["sigma"]
         for f in range(64, 111) if f in by]
bad = {}
for r in frames:
    if r["status"] != "ok":
        bad.setdefault(r["status"], []).append(r["frame"])
print(f"stiffness: tension {fit['tension_n_per_m']:.1f} N/m, E t {stiffness['et_n_per_m']:.2f} N/m "
      f"(x{fit['scale']:.3f} of the model's); sigma {fit['sigma_floor_n']:.3f} N (+) "
      f"{fit['model_error']:.3f} |F|")
for status, which in bad.items():
    print(f"{status}: frames {which}")
if plateau:
    mean_est = sum(r["magnitude"] for r in plateau) / len(plateau)
    mean_meas = sum(r["measured"] for r in plateau) / len(plateau)
    worst = max(abs(r["magnitude"] / r["measured"] - 1) for r in plateau)
    print(f"plateau 76-100: mean |F| {mean_est:.2f} N vs measured {mean_meas:.2f} N "
          f"({mean_est / mean_meas - 1:+.1%}), worst frame {worst:.1%} "
          f"({len(plateau)} of 25 frames sensed)")
if rest:
    print(f"rest 0-60, 115-149: max |F| {max(rest):.2f} N, "
          f"{sum(r > 0.5 for r in rest)} of {len(rest)} above 0.5 N")
if cover:
    print(f"2 sigma coverage 64-110: {sum(cover)} of {len(cover)} "
          f"({sum(cover) / len(cover):.1%})")
print(f"{len(frames)} frames in {seconds:.1f} s ({len(frames) / seconds:.1f} frames/s, "
      f"the whole run)")
EOF
