#!/usr/bin/env bash
# Draws a sweep, senses every scene and scores it: the command behind each table of
# docs/accuracy.md.
#
#   tools/sweeps/run.sh SWEEP.toml OUT_DIR COUNT SEED [NAME -- SENSE_ARGS...]
#
# Uses the release binary (built if needed). Writes OUT_DIR/scene_NNNN/sense.json,
# OUT_DIR/score.txt and OUT_DIR/score.json. The diamond's sweep needs SOFTSENSE_DATA.
# With NAME and sense arguments (e.g. `front -- --cameras cam0`), the scenes already drawn
# in OUT_DIR are sensed again with those arguments into sense_NAME.json and scored into
# score_NAME.txt/.json: one camera against two on the same scenes. SOFTSENSE_BIN: a binary
# to use instead of building this checkout's.
set -euo pipefail
if [ $# -lt 4 ] || { [ $# -gt 4 ] && [ "${6:-}" != "" ] && [ "$6" != "--" ]; }; then
    sed -n 2,12p "$0" >&2
    exit 2
fi
sweep="$1" out="$2" count="$3" seed="$4"
name="${5:-}"
shift 4
[ $# -gt 0 ] && shift
[ $# -gt 0 ] && shift
suffix="${name:+_$name}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
if [ -z "${SOFTSENSE_BIN:-}" ]; then
    cargo build --release --quiet --manifest-path "$root/Cargo.toml"
fi
bin="${SOFTSENSE_BIN:-${CARGO_TARGET_DIR:-$root/target}/release/softsense}"
if [ -z "$name" ]; then
    "$bin" scene sweep "$sweep" "$out" --count "$count" --seed "$seed"
fi
n=0
for d in "$out"/scene_*/; do
    # A frame that cannot be sensed still prints its JSON line (and exits 1): score it.
    "$bin" sense "$d" --json "$@" > "$d/sense$suffix.json" 2> "$d/sense$suffix.log" || true
    n=$((n + 1))
    printf '\rsensed %d/%d' "$n" "$count" >&2
done
echo >&2
"$bin" score "$out" --sense-file "sense$suffix.json" | tee "$out/score$suffix.txt"
"$bin" score "$out" --sense-file "sense$suffix.json" --json > "$out/score$suffix.json"
