//! The reference of unloaded frames (`inverse::tare`): a body that sits off its model's
//! surface by a known smooth field, seen from one eye, is fitted and brought back.

use softsense::fem::model::Model;
use softsense::geometry::raycast::Bvh;
use softsense::inverse::tare::{TareFit, TareParams};
use softsense::math::{dot, norm, sub, unit};

/// The bundled robot at rest, its surface triangles, an eye 0.5 m off its side, and the
/// points a camera there sees of a body that sits `offset(p)` outside each surface point p
/// (along the normal); each point with its true offset.
/// Node positions, surface triangles, the eye, and each seen point with its true offset.
type Seen = (
    Vec<[f64; 3]>,
    Vec<[usize; 3]>,
    [f64; 3],
    Vec<([f64; 3], f64)>,
);

fn seen_body(offset: impl Fn([f64; 3]) -> f64) -> Seen {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let model = Model::load(&root.join("meshes/models/robot.toml"), None).unwrap();
    let x = model.problem.mesh.nodes_in_rest.clone();
    let triangles = model.problem.mesh.surface().triangles;
    let [lo, hi] = model.problem.mesh.bbox();
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let eye = [centre[0] + 0.5, centre[1] + 0.1, centre[2] + 0.2];
    let bvh = Bvh::new(&x, &triangles);
    let mut points = Vec::new();
    for i in 0..80 {
        for j in 0..80 {
            let target = [
                centre[0],
                lo[1] + (hi[1] - lo[1]) * (i as f64 + 0.5) / 80.0,
                lo[2] + (hi[2] - lo[2]) * (j as f64 + 0.5) / 80.0,
            ];
            let d = unit(sub(target, eye));
            let Some((hit, _)) = bvh.cast_triangle(eye, d) else {
                continue;
            };
            if dot(hit.normal, d) > -0.5 {
                continue;
            }
            let p = [0, 1, 2].map(|k| eye[k] + hit.t * d[k]);
            let r = offset(p);
            points.push(([0, 1, 2].map(|k| p[k] + r * hit.normal[k]), r));
        }
    }
    (x, triangles, eye, points)
}

#[test]
fn a_body_that_sits_off_its_model_by_a_smooth_field_is_brought_back_to_the_surface() {
    // 1 mm out at the base, 2 mm at the top: a sag that grows along the body.
    let (x, triangles, eye, seen) = seen_body(|p| 1e-3 + 1e-3 * (p[2] / 0.13).clamp(0.0, 1.0));
    assert!(seen.len() > 1000, "{} points seen", seen.len());
    let points: Vec<[f64; 3]> = seen.iter().map(|s| s.0).collect();
    let mut fit = TareFit::new(x.len(), &triangles, TareParams::default());
    fit.add_view(&x, eye, &points);
    fit.end_frame();
    let tare = fit.finish().expect("points were fitted");
    let rms_true = (seen.iter().map(|s| s.1 * s.1).sum::<f64>() / seen.len() as f64).sqrt();
    assert!(
        (tare.rms_before / rms_true - 1.0).abs() < 0.05,
        "{} vs {rms_true}",
        tare.rms_before
    );
    // What is left is the outline's band (below).
    assert!(
        tare.rms_after < 0.15 * tare.rms_before,
        "{} left",
        tare.rms_after
    );
    let mut back = points.clone();
    tare.apply(&x, &triangles, eye, &mut back);
    // Each point moved back by its own offset, but near the outline: where the offset
    // widens it the ray passes the model's edge and the point stays (~1% here), and the
    // field is smoothed over the edge's nodes (~4%).
    let off: Vec<f64> = (points.iter().zip(&back).zip(&seen))
        .map(|((p, b), s)| (norm(sub(*p, *b)) - s.1).abs())
        .collect();
    let within = off.iter().filter(|&&e| e < 1e-4).count() as f64 / off.len() as f64;
    assert!(
        within > 0.9,
        "{:.1}% of points moved by their offset within 0.1 mm",
        100.0 * within
    );
}

#[test]
fn a_body_that_is_its_model_gets_no_reference_offsets() {
    let (x, triangles, eye, seen) = seen_body(|_| 0.0);
    let points: Vec<[f64; 3]> = seen.iter().map(|s| s.0).collect();
    let mut fit = TareFit::new(x.len(), &triangles, TareParams::default());
    fit.add_view(&x, eye, &points);
    let tare = fit.finish().unwrap();
    assert!(tare.largest_offset() < 1e-9, "{}", tare.largest_offset());
}

#[test]
fn points_that_meet_no_surface_make_no_reference() {
    let (x, triangles, eye, _) = seen_body(|_| 0.0);
    // Points behind the eye, looking away from the body.
    let away = vec![[eye[0] + 1.0, eye[1], eye[2]]; 10];
    let mut fit = TareFit::new(x.len(), &triangles, TareParams::default());
    fit.add_view(&x, eye, &away);
    assert!(fit.finish().is_none());
}
