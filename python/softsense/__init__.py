"""softsense: make a soft robot its own force sensor, from Python.

A thin layer over the Rust library: clouds are numpy arrays, the work runs in Rust with
the GIL released, and errors are :class:`SoftsenseError` with the command line's
messages. Ten lines from a recording to forces::

    import softsense
    rec = softsense.Recording.open("clouds/scenes/tip_weight")
    sensor = softsense.Sensor(rec.model_path, rec)     # objects or paths, alike
    for report in sensor.sense_all():
        for f in report.forces:
            print(report.frame, f.node, f.force, "+-", f.sigma)

Every argument that is a model, a recording or a file takes the library object or a path
(``str`` or ``os.PathLike``); a misspelt keyword is a ``TypeError`` listing the known ones.
See docs/python.md for the whole API.
"""

from __future__ import annotations

import inspect
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _softsense, batch, scene
from . import _args
from ._args import MissingPathError, PathLike, check_keywords, keywords, optional_path
from ._softsense import SoftsenseError, __version__

__all__ = [
    "batch", "calibrate", "explain", "hidden", "scene", "Cloud", "Compliance", "Force", "FrameReport", "Model", "Recording", "Sensor",
    "MissingPathError", "Solution", "SoftsenseError", "crop_box", "pass_through", "radius_outlier_removal",
    "read_cloud", "statistical_outlier_removal", "voxel_grid", "write_cloud",
]


def _rows(data: bytes, dtype: Any, width: int) -> np.ndarray:
    a = np.frombuffer(data, dtype=np.dtype(dtype).newbyteorder("<"))
    return a.reshape(-1, width).astype(dtype, copy=True) if width > 1 else a.astype(dtype, copy=True)


def _le_bytes(a: Any, dtype: Any, width: int, name: str) -> bytes:
    a = np.asarray(a)
    if width > 1 and (a.ndim != 2 or a.shape[1] != width):
        raise ValueError(f"{name}: expected an N x {width} array, got shape {a.shape}")
    if width == 1 and a.ndim != 1:
        raise ValueError(f"{name}: expected a length-N array, got shape {a.shape}")
    return np.ascontiguousarray(a, dtype=np.dtype(dtype).newbyteorder("<")).tobytes()


@dataclass
class Cloud:
    """A point cloud as numpy arrays (metres in, metres out).

    ``positions`` is N x 3 float32; ``colors`` N x 3 uint8, ``normals`` N x 3 float32,
    ``labels`` N uint32 and ``curvature`` N float32 are optional. An organised cloud has
    ``width * height == N``; an unorganised one ``height == 1``.
    """

    positions: np.ndarray
    colors: Optional[np.ndarray] = None
    normals: Optional[np.ndarray] = None
    labels: Optional[np.ndarray] = None
    curvature: Optional[np.ndarray] = None
    width: Optional[int] = None
    height: int = 1

    def __len__(self) -> int:
        return len(self.positions)

    def _native(self) -> "_softsense.NativeCloud":
        def opt(a: Any, dtype: Any, width: int, name: str) -> Optional[bytes]:
            return None if a is None else _le_bytes(a, dtype, width, name)

        return _softsense.NativeCloud(
            _le_bytes(self.positions, np.float32, 3, "positions"),
            opt(self.colors, np.uint8, 3, "colors"),
            opt(self.normals, np.float32, 3, "normals"),
            opt(self.labels, np.uint32, 1, "labels"),
            opt(self.curvature, np.float32, 1, "curvature"),
            self.width,
            self.height,
        )

    @classmethod
    def _from_native(cls, native: "_softsense.NativeCloud") -> "Cloud":
        p, c, n, l, k, width, height = native.parts()
        return cls(
            positions=_rows(p, np.float32, 3),
            colors=None if c is None else _rows(c, np.uint8, 3),
            normals=None if n is None else _rows(n, np.float32, 3),
            labels=None if l is None else _rows(l, np.uint32, 1),
            curvature=None if k is None else _rows(k, np.float32, 1),
            width=width,
            height=height,
        )

    @keywords
    def to_open3d(self) -> Any:
        """An ``open3d.geometry.PointCloud`` (positions, colours scaled to 0..1, normals)."""
        import open3d as o3d

        pcd = o3d.geometry.PointCloud()
        pcd.points = o3d.utility.Vector3dVector(np.asarray(self.positions, dtype=np.float64))
        if self.colors is not None:
            pcd.colors = o3d.utility.Vector3dVector(np.asarray(self.colors, dtype=np.float64) / 255.0)
        if self.normals is not None:
            pcd.normals = o3d.utility.Vector3dVector(np.asarray(self.normals, dtype=np.float64))
        return pcd

    @classmethod
    @keywords
    def from_open3d(cls, pcd: Any) -> "Cloud":
        """A cloud from an ``open3d.geometry.PointCloud`` (colours rounded to 0..255)."""
        positions = np.asarray(pcd.points, dtype=np.float32)
        colors = None
        if pcd.has_colors():
            colors = np.clip(np.rint(np.asarray(pcd.colors) * 255.0), 0, 255).astype(np.uint8)
        normals = np.asarray(pcd.normals, dtype=np.float32) if pcd.has_normals() else None
        return cls(positions=positions, colors=colors, normals=normals)


