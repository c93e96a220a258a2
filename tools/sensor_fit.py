#!/usr/bin/env python3
"""Fit a depth-sensor artefact model on real frames: temporal noise against distance and
incidence, flying pixels at depth edges, holes, quantisation.

Data: $SOFTSENSE_DATA/punyo (rest frames 0-60, RealSense, 0.1 mm units) and
$SOFTSENSE_DATA/pcl/grabber_sequence (3 Kinect frames, mm). Needs numpy and cv2 only.

    python3 tools/sensor_fit.py [--data DIR] [--only punyo|kinect] [--json OUT]

Prints every number docs/sensing.md ("Sensor artefacts fitted on real frames") quotes;
--json writes them too (the data test in tests/integration/sensor_fit.rs reads that).
The definitions (edge band, flat mask, flying pixel) are in the functions' docstrings.
"""

import argparse
import glob
import json
import os
import sys

import warnings

import cv2
import numpy as np

warnings.simplefilter("ignore", RuntimeWarning)
np.seterr(all="ignore")

PUNYO_UNIT = 1e-4  # m per raw unit (README)
KINECT_UNIT = 1e-3


def window(a, size, fn):
    """`fn` (np.nanmax / np.nanmin ...) over a size x size window, NaN outside."""
    r = size // 2
    p = np.pad(a, r, constant_values=np.nan)
    stack = [p[dv:dv + a.shape[0], du:du + a.shape[1]] for dv in range(size) for du in range(size)]
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return fn(np.stack(stack), axis=0)


def crossings(z, jump):
    """Depth-edge crossings along rows and columns. A crossing goes from a flat side to a
    flat side (each side's next pixel within jump/4 of it) with a jump over `jump` (m):
    straight (two adjacent pixels), through one flying pixel b (t = (b - a) / (c - a) in
    (0.1, 0.9)), or through a run of 1-3 holes. Returns the counts, the flying share of
    pixel crossings, the hole share of all crossings, and the quartiles of t."""
    direct = fly = holes = 0
    ts = []
    q = jump / 4
    for img in (z, z.T):
        a0, a, b, c, c1 = (img[:, i:img.shape[1] - 4 + i] for i in range(5))
        flat_a = np.abs(a - a0) < q
        # straight: a | b, with b's next (c) flat
        d = flat_a & (np.abs(b - a) > jump) & (np.abs(c - b) < q)
        direct += int(d.sum())
        t = (b - a) / (c - a)
        f = flat_a & (np.abs(c - a) > jump) & (np.abs(c1 - c) < q) & (t > 0.1) & (t < 0.9)
        fly += int(f.sum())
        ts.append(t[f])
        # holes: a, then 1-3 NaN, then a valid flat far side
        for n in (1, 2, 3):
            if img.shape[1] < n + 4:
                continue
            cols = [img[:, i:img.shape[1] - (n + 3) + i] for i in range(n + 4)]
            p0, p1 = cols[0], cols[1]
            gap = np.all([np.isnan(x) for x in cols[2:2 + n]], axis=0)
            e0, e1 = cols[2 + n], cols[3 + n]
            h = (np.abs(p1 - p0) < q) & gap & (np.abs(e1 - e0) < q) & (np.abs(e0 - p1) > jump)
            holes += int(h.sum())
    t = np.concatenate(ts)
    total = direct + fly + holes
    return {
        "crossings": int(total),
        "straight": int(direct),
        "through_flying_pixel": int(fly),
        "through_holes": int(holes),
        "flying_share_of_pixel_crossings": fly / max(direct + fly, 1),
        "hole_share_of_crossings": holes / max(total, 1),
        "t_quartiles": [float(x) for x in np.percentile(t, [25, 50, 75])] if t.size else [],
    }


def pooled(frames, jump):
    """`crossings` summed over frames (the t quartiles of all flying pixels)."""
    rs = [crossings(f, jump) for f in frames]
    keys = ["crossings", "straight", "through_flying_pixel", "through_holes"]
    out = {k: sum(r[k] for r in rs) for k in keys}
    pix = out["straight"] + out["through_flying_pixel"]
    out["flying_share_of_pixel_crossings"] = out["through_flying_pixel"] / max(pix, 1)
    out["hole_share_of_crossings"] = out["through_holes"] / max(out["crossings"], 1)
    ts = [r["t_quartiles"] for r in rs if r["t_quartiles"]]
    out["t_quartiles_mean_over_frames"] = [float(np.mean([t[j] for t in ts])) for j in range(3)]
    out["frames"] = len(frames)
    return out


