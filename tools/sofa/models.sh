#!/usr/bin/env bash
# The two SOFA tutorial robots ($SOFTSENSE_DATA/sofa-robots: the cable finger and the
# PneuNet) made into softsense models by `softsense model new`, each from its STL surface
# and, separately, from its own VTK volume mesh (issue 54 item 5; docs/accuracy.md,
# "Robots designed by others (SOFA)").
#
#   tools/sofa/models.sh OUT
#
# Writes OUT/finger_stl, OUT/finger_vtk, OUT/pneunet_stl, OUT/pneunet_vtk (model folders),
# then runs `softsense fem solve` and `softsense model check` on each, and copies the sweep
# files tools/sweeps/{finger,pneunet}_one_probe.toml into OUT, where their
# `model = "ROBOT_stl/model.toml"` finds the STL-made model:
#
#   tools/sweeps/run.sh OUT/finger_one_probe.toml OUT/finger_sweep COUNT SEED
#
# OUT holds data derived from SOFTSENSE_DATA: never commit it. Uses the release binary
# (built if needed); SOFTSENSE_BIN: a binary to use instead.
#
# The tutorials' values are read as written, in mm-kg-s (lengths in mm, moduli in kPa,
# mass in kg, gravity in mm/s^2): finger E = 18000 kPa (18 MPa; 18 kPa would fold the
# finger under its own weight), nu = 0.3, total mass 0.5 kg, gravity 981 mm/s^2 along -y
# (a tenth of Earth's, as the scene writes it); PneuNet E = 500 kPa with a 1500 kPa layer,
# nu = 0.3, total mass 0.04 kg, gravity 9810 mm/s^2 along -x.
set -euo pipefail
if [ $# -ne 1 ]; then
    sed -n 2,25p "$0" >&2
    exit 2
fi
out="$1"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
data="${SOFTSENSE_DATA:?set SOFTSENSE_DATA to the real-data folder (docs/testing.md)}/sofa-robots"
[ -d "$data" ] || { echo "models.sh: $data is missing" >&2; exit 1; }
if [ -z "${SOFTSENSE_BIN:-}" ]; then
    cargo build --release --quiet --manifest-path "$root/Cargo.toml"
fi
bin="${SOFTSENSE_BIN:-${CARGO_TARGET_DIR:-$root/target}/release/softsense}"
mkdir -p "$out"

# The finger: cable.json is the cable's path; the tutorial's CableConstraint pulls it from
# [0, 0, 0] (inside the fixed base), so every point of the file is an attach point.
printf '{"name": "cable", "pull": [0.0, 0.0, 0.0], "attach": %s}\n' \
    "$(cat "$data/finger/cable.json")" > "$out/finger_cable.json"
for src in stl vtk; do
    dir="$out/finger_$src"
    rm -rf "$dir"
    "$bin" model new "$data/finger/finger.$src" --out "$dir" \
        --young 18000 --poisson 0.3 --units mm-kg-s --gravity 0,-981,0 \
        --fixed-box=-5,0,0,10,15,20 --cable "$out/finger_cable.json" \
        --effector tip=-103.37,2.5,7.5 --mass 0.5
done

# The PneuNet: its outer surface already holds the cavity (a second shell); the cavity's
# own surface names the faces the pressure acts on.
for src in stl vtk; do
    dir="$out/pneunet_$src"
    surface="$data/pneunet/pneunetCut.stl"
    [ "$src" = vtk ] && surface="$data/pneunet/pneunetCutCoarse.vtk"
    rm -rf "$dir"
    "$bin" model new "$surface" --out "$dir" \
        --young 500 --poisson 0.3 --units mm-kg-s --gravity=-9810,0,0 \
        --fixed-box=-10,0,-20,0,30,20 --cavity "$data/pneunet/pneunetCavityCut.stl" \
        --effector tip=-115,25,0 --mass 0.04 --region=-100,22.5,-8,-19,28,8=1500
done

for m in finger_stl finger_vtk pneunet_stl pneunet_vtk; do
    echo "== $m"
    "$bin" fem solve "$out/$m/model.toml"
    "$bin" model check "$out/$m/model.toml"
done
for robot in finger pneunet; do
    cp "$root/tools/sweeps/${robot}_one_probe.toml" "$out/"
done
for extra in finger_two_cameras; do
    cp "$root/tools/sweeps/$extra.toml" "$out/"
done
