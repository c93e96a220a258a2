//! Coloured markers found in RGB-D frames (issue 36): blobs of the paint colour, their
//! pixels back-projected with their depth, the centre on the surface, identities across
//! frames.
//!
//! Per frame ([`detect_frame`]):
//! 1. **Colour.** A pixel matches when the angle between its RGB vector and the paint's is
//!    below `max_angle_deg` and its brightest channel is at least `min_value`: shading
//!    scales a colour's RGB but keeps its direction, so the test holds in light and shade.
//! 2. **Blobs.** 8-connected components of matching pixels, at least `min_pixels`.
//! 3. **Centre.** A plane is fitted to the blob's back-projected points with a depth
//!    (least squares, then once more without the points beyond 3 robust σ), and every blob
//!    pixel's ray, holes included, is cut with it; the centre is the mean of these cuts.
//!    The rays carry no depth noise, so the lateral position is the disc's pixel centroid
//!    and the depth noise enters only through the plane (σ/√n along its normal). On a
//!    curved patch the fitted plane lies below the surface at the centre by about
//!    r²/(4R) (R the radius of curvature: 0.11 mm for a 3 mm disc on a 20 mm radius).
//! 4. **Area check.** The blob's area on the plane (each pixel's footprint t²/(fx·fy·|n·r|),
//!    r its ray with z = 1) against πr²: a blob outside `area_range` is a marker partly
//!    hidden (its centre would be off) or two merged, and is left out.
//!
//! Across frames ([`track_detections`]): a detection takes the identity of the marker
//! whose expected position is nearest (closest pairs first), within `max_jump`; a marker is
//! expected at its last position moved by the displacement of the markers already matched
//! in the frame ([`super::motion`]), so markers that move with the body keep their
//! identities beyond `max_jump`; with a reference layout
//! the markers are the reference's and start at its positions, else the first frame's
//! detections are the markers (named `m0`, `m1`, ... in image order) and a later
//! unmatched detection is a new marker. A marker not detected in a frame is a missing entry.

use super::motion::MotionTracker;
use super::tracks::{MarkerTracks, TrackFrame};
use super::{MarkersError, MarkersResult};
use crate::camera::PinholeIntrinsics;
use crate::math::pose::Pose;
use crate::math::{dot, norm, sub};

/// Options of coloured-marker detection.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectParams {
    /// Paint colour (0-255 RGB; default [30, 60, 230], `scene generate`'s default paint).
    pub colour: [u8; 3],
    /// A pixel matches when its RGB vector is within this angle of the paint's (degrees;
    /// default 12).
    pub max_angle_deg: f64,
    /// And its brightest channel is at least this (0-255; default 40): dark pixels have no
    /// reliable hue.
    pub min_value: f64,
    /// Fewest pixels of a blob (default 8).
    pub min_pixels: usize,
    /// Marker disc radius (m; default 0.003), for the area check.
    pub radius: f64,
    /// A blob's area on the surface must be within this range of πr² (default [0.6, 1.6]).
    pub area_range: [f64; 2],
    /// A detection farther than this from where a marker is expected (its last position
    /// moved by its matched neighbours' displacement, [`super::motion`]) is not that marker
    /// (m; default 0.01).
    pub max_jump: f64,
}

impl Default for DetectParams {
    fn default() -> Self {
        Self {
            colour: [30, 60, 230],
            max_angle_deg: 12.0,
            min_value: 40.0,
            min_pixels: 8,
            radius: 0.003,
            area_range: [0.6, 1.6],
            max_jump: 0.01,
        }
    }
}