def normals_cos(points):
    """cos of the incidence angle per pixel: |n . ray| with n from the cross product of
    central differences over 2 pixels of the organised points (H x W x 3)."""
    du = np.roll(points, -2, axis=1) - np.roll(points, 2, axis=1)
    dv = np.roll(points, -2, axis=0) - np.roll(points, 2, axis=0)
    n = np.cross(du, dv)
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    ray = points / np.linalg.norm(points, axis=2, keepdims=True)
    c = np.abs((n * ray).sum(axis=2))
    c[:2, :] = c[-2:, :] = np.nan
    c[:, :2] = c[:, -2:] = np.nan
    return c


def binned(x, y, edges, fn=np.median, min_count=200):
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = (x >= lo) & (x < hi)
        if m.sum() >= min_count:
            out.append((float(lo), float(hi), int(m.sum()), float(fn(y[m]))))
    return out


def fit_floor_k(rows):
    """Least squares sigma = s0 + k z^2 on binned (z mid, sigma) rows, weighted by count."""
    z = np.array([(a + b) / 2 for a, b, _, _ in rows])
    s = np.array([r[3] for r in rows])
    w = np.sqrt(np.array([r[2] for r in rows], float))
    A = np.stack([np.ones_like(z), z * z], 1) * w[:, None]
    (s0, k), *_ = np.linalg.lstsq(A, s * w, rcond=None)
    return float(s0), float(k)


def gaps(values, lo, hi, width):
    """Median gap between the distinct raw values present, per band of `width` raw units."""
    u = np.unique(values)
    out = []
    for b in range(lo, hi, width):
        uu = u[(u >= b) & (u < b + width)]
        if uu.size > 2:
            out.append([b, b + width, int(uu.size), float(np.median(np.diff(uu)))])
    return out


def steps(values_per_pixel):
    """Per pixel, the smallest non-zero difference between the distinct values it took
    (raw units). values_per_pixel: frames x pixels."""
    v = np.sort(values_per_pixel, axis=0)
    d = np.diff(v, axis=0).astype(float)
    d[d == 0] = np.inf
    m = d.min(axis=0)
    m[~np.isfinite(m)] = np.nan
    return m


def holes_where(valid_stack, z_mean, cos, gray):
    """Where the holes are. Persistent holes (never valid), flicker (valid in some frames),
    and the dropout rate of flickering pixels by distance to the persistent holes, by
    incidence and by brightness."""
    n = valid_stack.shape[0]
    rate = 1.0 - valid_stack.mean(axis=0)
    never = rate == 1.0
    always = rate == 0.0
    flick = ~never & ~always
    dist = cv2.distanceTransform((~never).astype(np.uint8), cv2.DIST_L2, 3)
    seen = ~never
    out = {
        "frames": int(n),
        "hole_fraction_per_frame": [float(x) for x in (1 - valid_stack.mean(axis=(1, 2)))],
        "never_valid": float(never.mean()),
        "always_valid": float(always.mean()),
        "flicker": float(flick.mean()),
        "flicker_dropout_rate_mean": float(rate[flick].mean()),
        "dropout_by_distance_px": [],
        "dropout_by_cos_incidence": [],
        "dropout_by_brightness": [],
    }
    for lo, hi in [(0, 2), (2, 5), (5, 10), (10, 20), (20, 1e9)]:
        m = seen & (dist > lo) & (dist <= hi)
        if m.sum():
            out["dropout_by_distance_px"].append([lo, hi, int(m.sum()), float(rate[m].mean())])
    far = seen & (dist > 10) & ~np.isnan(cos)
    for lo, hi in [(0.0, 0.5), (0.5, 0.7), (0.7, 0.85), (0.85, 0.95), (0.95, 1.01)]:
        m = far & (cos >= lo) & (cos < hi)
        if m.sum() >= 100:
            out["dropout_by_cos_incidence"].append([lo, hi, int(m.sum()), float(rate[m].mean())])
    far = seen & (dist > 10)
    for lo, hi in [(0, 40), (40, 80), (80, 130), (130, 256)]:
        m = far & (gray >= lo) & (gray < hi)
        if m.sum() >= 100:
            out["dropout_by_brightness"].append([lo, hi, int(m.sum()), float(rate[m].mean())])
    out["random_dropout_far_from_holes"] = float(rate[seen & (dist > 20)].mean())
    return out


