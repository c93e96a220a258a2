//! Marker-based sensing: track files, the hidden rule, binding, W_ef against finite
//! differences of the FE solve, the location rule.
use softsense::fem::material::Material;
use softsense::fem::mesh::TetMesh;
use softsense::fem::solve::{
    Cable, CableControl, Formulation, MappedPoint, NewtonParams, PointLoad, Problem,
};
use softsense::fem::FemError;
use softsense::markers::tracks::{
    flag_hidden, read_motive_str, read_tracks_str, write_tracks_string, TracksError,
};
use softsense::markers::{
    bind_markers, locate_forces, CandidateLocation, Directions, MarkerSensor, MarkersError,
    MarkersParams, MarkersStatus,
};

#[test]
fn tracks_round_trip_through_the_csv_writer() {
    let text = "frame,marker,x,y,z\n0,a,0.1,0.2,0.3\n0,b,,,\n1,b,1e-3,-2.5,0\n";
    let t = read_tracks_str(text).unwrap();
    assert_eq!(t.names, ["a", "b"]);
    assert_eq!(t.frames.len(), 2);
    assert_eq!(t.frames[0].positions, [Some([0.1, 0.2, 0.3]), None]);
    // Frame 1 has no row for a: hidden.
    assert_eq!(t.frames[1].positions, [None, Some([1e-3, -2.5, 0.0])]);
    assert_eq!(read_tracks_str(&write_tracks_string(&t)).unwrap(), t);
}

#[test]
fn bad_track_lines_are_errors_naming_the_line() {
    let cases = [
        ("frame,marker,x,y,z\n0,a,0.1,0.2\n", 2),
        ("frame,marker,x,y,z\n0,a,0,0,0\n0,a,nan,0,0\n", 3),
        ("frame,marker,x,y,z\n0,a,0,0,0\n1,a,0,0,0\n0,b,0,0,0\n", 4),
        ("frame,marker,x,y,z\n0,a,0,0,0\n0,a,1,1,1\n", 3),
        ("frame,marker,x,y,z\n-1,a,0,0,0\n", 2),
        ("frame,marker,x,y,z\n0,a,0,,0\n", 2),
        ("time,x,y,z\n", 1),
        ("", 1),
    ];
    for (text, want) in cases {
        match read_tracks_str(text) {
            Err(TracksError::Parse { line, .. }) => assert_eq!(line, want, "{text:?}"),
            other => panic!("{text:?}: {other:?}"),
        }
    }
}

const MOTIVE: &str =
    "Format Version,1.23,Take Name,Take 1,Length Units,Millimeters,Coordinate Space,Global\n\
\n\
,,Marker,Marker,Marker,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Marker,Marker,Marker\n\
,Name,sheet:m1,sheet:m1,sheet:m1,body,body,body,body,sheet:m2,sheet:m2,sheet:m2\n\
,,Position,Position,Position,Rotation,Rotation,Rotation,Rotation,Position,Position,Position\n\
Frame,Time (Seconds),X,Y,Z,X,Y,Z,W,X,Y,Z\n\
0,0.000,10.0,20.0,30.0,0,0,0,1,1,2,3\n\
1,0.010,11.0,21.0,31.0,0,0,0,1,,,\n";

