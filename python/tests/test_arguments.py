"""Every call takes the library objects or paths alike, refuses other kinds naming the
argument, and lists the known keywords when one is misspelt."""

import json
import os
from pathlib import Path

import pytest

import softsense
import softsense.batch
import softsense.rerun
import softsense.scene
from conftest import ROOT

SCENE = ROOT / "clouds" / "scenes" / "tip_weight"
CALIB = ROOT / "clouds" / "scenes" / "calib"
MODEL = ROOT / "meshes" / "models" / "robot.toml"
MESH = ROOT / "meshes" / "robot.vtu"  # the mesh robot.toml names


def untimed(report):
    d = report.to_dict()
    d.pop("ms"), d.pop("timings")
    return d


@pytest.fixture(scope="module")
def model():
    return softsense.Model.load(MODEL)


@pytest.fixture(scope="module")
def rec():
    return softsense.Recording.open(SCENE)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, model):
    """A small hidden-effect dataset (two frames: explain's time grows with them), made from
    a Model object."""
    out = tmp_path_factory.mktemp("hidden")
    truth = softsense.hidden(out, model, ["young"], seed=3, frames=2)
    return out, truth


def test_objects_know_the_files_they_were_read_from(model, rec):
    assert Path(model.path) == MODEL
    assert Path(rec.path) == SCENE


def test_a_sensor_of_paths_senses_as_one_of_objects(model, rec):
    frame = rec.frames[-1]
    ours = untimed(softsense.Sensor(model, rec).sense(frame))
    for m, r in [(str(MODEL), str(SCENE)), (MODEL, SCENE), (model, SCENE), (str(MODEL), rec)]:
        sensor = softsense.Sensor(m, r)
        assert isinstance(sensor.recording, softsense.Recording)
        assert untimed(sensor.sense(frame)) == ours, (type(m), type(r))


def test_calibration_of_paths_is_calibration_of_objects(model):
    by_path = softsense.calibrate(str(CALIB), str(MODEL))
    by_object = softsense.calibrate(softsense.Recording.open(CALIB), model)
    assert by_object == by_path


def test_hidden_and_explain_take_objects_or_paths(tmp_path, model, dataset):
    out, truth = dataset
    # The dataset made from the Model object above is the one made from its file's path.
    again = softsense.hidden(tmp_path, str(MODEL), ["young"], seed=3, frames=2)
    assert again == truth
    for name in sorted(p.name for p in (out / "frames").iterdir()):
        assert (tmp_path / "frames" / name).read_bytes() == (out / "frames" / name).read_bytes(), name
    by_path = softsense.explain(str(MODEL), str(out / "frames"))
    by_object = softsense.explain(model, softsense.Recording.open(out / "frames"))
    assert json.dumps(by_object, sort_keys=True) == json.dumps(by_path, sort_keys=True)


def test_a_model_with_its_mesh_replaced_has_no_file_and_hidden_says_so(tmp_path, model):
    # The same mesh, but given: the model is no longer what its file says.
    replaced = softsense.Model.load(MODEL, mesh=MESH)
    assert replaced.path is None
    with pytest.raises(ValueError, match="model: .*no file behind it"):
        softsense.hidden(tmp_path, replaced, ["young"], frames=2)
    assert not any(tmp_path.iterdir())


CALLS = {
    "Model.load": lambda v: softsense.Model.load(v),
    "Recording.open": lambda v: softsense.Recording.open(v),
    "read_cloud": lambda v: softsense.read_cloud(v),
    "Sensor model": lambda v: softsense.Sensor(v, SCENE),
    "Sensor recording": lambda v: softsense.Sensor(MODEL, v),
    "calibrate recording": lambda v: softsense.calibrate(v, MODEL),
    "calibrate model": lambda v: softsense.calibrate(CALIB, v),
    "calibrate start": lambda v: softsense.calibrate(CALIB, MODEL, start=v),
    "explain model": lambda v: softsense.explain(v, SCENE),
    "explain frames": lambda v: softsense.explain(MODEL, v),
    "hidden out": lambda v: softsense.hidden(v, MODEL, ["young"]),
    "hidden model": lambda v: softsense.hidden("unused", v, ["young"]),
    "scene.generate spec": lambda v: softsense.scene.generate(v, "unused"),
    "scene.generate out": lambda v: softsense.scene.generate(ROOT / "clouds" / "scenes" / "probe_press.toml", v),
    "scene.sweep out": lambda v: softsense.scene.sweep(ROOT / "tools" / "sweeps" / "robot_one_probe.toml", v, 1, 1),
    "batch.plan manifest": lambda v: softsense.batch.plan(v, "unused"),
    "batch.run_item out": lambda v: softsense.batch.run_item(ROOT / "scenarios" / "batch" / "bundled.toml", "x", v),
}
ARGUMENT = {
    "Model.load": "path", "Recording.open": "path", "read_cloud": "path", "Sensor model": "model",
    "Sensor recording": "recording", "calibrate recording": "recording", "calibrate model": "model",
    "calibrate start": "start", "explain model": "model", "explain frames": "frames", "hidden out": "out",
    "hidden model": "model", "scene.generate spec": "spec", "scene.generate out": "out",
    "scene.sweep out": "out", "batch.plan manifest": "manifest", "batch.run_item out": "out",
}


