"""`softsense import`: bags written by the rosbags package in the RealSense layout (rosbag
v1) and as ROS 2 MCAP (plain and zstd chunks) and sqlite3 bags, from the depth and colour PNGs and intrinsics of a bundled
recording, import to recordings that sense to the same forces as the original."""

import json
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image as PilImage
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from conftest import ROOT, run_cli

SCENE = ROOT / "clouds" / "scenes" / "tip_weight"
MODEL = ROOT / "meshes" / "models" / "robot.toml"
T0 = 1_700_000_000 * 10**9
PERIOD = 33_333_333  # 30 fps, nanoseconds
# Everything `sense --json` prints per frame except the run time and the truth's scores (the
# imported folder has no truth.json: the bag does not carry it).
NOT_COMPARED = {"ms", "timings", "errors"}


def scene_frames():
    """(depth uint16 HxW, colour uint8 HxWx3) per frame of the bundled recording, and its
    intrinsics."""
    intr = json.loads((SCENE / "intrinsics.json").read_text())
    frames = []
    for depth in sorted(SCENE.glob("depth_*.png")):
        colour = SCENE / depth.name.replace("depth_", "color_")
        d = np.array(PilImage.open(depth))
        assert d.dtype == np.uint16, d.dtype
        frames.append((d, np.array(PilImage.open(colour).convert("RGB"))))
    return frames, intr


