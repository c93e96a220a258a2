#!/usr/bin/env python3
"""Reference implementation of the Punyo protocol (issue 53, docs/real-data.md).

NOT softsense: a small numpy/scipy script that fixes the method and its protocol before
softsense implements them, and serves as the oracle for that implementation. It reads
`$SOFTSENSE_DATA/punyo` in place (default ../shared/data/punyo) and writes OUT/summary.json
in the issue's format.

Method (all fixed on frames 0-70; frames 71-149 are only sensed):
- camera points to the mesh frame by the source's 25 deg rotation about the camera's y axis
  (the camera sits at the mesh origin; checked: rest points lie 0.25 mm from the mesh nodes,
  median);
- each mesh node is observed along its camera ray: the median depth of a 5x5 pixel window
  around the node's pixel (found in the ray table); nodes off the image, on the rim, or with
  a rest-frame scatter (MAD over frames 5-60) above 0.5 mm are not observed;
- the rest shape is what the camera sees in frames 0-4: each observed node moved along its
  ray to the mean observed range;
- the membrane is linear, about that rest shape: plane-stress triangles (modulus x thickness
  Et, nu = 0.3) plus the geometric stiffness of an isotropic pre-tension T (N/m), which is
  what makes an inflated membrane stiff; Et = 0.1 T;
- the pressure change from frames 0-4 is a known load (area-weighted outward normals);
- the unknown load is a non-negative inward push at every free node: min |A l - b|^2 / s^2
  over l >= 0 (NNLS), A the ray-projected compliance, s the per-node noise (>= 0.05 mm);
- T is fitted on frames 0, 5, ..., 55 and 60-70 against the measured magnitude (grid);
- sigma of |F|: 0.1 N (the rest frames' scatter) in quadrature with k |F|, k the RMS
  relative misfit of the fit's loaded frames 63-70 (the model-error term).

Usage: punyo_reference.py OUT
"""

import json
import os
import sys
import warnings

import cv2
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl
from scipy.optimize import nnls
from scipy.spatial import cKDTree

NU = 0.3
ET_OVER_T = 0.1
TENSIONS = [100, 150, 200, 250, 300, 350, 400, 500, 600, 800]
FIT_FRAMES = list(range(0, 60, 5)) + list(range(60, 71))
REST_FRAMES = range(5)


def read_vtk(path):
    """Binary legacy VTK 5.1: points, triangles and the vertex cells (the clamped rim)."""
    d = open(path, "rb").read()
    head = d.index(b"POINTS ")
    n = int(d[head:d.index(b"\n", head)].split()[1])
    i = d.index(b"\n", head) + 1
    pts = np.frombuffer(d[i:i + n * 24], dtype=">f8").reshape(-1, 3).copy()
    j = d.index(b"CELLS ", i)
    nc, ns = (int(v) for v in d[j:d.index(b"\n", j)].split()[1:3])
    k = d.index(b"OFFSETS vtktypeint64\n", j) + len(b"OFFSETS vtktypeint64\n")
    off = np.frombuffer(d[k:k + nc * 8], dtype=">i8")
    k = d.index(b"CONNECTIVITY vtktypeint64\n", k) + len(b"CONNECTIVITY vtktypeint64\n")
    con = np.frombuffer(d[k:k + ns * 8], dtype=">i8")
    cells = [con[off[c]:off[c + 1]] for c in range(nc - 1)]
    tris = np.array([c for c in cells if len(c) == 3])
    rim = np.array([c[0] for c in cells if len(c) == 1])
    return pts, tris, rim


def triangle_frame(x):
    e1 = x[1] - x[0]
    nrm = np.cross(e1, x[2] - x[0])
    area = np.linalg.norm(nrm) / 2
    e1 = e1 / np.linalg.norm(e1)
    e2 = np.cross(nrm / np.linalg.norm(nrm), e1)
    t = np.stack([e1, e2])
    xy = (x - x[0]) @ t.T
    b = np.array([xy[1, 1] - xy[2, 1], xy[2, 1] - xy[0, 1], xy[0, 1] - xy[1, 1]]) / (2 * area)
    c = np.array([xy[2, 0] - xy[1, 0], xy[0, 0] - xy[2, 0], xy[1, 0] - xy[0, 0]]) / (2 * area)
    return t, area, b, c


