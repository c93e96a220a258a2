#!/usr/bin/env bash
# Shows that a change leaves every answer as it was: runs `softsense sense --json` (plain
# and --track) on every bundled recording, `calibrate --json` on the calibration scene,
# `fem solve --json` / `fem compliance --json` on every bundled model, `markers` and
# `markers layout` on the bundled tracks, `control --json` on every bundled scenario,
# `scene generate` on two bundled scene files (every written file's bytes) and `hidden` +
# `explain --json` on a small hidden-effect dataset, at BASE_REV and at the working tree,
# and compares the outputs with the timings taken out. Forces, sigmas, statuses and
# warnings must agree to the bit (the JSON's shortest round-trip decimals).
#
# Usage: tools/check_same_answers.sh BASE_REV        compare the working tree with BASE_REV
#        tools/check_same_answers.sh --save DIR      write the working tree's answers to DIR
#        tools/check_same_answers.sh --against DIR   compare the working tree with DIR
# Env:   SAME_ANSWERS_PROFILE (release, default; or dev: answers do not depend on it),
#        SAME_ANSWERS_TARGET (target folder for BASE_REV's build, default
#        ${TMPDIR:-/tmp}/softsense-same-answers-target).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
profile="${SAME_ANSWERS_PROFILE:-release}"
profile_flag=()
bin_dir=debug
if [ "$profile" = release ]; then
    profile_flag=(--release)
    bin_dir=release
fi

