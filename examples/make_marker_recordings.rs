//! Generates the bundled marker recordings, deterministically, with the direct FE model:
//!
//! - `clouds/markers/sheet/tracks.csv` and `truth.json`: the soft sheet
//!   (`meshes/models/sheet.toml`), 25 markers on a 40 mm grid of its top face; frame 0
//!   unloaded (gravity only), frames 2-6 the weight pairs of thesis Table 4.4 (359-559 mN,
//!   along -z) at two of the bundled candidates (`meshes/models/sheet_candidates.csv`: c1 at
//!   (-60, 0) mm and c10 at (60, 0) mm), frame 1 half the lightest pair.
//! - `clouds/markers/robot/tracks.csv` and `truth.json`: the four-legged robot
//!   (`meshes/models/robot.toml`, north cable held at its 10 mm), the 16 surface nodes
//!   nearest the tip beyond 8 mm as markers; frame 0 unloaded, frames 1-4 the tip weights
//!   of thesis Table 4.5 (259-859 mN) at the model's `hook` force point.
//!
//! Each folder also gets `markers_truth.csv`: the same frames without noise (the exact
//! marker positions, as `scene generate` writes for painted markers).
//!
//! Options, to measure on other noise draws without touching the bundled files:
//! `--seed S` (default 36), `--unloaded N` unloaded frames before the loaded ones (default
//! 1; each its own noise draw), `--out DIR` (default `clouds/markers`).
//!
//! The sheet's `candidates.csv` lists its two loaded candidates alone (the known-location
//! case of Table 4.4). Marker positions are the FE solve's plus 0.1 mm Gaussian noise from a fixed seed, written
//! to 1 µm. The model files' own `[[loads]]` are not applied: the weights are the only load.
//! Run from the repository root:
//!
//! ```text
//! cargo run --example make_marker_recordings
//! cargo run --example make_marker_recordings -- --seed 7 --unloaded 10 --out /tmp/rec7
//! ```

use softsense::fem::model::Model;
use softsense::fem::solve::{MappedPoint, PointLoad};
use softsense::markers::bind::read_candidates;
use softsense::markers::tracks::write_tracks;
use softsense::markers::{CandidateLocation, MarkerTracks, TrackFrame};
use softsense::math::rand::normal;
use std::error::Error;
use std::path::Path;

/// One sigma of a marker coordinate (m).
const SIGMA: f64 = 1e-4;
/// The noise generator's seed of the bundled recordings.
const SEED: u64 = 36;

/// Command-line options (see the module docs).
struct Options {
    seed: u64,
    unloaded: usize,
    out: std::path::PathBuf,
}

