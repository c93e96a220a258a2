#!/usr/bin/env python3
"""Times every stage of stages.json for softsense, PCL and Open3D on the real clouds and
prints a Markdown table of medians. Called by tools/bench/run.sh (which builds the
programs); see tools/bench/README.md."""

import argparse
import json
import os
import statistics
import subprocess
import shutil
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


# Stage medians of softsense's `sense` stage (whole chain), per input: filled by run_softsense.
STAGE_MS = {}

# The thesis's rates (section 4.6): image processing at 10 Hz, FE update at 7 Hz.
THESIS = "thesis: image processing 10 Hz (100 ms), FE update 7 Hz (143 ms)"


def run_softsense(binary, spec, path, repeat):
    cmd = [binary, spec["stage"], path, str(repeat), json.dumps(spec.get("params", {}))]
    p = subprocess.run(cmd, capture_output=True, text=True)
    try:
        r = json.loads(p.stdout.strip().splitlines()[-1])
    except (IndexError, json.JSONDecodeError):
        return None, f"bench_stages failed: {p.stderr.strip()[-300:]}"
    if r.get("stage_ms"):
        STAGE_MS[path] = dict(r["stage_ms"])  # [name, ms] pairs, chain order
    return (r["timings_ms"], None) if r["ok"] else (None, r["error"])


def scene_folder(a, rel):
    """A stage's scene: a committed folder, or a scene file (.toml) generated once into
    --generated (its frames are not committed)."""
    path = os.path.join(ROOT, rel)
    if not rel.endswith(".toml"):
        return path
    out = os.path.join(a.generated, os.path.splitext(os.path.basename(rel))[0])
    if not os.path.exists(os.path.join(out, "truth.json")):
        if not a.cli:
            sys.exit(f"{rel}: a scene file needs --cli (the softsense binary) to generate it")
        shutil.rmtree(out, ignore_errors=True)
        os.makedirs(a.generated, exist_ok=True)
        subprocess.run([a.cli, "scene", "generate", path, out], check=True,
                       stdout=subprocess.DEVNULL)
    return out