def punyo(data):
    d = os.path.join(data, "punyo")
    raw = np.stack([cv2.imread(os.path.join(d, "depth_%04d.png" % i), cv2.IMREAD_UNCHANGED)
                    for i in range(61)]).astype(np.float64)
    valid = (raw > 0) & (raw < 65535)
    z = np.where(valid, raw * PUNYO_UNIT, np.nan)
    rays = np.load(os.path.join(d, "rays.npy")).astype(np.float64)
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            zm = np.nanmean(z, axis=0)
    pts = np.stack([rays[..., 0] * zm, rays[..., 1] * zm, zm], axis=2)
    cos = normals_cos(pts)
    gray = cv2.cvtColor(cv2.imread(os.path.join(d, "color_0000.jpg")), cv2.COLOR_BGR2GRAY)
    out = {"holes": holes_where(valid, zm, cos, gray.astype(float))}

    # Temporal noise: always-valid pixels away from edges (no 10 mm jump in a 5x5 window)
    # and 3 px away from any pixel that is ever a hole.
    always = valid.all(axis=0)
    near_hole = window(np.where(always, 0.0, 1.0), 7, np.nanmax) > 0
    edge = (window(zm, 5, np.nanmax) - window(zm, 5, np.nanmin)) > 0.010
    flat = always & ~near_hole & ~edge & ~np.isnan(cos)
    sd = np.std(z[:, flat], axis=0, ddof=1)
    zf, cf = zm[flat], cos[flat]
    rows = binned(zf, sd, np.arange(0.05, 0.26, 0.02))
    s0, k = fit_floor_k(rows)
    sd_all = np.std(z[:, always], axis=0, ddof=1)
    out["noise"] = {
        "sigma_by_z_every_always_valid_pixel": binned(zm[always], sd_all,
                                                       np.arange(0.05, 0.26, 0.02)),
        "flat_pixels": int(flat.sum()),
        "sigma_median_m": float(np.median(sd)),
        "sigma_by_z": rows,
        "fit_sigma0_m": s0,
        "fit_k_per_m": k,
        # Incidence at one depth band (80-160 mm, where most pixels are), so depth does not
        # stand in for it.
        "sigma_by_cos_incidence_80_160mm": binned(
            cf[(zf > 0.08) & (zf < 0.16)], sd[(zf > 0.08) & (zf < 0.16)],
            [0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 1.01]),
        "quantisation_share_m": PUNYO_UNIT / np.sqrt(12),
    }
    st = steps(raw[:, always])
    ok = ~np.isnan(st)
    zf_all = zm[always]
    out["quantisation"] = {
        "unit_m": PUNYO_UNIT,
        "step_raw_share": {str(s): float((st[ok] == s).mean()) for s in (1, 2, 3)},
        "step_raw_median_by_z": binned(zf_all[ok], st[ok], np.arange(0.05, 0.26, 0.02),
                                       min_count=100),
        # Steps seen anywhere: the gaps between distinct depths in 10 mm bands, all frames.
        "distinct_gap_raw_by_z": gaps(raw[valid], 500, 2500, 100),
    }
    # Flying pixels and edge holes, frames 0, 10, ..., 60 pooled: jumps over 10 mm.
    out["flying"] = dict(pooled([z[i] for i in range(0, 61, 10)], 0.010), jump_m=0.010)
    return out


def kinect(data):
    fs = sorted(glob.glob(os.path.join(data, "pcl", "grabber_sequence", "*_depth.tiff")))
    if len(fs) != 3:
        sys.exit(f"expected 3 Kinect depth frames, found {len(fs)}")
    raw = np.stack([cv2.imread(f, cv2.IMREAD_UNCHANGED) for f in fs]).astype(np.float64)
    valid = raw > 0
    z = np.where(valid, raw * KINECT_UNIT, np.nan)
    always = valid.all(axis=0)
    out = {"holes": {
        "hole_fraction_per_frame": [float(x) for x in 1 - valid.mean(axis=(1, 2))],
        "never_valid": float((~valid.any(axis=0)).mean()),
        "flicker": float((valid.any(axis=0) & ~always).mean()),
        # The left band of the depth image has no IR-projector overlap (Kinect v1: 8 px).
        "holes_in_left_8_columns": float((~valid[0][:, :8]).mean()),
    }}
    # Motion between frames: the median change over pixels valid in both.
    diffs = {}
    for a, b in [(0, 1), (0, 2), (1, 2)]:
        diffs[f"{a}-{b}"] = float(np.median((z[b] - z[a])[always]))
    out["median_change_m"] = diffs
    # Flat, static mask: valid in all 3 frames, no 20 mm jump in a 5x5 window, 3 px from
    # holes, and a 3-frame spread at most twice its 9x9 neighbourhood's median spread.
    zm = np.nanmean(z, axis=0)
    near_hole = window(np.where(always, 0.0, 1.0), 7, np.nanmax) > 0
    edge = (window(zm, 5, np.nanmax) - window(zm, 5, np.nanmin)) > 0.020
    spread = np.where(always, np.nanmax(z, 0) - np.nanmin(z, 0), np.nan)
    med = cv2.medianBlur(np.nan_to_num(spread * 1e3, nan=0).astype(np.float32), 5) * 1e-3
    base = always & ~near_hole & ~edge
    static = base & (spread <= 2 * med + KINECT_UNIT)
    res = {}
    for name, frames in [("frames 0-1", [0, 1]), ("frames 0-2", [0, 1, 2])]:
        for mname, m in [("all valid", always), ("flat static", static)]:
            sd = np.std(z[frames][:, m], axis=0, ddof=1)
            zz = zm[m]
            rows = binned(zz, sd / zz ** 2, np.arange(0.6, 1.8, 0.2), fn=np.mean)
            res[f"{name}, {mname}"] = {
                "pixels": int(m.sum()),
                "sigma_over_z2_mean_per_m": float(np.mean(sd / zz ** 2)),
                "rms_sigma_over_z2_per_m": float(np.sqrt(np.mean((sd / zz ** 2) ** 2))),
                "by_z": rows,
            }
    out["noise"] = res
    # Quantisation: gaps between the distinct depths present in a depth band of frame 0.
    u = np.unique(raw[0][valid[0]])
    q = []
    for lo in range(600, 1800, 200):
        uu = u[(u >= lo) & (u < lo + 200)]
        if uu.size > 2:
            zc = (lo + 100) * KINECT_UNIT
            q.append([lo * KINECT_UNIT, (lo + 200) * KINECT_UNIT,
                      float(np.median(np.diff(uu))) * KINECT_UNIT, zc])
    zc = np.array([r[3] for r in q])
    st = np.array([r[2] for r in q])
    out["quantisation"] = {
        "unit_m": KINECT_UNIT,
        "step_by_z": [r[:3] for r in q],
        "step_k_per_m": float((st * zc ** 2).sum() / (zc ** 4).sum()),
    }
    out["flying"] = dict(pooled(list(z), 0.05), jump_m=0.05)
    return out