fn options(root: &Path) -> Result<Options, Box<dyn Error>> {
    let mut o = Options {
        seed: SEED,
        unloaded: 1,
        out: root.join("clouds/markers"),
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    for pair in args.chunks(2) {
        let value = pair.get(1).ok_or("each option takes a value")?;
        match pair[0].as_str() {
            "--seed" => o.seed = value.parse()?,
            "--unloaded" => o.unloaded = value.parse()?,
            "--out" => o.out = value.into(),
            other => return Err(format!("unknown option {other}").into()),
        }
    }
    if o.unloaded == 0 {
        return Err("--unloaded must be at least 1".into());
    }
    Ok(o)
}

/// The sheet's two loaded candidates (of `meshes/models/sheet_candidates.csv`).
const SHEET_LOADED: [&str; 2] = ["c1", "c10"];

/// One frame's applied forces: (candidate name, force in N).
type FrameLoads = Vec<(&'static str, [f64; 3])>;

fn main() -> Result<(), Box<dyn Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let models = root.join("meshes/models");
    let opts = options(root)?;
    let unloaded = || std::iter::repeat_n(vec![], opts.unloaded);

    let sheet = Model::load(&models.join("sheet.toml"), None)?;
    let candidates = read_candidates(&models.join("sheet_candidates.csv"), &sheet.problem.mesh)?;
    let xs = [-0.08, -0.04, 0.0, 0.04, 0.08];
    let grid: Vec<[f64; 3]> = (xs.iter())
        .flat_map(|&x| xs.iter().map(move |&y| [x, y, 0.004]))
        .collect();
    let nodes: Vec<usize> = grid.iter().map(|&p| nearest_node(&sheet, p)).collect();
    let w = |f: f64| [0.0, 0.0, -f];
    // Thesis Table 4.4's weight pairs at two fixed candidates 120 mm apart, added one at a
    // time as on a bench; frame 1 (half the lightest pair) keeps each step under the 5 mm
    // hidden-marker jump.
    let pairs = [
        (0.18, 0.18),
        (0.359, 0.359),
        (0.459, 0.359),
        (0.459, 0.459),
        (0.559, 0.459),
        (0.559, 0.559),
    ];
    let frames: Vec<FrameLoads> = unloaded()
        .chain(pairs.map(|(a, b)| vec![(SHEET_LOADED[0], w(a)), (SHEET_LOADED[1], w(b))]))
        .collect();
    record(
        &sheet,
        &candidates,
        &nodes,
        &frames,
        opts.seed,
        &opts.out.join("sheet"),
    )?;
    let mut loaded = String::from("name,x,y,z,directions\n");
    for c in candidates
        .iter()
        .filter(|c| SHEET_LOADED.contains(&c.name.as_str()))
    {
        let [x, y, z] = c.position;
        loaded.push_str(&format!("{},{x:.3},{y:.3},{z:.3},normal\n", c.name));
    }
    std::fs::write(opts.out.join("sheet/candidates.csv"), loaded)?;

    let robot = Model::load(&models.join("robot.toml"), None)?;
    let mesh = &robot.problem.mesh;
    let candidates: Vec<CandidateLocation> = (robot.force_points.iter())
        .map(|e| CandidateLocation::from_force_point(e, mesh))
        .collect();
    let tip = [0.0, 0.0, 0.125];
    let mut near: Vec<usize> = (mesh.surface().nodes.into_iter())
        .filter(|&v| dist(mesh.nodes_in_rest[v], tip) > 0.008)
        .collect();
    near.sort_by(|&a, &b| {
        dist(mesh.nodes_in_rest[a], tip).total_cmp(&dist(mesh.nodes_in_rest[b], tip))
    });
    near.truncate(16);
    let frames: Vec<FrameLoads> = unloaded()
        .chain([0.259, 0.459, 0.659, 0.859].map(|f| vec![("hook", w(f))]))
        .collect();
    record(
        &robot,
        &candidates,
        &near,
        &frames,
        opts.seed,
        &opts.out.join("robot"),
    )?;
    Ok(())
}

fn dist(p: [f64; 3], q: [f64; 3]) -> f64 {
    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
}

/// The surface node of `model` nearest to `p` (rest, m).
fn nearest_node(model: &Model, p: [f64; 3]) -> usize {
    let mesh = &model.problem.mesh;
    (mesh.surface().nodes.into_iter())
        .min_by(|&a, &b| dist(mesh.nodes_in_rest[a], p).total_cmp(&dist(mesh.nodes_in_rest[b], p)))
        .expect("a surface")
}

/// Solves `model` under each frame's loads and writes the markers at `nodes` (named m0, m1,
/// ...) with noise as `dir/tracks.csv`, without as `dir/markers_truth.csv`, the loads as
/// `dir/truth.json`.
fn record(
    model: &Model,
    candidates: &[CandidateLocation],
    nodes: &[usize],
    frames: &[FrameLoads],
    seed: u64,
    dir: &Path,
) -> Result<(), Box<dyn Error>> {
    let mut tracks = MarkerTracks {
        names: (0..nodes.len()).map(|i| format!("m{i}")).collect(),
        frames: Vec::new(),
    };
    let mut exact = tracks.clone();
    let mut truth = Vec::new();
    for (k, loads) in frames.iter().enumerate() {
        let mut problem = model.problem.without_loads();
        for (name, force) in loads {
            let c = (candidates.iter().find(|c| c.name == *name))
                .ok_or_else(|| format!("no candidate {name}"))?;
            problem.loads.push(PointLoad {
                at: c.at(),
                force: *force,
            });
        }
        let sol = problem.solve_static(&model.newton)?;
        let at = |v: usize| MappedPoint::node(v).position(&sol.positions);
        let positions = (nodes.iter().enumerate())
            .map(|(m, &v)| {
                let q = at(v);
                let noisy =
                    [0, 1, 2].map(|a| q[a] + SIGMA * normal(seed, k as u64, m as u64, a as u64));
                Some(noisy.map(|c| (c * 1e6).round() / 1e6))
            })
            .collect();
        tracks.frames.push(TrackFrame {
            frame: k as u64,
            positions,
        });
        exact.frames.push(TrackFrame {
            frame: k as u64,
            positions: nodes.iter().map(|&v| Some(at(v))).collect(),
        });
        let forces: Vec<_> = (loads.iter())
            .map(|(name, f)| serde_json::json!({ "candidate": name, "force_n": f }))
            .collect();
        truth.push(serde_json::json!({ "frame": k, "forces": forces }));
    }
    std::fs::create_dir_all(dir)?;
    write_tracks(&dir.join("tracks.csv"), &tracks)?;
    write_tracks(&dir.join("markers_truth.csv"), &exact)?;
    let doc = serde_json::json!({
        "about": "forces applied by the direct FE model per frame (N, model frame); \
                  made by `cargo run --example make_marker_recordings`",
        "sigma_m": SIGMA,
        "seed": seed,
        "frames": truth,
    });
    std::fs::write(
        dir.join("truth.json"),
        serde_json::to_string_pretty(&doc)? + "\n",
    )?;
    println!("wrote {}", dir.display());
    Ok(())
}