def stamp(t):
    return {"sec": t // 10**9, "nanosec": t % 10**9}


class Msgs:
    """Message builders of one ROS distribution's typestore."""

    def __init__(self, store):
        self.ts = get_typestore(store)
        self.ros1 = store == Stores.ROS1_NOETIC
        t = self.ts.types
        self.Time, self.Header = t["builtin_interfaces/msg/Time"], t["std_msgs/msg/Header"]
        self.Image, self.Info = t["sensor_msgs/msg/Image"], t["sensor_msgs/msg/CameraInfo"]
        self.Roi, self.Float32 = t["sensor_msgs/msg/RegionOfInterest"], t["std_msgs/msg/Float32"]

    def header(self, t):
        s = self.Time(**stamp(t))
        return self.Header(seq=0, stamp=s, frame_id="cam") if self.ros1 else self.Header(stamp=s, frame_id="cam")

    def image(self, t, pixels, encoding):
        h, w = pixels.shape[:2]
        data = np.ascontiguousarray(pixels).view(np.uint8).reshape(-1)
        return self.Image(header=self.header(t), height=h, width=w, encoding=encoding,
                          is_bigendian=0, step=data.size // h, data=data)

    def info(self, intr):
        m = intr["intrinsic_matrix"]  # column-major
        k = np.array([m[0], 0.0, m[6], 0.0, m[4], m[7], 0.0, 0.0, 1.0])
        p = np.array([m[0], 0.0, m[6], 0.0, 0.0, m[4], m[7], 0.0, 0.0, 0.0, 1.0, 0.0])
        arrays = dict(D=np.zeros(5), K=k, R=np.eye(3).reshape(-1), P=p)
        if not self.ros1:
            arrays = {key.lower(): v for key, v in arrays.items()}
        roi = self.Roi(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
        return self.Info(header=self.header(T0), height=intr["height"], width=intr["width"],
                         distortion_model="plumb_bob", binning_x=0, binning_y=0, roi=roi, **arrays)

    def serialize(self, msg):
        if self.ros1:
            return self.ts.serialize_ros1(msg, msg.__msgtype__)
        return self.ts.serialize_cdr(msg, msg.__msgtype__)


def bag_messages(m, topics, drop_colour, colour=True):
    """(topic, stamp, message) of the bundled frames: depth at 30 fps, colour 1 ms later,
    the colour image of frame `drop_colour` missing."""
    frames, intr = scene_frames()
    out = [(topics["depth_info"], T0, m.info(intr))]
    if colour:
        out.append((topics["colour_info"], T0, m.info(intr)))
    for i, (depth, rgb) in enumerate(frames):
        t = T0 + i * PERIOD
        out.append((topics["depth"], t, m.image(t, depth, topics["depth_encoding"])))
        if colour and i != drop_colour:
            if topics["colour_encoding"] == "bgr8":
                rgb = rgb[:, :, ::-1]
            out.append((topics["colour"], t + 1_000_000, m.image(t + 1_000_000, rgb, topics["colour_encoding"])))
    return out


REALSENSE = {
    "depth": "/device_0/sensor_0/Depth_0/image/data",
    "depth_info": "/device_0/sensor_0/Depth_0/info/camera_info",
    "depth_encoding": "mono16",
    "colour": "/device_0/sensor_1/Color_0/image/data",
    "colour_info": "/device_0/sensor_1/Color_0/info/camera_info",
    "colour_encoding": "rgb8",
}
ROS2 = {
    "depth": "/camera/depth/image_rect_raw",
    "depth_info": "/camera/depth/camera_info",
    "depth_encoding": "16UC1",
    "colour": "/camera/color/image_raw",
    "colour_info": "/camera/color/camera_info",
    "colour_encoding": "bgr8",
}


def write_realsense_bag(path, drop_colour, compression=None):
    m = Msgs(Stores.ROS1_NOETIC)
    msgs = [("/device_0/sensor_0/option/Depth Units/value", T0, m.Float32(data=0.001))]
    msgs += bag_messages(m, REALSENSE, drop_colour)
    w = Writer1(path)
    if compression:
        w.set_compression(compression)  # before the file is opened
    with w:
        conns = {}
        for topic, t, msg in msgs:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msg.__msgtype__, typestore=m.ts)
            w.write(conns[topic], t, m.serialize(msg))


def write_ros2_bag(path, drop_colour, colour=True, storage=StoragePlugin.MCAP, zstd_chunks=False):
    m = Msgs(Stores.ROS2_HUMBLE)
    w = Writer2(path, version=9, storage_plugin=storage)
    if zstd_chunks:
        # The MCAP storage's own compression: zstd chunks, as ROS 2's writer makes them.
        w.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with w:
        conns = {}
        for topic, t, msg in bag_messages(m, ROS2, drop_colour, colour):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msg.__msgtype__, typestore=m.ts)
            w.write(conns[topic], t, m.serialize(msg))


def sensed(cli, folder):
    lines = run_cli(cli, "sense", str(folder), "--model", str(MODEL), "--json").stdout.splitlines()
    out = {}
    for line in lines:
        r = json.loads(line)
        if "frame" in r:
            out[r["frame"]] = {k: v for k, v in r.items() if k not in NOT_COMPARED}
    return out


def imported(cli, bag, out):
    summary = json.loads(run_cli(cli, "import", str(bag), str(out), "--json").stdout)
    # The bag has no pose or cable inputs: they come beside it, as for any recording.
    for name in ("camera_pose.json", "actuators.json"):
        shutil.copy(SCENE / name, out / name)
    return summary


@pytest.fixture(scope="module")
def original(cli):
    return sensed(cli, SCENE)


@pytest.mark.parametrize("compression", [None, "lz4"])
def test_a_realsense_bag_senses_to_the_original_forces_with_its_dropped_frame_left_out(tmp_path, cli, original, compression):
    bag = tmp_path / "walk.bag"
    fmt = Writer1.CompressionFormat.LZ4 if compression else None
    write_realsense_bag(bag, drop_colour=2, compression=fmt)
    summary = imported(cli, bag, tmp_path / "rec")
    assert summary["dropped_depth"] == [2]
    assert (summary["frames_written"], summary["paired"], summary["depth_unit"]) == (3, 3, 0.001)
    assert json.loads((tmp_path / "rec" / "intrinsics.json").read_text()) == json.loads((SCENE / "intrinsics.json").read_text())
    got = sensed(cli, tmp_path / "rec")
    assert sorted(got) == [0, 1, 3]
    for frame, result in got.items():
        assert result["status"] == "sensed"
        # Same depth values, unit, intrinsics and colour bytes: the same forces, bit for bit.
        assert result == original[frame], frame


def mcap_chunk_compressions(bag):
    """The compression named by each chunk record of the bag's .mcap files."""
    from rosbags.rosbag2.storage_mcap import McapReader

    out = set()
    for path in bag.glob("*.mcap"):
        reader = McapReader(path)
        reader.open()
        out |= {chunk.compression for chunk in reader.chunks}
        reader.close()
    return out


@pytest.mark.parametrize("zstd_chunks", [False, True])
def test_a_ros2_mcap_bag_senses_to_the_original_forces_with_its_dropped_frame_left_out(tmp_path, cli, original, zstd_chunks):
    bag = tmp_path / "rosbag2"
    write_ros2_bag(bag, drop_colour=1, zstd_chunks=zstd_chunks)
    assert mcap_chunk_compressions(bag) == ({"zstd"} if zstd_chunks else {""})
    summary = imported(cli, bag, tmp_path / "rec")
    assert summary["dropped_depth"] == [1]
    assert summary["colour_topic"] == ROS2["colour"]
    got = sensed(cli, tmp_path / "rec")
    assert sorted(got) == [0, 2, 3]
    for frame, result in got.items():
        assert result == original[frame], frame


def test_a_ros2_sqlite3_bag_senses_to_the_original_forces_with_its_dropped_frame_left_out(tmp_path, cli, original):
    bag = tmp_path / "rosbag2"
    write_ros2_bag(bag, drop_colour=1, storage=StoragePlugin.SQLITE3)
    assert [p.suffix for p in bag.glob("*.db3")] == [".db3"]
    summary = imported(cli, bag, tmp_path / "rec")
    assert summary["dropped_depth"] == [1]
    assert summary["colour_topic"] == ROS2["colour"]
    got = sensed(cli, tmp_path / "rec")
    assert sorted(got) == [0, 2, 3]
    for frame, result in got.items():
        assert result == original[frame], frame


def test_a_bag_without_colour_imports_depth_only_and_says_sense_will_find_no_robot(tmp_path, cli):
    bag = tmp_path / "rosbag2"
    write_ros2_bag(bag, drop_colour=None, colour=False)
    done = subprocess.run([cli, "import", str(bag), str(tmp_path / "rec")], cwd=ROOT, capture_output=True, text=True, check=True)
    assert "depth only" in done.stderr and "no_robot" in done.stderr, done.stderr
    assert sorted(p.name for p in (tmp_path / "rec").glob("*.png")) == [f"depth_{i:04}.png" for i in range(4)]
    for name in ("camera_pose.json", "actuators.json"):
        shutil.copy(SCENE / name, tmp_path / "rec" / name)
    # Every frame is sensed as no_robot (the robot is found by its colour), so sense exits 1,
    # saying the colour images are missing.
    done = subprocess.run([cli, "sense", str(tmp_path / "rec"), "--model", str(MODEL), "--json"],
                          cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 1 and "no colour images" in done.stderr, done.stderr
    assert [json.loads(line)["status"] for line in done.stdout.splitlines()] == ["no_robot"] * 4


def test_a_bz2_bag_and_a_missing_topic_are_clear_errors(tmp_path, cli):
    bag = tmp_path / "bz2.bag"
    write_realsense_bag(bag, drop_colour=None, compression=Writer1.CompressionFormat.BZ2)
    done = subprocess.run([cli, "import", str(bag), str(tmp_path / "a")], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 1 and "`bz2` are not read" in done.stderr, done.stderr
    bag = tmp_path / "walk.bag"
    write_realsense_bag(bag, drop_colour=None)
    done = subprocess.run([cli, "import", str(bag), str(tmp_path / "b"), "--depth-topic", "/nope"], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 1, done.stderr
    assert "no sensor_msgs/Image topic /nope" in done.stderr and REALSENSE["depth"] in done.stderr, done.stderr
