"""The Ray example runs a batch manifest in local mode with the results `softsense batch`
writes. Ray is optional: without SOFTSENSE_RAY=1 this is skipped with a message; with it, a
missing Ray is a failure."""

import json
import os
import subprocess
import sys

import pytest

import softsense.batch
from conftest import ROOT, run_cli

if not os.environ.get("SOFTSENSE_RAY"):
    pytest.skip("SOFTSENSE_RAY is not set (set it, with Ray installed, to run the Ray example)", allow_module_level=True)


def manifest(tmp_path):
    """A bundled recording and two sweep scenes (generated, then sensed): the bundled
    manifest's kinds of item, few enough for CI."""
    scenes = ROOT / "clouds" / "scenes"
    text = f"""
[[recording]]
path = "{scenes / 'tip_weight'}"

[[sweep]]
spec = "{ROOT / 'tools' / 'sweeps' / 'robot_one_probe.toml'}"
id = "one_probe"
count = 2
seed = 7
"""
    path = tmp_path / "manifest.toml"
    path.write_text(text)
    return path


def results(out):
    """Each result file without its wall times."""
    got = {}
    for f in sorted((out / "results").glob("*.json")):
        v = json.loads(f.read_text())
        v.pop("seconds", None)
        for frame in v.get("frames", []):
            frame.pop("ms"), frame.pop("timings")
        got[f.name] = v
    return got


def test_the_ray_example_writes_what_softsense_batch_writes(tmp_path, cli):
    import ray  # noqa: F401  (SOFTSENSE_RAY=1 asks for it: missing is a failure)

    m = manifest(tmp_path)
    run_cli(cli, "batch", str(m), "--out", str(tmp_path / "cli"), "--jobs", "2")
    example = ROOT / "python" / "examples" / "ray_batch.py"
    ran = subprocess.run(
        [sys.executable, str(example), str(m), "--out", str(tmp_path / "ray"), "--num-cpus", "2"],
        capture_output=True, text=True,
    )
    assert ran.returncode == 0, ran.stderr
    ours, theirs = results(tmp_path / "ray"), results(tmp_path / "cli")
    assert len(theirs) == 3 and sorted(ours) == sorted(theirs)
    assert ours == theirs
    # A second run finds everything done and runs nothing.
    assert softsense.batch.plan(m, tmp_path / "ray").todo == []
    again = subprocess.run(
        [sys.executable, str(example), str(m), "--out", str(tmp_path / "ray"), "--num-cpus", "2"],
        capture_output=True, text=True,
    )
    assert again.returncode == 0 and "0 to run, 3 done before" in again.stderr, again.stderr
