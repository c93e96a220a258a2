//! Depth reprojected into the colour camera, and the depth-to-colour extrinsic a RealSense
//! bag records.
//!
//! The RealSense Viewer writes each stream's extrinsic once, as a `geometry_msgs/Transform`
//! on `<stream>/tf/<reference>` (e.g. `/device_0/sensor_1/Color_0/tf/0`): the pose of the
//! reference stream in the stream's frame, `p_stream = R p_reference + t` (librealsense's
//! `rs2_extrinsics` from the reference to the stream, metres). With both streams' transforms
//! to the same reference, `colour_from_depth = colour_from_reference * depth_from_reference⁻¹`.

use super::msg::Transform;
use crate::camera::PinholeIntrinsics;
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion};
use std::collections::HashMap;

/// Farthest a stream may sit from its reference: the streams of one device are
/// centimetres apart, so metres mean a corrupt or wrongly scaled transform.
pub const MAX_TRANSLATION_M: f64 = 10.0;

/// The transform `t` (on `topic`) as an isometry, or why it is implausible: rotation not
/// a finite unit quaternion, translation not finite or `MAX_TRANSLATION_M` or more.
fn isometry(topic: &str, t: &Transform) -> Result<Isometry3<f64>, String> {
    let [x, y, z, w] = t.rotation;
    let q = Quaternion::new(w, x, y, z);
    let [tx, ty, tz] = t.translation;
    let shift = Translation3::new(tx, ty, tz);
    let problem = if !q.coords.iter().all(|v| v.is_finite()) || (q.norm() - 1.0).abs() > 1e-3 {
        format!("rotation {:?} is not a finite unit quaternion", t.rotation)
    } else if !shift.vector.iter().all(|v| v.is_finite())
        || shift.vector.norm() >= MAX_TRANSLATION_M
    {
        format!(
            "translation {:?} m is not finite and under {MAX_TRANSLATION_M} m",
            t.translation
        )
    } else {
        return Ok(Isometry3::from_parts(
            shift,
            UnitQuaternion::from_quaternion(q),
        ));
    };
    Err(format!("geometry_msgs/Transform on {topic}: {problem}"))
}

/// The stream a RealSense image topic belongs to (`/device_0/sensor_0/Depth_0`).
fn stream_of(image_topic: &str) -> &str {
    image_topic
        .strip_suffix("/image/data")
        .unwrap_or(image_topic)
}

/// `colour_from_depth` from the RealSense `tf` topics `tfs` (topic → transform), when both
/// image topics' streams have one to the same reference; `Ok(None)` otherwise, and an
/// error naming the topic when one of the two transforms is implausible.
pub fn realsense_colour_from_depth(
    tfs: &HashMap<String, Transform>,
    depth_topic: &str,
    colour_topic: &str,
) -> Result<Option<Isometry3<f64>>, String> {
    let to_reference = |image_topic: &str| -> HashMap<&str, (&str, &Transform)> {
        let stream = stream_of(image_topic);
        tfs.iter()
            .filter_map(|(topic, t)| {
                let (s, reference) = topic.rsplit_once("/tf/")?;
                (s == stream).then_some((reference, (topic.as_str(), t)))
            })
            .collect()
    };
    let (depth, colour) = (to_reference(depth_topic), to_reference(colour_topic));
    let mut shared: Vec<&&str> = depth.keys().filter(|r| colour.contains_key(**r)).collect();
    shared.sort();
    let Some(reference) = shared.first() else {
        return Ok(None);
    };
    let (topic, t) = depth[**reference];
    let depth_from_reference = isometry(topic, t)?;
    let (topic, t) = colour[**reference];
    let colour_from_reference = isometry(topic, t)?;
    Ok(Some(colour_from_reference * depth_from_reference.inverse()))
}

/// Whether `x` moves points by less than a micrometre (or a microradian).
pub fn is_identity(x: &Isometry3<f64>) -> bool {
    x.translation.vector.norm() < 1e-6 && x.rotation.angle() < 1e-6
}

/// Depth of the depth camera `from` reprojected into the colour camera `to` through
/// `colour_from_depth` (metres; `unit` is metres per depth unit). Each depth pixel covers
/// the colour pixels its footprint's corners map onto (their bounding box); its value is
/// the point's depth in the colour camera; where two land, the nearer surface wins.
pub fn align(
    depth: &[u16],
    unit: f64,
    from: &PinholeIntrinsics,
    to: &PinholeIntrinsics,
    colour_from_depth: &Isometry3<f64>,
) -> Vec<u16> {
    let (wd, hd) = (from.width as usize, from.height as usize);
    let (fxd, fyd, cxd, cyd) = (from.fx, from.fy, from.cx, from.cy);
    let (wc, hc) = (to.width as usize, to.height as usize);
    let (fxc, fyc, cxc, cyc) = (to.fx, to.fy, to.cx, to.cy);
    let range = |a: f64, b: f64, n: usize| {
        let lo = (a + 0.5).round().max(0.0) as usize;
        let hi = ((b + 0.5).round().max(0.0) as usize).min(n);
        lo..hi.max(lo)
    };
    let mut out = vec![0u16; wc * hc];
    for v in 0..hd {
        for u in 0..wd {
            let raw = depth[v * wd + u];
            if raw == 0 {
                continue;
            }
            let z = f64::from(raw) * unit;
            let to_colour = |du: f64, dv: f64| {
                let (x, y) = ((u as f64 + du - cxd) / fxd, (v as f64 + dv - cyd) / fyd);
                colour_from_depth * Point3::new(x * z, y * z, z)
            };
            let centre = to_colour(0.0, 0.0);
            if centre.z <= 0.0 {
                continue;
            }
            let value = (centre.z / unit).round().clamp(1.0, f64::from(u16::MAX)) as u16;
            let (mut umin, mut umax, mut vmin, mut vmax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
            for (du, dv) in [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)] {
                let p = to_colour(du, dv);
                let (uc, vc) = (fxc * p.x / p.z + cxc, fyc * p.y / p.z + cyc);
                (umin, umax) = (umin.min(uc), umax.max(uc));
                (vmin, vmax) = (vmin.min(vc), vmax.max(vc));
            }
            for vc in range(vmin, vmax, hc) {
                for uc in range(umin, umax, wc) {
                    let o = &mut out[vc * wc + uc];
                    if *o == 0 || value < *o {
                        *o = value;
                    }
                }
            }
        }
    }
    out
}