#[test]
fn motive_exports_give_metres_and_skip_rotations() {
    let t = read_motive_str(MOTIVE).unwrap();
    assert_eq!(t.names, ["sheet:m1", "sheet:m2"]);
    assert_eq!(t.frames[0].positions[0], Some([0.010, 0.020, 0.030]));
    assert_eq!(t.frames[0].positions[1], Some([0.001, 0.002, 0.003]));
    assert_eq!(t.frames[1].positions[1], None);
    let bad = MOTIVE.replace("11.0,21.0", "11.0,oops");
    match read_motive_str(&bad) {
        Err(TracksError::Parse { line, .. }) => assert_eq!(line, 8),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_marker_that_jumps_or_is_missing_is_hidden() {
    let text = "frame,marker,x,y,z\n0,a,0,0,0\n0,b,0,0,0\n1,a,0.001,0,0\n1,b,0.02,0,0\n2,a,,,\n2,b,0.001,0,0\n";
    let t = read_tracks_str(text).unwrap();
    let h = flag_hidden(&t, &MarkersParams::default());
    // b's jump of 20 mm in frame 1 is refused; in frame 2 it is back near its last
    // accepted position.
    assert_eq!(h, [[false, false], [false, true], [true, false]]);
}

/// A 5 x 5 grid of markers 40 mm apart on a sheet fixed at its corners, and the same grid
/// sagging under a load at its centre: each marker moves down by 0.5 mm + (`sag` − 0.5 mm)
/// (1 − r²/r_c²), r_c the corners' distance: 0.5 mm at the corners and `sag` (m) at the
/// centre.
fn sagging_grid(sag: f64) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let mut rest = Vec::new();
    let mut loaded = Vec::new();
    for i in 0..5 {
        for j in 0..5 {
            let (x, y) = (0.04 * (i as f64 - 2.0), 0.04 * (j as f64 - 2.0));
            let r2 = (x * x + y * y) / (2.0 * 0.08 * 0.08);
            rest.push([x, y, 0.0]);
            loaded.push([x, y, -(0.0005 + (sag - 0.0005) * (1.0 - r2))]);
        }
    }
    (rest, loaded)
}

fn grid_tracks(frames: &[Vec<Option<[f64; 3]>>]) -> softsense::markers::MarkerTracks {
    softsense::markers::MarkerTracks {
        names: (0..frames[0].len()).map(|m| format!("m{m}")).collect(),
        frames: (frames.iter().enumerate())
            .map(|(k, p)| softsense::markers::TrackFrame {
                frame: k as u64,
                positions: p.clone(),
            })
            .collect(),
    }
}

/// Issue 51 item 4: on the painted sheet seen from another camera the raw 5 mm jump rule
/// hid 4 of 16 markers of the first loaded frame that had only moved with the load.
#[test]
fn a_marker_that_moves_with_the_load_more_than_the_jump_is_not_hidden() {
    let (rest, loaded) = sagging_grid(0.012);
    let moved = (rest.iter().zip(&loaded))
        .filter(|(a, b)| (a[2] - b[2]).abs() > 0.005)
        .count();
    assert!(moved >= 5, "{moved} markers move more than the 5 mm jump");
    let t = grid_tracks(&[
        rest.iter().copied().map(Some).collect(),
        loaded.iter().copied().map(Some).collect(),
    ]);
    let h = flag_hidden(&t, &MarkersParams::default());
    assert_eq!(
        h[1],
        vec![false; 25],
        "markers that move with the load are kept"
    );
}

#[test]
fn a_marker_that_jumps_away_from_its_neighbours_motion_is_still_hidden() {
    let (rest, loaded) = sagging_grid(0.012);
    let mut now: Vec<Option<[f64; 3]>> = loaded.iter().copied().map(Some).collect();
    // The centre marker reported 8 mm sideways (a reflection; the sheet moves only down), a
    // marker swapped with its neighbour 40 mm along x, and one missing.
    now[12] = now[12].map(|p| [p[0] + 0.008, p[1], p[2]]);
    now[7] = now[2];
    now[20] = None;
    let t = grid_tracks(&[rest.iter().copied().map(Some).collect(), now]);
    let h = flag_hidden(&t, &MarkersParams::default());
    let hidden: Vec<usize> = (0..25).filter(|&m| h[1][m]).collect();
    // Marker 2 and its swapped copy 7 report the same point: 2 is accepted (it is where it
    // is expected), 7 is 40 mm off.
    assert_eq!(hidden, [7, 12, 20]);
}

/// Detection identities follow the body too: a detection 12 mm from the marker's last
/// position, beyond the 10 mm `max_jump`, keeps its identity when its neighbours moved
/// alike.
#[test]
fn detections_that_move_with_the_body_keep_their_identities() {
    let (rest, loaded) = sagging_grid(0.012);
    let mut shuffled = loaded.clone();
    shuffled.reverse();
    let (t, dropped) = softsense::markers::detect::track_detections(
        &[(0, rest.clone()), (1, shuffled)],
        None,
        0.01,
    );
    assert_eq!(dropped, 0);
    assert_eq!(t.names.len(), 25, "no marker started anew");
    for (m, p) in loaded.iter().enumerate() {
        assert_eq!(t.frames[1].positions[m], Some(*p), "marker {m}");
    }
}

/// A 100 x 20 x 20 mm bar fixed at x = 0, with an optional cable held at 2 mm.
fn bar(cable: bool) -> Problem {
    let mesh = TetMesh::structured_box([0.0; 3], [0.1, 0.02, 0.02], [10, 2, 2]).unwrap();
    let mut p = Problem::new(
        mesh,
        Material::new(1e5, 0.45).unwrap(),
        Formulation::Corotational,
    );
    p.fixed = p.mesh.nodes_in_box([-1e-6; 3], [1e-6, 1.0, 1.0]);
    if cable {
        let tip = p.mesh.nodes_in_box(
            [0.1 - 1e-6, 0.01 - 1e-6, 0.02 - 1e-6],
            [0.2, 0.01 + 1e-6, 0.03],
        )[0];
        p.cables.push(Cable {
            name: "c".into(),
            pull: [0.0, 0.01, 0.02],
            attach: vec![MappedPoint::node(tip)],
            control: CableControl::Displacement(0.002),
        });
    }
    p
}

/// The bar with its top face (z = 0.02) an open cavity held at a volume change of 0.1 cm³.
fn bar_with_held_cavity() -> Problem {
    let mut p = bar(false);
    let cavity = softsense::fem::solve::Cavity::from_box(
        "top",
        &p.mesh,
        [0.02, -1.0, 0.02 - 1e-6],
        [1.0, 1.0, 1.0],
        softsense::fem::solve::CavityControl::Volume(1e-7),
    )
    .unwrap();
    p.cavities.push(cavity);
    p
}

fn bar_sensor(cable: bool) -> MarkerSensor {
    sensor_on(bar(cable))
}

fn sensor_on(p: Problem) -> MarkerSensor {
    let surface = p.mesh.surface();
    let at = [
        [0.05, 0.013, 0.02],
        [0.1, 0.007, 0.011],
        [0.075, 0.0, 0.005],
    ];
    let names: Vec<String> = ["a", "b", "c"].map(String::from).to_vec();
    let markers = bind_markers(&p.mesh.nodes_in_rest, &surface, &names, &at, 1e-3).unwrap();
    let cand = vec![
        CandidateLocation::snapped(
            "tip",
            &p.mesh,
            &surface,
            [0.1, 0.01, 0.02],
            Directions::Free,
        )
        .unwrap(),
        CandidateLocation::snapped(
            "mid",
            &p.mesh,
            &surface,
            [0.06, 0.01, 0.02],
            Directions::Normal,
        )
        .unwrap(),
    ];
    MarkerSensor::new(
        &p,
        NewtonParams::default(),
        markers,
        cand,
        MarkersParams::default(),
    )
    .unwrap()
}

#[test]
fn markers_bind_to_their_nearest_surface_point() {
    let s = bar_sensor(false);
    let x = &s.problem.mesh.nodes_in_rest;
    for (m, want) in s.markers.iter().zip([
        [0.05, 0.013, 0.02],
        [0.1, 0.007, 0.011],
        [0.075, 0.0, 0.005],
    ]) {
        let p = m.at.position(x);
        assert!(
            (0..3).all(|k| (p[k] - want[k]).abs() < 1e-12),
            "{p:?} vs {want:?}"
        );
        assert!(m.distance < 1e-12);
    }
    let far = bind_markers(
        &s.problem.mesh.nodes_in_rest,
        &s.problem.mesh.surface(),
        &["f".into()],
        &[[0.05, 0.01, 0.05]],
        1e-3,
    );
    assert!(matches!(far, Err(FemError::OffSurface { .. })));
}

#[test]
fn w_ef_columns_match_finite_differences_of_the_fe_solve() {
    for (cable, p) in [
        ("none", bar(false)),
        ("cable", bar(true)),
        ("cavity", bar_with_held_cavity()),
    ] {
        let s = sensor_on(p);
        let lambda = [0.0, 0.0, -0.02, 0.01];
        let all = [0, 1, 2];
        let (_, w) = s.linearise(&lambda, &all, None).unwrap();
        let markers_under = |l: &[f64]| -> Vec<f64> {
            let mut p = s.problem.clone();
            let mut k = 0;
            for c in &s.locations {
                let mut f = [0.0; 3];
                for d in c.candidates.iter().map(|c| c.direction) {
                    (0..3).for_each(|a| f[a] += l[k] * d[a]);
                    k += 1;
                }
                p.loads.push(PointLoad {
                    at: c.at(),
                    force: f,
                });
            }
            let sol = p.solve_static(&s.newton).unwrap();
            s.markers
                .iter()
                .flat_map(|m| m.at.position(&sol.positions))
                .collect()
        };
        let h = 1e-4;
        for j in 0..lambda.len() {
            let (mut lp, mut lm) = (lambda.to_vec(), lambda.to_vec());
            lp[j] += h;
            lm[j] -= h;
            let (up, um) = (markers_under(&lp), markers_under(&lm));
            for i in 0..9 {
                let fd = (up[i] - um[i]) / (2.0 * h);
                assert!(
                    (w[(i, j)] - fd).abs() <= 1e-4 * w.amax(),
                    "cable {cable}: W[{i},{j}] = {} vs {fd}",
                    w[(i, j)]
                );
            }
        }
    }
}

#[test]
fn too_few_visible_markers_is_not_identifiable() {
    let s = bar_sensor(false);
    // One visible marker: 3 rows for 4 unknowns (Corollary 1).
    let est = s
        .solve_frame(0, &[Some([0.05, 0.013, 0.02]), None, None], None)
        .unwrap();
    assert_eq!(
        est.status,
        MarkersStatus::NotIdentifiable {
            rows: 3,
            unknowns: 4
        }
    );
    assert!(est.forces.is_empty());
    assert_eq!(est.hidden, [1, 2]);
    assert!(!est.warnings.is_empty());
}

#[test]
fn found_candidates_are_grouped_at_their_weighted_centre() {
    let s = bar_sensor(false);
    let mut est = s
        .solve_frame(
            0,
            &[
                Some([0.05, 0.013, 0.02]),
                Some([0.1, 0.007, 0.011]),
                Some([0.075, 0.0, 0.005]),
            ],
            None,
        )
        .unwrap();
    // Forces and sigmas set by hand: tip 3 N along -z, mid 1 N: both found, 40 mm apart.
    est.forces = vec![[0.0, 0.0, -3.0], [0.0, 0.0, 1.0]];
    est.sigma = vec![0.01; 4];
    let mut params = MarkersParams {
        group_radius: 0.05,
        ..Default::default()
    };
    let located = locate_forces(&est, &s.locations, &params);
    assert_eq!(located.len(), 1);
    assert_eq!(located[0].candidates, [0, 1]);
    let (pt, pm) = (s.locations[0].position, s.locations[1].position);
    let want = (0..3)
        .map(|k| 0.75 * pt[k] + 0.25 * pm[k])
        .collect::<Vec<_>>();
    assert!((0..3).all(|k| (located[0].centre[k] - want[k]).abs() < 1e-12));
    assert_eq!(located[0].force, [0.0, 0.0, -2.0]);
    // Apart when the radius is smaller; below the fraction of the largest, not found.
    params.group_radius = 0.01;
    assert_eq!(locate_forces(&est, &s.locations, &params).len(), 2);
    params.found_fraction = 0.5;
    assert_eq!(locate_forces(&est, &s.locations, &params).len(), 1);
    // Below its σ rule, not found.
    est.sigma = vec![1.0; 4];
    assert!(locate_forces(&est, &s.locations, &params).is_empty());
}

#[test]
fn candidate_files_snap_to_surface_nodes_and_name_bad_lines() {
    let p = bar(false);
    let text = "name,x,y,z,directions\ntip,0.1005,0.0098,0.0201,3d\nmid,0.06,0.01,0.02,normal\n";
    let c = softsense::markers::bind::parse_candidates(text, &p.mesh).unwrap();
    assert_eq!(c.len(), 2);
    assert_eq!(c[0].position, [0.1, 0.01, 0.02]);
    assert_eq!(c[0].unknowns(), 3);
    // The top face's normal at an interior node of it.
    let n = c[1].candidates[0].direction;
    assert!((n[2] - 1.0).abs() < 1e-12, "{n:?}");
    for (bad, line) in [
        ("a,0,0,0,normal\nb,0,0,0,sideways\n", 2),
        ("a,0,0,x,normal\n", 1),
        ("name,x,y,z,directions\n\na,0,0\n", 3),
    ] {
        match softsense::markers::bind::parse_candidates(bad, &p.mesh) {
            Err(
                MarkersError::CandidateCells { line: l, .. }
                | MarkersError::CandidateNumber { line: l, .. }
                | MarkersError::CandidateDirections { line: l, .. },
            ) => assert_eq!(l, line, "{bad:?}"),
            other => panic!("{bad:?}: {other:?}"),
        }
    }
}

/// The bar with 4 markers and 3 normal candidates on its top face, 30 mm apart.
fn bar_with_three_candidates() -> MarkerSensor {
    let p = bar(false);
    let surface = p.mesh.surface();
    let at = [
        [0.035, 0.0, 0.01],
        [0.055, 0.0, 0.01],
        [0.085, 0.0, 0.01],
        [0.1, 0.01, 0.01],
    ];
    let names: Vec<String> = (0..at.len()).map(|i| format!("m{i}")).collect();
    let markers = bind_markers(&p.mesh.nodes_in_rest, &surface, &names, &at, 1e-3).unwrap();
    let cand = [0.04, 0.07, 0.1]
        .iter()
        .map(|&x| {
            let name = format!("x{}", 1e3 * x);
            CandidateLocation::snapped(
                &name,
                &p.mesh,
                &surface,
                [x, 0.01, 0.02],
                Directions::Normal,
            )
            .unwrap()
        })
        .collect();
    let params = MarkersParams::default();
    MarkerSensor::new(&p, NewtonParams::default(), markers, cand, params).unwrap()
}

#[test]
fn stacking_frames_of_the_same_forces_locates_weak_forces_more_often_than_one_frame() {
    let s = bar_with_three_candidates();
    let noise = s.params.sigma;
    let free = s.problem.solve_static(&s.newton).unwrap();
    let exact =
        |x: &[[f64; 3]]| -> Vec<[f64; 3]> { s.markers.iter().map(|m| m.at.position(x)).collect() };
    let unloaded: Vec<_> = exact(&free.positions).into_iter().map(Some).collect();
    // One frame's σ of each candidate's force (the same at every small load: linear regime).
    let sigma1 = s.solve_frame(0, &unloaded, None).unwrap().sigma;
    const FRAMES: u64 = 4;
    const TRIALS: u64 = 40;
    let (mut single, mut stacked) = (0, 0);
    for t in 0..TRIALS {
        // One force at candidate t % 3 of 2-8 σ (one frame's), pressing into the bar. A
        // candidate is found above 5 σ: one frame should find about half of them, four
        // stacked frames (σ halved) about 90%.
        let c = (t % 3) as usize;
        let u = softsense::math::rand::uniform(t, 1, 0, 0);
        let mag = sigma1[c] * (2.0 + 6.0 * u);
        let d = s.locations[c].candidates[0].direction;
        let mut p = s.problem.clone();
        p.loads.push(PointLoad {
            at: s.locations[c].at(),
            force: d.map(|v| -mag * v),
        });
        let x = exact(&p.solve_static(&s.newton).unwrap().positions);
        let frames: Vec<Vec<Option<[f64; 3]>>> = (0..FRAMES)
            .map(|f| {
                (x.iter().enumerate())
                    .map(|(m, q)| {
                        Some([0, 1, 2].map(|k| {
                            q[k] + noise * softsense::math::rand::normal(t, f, m as u64, k as u64)
                        }))
                    })
                    .collect()
            })
            .collect();
        let located = |est: &softsense::markers::MarkerFrame| {
            let l = locate_forces(est, &s.locations, &s.params);
            l.len() == 1 && l[0].candidates == [c]
        };
        let last = s
            .solve_frame(t, &frames[FRAMES as usize - 1], None)
            .unwrap();
        let views: Vec<&[Option<[f64; 3]>]> = frames.iter().map(Vec::as_slice).collect();
        let all = s.solve_frames(t, &views, None).unwrap();
        assert_eq!(all.rows, 4 * last.rows);
        // The same frame k times: the same solution and linearisation, σ divided by √k.
        let same = s
            .solve_frames(t, &[&frames[3][..]; FRAMES as usize], None)
            .unwrap();
        let ratio = last.sigma[c] / same.sigma[c];
        assert!((ratio - 2.0).abs() < 1e-6, "σ ratio {ratio}");
        assert!((same.intensities[c] - last.intensities[c]).abs() < 1e-6 * last.sigma[c]);
        single += located(&last) as usize;
        stacked += located(&all) as usize;
    }
    eprintln!("located from one frame {single}/{TRIALS}, from {FRAMES} stacked {stacked}/{TRIALS}");
    assert!(
        stacked >= single + 8,
        "one frame {single}, stacked {stacked}"
    );
    assert!(stacked >= 30, "stacked {stacked} of {TRIALS}");
}

#[test]
fn known_loads_put_back_on_the_sensor_are_held_and_not_reported_as_candidate_forces() {
    let mut s = bar_with_three_candidates();
    // A known 20 mN push at the first marker's node, in every frame.
    let known = PointLoad {
        at: s.markers[0].at,
        force: [0.0, 0.0, -0.02],
    };
    s.problem.loads.push(known);
    let truth = 0.1;
    let mut p = s.problem.clone();
    let d = s.locations[1].candidates[0].direction;
    p.loads.push(PointLoad {
        at: s.locations[1].at(),
        force: d.map(|v| -truth * v),
    });
    let x = p.solve_static(&s.newton).unwrap().positions;
    let measured: Vec<_> = (s.markers.iter())
        .map(|m| Some(m.at.position(&x)))
        .collect();
    let est = s.solve_frame(0, &measured, None).unwrap();
    assert_eq!(est.forces.len(), 3);
    assert!(
        (est.intensities[1] + truth).abs() < 1e-4,
        "{:?}",
        est.intensities
    );
    assert!(est.intensities[0].abs() < 1e-4 && est.intensities[2].abs() < 1e-4);
    // The copy with other candidates keeps the known load.
    let other = s.with_locations(s.locations[..1].to_vec()).unwrap();
    assert_eq!(other.problem.loads.len(), 1);
}
