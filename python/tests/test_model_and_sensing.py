"""The FE model and sensing from Python, against the command line."""

import json

import numpy as np
import pytest

import softsense
from conftest import run_cli


def test_a_small_load_moves_the_robot_by_its_compliance_times_the_load(root):
    model = softsense.Model.load(root / "meshes" / "models" / "robot.toml")
    nodes, tets = model.nodes, model.tets
    assert nodes.shape[1] == 3 and tets.shape[1] == 4 and tets.max() < len(nodes)
    base = model.solve()
    tip = int(np.argmax(nodes[:, 2]))
    small = model.solve([(tip, (0.0, 0.0, -0.01))])
    assert base.converged and small.converged
    moved = small.displacement - base.displacement
    # The tip moves down under a downward push, more than any node far from it.
    assert moved[tip, 2] < 0
    assert abs(moved[tip, 2]) >= np.abs(moved[:, 2]).max() * 0.5
    # Twice the load, twice the motion (small loads: linear within 5%).
    double = model.solve([(tip, (0.0, 0.0, -0.02))]).displacement - base.displacement
    np.testing.assert_allclose(double[tip], 2 * moved[tip], rtol=0.05, atol=1e-9)


def test_the_compliance_is_symmetric_and_matches_the_command_line(root, cli):
    path = root / "meshes" / "models" / "robot.toml"
    c = softsense.Model.load(path).compliance()
    assert c.w.shape == (len(c.kinds), len(c.kinds))
    np.testing.assert_allclose(c.w, c.w.T, rtol=1e-6, atol=1e-12)
    theirs = json.loads(run_cli(cli, "fem", "compliance", str(path), "--json").stdout)
    np.testing.assert_array_equal(c.w, np.array(theirs["w"]))
    assert c.kinds == theirs["kinds"]


def test_sensing_gives_the_command_lines_forces_bit_for_bit(root, cli):
    scene = root / "clouds" / "scenes" / "tip_weight"
    rec = softsense.Recording.open(scene)
    sensor = softsense.Sensor(softsense.Model.load(rec.model_path), rec)
    ours = sensor.sense_all()
    lines = run_cli(cli, "sense", str(scene), "--json").stdout.splitlines()
    theirs = [json.loads(line) for line in lines]
    assert [r.frame for r in ours] == [t["frame"] for t in theirs] == rec.frames
    for r, t in zip(ours, theirs):
        d = r.to_dict()
        for timing in ("ms", "timings"):
            d.pop(timing), t.pop(timing)
        assert d == t
        assert r.status == "sensed" and r.forces
    one = sensor.sense(rec.frames[0])
    assert [f.to_dict() for f in one.forces] == [f.to_dict() for f in ours[0].forces]
    f = one.forces[0]
    assert f.force.shape == (3,) and f.covariance.shape == (3, 3) and f.sigma > 0


def test_a_reference_and_a_known_load_give_the_command_lines_answers(root, cli):
    scene = root / "clouds" / "scenes" / "tip_weight"
    rec = softsense.Recording.open(scene)
    model = softsense.Model.load(rec.model_path)
    sensor = softsense.Sensor(model, rec, reference_frames=1, known_load=(1, 0.26))
    ours = sensor.sense_all()
    lines = run_cli(cli, "sense", str(scene), "--json", "--reference-frames", "1", "--known-load", "1=0.26").stdout.splitlines()
    theirs = [json.loads(line) for line in lines]
    assert [r.reference for r in ours] == [True, True, False, False]
    for r, t in zip(ours, theirs):
        assert [f.to_dict() for f in r.forces] == t["forces"]
    with pytest.raises(softsense.SoftsenseError, match="known_load needs reference_frames"):
        softsense.Sensor(model, rec, known_load=(1, 0.26))


def test_errors_are_exceptions_with_the_command_lines_messages(root, tmp_path):
    with pytest.raises(softsense.SoftsenseError, match="no frames"):
        softsense.Recording.open(tmp_path)
    with pytest.raises(softsense.SoftsenseError):
        softsense.Model.load(tmp_path / "missing.toml")
    rec = softsense.Recording.open(root / "clouds" / "scenes" / "tip_weight")
    model = softsense.Model.load(rec.model_path)
    with pytest.raises(softsense.SoftsenseError, match="registration"):
        softsense.Sensor(model, rec, registration="sideways")
    with pytest.raises(softsense.SoftsenseError, match="no frame 999"):
        softsense.Sensor(model, rec).sense(999)
    with pytest.raises(softsense.SoftsenseError, match="nodes"):
        model.solve([(10**9, (0.0, 0.0, 1.0))])


def test_a_two_camera_recording_senses_as_the_command_line_fuses_it(root, cli, tmp_path):
    out = tmp_path / "rig"
    run_cli(cli, "scene", "generate", str(root / "clouds" / "scenes" / "two_cameras.toml"), str(out))
    for name in ("depth_0003.png", "color_0003.png"):
        (out / "side" / name).unlink()
    rec = softsense.Recording.open(out)
    assert rec.cameras == ["front", "side"]
    assert rec.robot_from_camera is None and all(p is not None for p in rec.camera_poses)
    with pytest.raises(softsense.SoftsenseError, match="pose file is for a one-camera folder"):
        softsense.Recording.open(out, pose=out / "front" / "camera_pose.json")
    ours = softsense.Sensor(softsense.Model.load(rec.model_path), rec).sense_all([2, 3])
    lines = run_cli(cli, "sense", str(out), "--json").stdout.splitlines()
    theirs = {t["frame"]: t for t in map(json.loads, lines)}
    for r in ours:
        d, t = r.to_dict(), theirs[r.frame]
        for timing in ("ms", "timings"):
            d.pop(timing), t.pop(timing)
        assert d == t
    assert [c["status"] for c in ours[0].cameras] == ["seen", "seen"]
    assert [c["status"] for c in ours[1].cameras] == ["seen", "missing"]
