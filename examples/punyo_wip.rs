//! WIP: the Punyo press through softsense's pieces (not the finished sense mode).
//! Usage: punyo_wip REC MODEL FRAMES_JSON
use softsense::fem::model::Model;
use softsense::inverse::pushes::{solve_pushes, PushParams, PushProblem};
use softsense::math::pose::Pose;
use softsense::recording::Recording;
use softsense::sense::membrane::*;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let rec = Recording::open(a[1].as_ref()).unwrap();
    let model = Model::load(a[2].as_ref(), None).unwrap();
    let frames: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&a[3]).unwrap()).unwrap();
    let frames = frames["frames"].as_array().unwrap();
    let p: Vec<f64> = frames
        .iter()
        .map(|f| f["pressure_hpa"].as_f64().unwrap() * 100.0)
        .collect();
    let w: Vec<[f64; 3]> = frames
        .iter()
        .map(|f| [0, 1, 2].map(|k| f["wrench"][k].as_f64().unwrap()))
        .collect();
    let bias = [0, 1, 2].map(|k| w[..61].iter().map(|v| v[k]).sum::<f64>() / 61.0);
    let meas: Vec<f64> = w
        .iter()
        .map(|v| (0..3).map(|k| (v[k] - bias[k]).powi(2)).sum::<f64>().sqrt())
        .collect();
    let p0 = p[..5].iter().sum::<f64>() / 5.0;
    let (c, s) = (25f64.to_radians().cos(), 25f64.to_radians().sin());
    let robot_from_camera = Pose::from_matrix(&[
        [c, 0.0, s, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [-s, 0.0, c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ])
    .unwrap();
    let camera_from_robot = robot_from_camera.inverse();
    let mesh = &model.problem.mesh;
    let x = mesh.nodes_in_rest.clone();
    let view = inside_view(mesh, [0.0; 3], &model.problem.held_nodes());
    let k = rec.camera_of(0).unwrap().intrinsics;
    let lens = rec.lens_of(0).unwrap();
    let rays = node_rays(&x, &view.seen, &camera_from_robot, &k, lens);
    let clouds: Vec<_> = (0..150).map(|f| rec.read_frame(f).unwrap()).collect();
    let obs = ObserveParams::default();
    let refs = rest_reference(
        rays,
        &clouds[..5],
        &clouds[5..61],
        &obs,
        &ReferenceParams::default(),
    );
    eprintln!(
        "seen {} pushed {} observed {}",
        view.seen.len(),
        view.pushed.len(),
        refs.len()
    );
    // Pressure pushes the inner face away from the cavity: -n times its nodal area.
    let surface = mesh.surface();
    let mut area = vec![0.0; x.len()];
    for t in &surface.triangles {
        let [p0, p1, p2] = t.map(|v| x[v]);
        let cr = softsense::math::cross(softsense::math::sub(p1, p0), softsense::math::sub(p2, p0));
        let ar = 0.5 * (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
        for &v in t {
            area[v] += ar / 3.0;
        }
    }
    let mut cols: Vec<(usize, [f64; 3])> = view.pushed.clone();
    cols.extend(
        view.seen
            .iter()
            .map(|&v| (v, surface.vertex_normals[v].map(|c| -c))),
    );
    let (wp, _) = ray_compliance(&model, &x, &refs, &cols).unwrap();
    let np = view.pushed.len();
    let wpress: Vec<f64> = (0..refs.len())
        .map(|i| {
            view.seen
                .iter()
                .enumerate()
                .map(|(j, &v)| wp[(i, np + j)] * area[v])
                .sum()
        })
        .collect();
    let push_w = wp.columns(0, np).into_owned();
    for f in 0..150 {
        let mut rows = Vec::new();
        let mut observed = Vec::new();
        for (i, r) in refs.iter().enumerate() {
            if let Some(m) = r.motion(&clouds[f], &obs) {
                if m.abs() < 0.02 {
                    rows.push(i);
                    observed.push(m);
                }
            }
        }
        let problem = PushProblem {
            compliance: push_w.select_rows(&rows),
            free: rows.iter().map(|&i| wpress[i] * (p[f] - p0)).collect(),
            observed,
            sigma: rows.iter().map(|&i| refs[i].sigma).collect(),
            directions: view.pushed.iter().map(|(_, d)| *d).collect(),
            positions: view.pushed.iter().map(|(v, _)| x[*v]).collect(),
        };
        let est = solve_pushes(&problem, &PushParams::default()).unwrap();
        println!(
            "{f} {:.3} {:.3} {:.3}",
            est.magnitude, meas[f], est.sigma_noise
        );
    }
}