Cloud.__init__ = keywords(Cloud.__init__)  # type: ignore[method-assign]


@keywords
def read_cloud(path: PathLike) -> Cloud:
    """Reads a PCD, PLY or XYZ file (chosen by extension)."""
    return Cloud._from_native(_softsense.read_cloud(_args.path(path, "path", must_exist=True)))


@keywords
def write_cloud(cloud: Cloud, path: PathLike, encoding: str = "binary") -> None:
    """Writes a cloud by extension, all or nothing; ``encoding`` is "binary", "ascii" or
    "binary_compressed" (PCD only; PLY writes binary)."""
    _softsense.write_cloud(_args.path(path, "path"), cloud._native(), encoding)


def _filter(name: str, cloud: Cloud, params: Dict[str, Any]) -> Tuple[Cloud, np.ndarray]:
    out, indices = _softsense.filter(name, cloud._native(), json.dumps(params) if params else None)
    return Cloud._from_native(out), _rows(indices, np.uint64, 1).astype(np.int64)


def voxel_grid(cloud: Cloud, leaf_size: Any, **params: Any) -> Tuple[Cloud, np.ndarray]:
    """Voxel-grid downsampling (PCL ``VoxelGrid``): one point per occupied voxel of edge
    ``leaf_size`` metres (a number or three). Other parameters: ``mode``,
    ``min_points_per_voxel``. Returns the cloud and, per output point, the smallest input
    index in its voxel."""
    leaf = [float(leaf_size)] * 3 if np.isscalar(leaf_size) else [float(v) for v in leaf_size]
    return _filter("voxel_grid", cloud, {"leaf_size": leaf, **params})


def statistical_outlier_removal(cloud: Cloud, k: int = 50, std_ratio: float = 1.0, **params: Any) -> Tuple[Cloud, np.ndarray]:
    """Removes points whose mean distance to their ``k`` neighbours exceeds the mean by
    ``std_ratio`` standard deviations (PCL ``StatisticalOutlierRemoval``). Returns the kept
    cloud and the kept input indices."""
    return _filter("statistical_outlier_removal", cloud, {"k": k, "std_ratio": std_ratio, **params})


def radius_outlier_removal(cloud: Cloud, radius: float, min_neighbors: int, **params: Any) -> Tuple[Cloud, np.ndarray]:
    """Keeps points with at least ``min_neighbors`` others within ``radius`` metres (PCL
    ``RadiusOutlierRemoval``). Returns the kept cloud and indices."""
    return _filter("radius_outlier_removal", cloud, {"radius": radius, "min_neighbors": min_neighbors, **params})


@keywords
def crop_box(cloud: Cloud, min: Sequence[float], max: Sequence[float], invert: bool = False) -> Tuple[Cloud, np.ndarray]:
    """Keeps the points inside the axis-aligned box ``min``..``max`` (metres, inclusive),
    or outside it with ``invert``. Returns the kept cloud and indices."""
    return _filter("crop_box", cloud, {"min": [float(v) for v in min], "max": [float(v) for v in max], "invert": invert})


@keywords
def pass_through(cloud: Cloud, field: str, min: float, max: float, negative: bool = False) -> Tuple[Cloud, np.ndarray]:
    """Keeps points whose ``field`` ("x", "y", "z", "normal_x", ..., "curvature") lies in
    ``min``..``max`` (PCL ``PassThrough``), or outside with ``negative``."""
    return _filter("pass_through", cloud, {"field": field, "min": min, "max": max, "negative": negative})