impl DetectParams {
    /// Checks every field's range; the error names the first bad one.
    pub fn validate(&self) -> MarkersResult<()> {
        let bad = |field, expected, value: String| {
            Err(MarkersError::DetectOption {
                field,
                expected,
                value,
            })
        };
        if !(self.max_angle_deg > 0.0 && self.max_angle_deg < 90.0) {
            return bad(
                "max_angle_deg",
                "in (0, 90)",
                self.max_angle_deg.to_string(),
            );
        }
        if !(self.min_value.is_finite() && self.min_value >= 0.0) {
            return bad("min_value", ">= 0", self.min_value.to_string());
        }
        if self.colour == [0, 0, 0] {
            return bad("colour", "not black", format!("{:?}", self.colour));
        }
        if !(self.radius > 0.0 && self.radius.is_finite()) {
            return bad("radius", "finite and > 0", self.radius.to_string());
        }
        if self.max_jump.is_nan() || self.max_jump <= 0.0 {
            return bad("max_jump", "> 0", self.max_jump.to_string());
        }
        let [lo, hi] = self.area_range;
        if !(lo >= 0.0 && hi >= lo && hi.is_finite()) {
            return bad("area_range", "0 <= lo <= hi", format!("[{lo}, {hi}]"));
        }
        Ok(())
    }
}

/// One marker found in a frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// Centre on the surface (m, robot frame).
    pub position: [f64; 3],
    /// Pixel centroid `[u, v]`.
    pub pixel: [f64; 2],
    /// Pixels in the blob.
    pub pixels: usize,
    /// Of which with a depth.
    pub with_depth: usize,
    /// The blob's area on the fitted plane over πr².
    pub area_ratio: f64,
}

/// Per pixel, whether its colour matches the paint (see the module docs).
pub fn colour_mask(colours: &[[u8; 3]], params: &DetectParams) -> Vec<bool> {
    let c = params.colour.map(f64::from);
    let cn = norm(c);
    let cos_max = params.max_angle_deg.to_radians().cos();
    colours
        .iter()
        .map(|p| {
            let p = p.map(f64::from);
            let pn = norm(p);
            p.iter().copied().fold(0.0, f64::max) >= params.min_value
                && pn > 0.0
                && dot(p, c) >= cos_max * pn * cn
        })
        .collect()
}

