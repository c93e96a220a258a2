//! Membrane sensing end to end on a synthetic membrane (truth = model, an upper bound): a
//! pre-tensioned disk seen from below by a pinhole camera, pushed from above by a known
//! load; its depth frames rasterised from the FE solution, and the push read back by
//! [`MembraneSensor`].

use softsense::camera::lens::Lens;
use softsense::camera::PinholeIntrinsics;
use softsense::cloud::PointCloud;
use softsense::fem::model::{Model, ModelSpec};
use softsense::fem::shell::{extrude, SurfaceMesh};
use softsense::fem::solve::{MappedPoint, PointLoad};
use softsense::math::pose::Pose;
use softsense::sense::membrane::{
    FitFrame, MembraneCamera, MembraneParams, MembraneSensor, MembraneStatus,
};

const CAMERA_Z: f64 = -0.06;

fn k() -> PinholeIntrinsics {
    PinholeIntrinsics {
        width: 160,
        height: 120,
        fx: 80.0,
        fy: 80.0,
        cx: 79.5,
        cy: 59.5,
    }
}

/// A clamped disk of 40 mm, 0.4 mm thick, pre-tensioned to 200 N/m, one layer grown up
/// (+z): the camera below sees layer 0, a push from above lands on layer 1.
fn disk_model() -> Model {
    let spec: ModelSpec = toml::from_str(
        "formulation = \"corotational\"\n[mesh]\npath = \"unused.vtk\"\n\
         shell = { thickness = 0.0004, layers = 1, side = \"outside\", tension = 200.0 }\n\
         [material]\nyoung = 5e4\npoisson = 0.45\n[[fixed]]\nmarked = true\n",
    )
    .unwrap();
    let surface = SurfaceMesh::disk(0.04, 8).unwrap();
    let params = spec.mesh.shell.unwrap();
    let body = extrude(&surface, &params).unwrap();
    Model::from_body(&spec, body).unwrap()
}

fn robot_from_camera() -> Pose {
    Pose::from_matrix(&[
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, CAMERA_Z],
        [0.0, 0.0, 0.0, 1.0],
    ])
    .unwrap()
}

/// The depth frame of the membrane's lower face with nodes at `x` (robot frame): each
/// lower-face triangle rasterised, depth interpolated linearly in the image, nearest kept.
fn frame(model: &Model, x: &[[f64; 3]]) -> PointCloud {
    let k = k();
    let (w, h) = (k.width as usize, k.height as usize);
    let mut z = vec![f64::INFINITY; w * h];
    let n = x.len() / 2;
    let surface = model.problem.mesh.surface();
    let project = |p: [f64; 3]| {
        let zc = p[2] - CAMERA_Z;
        [k.fx * p[0] / zc + k.cx, k.fy * p[1] / zc + k.cy, zc]
    };
    for t in surface
        .triangles
        .iter()
        .filter(|t| t.iter().all(|&v| v < n))
    {
        let [a, b, c] = t.map(|v| project(x[v]));
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
        if area.abs() < 1e-12 {
            continue;
        }
        let lo = |i: usize| a[i].min(b[i]).min(c[i]).floor().max(0.0) as usize;
        let hi = |i: usize, m: usize| (a[i].max(b[i]).max(c[i]).ceil() as usize).min(m - 1);
        for v in lo(1)..=hi(1, h) {
            for u in lo(0)..=hi(0, w) {
                let (pu, pv) = (u as f64, v as f64);
                let wa = ((b[0] - pu) * (c[1] - pv) - (c[0] - pu) * (b[1] - pv)) / area;
                let wb = ((c[0] - pu) * (a[1] - pv) - (a[0] - pu) * (c[1] - pv)) / area;
                let wc = 1.0 - wa - wb;
                if wa < -1e-9 || wb < -1e-9 || wc < -1e-9 {
                    continue;
                }
                let d = wa * a[2] + wb * b[2] + wc * c[2];
                z[v * w + u] = z[v * w + u].min(d);
            }
        }
    }
    let positions = (0..w * h)
        .map(|i| {
            let d = z[i];
            if !d.is_finite() {
                return [f32::NAN; 3];
            }
            let (u, v) = ((i % w) as f64, (i / w) as f64);
            [(u - k.cx) / k.fx * d, (v - k.cy) / k.fy * d, d].map(|c| c as f32)
        })
        .collect();
    PointCloud {
        width: w as u32,
        height: h as u32,
        ..PointCloud::from_positions(positions)
    }
}

/// The membrane pushed down (toward the camera) by `force` N spread over the upper-face
/// nodes within 6 mm of (12 mm, 0): the deformed nodes.
fn pushed(model: &Model, force: f64) -> Vec<[f64; 3]> {
    let x = &model.problem.mesh.nodes_in_rest;
    let n = x.len() / 2;
    let patch: Vec<usize> = (n..2 * n)
        .filter(|&v| (x[v][0] - 0.012).hypot(x[v][1]) < 0.006)
        .collect();
    assert!(patch.len() >= 3, "{patch:?}");
    let mut m = model.clone();
    m.problem.loads = (patch.iter())
        .map(|&v| PointLoad {
            at: MappedPoint::node(v),
            force: [0.0, 0.0, -force / patch.len() as f64],
        })
        .collect();
    let sol = m.problem.solve_static(&m.newton).unwrap();
    assert!(sol.converged);
    (x.iter().zip(&sol.displacement))
        .map(|(p, d)| [p[0] + d[0], p[1] + d[1], p[2] + d[2]])
        .collect()
}

