//! Forces from painted markers (issue 36): a scene with coloured markers generated, the
//! markers detected in its RGB-D frames, and the forces at the scene's load points solved
//! from the detected tracks and from the generator's true marker positions.
use softsense::fem::model::Model;
use softsense::markers::detect::{detect_recording, DetectParams};
use softsense::markers::tracks::{flag_hidden, read_tracks, MarkerTracks};
use softsense::markers::{
    bind_markers, CandidateLocation, Directions, MarkerSensor, MarkersParams,
};
use softsense::recording::Recording;
use softsense::scene::Scene;
use std::path::Path;

/// One loaded frame: the applied force at each load point and the estimates (N, along z,
/// positive down).
#[derive(Debug, Clone)]
pub struct PaintedFrame {
    /// Applied.
    pub applied: Vec<f64>,
    /// From the detected markers.
    pub detected: Vec<f64>,
    /// From the true marker positions (`markers_truth.csv`, no detection error).
    pub exact: Vec<f64>,
    /// One σ of each detected estimate from `sigma` (N).
    pub sigma: Vec<f64>,
    /// Detected markers hidden by [`flag_hidden`] (the expected-position rule) and left out
    /// of `detected`.
    pub hidden: usize,
    /// From the detected markers with the raw 5 mm jump rule of before issue 51 item 4
    /// ([`raw_jump_hidden`]) in place of [`flag_hidden`].
    pub detected_raw: Vec<f64>,
    /// Detected markers the raw jump rule hides.
    pub hidden_raw: usize,
}

impl PaintedFrame {
    /// Relative error of each detected estimate.
    pub fn detected_errors(&self) -> Vec<f64> {
        rel(&self.detected, &self.applied)
    }

    /// Relative error of each detected estimate with the raw jump rule.
    pub fn detected_raw_errors(&self) -> Vec<f64> {
        rel(&self.detected_raw, &self.applied)
    }

    /// Relative error of each estimate from the true marker positions.
    pub fn exact_errors(&self) -> Vec<f64> {
        rel(&self.exact, &self.applied)
    }
}

fn rel(est: &[f64], applied: &[f64]) -> Vec<f64> {
    est.iter()
        .zip(applied)
        .map(|(e, a)| (e - a).abs() / a)
        .collect()
}

/// A sensor on `model` whose markers are bound at the model's free equilibrium to the
/// first frame of `tracks`, with normal candidates at `points` (m). The model file's own
/// loads (the sheet's 50 mN push) are applied in every frame of the scene: they are kept
/// as known loads, not unknowns.
fn sensor(model: &Model, tracks: &MarkerTracks, points: &[[f64; 3]], sigma: f64) -> MarkerSensor {
    let mesh = &model.problem.mesh;
    let surface = mesh.surface();
    let free = model.problem.solve_static(&model.newton).unwrap();
    let first: Vec<[f64; 3]> = (tracks.frames[0].positions.iter())
        .map(|p| p.expect("every marker seen in the unloaded frame"))
        .collect();
    let markers = bind_markers(&free.positions, &surface, &tracks.names, &first, 0.005).unwrap();
    let candidates = (points.iter().enumerate())
        .map(|(i, p)| {
            CandidateLocation::snapped(&format!("c{i}"), mesh, &surface, *p, Directions::Normal)
                .unwrap()
        })
        .collect();
    let params = MarkersParams {
        sigma,
        ..Default::default()
    };
    let mut s = MarkerSensor::new(
        &model.problem,
        model.newton.clone(),
        markers,
        candidates,
        params,
    )
    .unwrap();
    s.problem.loads = model.problem.loads.clone();
    s
}

