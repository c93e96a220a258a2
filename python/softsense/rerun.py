"""Sensed frames in the rerun viewer, from Python: what ``softsense sense --rerun`` logs.

Needs ``rerun-sdk`` (``pip install "softsense[rerun]"``). The entities are made by the
library (``softsense::render::scene3d``, the same ones the command line writes); this
module only hands them to rerun. Each frame is on the ``frame`` timeline::

    import rerun as rr
    import softsense, softsense.rerun
    rec = softsense.Recording.open("clouds/scenes/tip_weight")
    sensor = softsense.Sensor(softsense.Model.load(rec.model_path), rec)
    softsense.rerun.save(sensor, "tip_weight.rrd")        # then: rerun tip_weight.rrd
    rr.init("softsense", spawn=True)                       # or live, into a viewer
    softsense.rerun.log(sensor)

The entity paths are listed in docs/rerun.md.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any, Dict, List, Optional, Sequence

import numpy as np

from ._args import PathLike, keywords, path as _path

if TYPE_CHECKING:  # pragma: no cover
    from . import FrameReport, Sensor

TIMELINE = "frame"


def _rerun() -> Any:
    try:
        import rerun
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            "softsense.rerun needs rerun-sdk: pip install 'softsense[rerun]' (or rerun-sdk>=0.36)"
        ) from e
    return rerun


@keywords
def log(
    sensor: "Sensor",
    frames: Optional[Sequence[int]] = None,
    window: Optional[int] = None,
    images: bool = True,
    recording: Any = None,
) -> List["FrameReport"]:
    """Senses ``frames`` (default: all) and logs each into ``recording`` (a
    ``rerun.RecordingStream``; default: the global one, e.g. from ``rr.init(...,
    spawn=True)``), after the static entities (axes, camera poses and pinholes). Returns the
    frames' reports, the same as ``sensor.sense_all``. ``images=False`` leaves out the
    colour frames."""
    from . import FrameReport

    rr = _rerun()
    given = None if frames is None else [int(f) for f in frames]
    for e in json.loads(sensor._native.scene_static()):
        _log_entity(rr, e, True, recording)
    reports = []
    for report, entities in sensor._native.sense_scenes(given, window, images):
        r = FrameReport._from_json(report)
        rr.set_time(TIMELINE, sequence=r.frame, recording=recording)
        for e in json.loads(entities):
            _log_entity(rr, e, False, recording)
        reports.append(r)
    return reports


@keywords
def save(
    sensor: "Sensor",
    path: PathLike,
    frames: Optional[Sequence[int]] = None,
    window: Optional[int] = None,
    images: bool = True,
) -> List["FrameReport"]:
    """Senses ``frames`` (default: all) into the ``.rrd`` file ``path`` (replaced), as
    ``softsense sense --rerun`` does; open it with ``rerun PATH``. Returns the reports."""
    rr = _rerun()
    stream = rr.RecordingStream("softsense")
    stream.save(_path(path, "path"))
    try:
        return log(sensor, frames, window, images, recording=stream)
    finally:
        stream.flush()
        stream.disconnect()


def _f32(a: Any, width: int) -> np.ndarray:
    return np.asarray(a, dtype=np.float32).reshape(-1, width)


def _u8(a: Any) -> np.ndarray:
    return np.asarray(a, dtype=np.uint8).reshape(-1, 3)


def _archetype(rr: Any, e: Dict[str, Any]) -> Any:
    """The rerun archetype of one entity's shape (docs/rerun.md)."""
    k = e["kind"]
    if k == "z_up":
        return rr.ViewCoordinates.RIGHT_HAND_Z_UP
    if k == "transform":
        m = rr.datatypes.Mat3x3(columns=np.asarray(e["rotation_columns"], dtype=np.float32))
        return rr.Transform3D(translation=e["translation"], mat3x3=m)
    if k == "pinhole":
        return rr.Pinhole(
            focal_length=e["focal"],
            principal_point=e["principal"],
            resolution=e["resolution"],
            image_plane_distance=e["plane_distance"],
        )
    if k == "image":
        rgb = np.asarray(e["rgb"], dtype=np.uint8).reshape(e["height"], e["width"], 3)
        return rr.Image(rgb)
    if k == "points":
        return rr.Points3D(
            _f32(e["positions"], 3),
            colors=_u8(e["colors"]),
            radii=e["radius"],
            labels=e["labels"] or None,
        )
    if k == "lines":
        strips = [_f32(s, 3) for s in e["strips"]]
        return rr.LineStrips3D(strips, colors=e["color"], radii=e["radius"])
    if k == "mesh":
        return rr.Mesh3D(
            vertex_positions=_f32(e["vertices"], 3),
            vertex_normals=_f32(e["normals"], 3),
            triangle_indices=np.asarray(e["triangles"], dtype=np.uint32).reshape(-1, 3),
            albedo_factor=e["color"],
        )
    if k == "arrows":
        return rr.Arrows3D(
            origins=_f32(e["origins"], 3),
            vectors=_f32(e["vectors"], 3),
            colors=e["color"],
            labels=e["labels"],
        )
    if k == "ellipsoids":
        return rr.Ellipsoids3D(
            centers=_f32(e["centers"], 3),
            half_sizes=_f32(e["half_sizes"], 3),
            quaternions=[rr.Quaternion(xyzw=q) for q in e["quaternions"]],
            colors=e["color"],
            fill_mode=rr.components.FillMode.MajorWireframe,
        )
    if k == "text":
        level = {"info": rr.TextLogLevel.INFO, "warn": rr.TextLogLevel.WARN, "error": rr.TextLogLevel.ERROR}
        return rr.TextLog(e["text"], level=level[e["level"]])
    if k == "scalar":
        return rr.Scalars(e["value"])
    if k == "clear":
        return rr.Clear(recursive=False)
    raise ValueError(f"unknown entity kind {k!r} at {e['path']} (softsense and its native module differ?)")


def _log_entity(rr: Any, e: Dict[str, Any], static: bool, recording: Any) -> None:
    rr.log(e["path"], _archetype(rr, e["shape"] | {"path": e["path"]}), static=static, recording=recording)
