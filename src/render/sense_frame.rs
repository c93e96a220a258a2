//! One sensed frame drawn for `softsense sense --render`: the camera's colour frame with
//! the robot segment, the registered features, the seen contacts and the force arrows.

use super::canvas::Canvas;
use super::overlay::{
    mask_from_indices, sense_overlay, ContactMark, FeatureMark, ForceArrow, OverlayParams,
    SenseOverlay,
};
use super::project::project_with;
use super::RenderError;
use crate::camera::PinholeIntrinsics;
use crate::sense::{FrameReport, Sensor, View};

/// The picture of `report` over `view`, the frame of the camera whose colour pinhole model
/// is `intrinsics`: the features as the frame's estimate registered them, each force's
/// contact ring and arrow labelled with its index, magnitude and 3-D one-sigma.
pub fn frame_picture(
    intrinsics: &PinholeIntrinsics,
    sensor: &Sensor,
    view: &View,
    report: &FrameReport,
) -> Result<Canvas, RenderError> {
    let frame = Canvas::from_rgb(view.width, view.height, view.color.clone())?;
    let mask = mask_from_indices(view.width, view.height, &view.robot_pixels);
    let camera = &sensor.cameras[view.camera];
    let (cam, eye) = (camera.robot_from_camera.inverse(), camera.eye);
    let px = |p: [f64; 3]| project_with(intrinsics, cam.apply(p));
    let x = if report.positions.is_empty() {
        &sensor.model.problem.mesh.nodes_in_rest
    } else {
        &report.positions
    };
    let features: Vec<FeatureMark> = (report.matches.iter())
        .filter_map(|(f, m)| {
            let (p, n) = (f.position(x), f.normal(x));
            // Another camera's features on faces this one sees from behind are left out.
            let to_eye: [f64; 3] = std::array::from_fn(|i| eye[i] - p[i]);
            if (0..3).map(|i| to_eye[i] * n[i]).sum::<f64>() <= 0.0 {
                return None;
            }
            Some(FeatureMark {
                pixel: px(p)?,
                visible: m.is_some(),
                matched: m.and_then(|m| px([0, 1, 2].map(|i| p[i] + m.offset * n[i]))),
            })
        })
        .collect();
    let contacts: Vec<ContactMark> = (report.forces.iter().enumerate())
        .filter_map(|(i, f)| {
            Some(ContactMark {
                pixel: px(f.seen_at.unwrap_or(f.location))?,
                label: format!("{i}: {}", f.source),
            })
        })
        .collect();
    // Labelled with the contact's index, so each arrow pairs with its contact mark; the
    // 3-D σ is the force's worst direction, which bounds the magnitude's σ.
    let forces: Vec<ForceArrow> = (report.forces.iter().enumerate())
        .map(|(i, f)| {
            let label = format!("{i}: {:.3} N ±{:.3} (3-D)", f.magnitude, f.sigma_max);
            ForceArrow::from_robot(&cam, f.location, f.force, Some(label))
        })
        .collect();
    let seen_by = match sensor.cameras.len() {
        1 => String::new(),
        _ => format!(" ({} of {} cameras)", camera.name, sensor.cameras.len()),
    };
    let title = format!(
        "frame {}{seen_by}: {} force(s), {}/{} features, residual {:.2} mm",
        report.frame,
        report.forces.len(),
        report.features_visible,
        report.features,
        report.residual_rms * 1e3
    );
    let overlay = SenseOverlay {
        title: &title,
        robot_mask: Some(&mask),
        features: &features,
        contacts: &contacts,
        forces: &forces,
    };
    let params = OverlayParams {
        intrinsics: *intrinsics,
        ..Default::default()
    };
    sense_overlay(&frame, &overlay, &params)
}
