#!/usr/bin/env bash
# Times each stage of tools/bench/stages.json for softsense, PCL and Open3D on the real
# 640x480 clouds in one run and prints a Markdown table of medians and speed-ups.
#
# Usage: tools/bench/run.sh [--repeat N] [--only NAME]... [--json out.json]
# Env:   SOFTSENSE_DATA (default ../shared/data), CARGO_TARGET_DIR, PYTHON (default python3)
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$root"
data="$(realpath "${SOFTSENSE_DATA:-$root/../shared/data}")"
target="${CARGO_TARGET_DIR:-$root/target}"

echo "run.sh: building bench_stages (release) and the PCL oracle" >&2
cargo build --release --quiet --example bench_stages --bin softsense
pcl_bin="$(tools/oracle/build.sh)"

exec "${PYTHON:-python3}" tools/bench/bench.py --data "$data" \
    --softsense "$target/release/examples/bench_stages" --pcl "$pcl_bin" \
    --cli "$target/release/softsense" --generated "$target/bench-scenes" \
    --python "${PYTHON:-python3}" "$@"
