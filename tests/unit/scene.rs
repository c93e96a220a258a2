//! Scene rendering pieces: the BVH against a brute-force ray caster, the camera, the sensor.
use proptest::prelude::*;
use softsense::fem::mesh::TetMesh;
use softsense::geometry::raycast::{ray_plane, ray_sphere, ray_triangle, Bvh};
use softsense::scene::camera::CameraSpec;
use softsense::scene::sensor::SensorModel;

fn box_surface() -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let m = TetMesh::structured_box([0.0, 0.0, 0.0], [0.1, 0.05, 0.03], [6, 3, 2]).unwrap();
    let s = m.surface();
    (m.nodes_in_rest.clone(), s.triangles)
}

proptest! {
    #[test]
    fn bvh_finds_the_same_nearest_hit_as_brute_force(
        ox in -0.2f64..0.3, oy in -0.2f64..0.2, oz in 0.1f64..0.4,
        tx in 0.0f64..0.1, ty in 0.0f64..0.05, tz in 0.0f64..0.03,
    ) {
        let (v, t) = box_surface();
        let bvh = Bvh::new(&v, &t);
        let o = [ox, oy, oz];
        let d = [tx - ox, ty - oy, tz - oz];
        // The nearest hit, and of equal ones the triangle given first.
        let (brute, first) = t
            .iter()
            .enumerate()
            .filter_map(|(k, tri)| ray_triangle(o, d, tri.map(|i| v[i]), 0.0).map(|t| (t, k)))
            .fold((f64::INFINITY, usize::MAX), |b, h| if h.0 < b.0 { h } else { b });
        let hit = bvh.cast_triangle(o, d);
        prop_assert!(hit.is_some());
        let (hit, k) = hit.unwrap();
        prop_assert_eq!(hit.t, brute);
        prop_assert_eq!(k, first);
    }
}

proptest! {
    #[test]
    fn a_refitted_bvh_finds_the_same_nearest_hit_as_brute_force_on_the_moved_mesh(
        ox in -0.2f64..0.3, oy in -0.2f64..0.2, oz in 0.1f64..0.4,
        tx in 0.0f64..0.1, ty in 0.0f64..0.05, tz in 0.0f64..0.03,
        bend in -2.0f64..2.0, seed in 0u64..1000,
    ) {
        let (rest, t) = box_surface();
        // A bend along x, plus a jitter per vertex: the groups built at rest no longer
        // match the moved mesh's layout, and the boxes must regrow to stay correct.
        let moved: Vec<[f64; 3]> = rest
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let j = ((i as u64 * 2654435761 + seed) % 1000) as f64 / 1000.0 - 0.5;
                [p[0], p[1] + 0.01 * j, p[2] + bend * p[0] * p[0] + 0.005 * j]
            })
            .collect();
        let mut bvh = Bvh::new(&rest, &t);
        prop_assert!(bvh.refit(&moved));
        let o = [ox, oy, oz + 0.05];
        let d = [tx - ox, ty - oy, tz - oz - 0.05];
        let brute = t
            .iter()
            .enumerate()
            .filter_map(|(k, tri)| ray_triangle(o, d, tri.map(|i| moved[i]), 0.0).map(|t| (t, k)))
            .fold(None, |b: Option<(f64, usize)>, h| match b {
                Some(b) if b.0 <= h.0 => Some(b),
                _ => Some(h),
            });
        let hit = bvh.cast_triangle(o, d).map(|(h, k)| (h.t, k));
        prop_assert_eq!(hit, brute);
        prop_assert_eq!(hit, Bvh::new(&moved, &t).cast_triangle(o, d).map(|(h, k)| (h.t, k)));
    }
}

#[test]
fn a_bvh_is_not_refitted_to_too_few_vertices() {
    let (v, t) = box_surface();
    let mut bvh = Bvh::new(&v, &t);
    let before = bvh.cast([0.05, 0.025, 1.0], [0.0, 0.0, -1.0]);
    assert!(!bvh.refit(&v[..v.len() - 1]));
    assert_eq!(bvh.cast([0.05, 0.025, 1.0], [0.0, 0.0, -1.0]), before);
}

