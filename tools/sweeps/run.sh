#!/usr/bin/env bash
# Draws a sweep, senses every scene and scores it: the command behind each table of
# docs/accuracy.md.
#
#   tools/sweeps/run.sh SWEEP.toml OUT_DIR COUNT SEED
#
# Uses the release binary (built if needed). Writes OUT_DIR/scene_NNNN/sense.json,
# OUT_DIR/score.txt and OUT_DIR/score.json. The diamond's sweep needs SOFTSENSE_DATA.
set -euo pipefail
if [ $# -ne 4 ]; then
    sed -n 2,9p "$0" >&2
    exit 2
fi
sweep="$1" out="$2" count="$3" seed="$4"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cargo build --release --quiet --manifest-path "$root/Cargo.toml"
bin="${CARGO_TARGET_DIR:-$root/target}/release/softsense"
"$bin" scene sweep "$sweep" "$out" --count "$count" --seed "$seed"
n=0
for d in "$out"/scene_*/; do
    # A frame that cannot be sensed still prints its JSON line (and exits 1): score it.
    "$bin" sense "$d" --json > "$d/sense.json" 2> "$d/sense.log" || true
    n=$((n + 1))
    printf '\rsensed %d/%d' "$n" "$count" >&2
done
echo >&2
"$bin" score "$out" | tee "$out/score.txt"
"$bin" score "$out" --json > "$out/score.json"