/// The hidden-marker rule before issue 51 item 4, kept to measure against: a marker more
/// than `jump` (m) from its last accepted position is hidden.
pub fn raw_jump_hidden(tracks: &MarkerTracks, jump: f64) -> Vec<Vec<bool>> {
    let mut last: Vec<Option<[f64; 3]>> = vec![None; tracks.names.len()];
    let mut out = Vec::new();
    for f in &tracks.frames {
        let flags = (f.positions.iter().zip(last.iter_mut()))
            .map(|(p, l)| match (p, *l) {
                (None, _) => true,
                (Some(p), Some(q))
                    if (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>() > jump * jump =>
                {
                    true
                }
                (Some(p), _) => {
                    *l = Some(*p);
                    false
                }
            })
            .collect();
        out.push(flags);
    }
    out
}

/// The forces along -z at each candidate, frame by frame after the first, with the markers
/// flagged in `hidden` (frames x markers) left out.
fn solve(
    s: &MarkerSensor,
    tracks: &MarkerTracks,
    hidden: &[Vec<bool>],
) -> Vec<(Vec<f64>, Vec<f64>)> {
    let mut previous = None;
    let mut out = Vec::new();
    for (f, flags) in tracks.frames.iter().zip(hidden).skip(1) {
        let seen: Vec<Option<[f64; 3]>> = (f.positions.iter().zip(flags))
            .map(|(p, h)| if *h { None } else { *p })
            .collect();
        let est = s.solve_frame(f.frame, &seen, previous.as_ref()).unwrap();
        assert_eq!(
            est.status,
            softsense::markers::MarkersStatus::Converged,
            "frame {}: {:?}",
            f.frame,
            est.warnings
        );
        out.push((
            est.forces.iter().map(|v| -v[2]).collect(),
            est.sigma.clone(),
        ));
        previous = Some(est);
    }
    out
}

/// `tests/fixtures/markers/painted_sheet_pairs.toml`: the painted sheet unloaded, then under
/// thesis Table 4.4's six pairs of weights at (∓40, 0) mm.
pub fn painted_pairs_scene() -> Scene {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    Scene::load(&root.join("tests/fixtures/markers/painted_sheet_pairs.toml")).unwrap()
}

/// `tests/fixtures/markers/painted_sheet_pairs_other_camera.toml`: the same sheet and
/// loads seen by a camera from the side (+x) instead of the front.
pub fn painted_pairs_other_camera_scene() -> Scene {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    Scene::load(&root.join("tests/fixtures/markers/painted_sheet_pairs_other_camera.toml")).unwrap()
}

/// Generates `scene` (frame 0 unloaded, every later frame with weights at the same
/// points), detects its markers, flags the hidden ones (as `softsense markers` does) and
/// solves the weights from the others; `sigma` is the marker noise assumed for the reported
/// σ (m). The same with the raw 5 mm jump rule, and from the true marker positions.
pub fn forces_from_painted(scene: &Scene, sigma: f64) -> Vec<PaintedFrame> {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frames");
    softsense::scene::generate(scene, &out, |_, _| {}).unwrap();
    let model = scene.model().unwrap();
    let points: Vec<[f64; 3]> = scene.spec.frames[1].loads.iter().map(|l| l.at).collect();
    let applied: Vec<Vec<f64>> = (scene.spec.frames[1..].iter())
        .map(|f| {
            assert!(f.loads.iter().zip(&points).all(|(l, p)| l.at == *p));
            f.loads.iter().map(|l| -l.force[2]).collect()
        })
        .collect();
    let rec = Recording::open(&out).unwrap();
    let (detected, _, dropped) = detect_recording(&rec, &DetectParams::default(), None).unwrap();
    assert_eq!(dropped, 0);
    let truth = read_tracks(&out.join(softsense::scene::MARKERS_TRUTH)).unwrap();
    let s = sensor(&model, &detected, &points, sigma);
    let params = MarkersParams::default();
    let (hidden, hidden_raw) = (
        flag_hidden(&detected, &params),
        raw_jump_hidden(&detected, params.hidden_jump),
    );
    let from_detected = solve(&s, &detected, &hidden);
    let from_raw = solve(&s, &detected, &hidden_raw);
    let none = vec![vec![false; truth.names.len()]; truth.frames.len()];
    let from_truth = solve(&sensor(&model, &truth, &points, sigma), &truth, &none);
    let count = |h: &[bool]| h.iter().filter(|h| **h).count();
    (applied.into_iter().enumerate())
        .map(|(i, applied)| PaintedFrame {
            applied,
            detected: from_detected[i].0.clone(),
            exact: from_truth[i].0.clone(),
            sigma: from_detected[i].1.clone(),
            hidden: count(&hidden[i + 1]),
            detected_raw: from_raw[i].0.clone(),
            hidden_raw: count(&hidden_raw[i + 1]),
        })
        .collect()
}
