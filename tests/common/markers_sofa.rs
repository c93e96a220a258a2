//! Marker sensing on the SOFA tutorial robots (issue 54 item 5; docs/accuracy.md, "Robots
//! designed by others (SOFA)"), by the documented commands: `softsense markers layout`
//! places the markers, the direct FE model of `common::markers` makes the tracks (an
//! unloaded frame and a loaded one, each with its own 0.1 mm noise), `softsense markers
//! --json` senses them, and each trial is scored against the load applied.
//!
//! The protocol, fixed before any scored run: the body's three normal candidates
//! (`meshes/models/<body>_candidates.csv`), one load per trial at a candidate drawn
//! uniformly, its magnitude uniform in the body's range (the one-probe sense sweeps':
//! finger 0.14-0.5 N, PneuNet 0.04-0.15 N), its direction uniform over the cap within
//! 15 degrees of the inward normal. Scoring follows `softsense score` where it applies:
//! *located* when a located force gathers the loaded candidate; a frame is *flagged* when
//! its status is not `Converged` or it has a warning; a *silent miss* is a load of an
//! unflagged frame that is not located or whose magnitude is off by more than
//! max(5%, 2σ), or a force located at an unloaded candidate of an unflagged frame.
use super::markers::{bundled_candidates, measure_loads, model, sensor};
use softsense::fem::model::Model;
use softsense::fem::solve::PointLoad;
use softsense::markers::tracks::write_tracks;
use softsense::markers::{Directions, MarkerSensor, MarkerTracks, TrackFrame};
use softsense::math::rand::uniform;
use softsense::math::{cross, norm};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Half-angle of the cone of load directions about the inward normal (degrees).
pub const CONE_DEG: f64 = 15.0;

/// A SOFA robot: its model and candidates under `meshes/models` and its load range (N).
pub struct Robot {
    pub body: &'static str,
    pub force: [f64; 2],
}

pub const FINGER: Robot = Robot {
    body: "finger",
    force: [0.14, 0.5],
};
pub const PNEUNET: Robot = Robot {
    body: "pneunet",
    force: [0.04, 0.15],
};

/// A robot with its markers laid out: the sensor the generator measures with, and the
/// files `softsense markers` reads.
pub struct Setup {
    pub model_file: PathBuf,
    pub candidates_file: PathBuf,
    pub sensor: MarkerSensor,
    /// The same sensor on a body whose Young's modulus is `young_factor` times the model's
    /// (the truth; the same sensor when 1).
    pub truth: MarkerSensor,
    pub i_w: f64,
}

fn softsense(args: &[&str], data: &Path) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_softsense"))
        .args(args)
        .env("SOFTSENSE_DATA", data)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "softsense {args:?}: {stderr}");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Lays out `markers` markers on `robot` with `softsense markers layout` (into `dir`) and
/// binds them at the layout's nodes (its `n<id>` names) at rest.
pub fn setup(robot: &Robot, markers: usize, young_factor: f64, data: &Path, dir: &Path) -> Setup {
    let root = super::project_root().join("meshes/models");
    let model_file = root.join(format!("{}.toml", robot.body));
    let candidates_file = root.join(format!("{}_candidates.csv", robot.body));
    let layout = dir.join(format!("{}_layout.csv", robot.body));
    let text = softsense(
        &[
            "markers",
            "layout",
            model_file.to_str().unwrap(),
            "--markers",
            &markers.to_string(),
            "--candidates",
            candidates_file.to_str().unwrap(),
            "--csv",
            layout.to_str().unwrap(),
            "--json",
        ],
        data,
    );
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let m = model(&format!("{}.toml", robot.body));
    let nodes: Vec<usize> = (doc["nodes"].as_array().unwrap().iter())
        .map(|v| v.as_u64().unwrap() as usize)
        .collect();
    assert_eq!(nodes.len(), markers, "{text}");
    let at_mm: Vec<[f64; 3]> = (nodes.iter())
        .map(|&v| m.problem.mesh.nodes_in_rest[v].map(|c| c * 1e3))
        .collect();
    let make = |m: &Model| {
        let s = sensor(m, &at_mm, &[], Directions::Normal);
        s.with_locations(bundled_candidates(m, robot.body)).unwrap()
    };
    let mut stiff = m.clone();
    let mat = &m.problem.material;
    stiff.problem.material =
        softsense::fem::material::Material::new(mat.young() * young_factor, mat.poisson()).unwrap();
    Setup {
        sensor: make(&m),
        truth: make(&stiff),
        model_file,
        candidates_file,
        i_w: doc["i_w_n_per_m"].as_f64().unwrap(),
    }
}