#[test]
fn bvh_normal_points_outward_on_the_top_face() {
    let (v, t) = box_surface();
    let bvh = Bvh::new(&v, &t);
    let h = bvh.cast([0.05, 0.025, 1.0], [0.0, 0.0, -1.0]).unwrap();
    assert!((h.t - 0.97).abs() < 1e-12);
    assert!((h.normal[2] - 1.0).abs() < 1e-12);
    assert!(bvh.cast([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]).is_none());
}

#[test]
fn sphere_and_plane_hits_are_exact() {
    let h = ray_sphere([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], 0.25).unwrap();
    assert!((h.t - 0.75).abs() < 1e-12 && (h.normal[2] + 1.0).abs() < 1e-12);
    assert!(ray_sphere([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.25).is_none());
    let p = ray_plane([0.1, 0.0, 0.5], [0.0, 0.0, -2.0], [0.0, 0.0, 1.0], 0.0, 0.3).unwrap();
    assert!((p.t - 0.25).abs() < 1e-12 && p.normal[2] == 1.0);
    assert!(ray_plane([0.5, 0.0, 0.5], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0], 0.0, 0.3).is_none());
}

#[test]
fn camera_ray_and_backprojection_agree() {
    let cam = CameraSpec::default().camera().unwrap();
    let d = cam.ray(100.0, 50.0);
    let p = cam.backproject(100.0, 50.0, 0.4);
    let (eye, axis_z) = (cam.eye(), cam.axis_z());
    assert_eq!(eye, CameraSpec::default().eye);
    for k in 0..3 {
        assert!((p[k] - (eye[k] + 0.4 * d[k])).abs() < 1e-15);
    }
    // The camera z component of the ray is 1: depth is the distance along the optical axis.
    let z: f64 = (0..3).map(|k| d[k] * axis_z[k]).sum();
    assert!((z - 1.0).abs() < 1e-12);
    // robot_from_camera maps camera (0,0,1) to eye + axis z.
    let t = cam.robot_from_camera().to_matrix();
    for (k, row) in t.iter().take(3).enumerate() {
        assert!((row[2] + row[3] - (eye[k] + axis_z[k])).abs() < 1e-15);
    }
    let mut bad = CameraSpec::default();
    bad.target = bad.eye;
    assert!(bad.camera().is_none());
}

#[test]
fn sensor_off_only_quantises_and_on_adds_noise_of_the_right_size() {
    let n = 20_000;
    let z = vec![0.5; n];
    let c = vec![1.0; n];
    let off = SensorModel {
        enabled: false,
        ..Default::default()
    };
    assert!(off.depth(&z, &c, 200, 1, 0).iter().all(|&d| d == 500));
    let on = SensorModel {
        depth_unit: 1e-5,
        ..Default::default()
    };
    let d = on.depth(&z, &c, 200, 1, 0);
    let mean = d.iter().map(|&v| v as f64 * 1e-5).sum::<f64>() / n as f64;
    let sd = (d
        .iter()
        .map(|&v| (v as f64 * 1e-5 - mean).powi(2))
        .sum::<f64>()
        / n as f64)
        .sqrt();
    let expected = on.depth_k * 0.25;
    assert!((mean - 0.5).abs() < 3.0 * expected / (n as f64).sqrt() + 1e-6);
    assert!(
        (sd / expected - 1.0).abs() < 0.03,
        "sd {sd} expected {expected}"
    );
    // Grazing pixels become holes.
    let g = on.depth(&z, &vec![0.05; n], 200, 1, 0);
    assert!(g.iter().all(|&v| v == 0));
}