def stiffness(x, tris, et, tension):
    """Plane-stress membrane (Et) plus the geometric stiffness of pre-tension T."""
    n = len(x)
    dm = et / (1 - NU**2) * np.array([[1, NU, 0], [NU, 1, 0], [0, 0, (1 - NU) / 2]])
    rows, cols, vals = [], [], []
    for tri in tris:
        t, area, b, c = triangle_frame(x[tri])
        bm = np.zeros((3, 6))
        for k in range(3):
            bm[0, 2 * k], bm[1, 2 * k + 1] = b[k], c[k]
            bm[2, 2 * k], bm[2, 2 * k + 1] = c[k], b[k]
        g = np.zeros((6, 9))
        for k in range(3):
            g[2 * k:2 * k + 2, 3 * k:3 * k + 3] = t
        ke = g.T @ (area * bm.T @ dm @ bm) @ g
        ke += np.kron(tension * area * (np.outer(b, b) + np.outer(c, c)), np.eye(3))
        dof = np.concatenate([[3 * v, 3 * v + 1, 3 * v + 2] for v in tri])
        rows.append(np.repeat(dof, 9))
        cols.append(np.tile(dof, 9))
        vals.append(ke.ravel())
    return sp.csc_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(3 * n, 3 * n)
    )


def area_normals(x, tris):
    an = np.zeros_like(x)
    for tri in tris:
        a = np.cross(x[tri[1]] - x[tri[0]], x[tri[2]] - x[tri[0]]) / 2
        an[tri] += a / 3
    return an


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out_dir = sys.argv[1]
    data = os.path.join(os.environ.get("SOFTSENSE_DATA", "../shared/data"), "punyo")
    pts, tris, rim = read_vtk(os.path.join(data, "equalized.vtk"))
    rays = np.load(os.path.join(data, "rays.npy"))
    frames = json.load(open(os.path.join(data, "frames.json")))["frames"]
    a = np.radians(25)
    mesh_from_camera = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    n = len(pts)

    # The node's pixel: nearest ray of the table to the node's (x/z, y/z).
    pc = pts @ mesh_from_camera  # camera frame
    q = pc[:, :2] / pc[:, 2:3]
    flat = rays.reshape(-1, 2)
    valid = np.nonzero(np.isfinite(flat[:, 0]))[0]
    dist, nearest = cKDTree(flat[valid]).query(q)
    pix = valid[nearest]
    h, w = rays.shape[:2]
    vv, uu = pix // w, pix % w

    def node_depths(f):
        z = cv2.imread(os.path.join(data, f"depth_{f:04d}.png"), cv2.IMREAD_UNCHANGED)
        if z is None:
            return np.full(n, np.nan)
        z = z.astype(float)
        z[(z == 0) | (z == 65535) | ~np.isfinite(rays[..., 0])] = np.nan
        out = np.full(n, np.nan)
        for i in range(n):
            win = z[max(vv[i] - 2, 0):vv[i] + 3, max(uu[i] - 2, 0):uu[i] + 3]
            win = win[np.isfinite(win)]
            if len(win) >= 5:
                out[i] = np.median(win) * 1e-4
        return out

    z_all = np.array([node_depths(f) for f in range(len(frames))])
    with warnings.catch_warnings():
        # Pixels never measured (a third of the image) make all-NaN columns: NaN is the answer.
        warnings.simplefilter("ignore", RuntimeWarning)
        z_ref = np.nanmean(z_all[list(REST_FRAMES)], 0)
        dz = z_all[5:61] - z_ref
        mad = 1.4826 * np.nanmedian(np.abs(dz - np.nanmedian(dz, 0)), 0)
    seen = (dist < 0.003) & np.isfinite(z_ref) & (mad < 5e-4)
    seen[rim] = False
    x = pts.copy()
    x[seen] = pts[seen] * (z_ref[seen] / pc[seen, 2])[:, None]
    free = np.setdiff1d(np.arange(n), rim)
    fdofs = np.concatenate([[3 * v, 3 * v + 1, 3 * v + 2] for v in free])
    an = area_normals(x, tris)
    normal = an / np.linalg.norm(an, axis=1)[:, None]
    obs = np.nonzero(seen)[0]
    ray_dir = x[obs] / np.linalg.norm(x[obs], axis=1)[:, None]
    col = {v: i for i, v in enumerate(free)}
    d = np.zeros((len(obs), len(fdofs)))
    for r, v in enumerate(obs):
        d[r, 3 * col[v]:3 * col[v] + 3] = ray_dir[r]
    pushes = np.zeros((len(fdofs), len(free)))
    for i, v in enumerate(free):
        pushes[3 * i:3 * i + 3, i] = -normal[v]
    pressure_load = an[free].ravel()
    sigma_node = np.maximum(mad[obs], 5e-5)
    p = np.array([fr["pressure_hpa"] for fr in frames]) * 100
    dp = p - p[list(REST_FRAMES)].mean()
    wr = np.array([fr["wrench"] for fr in frames])
    measured = np.linalg.norm(wr[:, :3] - wr[:61, :3].mean(0), axis=1)
    range_scale = np.linalg.norm(x[obs], axis=1) / x[obs, 2]

    def model(tension):
        k = stiffness(x, tris, ET_OVER_T * tension, tension)
        lu = spl.splu(k[fdofs][:, fdofs].tocsc())
        return d @ lu.solve(pushes), d @ lu.solve(pressure_load)

    def sense(f, a_push, a_pressure):
        dr = (z_all[f, obs] - z_ref[obs]) * range_scale
        ok = np.isfinite(dr) & (np.abs(dr) < 0.02) & np.isfinite(dp[f])
        if ok.sum() < 10:
            return None
        a_w = a_push[ok] / sigma_node[ok, None]
        b_w = (dr[ok] - a_pressure[ok] * dp[f]) / sigma_node[ok]
        lam = nnls(a_w, b_w, maxiter=5000)[0]
        return -(normal[free] * lam[:, None]).sum(0)

    best = None
    for tension in TENSIONS:
        a_push, a_pressure = model(tension)
        err = [np.linalg.norm(sense(f, a_push, a_pressure)) - measured[f] for f in FIT_FRAMES]
        rms = float(np.sqrt(np.mean(np.square(err))))
        print(f"fit: T {tension} N/m, rms {rms:.3f} N", file=sys.stderr)
        if best is None or rms < best[0]:
            best = (rms, tension)
    tension = best[1]
    a_push, a_pressure = model(tension)
    rel = [np.linalg.norm(sense(f, a_push, a_pressure)) / measured[f] - 1 for f in range(63, 71)]
    k_model = float(np.sqrt(np.mean(np.square(rel))))
    rows = []
    for f in range(len(frames)):
        force = sense(f, a_push, a_pressure)
        if force is None:
            rows.append({"frame": f, "status": "no_observation", "measured": measured[f]})
            continue
        mag = float(np.linalg.norm(force))
        rows.append({
            "frame": f, "net_force": force.tolist(), "magnitude": mag,
            "sigma": float(np.hypot(0.1, k_model * mag)), "measured": float(measured[f]),
        })
    os.makedirs(out_dir, exist_ok=True)
    summary = {"stiffness": {"tension_n_per_m": tension, "et_n_per_m": ET_OVER_T * tension,
                             "model_error": k_model}, "frames": rows}
    with open(os.path.join(out_dir, "summary.json"), "w") as fh:
        json.dump(summary, fh, indent=1)
    ok = [r for r in rows if "magnitude" in r]
    by = {r["frame"]: r for r in ok}
    plateau = [by[f] for f in range(76, 101) if f in by]
    mean_est = np.mean([r["magnitude"] for r in plateau])
    mean_meas = np.mean([r["measured"] for r in plateau])
    worst = max(abs(r["magnitude"] / r["measured"] - 1) for r in plateau)
    rest = [by[f]["magnitude"] for f in list(range(61)) + list(range(115, 150)) if f in by]
    cover = [abs(by[f]["magnitude"] - by[f]["measured"]) <= 2 * by[f]["sigma"]
             for f in range(64, 111) if f in by]
    print(f"T {tension} N/m, Et {ET_OVER_T * tension} N/m, model error {k_model:.3f}")
    print(f"plateau 76-100: mean |F| {mean_est:.2f} N vs measured {mean_meas:.2f} N "
          f"({mean_est / mean_meas - 1:+.1%}), worst frame {worst:.1%}")
    print(f"rest 0-60, 115-149: max |F| {max(rest):.2f} N, "
          f"{sum(r > 0.5 for r in rest)} of {len(rest)} above 0.5 N")
    print(f"2 sigma coverage 64-110: {np.mean(cover):.1%}")


if __name__ == "__main__":
    main()
