#!/usr/bin/env python3
"""Runs every bundled control scenario and prints docs/control.md's results table.

Usage: tools/control/table.py [SOFTSENSE_BINARY]   (default target/release/softsense;
the diamond scenario needs SOFTSENSE_DATA)."""
import json
import os
import subprocess
import sys

root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
binary = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "target/release/softsense")
folder = os.path.join(root, "scenarios/control")
print("| scenario | law | steps | status | average error (mm) | settled mean / max (mm) | lost / seen (mm) | gamma | k_p bound |")
print("| --- | --- | ---: | --- | ---: | --- | --- | ---: | ---: |")
for name in sorted(os.listdir(folder)):
    if not name.endswith(".toml"):
        continue
    if "diamond" in name and not os.environ.get("SOFTSENSE_DATA"):
        print(f"| {name} | (needs SOFTSENSE_DATA) | | | | | | | |")
        continue
    out = subprocess.run([binary, "control", os.path.join(folder, name), "--json"],
                         capture_output=True, text=True)
    if not out.stdout.strip():
        print(f"| {name} | error: {out.stderr.strip()} | | | | | | | |")
        continue
    r = json.loads(out.stdout)
    s = r["summary"]
    status = r["status"]["status"]
    if status != "completed":
        status += f" at step {r['status']['step']}"
    lost = (f"{s['lost_error_mm']:.3f} / {s['seen_error_mm']:.3f}"
            if s.get("lost_error_mm") is not None else "")
    bound = f"{s['gain_bound']:.2f}" if s.get("gain_bound") is not None else "none"
    print(f"| {name} | {r['law']} | {len(r['steps'])} | {status} | {s['average_error_mm']:.3f} | "
          f"{s['settled_error_mm']:.3f} / {s['settled_max_mm']:.3f} | {lost} | {s['gamma']:.3f} | {bound} |")