#[test]
fn a_model_path_relative_to_the_recording_leads_back_to_the_model_file() {
    let root = tempfile::tempdir().unwrap();
    let model_dir = root.path().join("meshes/models");
    let out = root.path().join("clouds/scenes/one");
    std::fs::create_dir_all(&model_dir).unwrap();
    std::fs::create_dir_all(&out).unwrap();
    let model = model_dir.join("robot.toml");
    std::fs::write(&model, "").unwrap();
    let rel = softsense::scene::relative_to(&model, &out).unwrap();
    assert_eq!(
        rel,
        std::path::Path::new("../../../meshes/models/robot.toml")
    );
    assert_eq!(
        std::fs::canonicalize(out.join(&rel)).unwrap(),
        std::fs::canonicalize(&model).unwrap()
    );
    // A model inside the recording's folder, and a path that does not exist.
    std::fs::write(out.join("m.toml"), "").unwrap();
    let inside = softsense::scene::relative_to(&out.join("m.toml"), &out).unwrap();
    assert_eq!(inside, std::path::Path::new("m.toml"));
    assert!(softsense::scene::relative_to(&root.path().join("missing.toml"), &out).is_none());
    // Folders that share only the root (`/dev` and a temporary folder): the absolute path,
    // not a climb to the root and back down.
    #[cfg(target_os = "linux")]
    {
        let abs = softsense::scene::relative_to(&model, std::path::Path::new("/dev")).unwrap();
        assert_eq!(abs, std::fs::canonicalize(&model).unwrap());
    }
}

#[test]
fn a_sensor_model_out_of_range_is_refused_by_name() {
    assert_eq!(SensorModel::default().validate(), Ok(()));
    type Spoil = fn(&mut SensorModel);
    let cases: [(&str, Spoil); 12] = [
        ("depth_unit", |s| s.depth_unit = 0.0),
        ("depth_k", |s| s.depth_k = -0.001),
        ("grazing_deg", |s| s.grazing_deg = 95.0),
        ("edge_jump", |s| s.edge_jump = f64::NAN),
        ("edge_hole_probability", |s| s.edge_hole_probability = 1.5),
        ("color_sigma", |s| s.color_sigma = f64::INFINITY),
        ("depth_sigma_floor", |s| s.depth_sigma_floor = -1e-5),
        ("depth_sigma_incidence", |s| {
            s.depth_sigma_incidence = f64::NAN
        }),
        ("depth_step_k", |s| s.depth_step_k = -0.003),
        ("hole_probability", |s| s.hole_probability = 1.01),
        ("flying_probability", |s| s.flying_probability = -0.1),
        ("flying_spread", |s| s.flying_spread = 2.0),
    ];
    for (name, spoil) in cases {
        let mut s = SensorModel::default();
        spoil(&mut s);
        let e = s.validate().unwrap_err();
        assert!(e.starts_with(&format!("sensor.{name} ")), "{e}");
    }
}

#[test]
fn a_load_off_the_robot_is_refused_before_any_frame_is_made() {
    // Frame 1's probe is given in millimetres: 116 m from the robot in metres. Snapping it
    // to the nearest surface node would make a scene nobody asked for.
    let model = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/models/robot.toml");
    let dir = tempfile::tempdir().unwrap();
    let scene_file = dir.path().join("slip.toml");
    let probe = |at: &str| {
        format!(
            "[[frames]]\n[[frames.loads]]\nkind = \"probe\"\nat = {at}\nforce = [0.0, 0.4, 0.0]\n"
        )
    };
    std::fs::write(
        &scene_file,
        format!(
            "model = {:?}\n{}{}",
            model.display().to_string(),
            probe("[0.0572, -0.0132, 0.1]"),
            probe("[57.2, -13.2, 100.0]")
        ),
    )
    .unwrap();
    let scene = softsense::scene::Scene::load(&scene_file).unwrap();
    let out = dir.path().join("out");
    let e = softsense::scene::generate(&scene, &out, |_, _| {})
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("frame 1, load 0: at = [57.2, -13.2, 100]"),
        "{e}"
    );
    assert!(e.contains("in metres"), "{e}");
    assert!(
        !out.join("depth_0000.png").exists(),
        "frame 0 was made first"
    );
    // On the surface (a node of the rest mesh, within the limit) it is accepted.
    let m = softsense::fem::model::Model::load(&model, None).unwrap();
    let ok = softsense::scene::render_frame(&scene, &m, 0);
    assert!(ok.is_ok(), "{:?}", ok.err());
}
