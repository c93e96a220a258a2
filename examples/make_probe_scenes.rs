//! Writes the probe scene files `clouds/scenes/probe_side.toml` (one probe at each of 5
//! random places on the robot's sides, one per frame) and `clouds/scenes/two_probes.toml`
//! (two probes at once, 3 frames). Places are drawn (fixed seed) among surface nodes the
//! default camera sees, on the legs (z > 20 mm) and facing sideways (|n_z| < 0.5); the force
//! pushes along the inward normal tilted by up to 15 degrees, 0.3-0.8 N.
//!
//! Run: `cargo run --release --example make_probe_scenes`, then
//! `softsense scene generate clouds/scenes/probe_side.toml clouds/scenes/probe_side --force`
//! (and the same for two_probes).
use softsense::fem::model::Model;
use softsense::register::vertex_normals;
use softsense::scene::camera::CameraSpec;
use softsense::scene::raycast::Bvh;
use softsense::scene::sensor::SensorModel;
use std::fmt::Write as _;
use std::path::Path;

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        // splitmix64
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let model = Model::load(&root.join("meshes/models/robot.toml"), None).expect("robot model");
    let mesh = &model.problem.mesh;
    let s = mesh.surface();
    let x = &mesh.nodes_in_rest;
    let n = vertex_normals(x, &s.triangles);
    let eye = CameraSpec::default().eye;
    let bvh = Bvh::new(x, &s.triangles);
    let candidates: Vec<usize> = s
        .nodes
        .iter()
        .copied()
        .filter(|&v| {
            let p = x[v];
            let d = [p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]];
            let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let facing = -(d[0] * n[v][0] + d[1] * n[v][1] + d[2] * n[v][2]) / dist;
            let seen = bvh
                .cast(eye, d)
                .is_some_and(|h| (h.t - 1.0).abs() * dist < 1e-6);
            p[2] > 0.02 && n[v][2].abs() < 0.5 && facing > 0.5 && seen
        })
        .collect();
    eprintln!("{} candidate places", candidates.len());
    // `--held-out SEED FRAMES OUT.toml`: a scene drawn the same way with another seed, to
    // check settings chosen on the committed scenes on data they were not chosen on.
    let args: Vec<String> = std::env::args().skip(1).collect();
    // After them, `--hd`: the scene's camera is the 1280x720 stream
    // (`CameraSpec::d415_1280x720`, the same loads and pose), with the depth noise of the
    // same disparity noise at its focal length (`SensorModel::for_camera`); `--depth-unit M`:
    // the depth PNG's unit (m, default 0.001).
    fn usage() -> ! {
        eprintln!(
            "usage: make_probe_scenes [--held-out SEED FRAMES OUT.toml [--hd] [--depth-unit M]]"
        );
        std::process::exit(2);
    }
    let (mut hd, mut depth_unit) = (false, None);
    let mut rest = args.iter();
    let mut args = Vec::new();
    while let Some(a) = rest.next() {
        match a.as_str() {
            "--hd" => hd = true,
            "--depth-unit" => match rest.next().map(|v| v.parse::<f64>()) {
                Some(Ok(u)) if u > 0.0 => depth_unit = Some(u),
                _ => usage(),
            },
            _ => args.push(a.clone()),
        }
    }
    let held_out = match args.as_slice() {
        [] if !hd && depth_unit.is_none() => None,
        [flag, seed, frames, out] if flag == "--held-out" => {
            match (seed.parse::<u64>(), frames.parse::<usize>()) {
                (Ok(seed), Ok(frames)) => Some((seed, frames, out.clone())),
                _ => usage(),
            }
        }
        _ => usage(),
    };
    let mut rng = Rng(held_out.as_ref().map_or(2026, |h| h.0));
    let probe = |rng: &mut Rng, v: usize| -> String {
        // Inward normal tilted by up to 15 degrees about a random axis.
        let inward = n[v].map(|c| -c);
        let a = if inward[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let t1 = unit(cross(inward, a));
        let t2 = cross(inward, t1);
        let (tilt, phi) = (
            15f64.to_radians() * rng.next(),
            std::f64::consts::TAU * rng.next(),
        );
        let mag = 0.3 + 0.5 * rng.next();
        let dir: Vec<f64> = (0..3)
            .map(|k| tilt.cos() * inward[k] + tilt.sin() * (phi.cos() * t1[k] + phi.sin() * t2[k]))
            .collect();
        format!(
            "[[frames.loads]]\nkind = \"probe\"\nat = [{:.5}, {:.5}, {:.5}]\nforce = [{:.4}, {:.4}, {:.4}]\n",
            x[v][0], x[v][1], x[v][2], mag * dir[0], mag * dir[1], mag * dir[2]
        )
    };
    let header = |what: &str, seed: u64| {
        format!(
            "# {what}\n# Made by `cargo run --example make_probe_scenes` (fixed seed); regenerate the frames:\n\
             # softsense scene generate clouds/scenes/<name>.toml clouds/scenes/<name> --force\n\
             model = \"../../meshes/models/robot.toml\"\nseed = {seed}\n\n[sensor]\nenabled = true\n\
             depth_k = 0.002        # sigma = k z^2: 0.5 mm at 0.5 m\ncolor_sigma = 3.0\n"
        )
    };
    if let Some((seed, frames, out)) = held_out {
        let mut scene = header(
            &format!("Held out: a probe at {frames} random places, one per frame (seed {seed})."),
            seed,
        );
        // The TOML sits outside clouds/scenes: the model path is made absolute.
        scene = scene.replace(
            "../../meshes/models/robot.toml",
            &root.join("meshes/models/robot.toml").display().to_string(),
        );
        if hd {
            let camera = CameraSpec::d415_1280x720();
            let k = SensorModel::for_camera(&camera).depth_k;
            let sd_noise = "depth_k = 0.002        # sigma = k z^2: 0.5 mm at 0.5 m";
            assert!(
                scene.contains(sd_noise),
                "the header sets the 640x480 depth noise"
            );
            scene = scene.replace(
                sd_noise,
                &format!(
                    "depth_k = {k:.7}    # the same disparity noise at fx {}: 0.33 mm at 0.5 m",
                    camera.fx
                ),
            );
            let camera = toml::to_string(&camera).expect("camera as TOML");
            let _ = write!(scene, "\n[camera]\n{camera}");
        }
        if let Some(u) = depth_unit {
            assert!(
                scene.contains("color_sigma = 3.0\n"),
                "the header ends its [sensor]"
            );
            scene = scene.replace(
                "color_sigma = 3.0\n",
                &format!("color_sigma = 3.0\ndepth_unit = {u}\n"),
            );
        }
        for _ in 0..frames {
            let v = candidates[(rng.next() * candidates.len() as f64) as usize];
            let _ = write!(scene, "\n[[frames]]\n{}", probe(&mut rng, v));
        }
        std::fs::write(&out, scene).expect("write");
        return;
    }
    let mut one = header(
        "A probe pushing on the robot's side at 5 random places, one per frame.",
        11,
    );
    for _ in 0..5 {
        let v = candidates[(rng.next() * candidates.len() as f64) as usize];
        let _ = write!(one, "\n[[frames]]\n{}", probe(&mut rng, v));
    }
    std::fs::write(root.join("clouds/scenes/probe_side.toml"), one).expect("write");
    let mut two = header(
        "Two probes pushing at once at random places at least 50 mm apart.",
        12,
    );
    for _ in 0..3 {
        let a = candidates[(rng.next() * candidates.len() as f64) as usize];
        let b = loop {
            let b = candidates[(rng.next() * candidates.len() as f64) as usize];
            let d: f64 = (0..3)
                .map(|k| (x[a][k] - x[b][k]).powi(2))
                .sum::<f64>()
                .sqrt();
            if d > 0.05 {
                break b;
            }
        };
        let _ = write!(
            two,
            "\n[[frames]]\n{}{}",
            probe(&mut rng, a),
            probe(&mut rng, b)
        );
    }
    std::fs::write(root.join("clouds/scenes/two_probes.toml"), two).expect("write");
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|c| c / l)
}
