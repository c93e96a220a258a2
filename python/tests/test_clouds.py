"""Clouds through numpy: read, write, filter, Open3D interop."""

import numpy as np
import pytest

import softsense
from conftest import run_cli


def test_a_bundled_cloud_round_trips_through_numpy_in_every_format(root, tmp_path):
    cloud = softsense.read_cloud(root / "clouds" / "demo_scene.pcd")
    assert cloud.positions.dtype == np.float32 and cloud.positions.shape == (len(cloud), 3)
    for name, encoding in [("a.pcd", "binary"), ("b.pcd", "ascii"), ("c.pcd", "binary_compressed"), ("d.ply", "binary"), ("e.ply", "ascii")]:
        softsense.write_cloud(cloud, tmp_path / name, encoding)
        back = softsense.read_cloud(tmp_path / name)
        np.testing.assert_array_equal(back.positions, cloud.positions)
        if cloud.colors is not None:
            np.testing.assert_array_equal(back.colors, cloud.colors)


def test_arrays_made_in_numpy_are_written_and_read_back_with_every_attribute(tmp_path):
    rng = np.random.default_rng(7)
    n = 500
    cloud = softsense.Cloud(
        positions=rng.normal(size=(n, 3)).astype(np.float32),
        colors=rng.integers(0, 256, size=(n, 3), dtype=np.uint8),
        normals=rng.normal(size=(n, 3)).astype(np.float32),
        labels=rng.integers(0, 9, size=n, dtype=np.uint32),
    )
    softsense.write_cloud(cloud, tmp_path / "x.pcd")
    back = softsense.read_cloud(tmp_path / "x.pcd")
    for a in ("positions", "colors", "normals", "labels"):
        np.testing.assert_array_equal(getattr(back, a), getattr(cloud, a))


def test_the_voxel_grid_gives_what_the_command_line_gives(root, tmp_path, cli):
    src = root / "clouds" / "demo_scene.pcd"
    out = tmp_path / "cli.pcd"
    run_cli(cli, "filter", str(src), str(out), "--voxel", "0.01")
    ours, indices = softsense.voxel_grid(softsense.read_cloud(src), 0.01)
    theirs = softsense.read_cloud(out)
    np.testing.assert_array_equal(ours.positions, theirs.positions)
    assert indices.shape == (len(ours),) and indices.min() >= 0


def test_outlier_removal_and_crops_return_kept_indices_into_the_input():
    rng = np.random.default_rng(3)
    pts = rng.uniform(-0.1, 0.1, size=(2000, 3)).astype(np.float32)
    pts[:5] = 5.0 + rng.uniform(size=(5, 3))  # far away
    cloud = softsense.Cloud(positions=pts)
    kept, idx = softsense.statistical_outlier_removal(cloud, k=20, std_ratio=2.0)
    assert not set(range(5)) & set(idx.tolist())
    np.testing.assert_array_equal(kept.positions, pts[idx])
    boxed, idx = softsense.crop_box(cloud, [-0.05] * 3, [0.05] * 3)
    assert np.all(np.abs(boxed.positions) <= 0.05) and len(idx) == len(boxed)
    slab, _ = softsense.pass_through(cloud, "z", 0.0, 0.1)
    assert np.all((slab.positions[:, 2] >= 0) & (slab.positions[:, 2] <= 0.1))
    sparse, _ = softsense.radius_outlier_removal(cloud, radius=0.03, min_neighbors=3)
    assert len(sparse) <= len(cloud) - 5


def test_bad_input_raises_with_the_librarys_message(tmp_path):
    with pytest.raises(softsense.SoftsenseError, match="nope.pcd"):
        softsense.read_cloud(tmp_path / "nope.pcd")
    with pytest.raises(softsense.SoftsenseError, match="leaf"):
        softsense.voxel_grid(softsense.Cloud(positions=np.zeros((3, 3), np.float32)), -1.0)
    with pytest.raises(TypeError, match="unknown parameter"):
        softsense.voxel_grid(softsense.Cloud(positions=np.zeros((3, 3), np.float32)), 0.1, leafsize=2)
    with pytest.raises(ValueError, match="N x 3"):
        softsense.write_cloud(softsense.Cloud(positions=np.zeros((3, 2), np.float32)), tmp_path / "x.pcd")


def test_clouds_cross_to_open3d_and_back():
    o3d = pytest.importorskip("open3d", reason="Open3D is not installed (pip install softsense[open3d])")
    rng = np.random.default_rng(1)
    cloud = softsense.Cloud(
        positions=rng.normal(size=(100, 3)).astype(np.float32),
        colors=rng.integers(0, 256, size=(100, 3), dtype=np.uint8),
    )
    pcd = cloud.to_open3d()
    assert isinstance(pcd, o3d.geometry.PointCloud) and len(pcd.points) == 100
    back = softsense.Cloud.from_open3d(pcd)
    np.testing.assert_array_equal(back.positions, cloud.positions)
    np.testing.assert_array_equal(back.colors, cloud.colors)
    # Open3D's voxel semantics (grid from the minimum bound) give Open3D's voxel count.
    ours, _ = softsense.voxel_grid(cloud, 0.5, mode="open3d")
    assert len(ours) == len(pcd.voxel_down_sample(0.5).points)
