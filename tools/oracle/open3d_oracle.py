#!/usr/bin/env python3
"""Open3D 0.20 oracle for softsense's tests and benchmarks.

Usage: open3d_oracle.py JOB.json
  JOB = {"stage": "...", "input": "/abs/in", "output_dir": "/abs/dir",
         "params": {...}, "repeat": 1}
Writes output_dir/result.json (always, also on failure: ok=false, error="...") and, for
stages that produce a cloud, output_dir/cloud.pcd: a binary PCD written by the small
writer below (x y z as float32, normal_x/y/z as float32 when present, rgb as packed
uint32 with colours round(clamp(c,0,1)*255) when present), because Open3D's own writer
cannot write an organized WIDTH x HEIGHT. Stages and parameters: tools/oracle/README.md.
Exit status: 0 when result.json says ok, 1 otherwise, 2 when the job file is unusable.
"""

import json
import os
import sys
import time

import numpy as np
import open3d as o3d


class StageError(Exception):
    """A parameter or input problem reported in result.json."""


def param(params, key, default=None, required=False):
    if key in params and params[key] is not None:
        return params[key]
    if required:
        raise StageError(f"param `{key}` is required")
    return default


def timed(repeat, timings, fn):
    """Runs fn() `repeat` times, appending each wall time in ms; returns the last result."""
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        timings.append((time.perf_counter() - t0) * 1e3)
    return out


def write_pcd(path, points, normals=None, colors=None, width=None, height=1):
    """Binary PCD v0.7 of float32 x y z [+ normals] [+ packed rgb]."""
    n = len(points)
    if width is None:
        width = n
    if width * height != n:
        raise StageError(f"organized size {width}x{height} does not match {n} points")
    cols = [("x", "F"), ("y", "F"), ("z", "F")]
    arrays = [np.asarray(points, dtype=np.float64).astype(np.float32)]
    if normals is not None:
        cols += [("normal_x", "F"), ("normal_y", "F"), ("normal_z", "F")]
        arrays.append(np.asarray(normals, dtype=np.float64).astype(np.float32))
    fields = [c for c, _ in cols]
    rec = [(c, "<f4") for c in fields]
    if colors is not None:
        rec.append(("rgb", "<u4"))
        fields.append("rgb")
    data = np.empty(n, dtype=rec)
    flat = np.concatenate(arrays, axis=1) if arrays else np.empty((n, 0), np.float32)
    for i, c in enumerate(c for c, _ in cols):
        data[c] = flat[:, i]
    if colors is not None:
        c8 = np.rint(np.clip(np.asarray(colors, dtype=np.float64), 0.0, 1.0) * 255.0).astype(np.uint32)
        data["rgb"] = (c8[:, 0] << 16) | (c8[:, 1] << 8) | c8[:, 2]
    types = ["F"] * (len(fields) - (1 if colors is not None else 0)) + (["U"] if colors is not None else [])
    header = (
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
        f"FIELDS {' '.join(fields)}\nSIZE {' '.join(['4'] * len(fields))}\n"
        f"TYPE {' '.join(types)}\nCOUNT {' '.join(['1'] * len(fields))}\n"
        f"WIDTH {width}\nHEIGHT {height}\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n"
    )
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(data.tobytes())
    return fields


def save_cloud(out_dir, result, pcd, normals=None, width=None, height=1):
    pts = np.asarray(pcd.points)
    if normals is None and pcd.has_normals():
        normals = np.asarray(pcd.normals)
    colors = np.asarray(pcd.colors) if pcd.has_colors() else None
    fields = write_pcd(os.path.join(out_dir, "cloud.pcd"), pts, normals, colors, width, height)
    result.update(points=len(pts), width=width if width is not None else len(pts), height=height, fields=fields)


def read_cloud(path):
    pcd = o3d.io.read_point_cloud(path)  # remove_nan_points=False, remove_infinite_points=False
    if len(pcd.points) == 0 and os.path.getsize(path) > 0:
        # Open3D reports read failures only as a warning and an empty cloud.
        with open(path, "rb") as f:
            head = f.read(4096)
        if b"POINTS 0" not in head and b"element vertex 0" not in head:
            raise StageError(f"Open3D read no points from {path}")
    return pcd


def finite_subset(pcd):
    """(cloud of the finite points, their input indices): Open3D's KD-tree is unspecified
    on NaN coordinates, so neighbourhood stages run on finite points only."""
    pts = np.asarray(pcd.points)
    idx = np.flatnonzero(np.isfinite(pts).all(axis=1))
    return pcd.select_by_index(idx.tolist()), idx