@dataclass
class Solution:
    """A static FE solve: ``displacement`` and ``positions`` (N x 3, m), per cable
    ``cable_tension`` (N), ``cable_shortening`` (m) and ``cable_slack``, per pressure cavity
    ``cavity_pressure`` (Pa) and ``cavity_volume_change`` (m^3)."""

    displacement: np.ndarray
    positions: np.ndarray
    converged: bool
    iterations: int
    residuals: List[float]
    cable_tension: np.ndarray
    cable_shortening: np.ndarray
    cable_slack: List[bool]
    warning: Optional[str] = None
    cavity_pressure: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cavity_volume_change: np.ndarray = field(default_factory=lambda: np.zeros(0))


@dataclass
class Compliance:
    """The constraint-space compliance W = H K^-1 H^T (m/N), its free motion per row (m)
    and each row's kind ("Effector", "Actuator" or "Force")."""

    w: np.ndarray
    delta_free: np.ndarray
    kinds: List[str]


class Model:
    """A finite-element model (a TOML model file and its tetrahedral mesh)."""

    def __init__(self, native: "_softsense.Model") -> None:
        self._native = native

    @classmethod
    @keywords
    def load(cls, path: PathLike, mesh: Optional[PathLike] = None) -> "Model":
        """Loads a model file; ``mesh`` replaces the mesh it names."""
        return cls(_softsense.Model.load(_args.path(path, "path", must_exist=True), optional_path(mesh, "mesh", must_exist=True)))

    @property
    def path(self) -> Optional[Path]:
        """The model file, or None when ``mesh`` replaced the mesh it names (no file
        describes the model then)."""
        return self._native.path

    @property
    def nodes(self) -> np.ndarray:
        """Rest node positions, N x 3 float64 (m)."""
        return _rows(self._native.nodes(), np.float64, 3)

    @property
    def tets(self) -> np.ndarray:
        """Tetrahedra, M x 4 int64 node indices."""
        return _rows(self._native.tets(), np.uint64, 4).astype(np.int64)

    @property
    def cables(self) -> List[str]:
        """Cable names, in model order."""
        return self._native.cables()

    @property
    def cavities(self) -> List[str]:
        """Pressure cavity names, in model order."""
        return self._native.cavities()

    @keywords
    def solve(
        self,
        loads: Optional[Sequence[Tuple[int, Sequence[float]]]] = None,
        pressures: Optional[Dict[str, float]] = None,
    ) -> Solution:
        """Static equilibrium under the model's loads and actuator inputs plus ``loads``, a
        list of ``(node, (fx, fy, fz))`` in newtons, and ``pressures``, cavity name to
        pressure in pascals (unnamed cavities keep the model's input)."""
        given = None if loads is None else [(int(n), *map(float, f)) for n, f in loads]
        p = None if pressures is None else {str(k): float(v) for k, v in pressures.items()}
        d = self._native.solve(given, p)
        return Solution(
            displacement=_rows(d["displacement"], np.float64, 3),
            positions=_rows(d["positions"], np.float64, 3),
            converged=d["converged"],
            iterations=d["iterations"],
            residuals=list(d["residuals"]),
            cable_tension=np.array(d["cable_tension"], dtype=np.float64),
            cable_shortening=np.array(d["cable_shortening"], dtype=np.float64),
            cable_slack=list(d["cable_slack"]),
            warning=d["warning"],
            cavity_pressure=np.array(d["cavity_pressure"], dtype=np.float64),
            cavity_volume_change=np.array(d["cavity_volume_change"], dtype=np.float64),
        )

    @keywords
    def compliance(self) -> Compliance:
        """W at the rest state, as ``softsense fem compliance`` prints it."""
        d = self._native.compliance()
        n = len(d["kinds"])
        return Compliance(
            w=_rows(d["w"], np.float64, 1).reshape(n, n),
            delta_free=np.array(d["delta_free"], dtype=np.float64),
            kinds=list(d["kinds"]),
        )