/// The 8-connected components of `mask` (row-major, `width` columns) with at least
/// `min_pixels` pixels, each as its pixel indices, in order of their first pixel.
pub fn find_blobs(mask: &[bool], width: usize, min_pixels: usize) -> Vec<Vec<usize>> {
    if width == 0 {
        return Vec::new();
    }
    let height = mask.len() / width;
    let mut seen = vec![false; mask.len()];
    let mut blobs = Vec::new();
    let mut stack = Vec::new();
    for start in 0..width * height {
        if !mask[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        stack.push(start);
        let mut blob = Vec::new();
        while let Some(i) = stack.pop() {
            blob.push(i);
            let (u, v) = ((i % width) as i64, (i / width) as i64);
            for dv in -1..=1 {
                for du in -1..=1 {
                    let (nu, nv) = (u + du, v + dv);
                    if nu < 0 || nv < 0 || nu >= width as i64 || nv >= height as i64 {
                        continue;
                    }
                    let j = nv as usize * width + nu as usize;
                    if mask[j] && !seen[j] {
                        seen[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
        if blob.len() >= min_pixels {
            blob.sort_unstable();
            blobs.push(blob);
        }
    }
    blobs
}

/// A plane `n·p = d` (unit n) fitted to `points` by least squares; `None` for fewer than
/// three points or a degenerate set.
fn fit_plane(points: &[[f64; 3]]) -> Option<([f64; 3], f64)> {
    if points.len() < 3 {
        return None;
    }
    let m = points.len() as f64;
    let mut c = [0.0; 3];
    for p in points {
        (0..3).for_each(|k| c[k] += p[k] / m);
    }
    let mut cov = nalgebra::Matrix3::<f64>::zeros();
    for p in points {
        let q = nalgebra::Vector3::from(sub(*p, c));
        cov += q * q.transpose();
    }
    let eig = cov.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let [k, middle, largest] = order;
    // Collinear points (or one point repeated) span no plane.
    let spread = eig.eigenvalues[middle];
    if spread.is_nan() || spread <= 1e-12 * eig.eigenvalues[largest] {
        return None;
    }
    let v = eig.eigenvectors.column(k);
    let n = [v[0], v[1], v[2]];
    Some((n, dot(n, c)))
}

/// The plane of `points` fitted twice: the second time without the points farther than
/// three robust σ (1.4826 × the median absolute residual, at least 0.1 mm) from the first.
fn robust_plane(points: &[[f64; 3]]) -> Option<([f64; 3], f64)> {
    let (n, d) = fit_plane(points)?;
    let r: Vec<f64> = points.iter().map(|p| (dot(n, *p) - d).abs()).collect();
    let sigma = (1.4826 * crate::math::median(&mut r.clone())).max(1e-4);
    let kept: Vec<[f64; 3]> = (points.iter().zip(&r))
        .filter(|(_, e)| **e <= 3.0 * sigma)
        .map(|(p, _)| *p)
        .collect();
    if kept.len() == points.len() {
        return Some((n, d));
    }
    fit_plane(&kept)
}

/// The centre on the surface of one blob (camera frame; see the module docs), its area
/// over πr² and the number of its pixels with a depth; `None` without a plane.
pub fn locate_blob(
    blob: &[usize],
    points_in_camera: &[[f32; 3]],
    k: &PinholeIntrinsics,
    radius: f64,
) -> Option<([f64; 3], f64, usize)> {
    let w = k.width as usize;
    let with_depth: Vec<[f64; 3]> = (blob.iter())
        .map(|&i| points_in_camera[i].map(f64::from))
        .filter(|p| p.iter().all(|c| c.is_finite()) && p[2] > 0.0)
        .collect();
    let (n, d) = robust_plane(&with_depth)?;
    let (mut sum, mut area) = ([0.0; 3], 0.0);
    for &i in blob {
        let r = [
            ((i % w) as f64 - k.cx) / k.fx,
            ((i / w) as f64 - k.cy) / k.fy,
            1.0,
        ];
        let nr = dot(n, r);
        if nr.abs() < 1e-9 {
            return None; // the plane is seen edge-on
        }
        let t = d / nr;
        (0..3).for_each(|c| sum[c] += t * r[c]);
        area += t * t / (k.fx * k.fy * nr.abs());
    }
    let m = blob.len() as f64;
    let ratio = area / (std::f64::consts::PI * radius * radius);
    Some((sum.map(|s| s / m), ratio, with_depth.len()))
}

/// The markers in one frame: `colours` and `points_in_camera` row-major over the image of
/// `k` (an organized cloud's colours and positions, NaN where there is no depth),
/// `robot_from_camera` the camera pose. Blobs that cannot be located or fail the area
/// check are left out.
pub fn detect_frame(
    colours: &[[u8; 3]],
    points_in_camera: &[[f32; 3]],
    k: &PinholeIntrinsics,
    robot_from_camera: &Pose,
    params: &DetectParams,
) -> MarkersResult<Vec<Detection>> {
    params.validate()?;
    let n = k.width as usize * k.height as usize;
    if colours.len() != n || points_in_camera.len() != n {
        return Err(MarkersError::DetectImage {
            colours: colours.len(),
            points: points_in_camera.len(),
            width: k.width,
            height: k.height,
        });
    }
    let w = k.width as usize;
    let mask = colour_mask(colours, params);
    let mut out = Vec::new();
    for blob in find_blobs(&mask, w, params.min_pixels) {
        let Some((c, ratio, with_depth)) = locate_blob(&blob, points_in_camera, k, params.radius)
        else {
            continue;
        };
        if !(params.area_range[0]..=params.area_range[1]).contains(&ratio) {
            continue;
        }
        let m = blob.len() as f64;
        let pixel = [
            blob.iter().map(|&i| (i % w) as f64).sum::<f64>() / m,
            blob.iter().map(|&i| (i / w) as f64).sum::<f64>() / m,
        ];
        out.push(Detection {
            position: robot_from_camera.apply(c),
            pixel,
            pixels: blob.len(),
            with_depth,
            area_ratio: ratio,
        });
    }
    Ok(out)
}

/// Identities across frames (see the module docs): `frames` are (frame number, that
/// frame's detected positions); `reference` the marker names and positions to start from;
/// `max_jump` (m) how far from its expected position ([`super::motion`]: its last position
/// moved by the displacement of the markers already matched in this frame) a detection may
/// be and still be that marker. Returns the tracks and the number of detections left
/// unassigned (only with a reference: without one they start new markers).
pub fn track_detections(
    frames: &[(u64, Vec<[f64; 3]>)],
    reference: Option<&MarkerTracks>,
    max_jump: f64,
) -> (MarkerTracks, usize) {
    let mut names: Vec<String> = Vec::new();
    let mut tracker = MotionTracker::new(0);
    if let Some(r) = reference {
        names = r.names.clone();
        tracker = MotionTracker::new(names.len());
        let start: Vec<Option<[f64; 3]>> = (0..names.len())
            .map(|m| r.frames.iter().find_map(|f| f.positions[m]))
            .collect();
        tracker.record(&start);
    }
    let mut out = Vec::with_capacity(frames.len());
    let mut dropped = 0;
    for (frame, detected) in frames {
        let matched = tracker.match_step(detected, |_| 0..detected.len(), max_jump);
        let mut positions: Vec<Option<[f64; 3]>> =
            matched.iter().map(|j| j.map(|j| detected[j])).collect();
        let mut used = vec![false; detected.len()];
        matched.iter().flatten().for_each(|&j| used[j] = true);
        for (j, p) in detected.iter().enumerate() {
            if used[j] {
                continue;
            }
            if reference.is_some() {
                dropped += 1;
            } else {
                names.push(format!("m{}", names.len()));
                tracker.add_marker();
                positions.push(Some(*p));
            }
        }
        tracker.record(&positions);
        out.push(TrackFrame {
            frame: *frame,
            positions,
        });
    }
    out.iter_mut()
        .for_each(|f| f.positions.resize(names.len(), None));
    (MarkerTracks { names, frames: out }, dropped)
}

/// Each detected position's distance to the nearest true marker of the same frame (m),
/// over the frames both have; frames are matched by number.
pub fn errors_against(detected: &MarkerTracks, truth: &MarkerTracks) -> Vec<f64> {
    let mut out = Vec::new();
    for f in &detected.frames {
        let Some(t) = truth.frames.iter().find(|t| t.frame == f.frame) else {
            continue;
        };
        for p in f.positions.iter().flatten() {
            let nearest = (t.positions.iter().flatten())
                .map(|q| norm(sub(*p, *q)))
                .fold(f64::INFINITY, f64::min);
            out.push(nearest);
        }
    }
    out
}

/// Every frame of `rec` searched for markers ([`detect_frame`], the recording's camera
/// pose), then identities assigned ([`track_detections`]). Returns the tracks, each
/// frame's detections, and the detections left unassigned.
pub fn detect_recording(
    rec: &crate::recording::Recording,
    params: &DetectParams,
    reference: Option<&MarkerTracks>,
) -> MarkersResult<(MarkerTracks, Vec<Vec<Detection>>, usize)> {
    params.validate()?;
    let pose = (rec.robot_from_camera.as_ref()).ok_or_else(|| MarkersError::NoCameraPose {
        dir: rec.dir.display().to_string(),
    })?;
    let mut all = Vec::with_capacity(rec.frames.len());
    let mut per_frame = Vec::with_capacity(rec.frames.len());
    for &f in &rec.frames {
        let fail = |source| MarkersError::DetectFrame { frame: f, source };
        let cloud = rec.read_frame(f).map_err(fail)?;
        let colours = (cloud.colors.as_ref()).ok_or(MarkersError::NoColour { frame: f })?;
        let mut k = rec.camera_of(f).map_err(fail)?.intrinsics;
        (k.width, k.height) = (cloud.width, cloud.height);
        let found = detect_frame(colours, &cloud.positions, &k, pose, params)?;
        per_frame.push((f as u64, found.iter().map(|d| d.position).collect()));
        all.push(found);
    }
    let (tracks, dropped) = track_detections(&per_frame, reference, params.max_jump);
    Ok((tracks, all, dropped))
}