def generator(fit, unit, kinect):
    """The `[sensor]` values these numbers give (docs/sensing.md says which are fitted and
    which are kept): noise σ₀ with the unit's rounding taken out, p = s / (2 - s) for a
    flying share s of crossings (two edge pixels per crossing, either may fly), the spread
    of t from its quartiles (uniform in 1/2 ± spread/2 has an interquartile range of
    spread/2)."""
    s = fit["flying"]["flying_share_of_pixel_crossings"]
    q = fit["flying"]["t_quartiles_mean_over_frames"]
    out = {
        "depth_unit": unit,
        "flying_probability": s / (2 - s),
        "flying_spread": min(1.0, 2 * (q[2] - q[0])),
        "edge_hole_probability": fit["flying"]["hole_share_of_crossings"],
    }
    if kinect:
        out["depth_step_k"] = fit["quantisation"]["step_k_per_m"]
        # The mean 2-frame standard deviation is sqrt(2/pi) of sigma.
        mean = fit["noise"]["frames 0-1, flat static"]["sigma_over_z2_mean_per_m"]
        out["depth_k"] = mean / np.sqrt(2 / np.pi)
        out["hole_probability"] = fit["holes"]["flicker"]
    else:
        sig = fit["noise"]["sigma_median_m"]
        out["depth_sigma_floor"] = float(np.sqrt(max(sig ** 2 - unit ** 2 / 12, 0.0)))
        out["hole_probability"] = fit["holes"]["random_dropout_far_from_holes"]
        out["depth_sigma_incidence"] = 0.0
    return out


def show(prefix, v):
    if isinstance(v, dict):
        for k, x in v.items():
            show(f"{prefix}.{k}" if prefix else k, x)
    elif isinstance(v, float):
        print(f"{prefix}: {v:.6g}")
    elif isinstance(v, list) and v and isinstance(v[0], (list, tuple)):
        print(f"{prefix}:")
        for r in v:
            print("   ", "  ".join(f"{x:.6g}" if isinstance(x, float) else str(x) for x in r))
    elif isinstance(v, list) and v and isinstance(v[0], float):
        print(f"{prefix}: [{', '.join(f'{x:.4g}' for x in v)}]")
    else:
        print(f"{prefix}: {v}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=os.environ.get("SOFTSENSE_DATA"))
    ap.add_argument("--only", choices=["punyo", "kinect"])
    ap.add_argument("--json")
    a = ap.parse_args()
    if not a.data:
        sys.exit("set SOFTSENSE_DATA or pass --data")
    out = {}
    if a.only in (None, "punyo"):
        out["punyo"] = punyo(a.data)
        out["punyo"]["generator"] = generator(out["punyo"], PUNYO_UNIT, False)
    if a.only in (None, "kinect"):
        out["kinect"] = kinect(a.data)
        out["kinect"]["generator"] = generator(out["kinect"], KINECT_UNIT, True)
    show("", out)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