class Recording:
    """A recording folder of one camera, or of several (one sub-folder each), as ``softsense
    sense`` reads it (docs/recording-format.md)."""

    def __init__(self, native: "_softsense.Recording") -> None:
        self._native = native

    @classmethod
    @keywords
    def open(cls, path: PathLike, pose: Optional[PathLike] = None) -> "Recording":
        """Opens a recording folder; ``pose`` is a camera pose file used instead of the
        folder's (a one-camera folder only)."""
        return cls(_softsense.Recording.open(_args.path(path, "path", must_exist=True), optional_path(pose, "pose", must_exist=True)))

    @property
    def path(self) -> Path:
        """The folder."""
        return self._native.path

    @property
    def frames(self) -> List[int]:
        """Frame numbers (of any camera)."""
        return self._native.frames

    @property
    def cameras(self) -> List[str]:
        """The cameras' names (``["camera"]`` for a one-camera folder)."""
        return self._native.cameras

    @property
    def robot_from_camera(self) -> Optional[List[List[float]]]:
        """A one-camera folder's camera pose, row-major 4x4 (p_robot = T p_camera), or None
        (no pose, or several cameras: see ``camera_poses``)."""
        return self._native.robot_from_camera

    @property
    def camera_poses(self) -> List[Optional[List[List[float]]]]:
        """Every camera's pose (None where it has none), in camera order."""
        return self._native.camera_poses

    @property
    def model_path(self) -> Optional[Path]:
        """The model file the recording names (truth.json or calibration.json), or None."""
        return self._native.model_path

    @property
    def warnings(self) -> List[str]:
        """Warnings from opening the folder."""
        return self._native.warnings

    def __repr__(self) -> str:
        return f"Recording({str(self.path)!r}, frames={self.frames})"


ModelLike = Union[Model, PathLike]
RecordingLike = Union[Recording, PathLike]


def _model(value: Any, name: str = "model") -> Model:
    """A model argument as a Model: one given, or the file given loaded."""
    return value if isinstance(value, Model) else Model.load(_args.path(value, name, True, (Model,)))


def _recording(value: Any, name: str = "recording") -> Recording:
    """A recording argument as a Recording: one given, or the folder given opened."""
    return value if isinstance(value, Recording) else Recording.open(_args.path(value, name, True, (Recording,)))


@dataclass
class Force:
    """One estimated force: where (robot frame, m), the FE node, the force (N), its
    magnitude with one-sigma uncertainty, the largest one-sigma over all directions and the
    3x3 covariance (N^2)."""

    source: str
    location: np.ndarray
    node: Optional[int]
    force: np.ndarray
    magnitude: float
    sigma: float
    sigma_max: float
    covariance: np.ndarray
    raw: Dict[str, Any] = field(repr=False, default_factory=dict)

    @classmethod
    def _from_dict(cls, d: Dict[str, Any]) -> "Force":
        return cls(
            source=d["source"],
            location=np.array(d["location"], dtype=np.float64),
            node=d["node"],
            force=np.array(d["force"], dtype=np.float64),
            magnitude=d["magnitude"],
            sigma=d["sigma"],
            sigma_max=d["sigma_max"],
            covariance=np.array(d["covariance"], dtype=np.float64),
            raw=d,
        )

    def to_dict(self) -> Dict[str, Any]:
        """The force as ``softsense sense --json`` prints it."""
        return dict(self.raw)


@dataclass
class FrameReport:
    """What sensing found in one frame: its ``status`` ("sensed", "no_robot",
    "no_features", "unreadable", "not_solved", "too_many_contacts") with ``detail``, the
    forces, the warnings, the registration residual (m), for a recording of several
    cameras each camera's part (``cameras``: name and status "seen", "no_robot" (read, no
    robot point: check its pose), "missing" or "unreadable"; empty for one camera), whether it is one of the sensor's ``reference``
    frames (it then reads near zero by construction) and, for generated recordings, the
    errors against the truth."""

    frame: int
    status: str
    detail: Any
    forces: List[Force]
    warnings: List[str]
    residual_rms: Optional[float]
    reliable: bool
    errors: Optional[List[Dict[str, Any]]]
    cameras: List[Dict[str, Any]] = field(default_factory=list)
    reference: bool = False
    raw: Dict[str, Any] = field(repr=False, default_factory=dict)

    @classmethod
    def _from_json(cls, text: str) -> "FrameReport":
        d = json.loads(text)
        return cls(
            frame=d["frame"],
            status=d["status"],
            detail=d.get("detail"),
            forces=[Force._from_dict(f) for f in d["forces"]],
            warnings=list(d["warnings"]),
            residual_rms=d["residual_rms"],
            reliable=d["reliable"],
            errors=d["errors"],
            cameras=list(d.get("cameras", [])),
            reference=bool(d.get("reference", False)),
            raw=d,
        )

    def to_dict(self) -> Dict[str, Any]:
        """The report as ``softsense sense --json`` prints it (one JSON line)."""
        return json.loads(json.dumps(self.raw))


