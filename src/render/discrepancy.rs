//! The pictures of an `explain` report: the mean held-out residual at each feature point
//! before and after the kept effects, and the selection criterion of the first step.

use super::{
    bar_chart, side_by_side, surface_map, Canvas, ColorMap, RenderError, SurfaceMapParams,
    SurfaceMesh, SurfaceValues, WHITE,
};
use crate::camera::{Camera, PinholeIntrinsics};
use crate::discrepancy::Explanation;
use std::path::Path;

/// The recorded image size.
pub fn recorded_image_size(camera: &Camera) -> [u32; 2] {
    [camera.intrinsics.width, camera.intrinsics.height]
}

/// Mean held-out residual per feature (mm), NaN where never seen.
fn mean_residual_mm(x: &Explanation, which: usize) -> Vec<f64> {
    let mut sum = vec![0.0; x.features.len()];
    let mut n = vec![0usize; x.features.len()];
    for frame in &x.holdout_residuals[which] {
        for r in frame {
            if let Some(s) = sum.get_mut(r.feature) {
                *s += r.r * 1e3;
                n[r.feature] += 1;
            }
        }
    }
    sum.iter()
        .zip(&n)
        .map(|(s, &k)| if k > 0 { s / k as f64 } else { f64::NAN })
        .collect()
}

/// Writes `residual_before.png`, `residual_after.png` (the mean held-out residual at each
/// feature point over the rest surface, seen from the recording's camera, one shared
/// colour range), `residual_before_after.png` (both side by side) and `criterion.png`
/// (ΔBIC per candidate of the first greedy step) into `dir`; returns the file names.
pub fn write_discrepancy_pictures(
    dir: &Path,
    x: &Explanation,
    rest: &[[f64; 3]],
    triangles: &[[usize; 3]],
    camera: &Camera,
    size: [u32; 2],
) -> Result<Vec<String>, RenderError> {
    std::fs::create_dir_all(dir).map_err(|e| RenderError::Image {
        path: dir.display().to_string(),
        message: e.to_string(),
    })?;
    let intr = PinholeIntrinsics {
        width: size[0],
        height: size[1],
        ..camera.intrinsics
    };
    let view = Camera::new(intr, *camera.robot_from_camera());
    let surface = SurfaceMesh {
        vertices_in_robot: rest,
        triangles,
        values: SurfaceValues::None,
        markers: &[],
    };
    let mut written = Vec::new();
    let panels = residual_maps(dir, x, &surface, &view, &mut written)?;
    let refs: Vec<(&str, &Canvas)> = panels.iter().map(|(n, c)| (*n, c)).collect();
    side_by_side(&refs, WHITE)?.save_png(dir.join("residual_before_after.png"))?;
    written.push("residual_before_after.png".into());
    if let Some(chart) = criterion_chart(x)? {
        chart.save_png(dir.join("criterion.png"))?;
        written.push("criterion.png".into());
    }
    Ok(written)
}

/// The residual maps before and after (one shared colour range), each written to
/// `residual_{name}.png` and returned as a panel.
fn residual_maps(
    dir: &Path,
    x: &Explanation,
    surface: &SurfaceMesh<'_>,
    view: &Camera,
    written: &mut Vec<String>,
) -> Result<Vec<(&'static str, Canvas)>, RenderError> {
    let before = mean_residual_mm(x, 0);
    let after = mean_residual_mm(x, 1);
    let lim = before
        .iter()
        .chain(&after)
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(1e-3);
    let mut panels = Vec::new();
    for (name, vals) in [("before", &before), ("after", &after)] {
        let markers: Vec<([f64; 3], f64)> = x
            .features
            .iter()
            .zip(vals.iter())
            .filter(|(_, v)| v.is_finite())
            .map(|(f, v)| (f.rest, *v))
            .collect();
        let mesh = SurfaceMesh {
            markers: &markers,
            ..*surface
        };
        let params = SurfaceMapParams {
            title: format!("held-out residual {name} (mean over frames)"),
            value_label: "residual mm".into(),
            colormap: ColorMap::Diverging,
            range: Some([-lim, lim]),
            marker_radius: 3.0,
            ..Default::default()
        };
        let c = surface_map(&mesh, view, &params)?;
        let file = format!("residual_{name}.png");
        c.save_png(dir.join(&file))?;
        written.push(file);
        panels.push((name, c));
    }
    Ok(panels)
}

/// ΔBIC against no new effect per candidate of the first step (up to 12), if any step.
fn criterion_chart(x: &Explanation) -> Result<Option<Canvas>, RenderError> {
    let Some(step) = x.steps.first() else {
        return Ok(None);
    };
    let cands: Vec<_> = step
        .candidates
        .iter()
        .filter(|c| c.bic.is_finite())
        .take(12)
        .collect();
    let labels: Vec<String> = cands
        .iter()
        .map(|c| format!("{}{}", c.name, if c.refined { "" } else { " (lin)" }))
        .collect();
    let label_refs: Vec<&str> = labels.iter().map(|s| s.as_str()).collect();
    let values: Vec<f64> = cands.iter().map(|c| c.bic - step.bic_current).collect();
    bar_chart(
        "ΔBIC vs no new effect, step 1 (lower is better)",
        &label_refs,
        &values,
        Some(0).filter(|_| step.accepted),
        720,
        40 + 22 * values.len() as u32,
    )
    .map(Some)
}