def print_cameras_table():
    """A several-camera scene's frame against its first camera's alone (alternated frame by
    frame in one process)."""
    rows = [(p, st) for p, st in STAGE_MS.items() if st.get("first_camera_total")]
    if not rows:
        return
    print("\nseveral cameras: ms per frame with every camera against the first camera alone, "
          "frame by frame in alternation, one frame at a time\n")
    print("| scene | cameras | ms, all cameras | ms, first camera | ratio |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for path, st in rows:
        all_ms, one_ms = st["total"], st["first_camera_total"]
        print(f"| {os.path.basename(path)} | {st.get('cameras', '?'):.0f} | {all_ms:.0f}"
              f" | {one_ms:.0f} | {all_ms / one_ms:.2f}x |")


def print_stage_table():
    """Per-stage medians of the whole-chain (`sense`) inputs, with frames per second."""
    if not STAGE_MS:
        return
    extra = ("stream", "stream_one_thread", "track", "track_steady", "first_camera_total",
             "cameras")
    names = [n for n in next(iter(STAGE_MS.values())).keys() if n not in extra]
    print(f"\nsoftsense whole chain per frame (`sense`), median ms per stage; {THESIS}\n")
    print("frames/s: one frame at a time (1000 / total); stream frames/s: `sense_frames` with as "
          "many frames at a time as threads, wall clock; tracked frames/s: `track_frames` "
          "(`sense --track`), whole passes, the first frame of each cold; tracked steady: "
          "the frames that started from the one before, median wall time between them "
          "(n/a: no frame did)\n")
    print("| scene | " + " | ".join(names)
          + " | frames/s | stream frames/s | tracked frames/s | tracked steady frames/s |")
    print("| --- | " + " | ".join("---:" for _ in names) + " | ---: | ---: | ---: | ---: |")

    def rate(ms):
        return f"{1e3 / ms:.1f}" if ms else "n/a"

    for path, st in STAGE_MS.items():
        print(f"| {os.path.basename(path)} | " + " | ".join(fmt(st[n]) for n in names)
              + f" | {rate(st.get('total'))} | {rate(st.get('stream'))}"
              + f" | {rate(st.get('track'))} | {rate(st.get('track_steady'))} |")
    # How the stream scales with the cores: the same stream on one thread.
    if any(st.get("stream_one_thread") for st in STAGE_MS.values()):
        threads = os.environ.get("RAYON_NUM_THREADS") or str(os.cpu_count())
        print(f"\nstream on one thread against the stream above ({threads} threads): frames "
              "are independent, so the stream scales with the cores; threads for 30 frames/s = "
              "30 / (one-thread frames/s), at the one-thread rate per core (a lower bound: "
              "the measured scaling is below the thread count)\n")
        print(f"| scene | stream frames/s, 1 thread | stream frames/s, {threads} threads "
              "| scaling | threads for 30 frames/s |")
        print("| --- | ---: | ---: | ---: | ---: |")
        for path, st in STAGE_MS.items():
            one, many = st.get("stream_one_thread"), st.get("stream")
            if not one or not many:
                continue
            print(f"| {os.path.basename(path)} | {rate(one)} | {rate(many)} | {one / many:.2f}x"
                  f" | {30 * one / 1e3:.1f} |")


def run_oracle(cmd_prefix, spec, path, repeat):
    with tempfile.TemporaryDirectory() as d:
        job = {"stage": spec["stage"], "input": path, "output_dir": d,
               "params": spec.get("params", {}), "repeat": repeat}
        with open(os.path.join(d, "job.json"), "w") as f:
            json.dump(job, f)
        p = subprocess.run(cmd_prefix + [os.path.join(d, "job.json")], capture_output=True, text=True)
        try:
            with open(os.path.join(d, "result.json")) as f:
                r = json.load(f)
        except (OSError, json.JSONDecodeError):
            return None, f"oracle failed: {p.stderr.strip()[-300:]}"
    return (r["timings_ms"], None) if r["ok"] else (None, r["error"])


def fmt(ms):
    return "n/a" if ms is None else (f"{ms:.2f}" if ms < 10 else f"{ms:.1f}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", required=True)
    ap.add_argument("--softsense", required=True, help="path of the bench_stages binary")
    ap.add_argument("--pcl", required=True, help="path of pcl_oracle")
    ap.add_argument("--python", default=sys.executable)
    ap.add_argument("--repeat", type=int, default=11)
    ap.add_argument("--rounds", type=int, default=1,
                    help="run the libraries in turn this many times per stage and file, each with "
                         "--repeat repetitions, and pool the timings: a slow minute then hits every "
                         "library, not just one (this machine drifts by 20-40%%); with more than one "
                         "round the table also shows the range of the per-round speed-ups")
    ap.add_argument("--cli", help="path of the softsense binary: generates the scenes given as "
                    "scene files (.toml) in a stage's \"scenes\" into --generated")
    ap.add_argument("--generated", default=os.path.join(ROOT, "target", "bench-scenes"),
                    help="where generated scenes are kept between runs")
    ap.add_argument("--stages", default=os.path.join(HERE, "stages.json"))
    ap.add_argument("--only", action="append",
                    help="a stage name as in stages.json (exact; names may contain commas); repeatable")
    ap.add_argument("--json", help="also write all timings to this file")
    a = ap.parse_args()
    if a.repeat < 1 or a.rounds < 1:
        ap.error("--repeat and --rounds must be at least 1")

    cfg = json.load(open(a.stages))
    libs = {
        "softsense": lambda s, p: run_softsense(a.softsense, s, p, a.repeat),
        "pcl": lambda s, p: run_oracle([a.pcl], s, p, a.repeat),
        "open3d": lambda s, p: run_oracle([a.python, os.path.join(ROOT, "tools/oracle/open3d_oracle.py")], s, p, a.repeat),
    }
    only = set(a.only) if a.only else None
    unknown = (only or set()) - {st["name"] for st in cfg["stages"]}
    if unknown:
        ap.error(f"--only: no such stage {sorted(unknown)}")
    rows, raw, notes = [], [], []
    for st in cfg["stages"]:
        if only and st["name"] not in only:
            continue
        # A stage may name its own inputs ("scenes": folders relative to the repository).
        inputs = ([scene_folder(a, rel) for rel in st["scenes"]] if "scenes" in st
                  else [os.path.join(a.data, rel) for rel in cfg["files"]])
        for path in inputs:
            rel = os.path.relpath(path, ROOT) if "scenes" in st else os.path.relpath(path, a.data)
            # Per library: the timings of each round (libraries alternate within a round).
            per_round = {lib: [] for lib in libs}
            errors = {}
            for rnd in range(a.rounds):
                for lib, fn in libs.items():
                    spec = st.get(lib)
                    if spec is None or lib in errors:
                        continue
                    times, err = fn(spec, path)
                    if err:
                        errors[lib] = err
                        notes.append(f"{st['name']} / {os.path.basename(rel)} / {lib}: {err}")
                        continue
                    per_round[lib].append(times)
                    tag = f" (round {rnd + 1}/{a.rounds})" if a.rounds > 1 else ""
                    print(f"  {st['name']:<22} {os.path.basename(rel):<40} {lib:<9} "
                          f"{fmt(statistics.median(times))} ms{tag}", file=sys.stderr)
            med = {}
            for lib in libs:
                if st.get(lib) is None:
                    med[lib] = None
                    continue
                pooled = [t for r in per_round[lib] for t in r] if lib not in errors else []
                med[lib] = statistics.median(pooled) if pooled else None
                raw.append({"stage": st["name"], "file": rel, "lib": lib,
                            "timings_ms": pooled or None, "rounds": per_round[lib],
                            "error": errors.get(lib)})
            others = [m for m in (med["pcl"], med["open3d"]) if m is not None]
            ratio = (min(others) / med["softsense"]) if others and med["softsense"] else None
            # The speed-up of each round on its own, from that round's medians.
            spread = []
            if a.rounds > 1 and ratio is not None:
                for rnd in range(a.rounds):
                    ours = statistics.median(per_round["softsense"][rnd])
                    theirs = [statistics.median(per_round[o][rnd]) for o in ("pcl", "open3d")
                              if med[o] is not None]
                    spread.append(min(theirs) / ours)
            rows.append((st["name"], os.path.basename(rel), med, ratio, spread))

    runs = f"{a.repeat} runs" if a.rounds == 1 else f"{a.rounds} alternating rounds of {a.repeat} runs"
    print(f"softsense vs PCL 1.13 / Open3D 0.20: median of {runs}, ms, {os.cpu_count()} cores; "
          "speed-up = faster of PCL and Open3D divided by softsense (> 1: softsense is faster)\n")
    extra = " per-round speed-ups |" if a.rounds > 1 else ""
    print("| stage | cloud | softsense ms | PCL ms | Open3D ms | speed-up vs faster |" + extra)
    print("| --- | --- | ---: | ---: | ---: | ---: |" + (" ---: |" if extra else ""))
    for name, cloud, med, ratio, spread in rows:
        r = "n/a" if ratio is None else f"{ratio:.2f}x"
        line = f"| {name} | {cloud} | {fmt(med['softsense'])} | {fmt(med['pcl'])} | {fmt(med['open3d'])} | {r} |"
        if extra:
            line += (f" {min(spread):.2f}-{max(spread):.2f}x |" if spread else " n/a |")
        print(line)
    print_stage_table()
    print_cameras_table()
    if notes:
        print("\nNot measured:")
        for n in notes:
            print(f"- {n}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(raw, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