def read_image(path, color):
    """uint16 depth or uint8 RGB image as an o3d.geometry.Image. Open3D reads PNG/JPG
    itself; TIFF goes through OpenCV (BGR converted to RGB)."""
    ext = os.path.splitext(path)[1].lower()
    if ext in (".png", ".jpg", ".jpeg"):
        img = o3d.io.read_image(path)
        if np.asarray(img).size == 0:
            raise StageError(f"Open3D could not read {path}")
        return img
    import cv2

    arr = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if arr is None:
        raise StageError(f"OpenCV could not read {path}")
    if color:
        if arr.ndim == 3 and arr.shape[2] == 4:
            arr = cv2.cvtColor(arr, cv2.COLOR_BGRA2RGB)
        elif arr.ndim == 3:
            arr = cv2.cvtColor(arr, cv2.COLOR_BGR2RGB)
    return o3d.geometry.Image(np.ascontiguousarray(arr))


def stage_load(job, result, timings):
    pcd = timed(job["repeat"], timings, lambda: read_cloud(job["input"]))
    save_cloud(job["output_dir"], result, pcd)


def stage_rgbd(job, result, timings):
    p = job["params"]
    depth = read_image(job["input"], color=False)
    color = read_image(param(p, "color", required=True), color=True)
    h, w = np.asarray(depth).shape[:2]
    intr = o3d.camera.PinholeCameraIntrinsic(
        w, h, float(param(p, "fx", required=True)), float(param(p, "fy", required=True)),
        float(param(p, "cx", required=True)), float(param(p, "cy", required=True)))
    scale = float(param(p, "depth_scale", 1000.0))
    trunc = float(param(p, "depth_trunc", 1.0e9))

    def run():
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            color, depth, depth_scale=scale, depth_trunc=trunc, convert_rgb_to_intensity=False)
        return o3d.geometry.PointCloud.create_from_rgbd_image(rgbd, intr, project_valid_depth_only=False)

    pcd = timed(job["repeat"], timings, run)
    save_cloud(job["output_dir"], result, pcd, width=w, height=h)


def stage_crop_box(job, result, timings):
    p = job["params"]
    pcd = read_cloud(job["input"])
    box = o3d.geometry.AxisAlignedBoundingBox(
        np.asarray(param(p, "min", required=True), float), np.asarray(param(p, "max", required=True), float))
    invert = bool(param(p, "invert", False))
    n = len(pcd.points)

    def run():
        inside = np.asarray(box.get_point_indices_within_bounding_box(pcd.points), dtype=np.int64)
        if invert:
            mask = np.ones(n, bool)
            mask[inside] = False
            return np.flatnonzero(mask)
        return np.sort(inside)

    # "time": "cloud" times the cropped cloud with every field (what `pcd.crop(box)`
    # returns); the default times the kept indices only.
    time_what = param(p, "time", "indices")
    if time_what not in ("indices", "cloud"):
        raise StageError('`time` must be "indices" or "cloud"')
    if time_what == "cloud":
        timed(job["repeat"], timings, lambda: pcd.crop(box, invert))
        idx = run()
    else:
        idx = timed(job["repeat"], timings, run)
    result["indices"] = idx.tolist()
    save_cloud(job["output_dir"], result, pcd.select_by_index(idx.tolist()))


def stage_passthrough(job, result, timings):
    """PassThrough on x, y or z as an Open3D crop with infinite bounds on the other axes."""
    p = job["params"]
    axis = {"x": 0, "y": 1, "z": 2}.get(param(p, "field", required=True))
    if axis is None:
        raise StageError("Open3D passthrough supports field x, y or z only")
    lo = np.full(3, -np.inf)
    hi = np.full(3, np.inf)
    lo[axis] = float(param(p, "min", required=True))
    hi[axis] = float(param(p, "max", required=True))
    job["params"] = {"min": lo.tolist(), "max": hi.tolist(), "invert": bool(param(p, "negative", False)),
                     "time": param(p, "time", "indices")}
    stage_crop_box(job, result, timings)


def stage_voxel(job, result, timings):
    leaf = float(param(job["params"], "leaf", required=True))
    # On a cloud with NaN points Open3D's bounding box is NaN and voxel_down_sample returns
    # a single NaN point (measured), so the reference is taken on the finite points.
    pcd, _ = finite_subset(read_cloud(job["input"]))
    out = timed(job["repeat"], timings, lambda: pcd.voxel_down_sample(leaf))
    save_cloud(job["output_dir"], result, out)


def indices_stage(job, result, timings, fn):
    pcd = read_cloud(job["input"])
    finite, to_input = finite_subset(pcd)
    _, kept = timed(job["repeat"], timings, lambda: fn(finite))
    idx = np.sort(to_input[np.asarray(kept, dtype=np.int64)])
    result["indices"] = idx.tolist()
    save_cloud(job["output_dir"], result, pcd.select_by_index(idx.tolist()))