@pytest.mark.parametrize("call", sorted(CALLS))
@pytest.mark.parametrize("bad", [{"path": "x"}, 3, b"bytes/path"])
def test_a_wrong_kind_is_a_type_error_naming_the_argument_and_the_kinds(call, bad):
    with pytest.raises(TypeError) as e:
        CALLS[call](bad)
    message = str(e.value)
    assert message.startswith(ARGUMENT[call] + ": expected "), message
    assert "str or os.PathLike" in message and type(bad).__name__ in message
    assert repr(bad) not in message  # never as if it were a path


def test_a_model_where_a_recording_goes_is_refused_by_kind(model, rec):
    with pytest.raises(TypeError, match="recording: expected Recording or str or os.PathLike, got Model"):
        softsense.Sensor(model, model)
    with pytest.raises(TypeError, match="model: expected Model or str or os.PathLike, got Recording"):
        softsense.calibrate(CALIB, rec)
    with pytest.raises(TypeError, match="frames: expected Recording or str or os.PathLike, got Model"):
        softsense.explain(MODEL, model)


@pytest.mark.parametrize("call", ["Model.load", "Recording.open", "read_cloud", "Sensor model", "Sensor recording",
                                  "calibrate recording", "calibrate model", "calibrate start", "explain model",
                                  "explain frames", "hidden model", "scene.generate spec", "batch.plan manifest"])
def test_a_missing_input_is_file_not_found_naming_the_argument(call, tmp_path):
    missing = tmp_path / "missing"
    with pytest.raises(FileNotFoundError, match=f"^{ARGUMENT[call]}: .*missing does not exist") as e:
        CALLS[call](missing)
    # Also a SoftsenseError, as the library's own errors about unreadable files are.
    assert isinstance(e.value, softsense.SoftsenseError)


MISSPELT = [
    (lambda m, r: softsense.Sensor(m, r, featurs=40), "Sensor", "featurs", "features", "modulus_from_sag"),
    (lambda m, r: softsense.Sensor(m, r, robot_colour=(1, 2, 3)), "Sensor", "robot_colour", "robot_color", "known_load"),
    (lambda m, r: softsense.Sensor(m, r).sense(frme=0), "Sensor.sense", "frme", "frame", "frame"),
    (lambda m, r: softsense.Sensor(m, r).sense_all(windw=2), "Sensor.sense_all", "windw", "window", "frames"),
    (lambda m, r: softsense.calibrate(CALIB, m, fram=0), "calibrate", "fram", "frame", "robot_color"),
    (lambda m, r: softsense.explain(m, SCENE, hold_out=0.5), "explain", "hold_out", "holdout", "robot_color"),
    (lambda m, r: softsense.hidden("x", m, ["young"], sead=2), "hidden", "sead", "seed", "magnitude"),
    (lambda m, r: softsense.scene.generate(spec="a.toml", outt="b"), "generate", "outt", "out", "spec"),
    (lambda m, r: softsense.scene.sweep("a.toml", "b", 1, sed=2), "sweep", "sed", "seed", "count"),
    (lambda m, r: softsense.batch.plan("m.toml", "o", retry_faild=True), "plan", "retry_faild", "retry_failed", "out"),
    (lambda m, r: softsense.batch.run_item("m.toml", "i", "o", windows=2), "run_item", "windows", "window", "item_id"),
    (lambda m, r: softsense.Model.load(MODEL, meshes="x"), "Model.load", "meshes", "mesh", "path"),
    (lambda m, r: m.solve(load=[]), "Model.solve", "load", "loads", "pressures"),
    (lambda m, r: softsense.Recording.open(SCENE, poses="p.json"), "Recording.open", "poses", "pose", "path"),
    (lambda m, r: softsense.write_cloud(softsense.Cloud(positions=[[0.0] * 3]), "x.pcd", encodng="ascii"),
     "write_cloud", "encodng", "encoding", "path"),
    (lambda m, r: softsense.crop_box(softsense.Cloud(positions=[[0.0] * 3]), [0] * 3, [1] * 3, inverted=True),
     "crop_box", "inverted", "invert", "max"),
    (lambda m, r: softsense.Cloud(position=[[0.0] * 3]), "Cloud", "position", "positions", "curvature"),
    (lambda m, r: softsense.rerun.save(softsense.Sensor(m, r), "x.rrd", frame=[0]), "save", "frame", "frames", "images"),
]


@pytest.mark.parametrize("call, where, wrong, meant, other", MISSPELT, ids=[f"{w}-{x}" for _, w, x, _, _ in MISSPELT])
def test_a_misspelt_keyword_lists_the_known_ones(call, where, wrong, meant, other, model, rec):
    with pytest.raises(TypeError) as e:
        call(model, rec)
    message = str(e.value)
    assert message.startswith(f"{where}() got an unexpected keyword argument {wrong!r}"), message
    assert f"did you mean {meant!r}?" in message, message
    known = message.split("(known: ", 1)[1].rstrip(")").split(", ")
    assert meant in known and other in known, known


def test_paths_may_be_path_objects_or_text(model):
    assert softsense.Model.load(str(MODEL)).cables == softsense.Model.load(MODEL).cables == model.cables

    class Spelled(os.PathLike):
        def __fspath__(self):
            return str(SCENE)

    assert softsense.Recording.open(Spelled()).frames == softsense.Recording.open(str(SCENE)).frames