class Sensor:
    """The sensing chain for one model and one recording (``softsense sense``).

    Options are the command line's: ``features`` (surface feature points), ``registration``
    ("auto", "features" or "dense"), ``robot_color`` (sRGB triple), ``max_contacts``,
    ``reference_frames`` (the first N frames, unloaded, as the reference: later frames are
    sensed relative to them), ``known_load`` ((frame, newtons): the modulus calibrated
    so that frame reads its load) and ``modulus_from_sag`` (the modulus from the reference
    frames' sag under the model's gravity and density). The recording's cable inputs are used as the command
    line uses them. ``model`` and ``recording`` are objects or paths.
    """

    # The native constructor's keywords (its signature, python/src/sense.rs), checked here
    # so that a misspelt option lists them.
    _KEYWORDS = tuple(inspect.signature(_softsense.Sensor).parameters)

    def __init__(self, model: ModelLike, recording: RecordingLike, **options: Any) -> None:
        check_keywords("Sensor", options, self._KEYWORDS)
        if "robot_color" in options:
            options["robot_color"] = tuple(int(v) for v in options["robot_color"])
        recording = _recording(recording)
        self._native = _softsense.Sensor(_model(model)._native, recording._native, **options)
        self.recording = recording

    @keywords
    def sense(self, frame: int) -> FrameReport:
        """Senses one frame (a bad frame comes back with its status, never raises)."""
        return FrameReport._from_json(self._native.sense(int(frame)))

    @keywords
    def sense_all(self, frames: Optional[Sequence[int]] = None, window: Optional[int] = None) -> List[FrameReport]:
        """Senses ``frames`` (default all), ``window`` of them side by side; in frame
        order, each frame's answer the same for any window."""
        given = None if frames is None else [int(f) for f in frames]
        return [FrameReport._from_json(t) for t in self._native.sense_all(given, window)]

    def __iter__(self) -> Iterator[FrameReport]:
        for frame in self.recording.frames:
            yield self.sense(frame)

    @property
    def features(self) -> int:
        """Number of surface feature points."""
        return self._native.features


@keywords
def explain(model: ModelLike, frames: RecordingLike, robot_color: Sequence[int] = (40, 200, 60), holdout: float = 0.25) -> Dict[str, Any]:
    """Where the model and the frames in ``frames`` (a folder such as :func:`hidden`
    writes) disagree, which missing effect explains it, and the residual before and after
    (``softsense explain MODEL FRAMES --json``). ``holdout`` is the share of frames held out
    to confirm the explanation. Nothing is written: ``softsense explain --out`` writes the
    report and its pictures."""
    rgb = tuple(int(v) for v in robot_color)
    given = _args.path(frames, "frames", True, (Recording,))  # checked before the model is loaded
    return json.loads(_softsense.explain_frames(_model(model)._native, given, rgb, float(holdout)))


@keywords
def hidden(out: PathLike, model: ModelLike, effects: Sequence[str], magnitude: float = 0.5, seed: int = 1, frames: int = 8) -> Dict[str, Any]:
    """Writes frames of ``model`` with hidden ``effects`` into ``out/frames`` and their truth
    into ``out/truth_hidden.json`` (``softsense hidden``), to test :func:`explain` on;
    returns the truth. The dataset is made from the model's file, so a ``Model`` loaded
    with its mesh replaced is refused."""
    if isinstance(effects, str):  # a lone name would be read as one effect per letter
        raise TypeError(f"effects: expected a list of effect names, got the string {effects!r}")
    m, o = _args.path(model, "model", True, (Model,)), _args.path(out, "out")
    return json.loads(_softsense.hidden_dataset(o, m, [str(e) for e in effects], float(magnitude), int(seed), int(frames)))


@keywords
def calibrate(recording: RecordingLike, model: ModelLike, start: Optional[PathLike] = None, frame: int = 0, robot_color: Sequence[int] = (40, 200, 60)) -> Dict[str, Any]:
    """The camera pose and cable inputs from one frame of a recording (``softsense
    calibrate``, thesis 3.3.2): ``robot_from_camera`` (4x4), the cables' tensions and
    shortenings, the residual and the status. ``start`` is the rough pose file (default:
    the recording's ``rough_pose.json``); calibrate on a frame where nothing touches the
    robot. Nothing is written: ``softsense calibrate`` writes ``calibration.json``. The
    recording is read from its folder, as the command line reads it (one camera)."""
    rgb = tuple(int(v) for v in robot_color)
    # The paths are checked before the model is loaded.
    rec = _args.path(recording, "recording", True, (Recording,))
    pose = optional_path(start, "start", must_exist=True)
    return json.loads(_softsense.calibrate_recording(rec, _model(model)._native, pose, int(frame), rgb))

