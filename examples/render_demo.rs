//! Renders the robot mesh and a few charts with `softsense::render`, into a directory
//! (default `/tmp/render_demo`), to check by eye that the pictures read well:
//!
//! - `surface_height.png`: the robot surface coloured by height (sequential map);
//! - `residual_before_after.png`: a made-up signed "residual" field on the surface before
//!   and after a correction (diverging map), side by side, with feature-point markers;
//! - `criterion_bars.png`: a criterion per candidate effect, with a negative, a NaN and an
//!   infinite value, the chosen one highlighted;
//! - `sense_overlay.png`: the tip-weight scene's colour frame with the robot segment,
//!   feature points, a contact and the force arrow;
//! - `font.png`: every glyph of the built-in font at scales 1 to 3.
//!
//! Run from the repository root: `cargo run --example render_demo [OUT_DIR]`.

use softsense::camera::Camera;
use softsense::fem::meshio::read_mesh;
use softsense::render::{
    bar_chart, project_with, sense_overlay, side_by_side, surface_map, Canvas, ColorMap,
    ContactMark, FeatureMark, ForceArrow, OverlayParams, SenseOverlay, SurfaceMapParams,
    SurfaceMesh, SurfaceValues, BLACK, WHITE,
};
use std::path::{Path, PathBuf};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "/tmp/render_demo".into()),
    );
    std::fs::create_dir_all(&out)?;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut mesh = read_mesh(&root.join("meshes/robot.vtu"))?;
    for p in &mut mesh.nodes_in_rest {
        *p = p.map(|c| c * 1e-3); // mm -> m
    }
    let surface = mesh.surface();
    let vertices = &mesh.nodes_in_rest;
    println!(
        "robot: {} nodes, {} surface triangles",
        vertices.len(),
        surface.triangles.len()
    );

    // 1. Height on the surface.
    let height_mm: Vec<f64> = vertices.iter().map(|p| p[2] * 1e3).collect();
    let view = Camera::orbit(vertices, -60.0, 30.0, 640, 480).ok_or("no view")?;
    let start = std::time::Instant::now();
    let picture = surface_map(
        &SurfaceMesh {
            vertices_in_robot: vertices,
            triangles: &surface.triangles,
            values: SurfaceValues::PerVertex(&height_mm),
            markers: &[],
        },
        &view,
        &SurfaceMapParams {
            title: "Robot surface, height above the base (mm)".into(),
            value_label: "z mm".into(),
            ..SurfaceMapParams::default()
        },
    )?;
    println!("surface_map: {:.1} ms", start.elapsed().as_secs_f64() * 1e3);
    picture.save_png(out.join("surface_height.png"))?;

    // 2. A signed residual before and after: a bending-like field, then 10% of it.
    let before: Vec<f64> = vertices
        .iter()
        .map(|p| 1e3 * p[0] * p[2] / 0.125 * 0.1 + 0.4 * (p[1] * 40.0).sin())
        .collect();
    let after: Vec<f64> = before.iter().map(|v| 0.1 * v).collect();
    let markers_before: Vec<([f64; 3], f64)> = surface
        .nodes
        .iter()
        .step_by(surface.nodes.len() / 51)
        .map(|&i| (vertices[i], before[i]))
        .collect();
    let markers_after: Vec<([f64; 3], f64)> =
        markers_before.iter().map(|(p, v)| (*p, 0.1 * v)).collect();
    let range = softsense::render::symmetric_range(&before);
    let panel = |values: &[f64], markers: &[([f64; 3], f64)], title: &str| {
        surface_map(
            &SurfaceMesh {
                vertices_in_robot: vertices,
                triangles: &surface.triangles,
                values: SurfaceValues::PerVertex(values),
                markers,
            },
            &view,
            &SurfaceMapParams {
                title: title.into(),
                value_label: "normal mm".into(),
                colormap: ColorMap::Diverging,
                range: Some(range),
                ..SurfaceMapParams::default()
            },
        )
    };
    let b = panel(&before, &markers_before, "held-out residual, nominal model")?;
    let a = panel(
        &after,
        &markers_after,
        "held-out residual, with the fitted effect",
    )?;
    side_by_side(&[("before", &b), ("after", &a)], WHITE)?
        .save_png(out.join("residual_before_after.png"))?;

    // 3. Criterion per candidate effect.
    let labels = [
        "no missing effect",
        "gravity / density",
        "Young's modulus scale",
        "regional stiffness (leg N)",
        "point load",
        "cable offset (north)",
        "camera pose",
        "depth scale + offset",
        "Poisson ratio",
    ];
    let values = [
        412.0,
        388.5,
        -57.25,
        12.0,
        f64::NAN,
        301.0,
        0.0,
        f64::INFINITY,
        402.0,
    ];
    bar_chart(
        "BIC per candidate effect (lower is better)",
        &labels,
        &values,
        Some(2),
        720,
        320,
    )?
    .save_png(out.join("criterion_bars.png"))?;

    // 4. The sense overlay on a generated frame.
    let scene = root.join("clouds/scenes/tip_weight");
    let frame = Canvas::from_png(scene.join("color_0003.png"))?;
    let pose: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(scene.join("camera_pose.json"))?)?;
    let m: [[f64; 4]; 4] = serde_json::from_value(pose["robot_from_camera"].clone())?;
    let camera = softsense::io::intrinsics::read_camera_model(scene.join("intrinsics.json"))?;
    let k = camera.intrinsics;
    let cam = *Camera::from_matrix(k, &m)?.camera_from_robot();
    let mask: Vec<bool> = frame
        .pixels()
        .iter()
        .map(|p| i32::from(p[1]) > i32::from(p[0]) + 60 && i32::from(p[1]) > i32::from(p[2]) + 60)
        .collect();
    let features: Vec<FeatureMark> = surface
        .nodes
        .iter()
        .step_by(surface.nodes.len() / 51)
        .filter_map(|&i| {
            let p = cam.apply(vertices[i]);
            let n = cam.rotate(surface.vertex_normals[i]);
            let uv = project_with(&k, p)?;
            let facing = n[0] * p[0] + n[1] * p[1] + n[2] * p[2] < 0.0;
            Some(FeatureMark {
                pixel: uv,
                visible: facing,
                matched: facing.then_some([uv[0] + 3.0, uv[1] + 4.0]),
            })
        })
        .collect();
    let tip = cam.apply([0.0, 0.0, 0.125]);
    let contacts = vec![ContactMark {
        pixel: project_with(&k, tip).ok_or("tip behind camera")?,
        label: "c1 tip".into(),
    }];
    let forces = vec![ForceArrow::from_robot(
        &cam,
        [0.0, 0.0, 0.125],
        [0.0, 0.0, -1.06],
        Some("1.06 ± 0.02 N".into()),
    )];
    let start = std::time::Instant::now();
    let picture = sense_overlay(
        &frame,
        &SenseOverlay {
            title: "tip_weight frame 3: 1 contact, 1.06 N",
            robot_mask: Some(&mask),
            features: &features,
            contacts: &contacts,
            forces: &forces,
        },
        &OverlayParams {
            intrinsics: k,
            metres_per_newton: None,
            ..OverlayParams::default()
        },
    )?;
    println!(
        "sense_overlay: {:.1} ms",
        start.elapsed().as_secs_f64() * 1e3
    );
    picture.save_png(out.join("sense_overlay.png"))?;

    // 5. The font.
    let mut sheet = Canvas::new(620, 240, WHITE)?;
    let ascii: String = (32u8..=126)
        .map(char::from)
        .chain("°±µ²³·×σχΔ≤≥→".chars())
        .collect();
    let mut y = 6;
    for scale in 1..=2u32 {
        let chars: Vec<char> = ascii.chars().collect();
        let per_line = 600 / softsense::render::text_size("M", scale).0.max(1) as usize;
        for chunk in chars.chunks(per_line) {
            let line: String = chunk.iter().collect();
            sheet.text(6, y, &line, BLACK, scale);
            y += i64::from(softsense::render::text_size(&line, scale).1) + 4;
        }
    }
    sheet.save_png(out.join("font.png"))?;
    println!("wrote pictures into {}", out.display());
    Ok(())
}