def stage_radius_outlier(job, result, timings):
    p = job["params"]
    nb = int(param(p, "min_neighbors", required=True))
    r = float(param(p, "radius", required=True))
    indices_stage(job, result, timings, lambda c: c.remove_radius_outlier(nb_points=nb, radius=r))


def stage_statistical_outlier(job, result, timings):
    p = job["params"]
    nb = int(param(p, "nb_neighbors", required=True))
    ratio = float(param(p, "std_ratio", required=True))
    indices_stage(job, result, timings, lambda c: c.remove_statistical_outlier(nb_neighbors=nb, std_ratio=ratio))


def stage_normals(job, result, timings):
    p = job["params"]
    pcd = read_cloud(job["input"])
    finite, to_input = finite_subset(pcd)
    finite.normals = o3d.utility.Vector3dVector()  # no prior normals: no orientation hint
    k, radius = param(p, "k"), param(p, "radius")
    if (k is None) == (radius is None):
        raise StageError("normals: give exactly one of `k` and `radius`")
    search = (o3d.geometry.KDTreeSearchParamKNN(int(k)) if k is not None
              else o3d.geometry.KDTreeSearchParamRadius(float(radius)))
    vp = param(p, "viewpoint")

    def run():
        c = o3d.geometry.PointCloud(finite)
        c.estimate_normals(search_param=search)
        if vp is not None:
            c.orient_normals_towards_camera_location(np.asarray(vp, dtype=float))
        return c

    # The copy in run() is part of each timing; it is small next to the search.
    est = timed(job["repeat"], timings, run)
    pts = np.asarray(pcd.points)
    normals = np.full((len(pts), 3), np.nan)
    normals[to_input] = np.asarray(est.normals)
    out = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    save_cloud(job["output_dir"], result, out, normals=normals)


# --- SEGMENTATION STAGES (owned by the `segment` work) ---------------------------------
def stage_cluster_dbscan(job, result, timings):
    """cluster_dbscan(eps, min_points) on the finite points. `labels`: one per input point
    (-1: noise or non-finite); `clusters`: input indices per label, in label order."""
    p = job["params"]
    eps = float(param(p, "eps", required=True))
    min_points = int(param(p, "min_points", required=True))
    pcd = read_cloud(job["input"])
    finite, to_input = finite_subset(pcd)
    labels = timed(job["repeat"], timings,
                   lambda: np.asarray(finite.cluster_dbscan(eps=eps, min_points=min_points, print_progress=False)))
    n = len(pcd.points)
    full = np.full(n, -1, dtype=np.int64)
    full[to_input] = labels
    result["points"] = n
    result["labels"] = full.tolist()
    k = int(labels.max()) + 1 if labels.size else 0
    result["clusters"] = [np.flatnonzero(full == c).tolist() for c in range(k)]
# --- END OF SEGMENTATION STAGES ---------------------------------------------------------


STAGES = {
    "load": stage_load,
    "rgbd_to_cloud": stage_rgbd,
    "passthrough": stage_passthrough,
    "crop_box": stage_crop_box,
    "voxel": stage_voxel,
    "radius_outlier": stage_radius_outlier,
    "statistical_outlier": stage_statistical_outlier,
    "normals": stage_normals,
    "cluster_dbscan": stage_cluster_dbscan,
}


def main():
    if len(sys.argv) != 2:
        print(f"usage: {sys.argv[0]} JOB.json", file=sys.stderr)
        return 2
    try:
        with open(sys.argv[1]) as f:
            job = json.load(f)
        for key in ("stage", "input", "output_dir"):
            if not isinstance(job.get(key), str):
                raise StageError(f"job needs string key `{key}`")
        job["params"] = job.get("params") or {}
        job["repeat"] = max(1, int(job.get("repeat") or 1))
    except (OSError, ValueError, StageError) as e:
        print(f"open3d_oracle: {e}", file=sys.stderr)
        return 2
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    result = {"library": "open3d", "version": o3d.__version__, "stage": job["stage"], "ok": True, "error": None}
    timings = []
    try:
        fn = STAGES.get(job["stage"])
        if fn is None:
            raise StageError(f"unknown stage `{job['stage']}`")
        fn(job, result, timings)
    except Exception as e:  # every failure is reported in result.json
        result.update(ok=False, error=f"{type(e).__name__}: {e}")
    result["timings_ms"] = timings
    with open(os.path.join(job["output_dir"], "result.json"), "w") as f:
        json.dump(result, f)
        f.write("\n")
    if not result["ok"]:
        print(f"open3d_oracle: {result['error']}", file=sys.stderr)
    return 0 if result["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
