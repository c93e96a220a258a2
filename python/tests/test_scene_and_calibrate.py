"""Scene generation and calibration from Python write and find what the command line does."""

import json

import numpy as np
import pytest

import softsense
from conftest import run_cli


def test_a_scene_generated_from_python_is_byte_for_byte_the_command_lines(root, tmp_path, cli):
    spec = root / "clouds" / "scenes" / "probe_press.toml"
    truth = softsense.scene.generate(spec, tmp_path / "py")
    run_cli(cli, "scene", "generate", str(spec), str(tmp_path / "cli"))
    ours = sorted(p.name for p in (tmp_path / "py").iterdir())
    assert ours == sorted(p.name for p in (tmp_path / "cli").iterdir())
    for name in ours:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    assert truth == json.loads((tmp_path / "py" / "truth.json").read_text())


def test_a_sweep_from_python_draws_the_command_lines_scenes(root, tmp_path, cli):
    spec = root / "tools" / "sweeps" / "robot_one_probe.toml"
    draws = softsense.scene.sweep(spec, tmp_path / "py", 2, 11)
    run_cli(cli, "scene", "sweep", str(spec), str(tmp_path / "cli"), "--count", "2", "--seed", "11")
    assert draws == json.loads((tmp_path / "cli" / "draws.json").read_text())


def test_calibration_from_python_finds_the_command_lines_pose(root, tmp_path, cli):
    scene = root / "clouds" / "scenes" / "calib"
    model = root / "meshes" / "models" / "robot.toml"
    ours = softsense.calibrate(scene, model)
    theirs = json.loads(run_cli(cli, "calibrate", str(scene), str(model), "--out", str(tmp_path / "c.json"), "--json").stdout)
    np.testing.assert_array_equal(np.array(ours["robot_from_camera"]), np.array(theirs["robot_from_camera"]))
    assert ours["status"] == theirs["status"] and ours["actuators"] == theirs["actuators"]


def test_hidden_and_explain_give_the_command_lines_dataset_and_explanation(root, cli, tmp_path):
    model = root / "meshes" / "models" / "robot.toml"
    truth = softsense.hidden(tmp_path / "ours", model, ["young"], seed=3, frames=4)
    run_cli(cli, "hidden", str(tmp_path / "theirs"), "--model", str(model), "--effects", "young",
            "--seed", "3", "--frames", "4")
    theirs_truth = json.loads((tmp_path / "theirs" / "truth_hidden.json").read_text())
    assert truth == theirs_truth
    for name in sorted(p.name for p in (tmp_path / "theirs" / "frames").iterdir()):
        ours_file = tmp_path / "ours" / "frames" / name
        assert ours_file.read_bytes() == (tmp_path / "theirs" / "frames" / name).read_bytes(), name
    ours = softsense.explain(model, tmp_path / "ours" / "frames")
    theirs = json.loads(run_cli(cli, "explain", str(model), str(tmp_path / "theirs" / "frames"), "--json").stdout)
    assert ours == theirs
    with pytest.raises(softsense.SoftsenseError, match="use one of"):
        softsense.hidden(tmp_path / "bad", model, ["gravity-well"])