/// One trial's load and what `softsense markers` made of it.
#[derive(Debug)]
pub struct Trial {
    pub candidate: usize,
    pub magnitude: f64,
    /// The loaded candidate's estimated magnitude and its σ (N).
    pub estimate: f64,
    pub sigma: f64,
    pub located: bool,
    /// Forces located at unloaded candidates.
    pub phantoms: usize,
    pub flagged: bool,
    pub silent: bool,
    /// Markers hidden in the loaded frame, and its I_w (N/m).
    pub hidden: usize,
    pub i_w: f64,
    /// The magnitude and σ with the loaded candidate alone as the candidate (N).
    pub known: [f64; 2],
}

/// A draw of trial `t` of `seed` in [0, 1).
fn draw(seed: u64, t: u64, k: u64) -> f64 {
    uniform(seed, t, k, 54)
}

/// The load of trial `t`: a candidate, and a force within the cone about its inward normal.
pub fn load(robot: &Robot, s: &MarkerSensor, seed: u64, t: u64) -> (usize, [f64; 3]) {
    let n = s.locations.len();
    let c = ((draw(seed, t, 0) * n as f64) as usize).min(n - 1);
    let out = s.locations[c].candidates[0].direction;
    let unit = |v: [f64; 3]| v.map(|c| c / norm(v));
    let inward = unit(out.map(|v| -v));
    // Two unit vectors across the normal.
    let helper = if inward[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let a = unit(cross(inward, helper));
    let b = cross(inward, a);
    // Uniform over the spherical cap: cos(theta) uniform in [cos(cone), 1].
    let cos_t = 1.0 - draw(seed, t, 1) * (1.0 - CONE_DEG.to_radians().cos());
    let sin_t = (1.0 - cos_t * cos_t).sqrt();
    let phi = std::f64::consts::TAU * draw(seed, t, 2);
    let mag = robot.force[0] + (robot.force[1] - robot.force[0]) * draw(seed, t, 3);
    let dir = [0, 1, 2].map(|k| cos_t * inward[k] + sin_t * (phi.cos() * a[k] + phi.sin() * b[k]));
    (c, dir.map(|v| mag * v))
}

/// Runs trial `t`: writes its two frames into `dir/tracks.csv`, senses them with
/// `softsense markers --json` and scores the loaded frame.
pub fn trial(robot: &Robot, setup: &Setup, seed: u64, t: u64, data: &Path, dir: &Path) -> Trial {
    let (c, force) = load(robot, &setup.sensor, seed, t);
    let magnitude = norm(force);
    let noise = |f: u64| (draw(seed, t, 10 + f) * 2f64.powi(52)) as u64;
    let truth = &setup.truth;
    let loaded = vec![PointLoad {
        at: truth.locations[c].at(),
        force,
    }];
    let frames = [
        measure_loads(truth, Vec::new(), noise(0)),
        measure_loads(truth, loaded, noise(1)),
    ];
    let tracks = MarkerTracks {
        names: (0..truth.markers.len()).map(|m| format!("m{m}")).collect(),
        frames: (frames.into_iter().enumerate())
            .map(|(k, positions)| TrackFrame {
                frame: k as u64,
                positions,
            })
            .collect(),
    };
    let file = dir.join("tracks.csv");
    write_tracks(&file, &tracks).unwrap();
    let mut among = score(
        &loaded_frame(setup, &file, &setup.candidates_file, data),
        c,
        magnitude,
    );
    // The known location (the thesis's known-location runs): the loaded candidate alone.
    let text = std::fs::read_to_string(&setup.candidates_file).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let known = dir.join("known.csv");
    std::fs::write(&known, format!("{}\n{}\n", lines[0], lines[c + 1])).unwrap();
    let alone = score(&loaded_frame(setup, &file, &known, data), 0, magnitude);
    among.known = [alone.estimate, alone.sigma];
    among.candidate = c;
    among
}

/// `softsense markers --json` on `tracks` (an unloaded and a loaded frame) with these
/// candidates: the loaded frame's document.
fn loaded_frame(setup: &Setup, tracks: &Path, candidates: &Path, data: &Path) -> serde_json::Value {
    let text = softsense(
        &[
            "markers",
            tracks.to_str().unwrap(),
            setup.model_file.to_str().unwrap(),
            "--candidates",
            candidates.to_str().unwrap(),
            "--json",
        ],
        data,
    );
    let docs: Vec<serde_json::Value> = serde_json::Deserializer::from_str(&text)
        .into_iter()
        .map(|v| v.unwrap())
        .collect();
    assert_eq!(docs.len(), 2, "one document per frame: {text}");
    docs[1].clone()
}

/// Scores one `softsense markers --json` frame against a load of `magnitude` at `c`.
fn score(frame: &serde_json::Value, c: usize, magnitude: f64) -> Trial {
    let flagged = frame["status"] != "Converged"
        || !frame["warnings"].as_array().is_some_and(|w| w.is_empty());
    let f64_at = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let (estimate, sigma) = match frame["forces_n"].get(c) {
        Some(f) => (
            (0..3).map(|k| f64_at(&f[k]).powi(2)).sum::<f64>().sqrt(),
            f64_at(&frame["sigma_n"][c]),
        ),
        None => (f64::NAN, f64::NAN),
    };
    let located_at = |l: &serde_json::Value| {
        (l["candidates"].as_array().unwrap().iter()).any(|i| i.as_u64() == Some(c as u64))
    };
    let all = frame["located"].as_array().cloned().unwrap_or_default();
    let located = all.iter().any(located_at);
    let phantoms = all.iter().filter(|l| !located_at(l)).count();
    let bad = (estimate - magnitude).abs() > (0.05 * magnitude).max(2.0 * sigma);
    Trial {
        candidate: c,
        magnitude,
        estimate,
        sigma,
        located,
        phantoms,
        flagged,
        hidden: frame["hidden"].as_array().map_or(0, |h| h.len()),
        i_w: f64_at(&frame["i_w_n_per_m"]),
        known: [f64::NAN; 2],
        silent: !flagged && (!located || !estimate.is_finite() || bad || phantoms > 0),
    }
}

/// The counts over trials, per loaded candidate and in all.
#[derive(Debug, Default, Clone, Copy)]
pub struct Tally {
    pub loads: usize,
    pub located: usize,
    pub within_5: usize,
    /// Over located loads: |error| within 2σ.
    pub within_2_sigma: usize,
    pub flagged: usize,
    pub silent: usize,
    pub phantoms: usize,
    /// Sum of |magnitude error| / magnitude over located loads.
    pub error_sum: f64,
    /// Over all loads: the loaded candidate's |error| within 2σ (located or not).
    pub covered: usize,
    /// The known location: within 5%, |error| within 2σ, sum of |error| / magnitude.
    pub known_within_5: usize,
    pub known_covered: usize,
    pub known_error_sum: f64,
}

impl Tally {
    pub fn add(&mut self, t: &Trial) {
        self.loads += 1;
        let err = (t.estimate - t.magnitude).abs();
        if t.located {
            self.located += 1;
            self.within_5 += usize::from(err <= 0.05 * t.magnitude);
            self.within_2_sigma += usize::from(err <= 2.0 * t.sigma);
            self.error_sum += err / t.magnitude;
        }
        self.covered += usize::from(err <= 2.0 * t.sigma);
        let known = (t.known[0] - t.magnitude).abs();
        self.known_within_5 += usize::from(known <= 0.05 * t.magnitude);
        self.known_covered += usize::from(known <= 2.0 * t.known[1]);
        self.known_error_sum += known / t.magnitude;
        self.flagged += usize::from(t.flagged);
        self.silent += usize::from(t.silent);
        self.phantoms += t.phantoms;
    }

    pub fn line(&self) -> String {
        format!(
            "{} loads: located {}, within 5% {}, within 2 sigma {} of located, mean |error| {:.1}% \
             of located, flagged {}, phantoms {}, silent misses {}, within 2 sigma {} of all; \
             known location: within 5% {}, within 2 sigma {}, mean |error| {:.1}%",
            self.loads,
            self.located,
            self.within_5,
            self.within_2_sigma,
            100.0 * self.error_sum / self.located.max(1) as f64,
            self.flagged,
            self.phantoms,
            self.silent,
            self.covered,
            self.known_within_5,
            self.known_covered,
            100.0 * self.known_error_sum / self.loads.max(1) as f64,
        )
    }
}

/// Runs trials `0..count` of `seed`, printing each, and tallies them per candidate.
pub fn sweep(
    robot: &Robot,
    setup: &Setup,
    seed: u64,
    count: u64,
    data: &Path,
    dir: &Path,
) -> Vec<Tally> {
    let mut per = vec![Tally::default(); setup.sensor.locations.len() + 1];
    for t in 0..count {
        let r = trial(robot, setup, seed, t, data, dir);
        println!("{} trial {t}: {r:?}", robot.body);
        per[r.candidate].add(&r);
        per[setup.sensor.locations.len()].add(&r);
    }
    per
}