/// The sensor of `model` through the test camera.
fn sensor_of(
    model: &Model,
    rest: &[(&PointCloud, f64)],
    still: &[&PointCloud],
    params: MembraneParams,
) -> softsense::sense::membrane::MembraneResult<MembraneSensor> {
    let (k, lens, pose) = (k(), Lens::Pinhole, robot_from_camera());
    let camera = MembraneCamera {
        intrinsics: &k,
        lens: &lens,
        robot_from_camera: &pose,
    };
    MembraneSensor::new(model, camera, rest, still, params)
}

#[test]
fn a_push_on_the_unseen_face_of_a_synthetic_membrane_is_read_back_from_the_seen_one() {
    let model = disk_model();
    let rest = frame(&model, &model.problem.mesh.nodes_in_rest);
    let mut params = MembraneParams::default();
    // Noise-free frames: every node's noise is the floor.
    params.reference.sigma_floor = 1e-5;
    let mut sensor = sensor_of(&model, &[(&rest, 0.0)], &[&rest, &rest, &rest], params).unwrap();
    assert!(sensor.pose_offset < 1e-4, "{}", sensor.pose_offset);
    assert!(sensor.refs.len() > 50, "{} nodes read", sensor.refs.len());
    // The rest frame reads nothing.
    let still = sensor.estimate(&sensor.observe(&rest), 0.0);
    assert_eq!(still.status, MembraneStatus::Ok);
    assert!(still.magnitude < 1e-3, "{}", still.magnitude);
    let mut rows = Vec::new();
    for force in [0.001, 0.05, 0.2] {
        let cloud = frame(&model, &pushed(&model, force));
        let e = sensor.estimate(&sensor.observe(&cloud), 0.0);
        assert_eq!(e.status, MembraneStatus::Ok);
        println!(
            "push {force} N: read {:.4} N {:?}, centre {:?}, {} patch nodes",
            e.magnitude,
            e.net_force,
            e.centre_of_pressure,
            e.patch_nodes.len()
        );
        // Rasterised depth is not the nodes' exact depth: within 3%, pushing down, near
        // the patch.
        assert!(
            (e.magnitude / force - 1.0).abs() < 0.03,
            "{force}: {}",
            e.magnitude
        );
        assert!(e.net_force[2] < -0.9 * e.magnitude, "{:?}", e.net_force);
        let c = e.centre_of_pressure;
        assert!((c[0] - 0.012).hypot(c[1]) < 0.006, "centre {c:?}");
        rows.push(FitFrame {
            frame: rows.len(),
            motions: sensor.observe(&cloud),
            pressure: 0.0,
            known: force,
        });
    }
    // The fit finds the model's own stiffness again (truth = model).
    let fit = sensor.fit_stiffness(&rows).unwrap();
    assert!((fit.scale - 1.0).abs() < 0.1, "scale {}", fit.scale);
}

#[test]
fn a_frame_without_pressure_or_with_too_few_nodes_gets_a_status() {
    let model = disk_model();
    let rest = frame(&model, &model.problem.mesh.nodes_in_rest);
    let sensor = sensor_of(
        &model,
        &[(&rest, 0.0)],
        &[&rest, &rest, &rest],
        MembraneParams::default(),
    )
    .unwrap();
    let motions = sensor.observe(&rest);
    let e = sensor.estimate(&motions, f64::NAN);
    assert_eq!(e.status, MembraneStatus::NoPressure);
    let blank = PointCloud {
        width: rest.width,
        height: rest.height,
        ..PointCloud::from_positions(vec![[f32::NAN; 3]; rest.len()])
    };
    let e = sensor.estimate(&sensor.observe(&blank), 0.0);
    assert_eq!((e.status, e.nodes_read), (MembraneStatus::TooFewNodes, 0));
    // A rest frame whose pressure is NaN, or no rest frame, is refused.
    let err = sensor_of(&model, &[], &[], MembraneParams::default());
    assert!(err.unwrap_err().to_string().contains("no rest frames"));
    let err = sensor_of(&model, &[(&rest, f64::NAN)], &[], MembraneParams::default());
    assert!(err.unwrap_err().to_string().contains("pressure"));
}

#[test]
fn sense_membrane_refuses_options_it_does_not_take_and_a_body_that_is_not_a_shell() {
    let root = softsense_root();
    let scene = root.join("clouds/scenes/tip_weight");
    let run = |extra: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_softsense"))
            .arg("sense")
            .arg(&scene)
            .args(["--membrane"])
            .args(extra)
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    };
    // The rest frames are required.
    let (code, err) = run(&[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--reference-frames"), "{err}");
    let (code, err) = run(&["--reference-frames", "1", "--track"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--membrane does not take --track"), "{err}");
    // The tip-weight robot is a solid: said, not a panic.
    let (code, err) = run(&["--reference-frames", "1"]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("must be a shell"), "{err}");
}

fn softsense_root() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}