# Runs every answer-producing command with BIN from the repository at REPO into OUT.
answers() {
    local bin="$1" repo="$2" out="$3"
    mkdir -p "$out"
    local scene
    for scene in tip_weight probe_press probe_side two_probes; do
        "$bin" sense "$repo/clouds/scenes/$scene" --json >"$out/sense_$scene.jsonl" 2>/dev/null
        "$bin" sense "$repo/clouds/scenes/$scene" --json --track >"$out/track_$scene.jsonl" 2>/dev/null
    done
    "$bin" calibrate "$repo/clouds/scenes/calib" "$repo/meshes/models/robot.toml" \
        --start "$repo/clouds/scenes/calib/rough_pose.json" --out "$out/calibration.json" \
        --json >"$out/calibrate.json" 2>/dev/null
    local spec
    for spec in tip_weight two_probes; do
        "$bin" scene generate "$repo/clouds/scenes/$spec.toml" "$out/gen_$spec" >/dev/null 2>&1
        # Images by their bytes; JSON files by content (they name paths relative to OUT).
        (cd "$out/gen_$spec" && sha256sum $(ls | grep -v '\.json$' | sort)) >"$out/scene_$spec.sha256"
        local json
        for json in "$out/gen_$spec"/*.json; do
            cp "$json" "$out/scene_${spec}_$(basename "$json")"
        done
        rm -rf "${out:?}/gen_$spec"
    done
    "$bin" hidden "$out/hidden" --model "$repo/meshes/models/robot.toml" --effects young \
        --seed 3 --frames 6 >/dev/null 2>&1
    "$bin" explain "$repo/meshes/models/robot.toml" "$out/hidden/frames" --json \
        >"$out/explain.json" 2>/dev/null
    rm -rf "${out:?}/hidden"
    "$bin" markers "$repo/clouds/markers/sheet/tracks.csv" "$repo/meshes/models/sheet.toml" \
        --candidates "$repo/clouds/markers/sheet/candidates.csv" --json >"$out/markers_sheet.json" 2>/dev/null
    "$bin" markers "$repo/clouds/markers/robot/tracks.csv" "$repo/meshes/models/robot.toml" \
        --json >"$out/markers_robot.json" 2>/dev/null
    "$bin" markers "$repo/clouds/markers/robot/tracks.csv" "$repo/meshes/models/robot.toml" \
        --force-points hook --json >"$out/markers_robot_hook.json" 2>/dev/null
    "$bin" markers layout "$repo/meshes/models/sheet.toml" --markers 4 \
        --candidates "$repo/meshes/models/sheet_candidates.csv" --json >"$out/layout_sheet.json" 2>/dev/null
    "$bin" markers layout "$repo/meshes/models/robot.toml" --markers 3 --json \
        >"$out/layout_robot.json" 2>/dev/null
    local scenario
    for scenario in "$repo"/scenarios/control/*.toml; do
        # The diamond's scenarios need SOFTSENSE_DATA: without it both sides fail alike.
        local name
        name="$(basename "$scenario" .toml)"
        "$bin" control "$scenario" --json >"$out/control_$name.json" 2>/dev/null || echo "exit $?" >>"$out/control_$name.json"
    done
    local model
    for model in "$repo"/meshes/models/*.toml; do
        local name
        name="$(basename "$model" .toml)"
        "$bin" fem solve "$model" --json >"$out/fem_solve_$name.json" 2>/dev/null || echo "exit $?" >>"$out/fem_solve_$name.json"
        "$bin" fem compliance "$model" --json >"$out/fem_compliance_$name.json" 2>/dev/null || echo "exit $?" >>"$out/fem_compliance_$name.json"
    done
}

# Drops timing fields (wall-clock) and absolute paths, so only answers are compared.
normalise() {
    python3 - "$1" <<'EOF'
import json, re, sys, pathlib
TIMING = re.compile(r"(^|_)(ms|seconds|secs|time|timings|wall|elapsed|fps|frames_per_second)($|_)")
def clean(v):
    if isinstance(v, dict):
        return {k: clean(x) for k, x in v.items() if not TIMING.search(k)}
    if isinstance(v, list):
        return [clean(x) for x in v]
    if isinstance(v, str) and "/" in v:
        return pathlib.PurePath(v).name
    return v
for path in sorted(pathlib.Path(sys.argv[1]).iterdir()):
    text = path.read_text()
    try:
        out = [json.dumps(clean(json.loads(text)), sort_keys=True)]
    except json.JSONDecodeError:
        out = []
        for line in text.splitlines():
            try:
                out.append(json.dumps(clean(json.loads(line)), sort_keys=True))
            except json.JSONDecodeError:
                out.append(line)
    path.write_text("\n".join(out) + "\n")
EOF
}

build_here() {
    # In the dev profile, build the binary as `cargo test` does (with the test targets, so
    # dev-dependency features are unified the same way): a bare `--bin` build would give a
    # second feature set, rebuild much of the tree and overwrite the binary the tests use.
    local targets=(--bin softsense)
    if [ "$profile" = dev ]; then
        targets+=(--tests)
    fi
    cargo build -q "${profile_flag[@]}" "${targets[@]}"
    echo "${CARGO_TARGET_DIR:-$root/target}/$bin_dir/softsense"
}

compare() {
    local base="$1" head="$2"
    if diff -r "$base" "$head" >/dev/null; then
        echo "check_same_answers: identical ($(ls "$head" | wc -l) outputs)"
    else
        echo "check_same_answers: answers differ:" >&2
        diff -r "$base" "$head" | head -40 >&2
        exit 1
    fi
}

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

case "${1:-}" in
--save)
    dir="${2:?--save needs a folder}"
    bin="$(build_here)"
    answers "$bin" "$root" "$dir"
    normalise "$dir"
    echo "check_same_answers: saved $(ls "$dir" | wc -l) outputs to $dir"
    ;;
--against)
    dir="${2:?--against needs a folder}"
    bin="$(build_here)"
    answers "$bin" "$root" "$work/head"
    normalise "$work/head"
    compare "$dir" "$work/head"
    ;;
"" | -h | --help)
    sed -n 2,16p "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
*)
    base_rev="$1"
    git rev-parse --verify -q "$base_rev^{commit}" >/dev/null || {
        echo "check_same_answers: $base_rev is not a commit" >&2
        exit 2
    }
    git worktree add -q --detach "$work/base" "$base_rev"
    trap 'git worktree remove --force "$work/base"; rm -rf "$work"' EXIT
    base_target="${SAME_ANSWERS_TARGET:-${TMPDIR:-/tmp}/softsense-same-answers-target}"
    (cd "$work/base" && CARGO_TARGET_DIR="$base_target" cargo build -q "${profile_flag[@]}" --bin softsense)
    answers "$base_target/$bin_dir/softsense" "$work/base" "$work/base_out"
    normalise "$work/base_out"
    bin="$(build_here)"
    answers "$bin" "$root" "$work/head"
    normalise "$work/head"
    compare "$work/base_out" "$work/head"
    ;;
esac
