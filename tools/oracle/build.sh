#!/usr/bin/env bash
# Compiles tools/oracle/pcl_oracle.cpp to tools/oracle/build/pcl_oracle against the
# system PCL 1.13 (pkg-config). Rebuilds only when the source (or this script) is newer
# than the binary. Prints the binary's path on stdout; compiler chatter goes to stderr.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
src="$here/pcl_oracle.cpp"
out_dir="$here/build"
bin="$out_dir/pcl_oracle"

if [ -x "$bin" ] && [ "$bin" -nt "$src" ] && [ "$bin" -nt "${BASH_SOURCE[0]}" ]; then
    echo "$bin"
    exit 0
fi

mkdir -p "$out_dir"
modules="pcl_common pcl_io pcl_filters pcl_features pcl_search pcl_kdtree pcl_segmentation"
# shellcheck disable=SC2086 # word splitting of the pkg-config flags is intended
flags="$(pkg-config --cflags --libs $modules)"
echo "build.sh: g++ -O2 $src -> $bin" >&2
tmp="$bin.tmp.$$"
# shellcheck disable=SC2086
g++ -std=c++17 -O2 -w -o "$tmp" "$src" $flags -lboost_system
mv -f "$tmp" "$bin"
echo "$bin"
