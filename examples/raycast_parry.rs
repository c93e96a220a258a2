//! Times parry3d's triangle-mesh ray casting against ours ([`Bvh`]) on the rays a scene
//! render casts: every pixel of the default 640x480 camera against the robot surface, at
//! rest (`meshes/models/robot.toml`) and deformed (`clouds/scenes/tip_weight.toml` frame
//! 0). Counts pixels whose hit/miss differs or whose depth differs by more than 1e-9 m,
//! and times build and queries separately, in alternating rounds (one thread each).
//!
//! Run: `cargo run --release --example raycast_parry [rounds]`.
use parry3d_f64::math::{Point, Vector};
use parry3d_f64::query::{Ray, RayCast};
use parry3d_f64::shape::TriMesh;
use softsense::camera::Camera;
use softsense::fem::model::Model;
use softsense::geometry::raycast::Bvh;
use softsense::scene::camera::CameraSpec;
use softsense::scene::{render_frame, Scene};
use std::path::Path;
use std::time::{Duration, Instant};

/// Per pixel: the ray parameter of the nearest hit (the depth, as rays have camera-z 1).
type Depths = Vec<Option<f64>>;

fn rays(camera: &Camera) -> Vec<[f64; 3]> {
    let (w, h) = (
        camera.intrinsics.width as usize,
        camera.intrinsics.height as usize,
    );
    (0..w * h)
        .map(|i| camera.ray((i % w) as f64, (i / w) as f64))
        .collect()
}

fn ours(
    nodes: &[[f64; 3]],
    tris: &[[usize; 3]],
    eye: [f64; 3],
    dirs: &[[f64; 3]],
) -> (Duration, Duration, Depths) {
    let t0 = Instant::now();
    let bvh = Bvh::new(nodes, tris);
    let build = t0.elapsed();
    let t1 = Instant::now();
    let depths = dirs
        .iter()
        .map(|&d| bvh.cast(eye, d).map(|h| h.t))
        .collect();
    (build, t1.elapsed(), depths)
}

fn parry(
    nodes: &[[f64; 3]],
    tris: &[[usize; 3]],
    eye: [f64; 3],
    dirs: &[[f64; 3]],
) -> (Duration, Duration, Depths) {
    let t0 = Instant::now();
    let vertices: Vec<Point<f64>> = nodes.iter().map(|p| Point::new(p[0], p[1], p[2])).collect();
    let indices: Vec<[u32; 3]> = tris.iter().map(|t| t.map(|i| i as u32)).collect();
    let mesh = TriMesh::new(vertices, indices).expect("a valid triangle mesh");
    let build = t0.elapsed();
    let t1 = Instant::now();
    let origin = Point::new(eye[0], eye[1], eye[2]);
    let depths = dirs
        .iter()
        .map(|d| {
            let ray = Ray::new(origin, Vector::new(d[0], d[1], d[2]));
            mesh.cast_local_ray(&ray, f64::MAX, false)
        })
        .collect();
    (build, t1.elapsed(), depths)
}

/// Pixels whose hit/miss differs, whose depth differs by more than 1e-9 m, whose depth
/// differs in any bit, and the largest depth difference (m).
fn differing(a: &Depths, b: &Depths) -> (usize, usize, usize, f64) {
    let (mut hit_miss, mut depth, mut bits, mut worst) = (0, 0, 0, 0.0f64);
    for (x, y) in a.iter().zip(b) {
        match (x, y) {
            (Some(x), Some(y)) => {
                let e = (x - y).abs();
                worst = worst.max(e);
                depth += usize::from(e > 1e-9);
                bits += usize::from(x.to_bits() != y.to_bits());
            }
            (None, None) => {}
            _ => hit_miss += 1,
        }
    }
    (hit_miss, depth, bits, worst)
}

fn ms(d: &[Duration]) -> String {
    let mut v: Vec<f64> = d.iter().map(|d| d.as_secs_f64() * 1e3).collect();
    v.sort_by(f64::total_cmp);
    format!("median {:.2} ms, min {:.2} ms", v[v.len() / 2], v[0])
}

fn compare(name: &str, nodes: &[[f64; 3]], tris: &[[usize; 3]], rounds: usize) {
    let camera = CameraSpec::default().camera().expect("default camera");
    let (eye, dirs) = (camera.eye(), rays(&camera));
    let mut times = [[Vec::new(), Vec::new()], [Vec::new(), Vec::new()]];
    let mut answers = (Vec::new(), Vec::new());
    for round in 0..rounds {
        // Alternate which goes first, so drift in machine load hits both alike.
        for k in [round % 2, 1 - round % 2] {
            let (build, query, depths) = if k == 0 {
                ours(nodes, tris, eye, &dirs)
            } else {
                parry(nodes, tris, eye, &dirs)
            };
            times[k][0].push(build);
            times[k][1].push(query);
            if k == 0 {
                answers.0 = depths;
            } else {
                answers.1 = depths;
            }
        }
    }
    let hits = answers.0.iter().filter(|d| d.is_some()).count();
    let (hit_miss, depth, bits, worst) = differing(&answers.0, &answers.1);
    println!(
        "{name}: {} triangles, {} rays, {hits} hits (ours)",
        tris.len(),
        dirs.len()
    );
    println!(
        "  ours : build {}; queries {}",
        ms(&times[0][0]),
        ms(&times[0][1])
    );
    println!(
        "  parry: build {}; queries {}",
        ms(&times[1][0]),
        ms(&times[1][1])
    );
    println!("  differ: {hit_miss} hit/miss, {depth} depth > 1e-9 m, {bits} depth in any bit (largest {worst:.3e} m)");
}

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(7);
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let model = Model::load(&root.join("meshes/models/robot.toml"), None).expect("robot model");
    let surface = model.problem.mesh.surface();
    compare(
        "robot at rest",
        &model.problem.mesh.nodes_in_rest,
        &surface.triangles,
        rounds,
    );
    let scene = Scene::load(&root.join("clouds/scenes/tip_weight.toml")).expect("scene");
    let model = scene.model().expect("scene model");
    let surface = model.problem.mesh.surface();
    let frame = render_frame(&scene, &model, 0).expect("frame 0");
    compare(
        "tip_weight frame 0",
        &frame.positions,
        &surface.triangles,
        rounds,
    );
}
