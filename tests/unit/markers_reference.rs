//! The markers' reference frames (none loaded, no more than there are), empty track and
//! candidate files, candidates off the surface, and Motive's length units (issue 52).
use softsense::fem::mesh::TetMesh;
use softsense::markers::bind::{parse_candidates, MAX_CANDIDATE_DISTANCE};
use softsense::markers::reference::{reference_positions, LOADED_RATIO};
use softsense::markers::tracks::{read_motive_str, read_tracks_str, TracksError};
use softsense::markers::{MarkerTracks, MarkersError, MarkersParams, TrackFrame};
use softsense::math::rand::normal;

/// 9 markers on a 30 mm grid, frame `k` moved by `moved[k]` (m, along z) plus noise of
/// `sigma` per coordinate.
fn grid_tracks(moved: &[f64], sigma: f64) -> MarkerTracks {
    let rest: Vec<[f64; 3]> = (0..9)
        .map(|i| [0.03 * (i % 3) as f64, 0.03 * (i / 3) as f64, 0.0])
        .collect();
    let frames = (moved.iter().enumerate())
        .map(|(k, dz)| TrackFrame {
            frame: k as u64,
            positions: (rest.iter().enumerate())
                .map(|(m, p)| {
                    let noise = |a: u64| sigma * normal(7, k as u64, m as u64, a);
                    Some([p[0] + noise(0), p[1] + noise(1), p[2] + dz + noise(2)])
                })
                .collect(),
        })
        .collect();
    MarkerTracks {
        names: (0..9).map(|i| format!("m{i}")).collect(),
        frames,
    }
}

#[test]
fn unloaded_reference_frames_are_averaged_and_a_loaded_one_is_refused_by_name() {
    let params = MarkersParams::default();
    let tracks = grid_tracks(&[0.0, 0.0, 0.0, 0.002], params.sigma);
    let r = reference_positions(&tracks, 3, &params).unwrap();
    assert_eq!(r.counts, [3; 9]);
    // The mean of three frames is nearer the rest position than one frame's noise.
    assert!(
        r.positions[4][2].abs() < 3.0 * params.sigma,
        "{:?}",
        r.positions[4]
    );
    match reference_positions(&tracks, 4, &params) {
        Err(MarkersError::ReferenceFrameLoaded {
            frame,
            index,
            moved,
            ..
        }) => {
            assert_eq!((frame, index), (3, 3));
            assert!((moved - 0.002).abs() < 3e-4, "{moved}");
        }
        other => panic!("{other:?}"),
    }
    // A move within what the noise explains is not a load.
    let small = LOADED_RATIO * 6f64.sqrt() * params.sigma / 4.0;
    let tracks = grid_tracks(&[0.0, small], params.sigma);
    assert!(reference_positions(&tracks, 2, &params).is_ok());
}

#[test]
fn more_reference_frames_than_the_tracks_have_is_refused() {
    let params = MarkersParams::default();
    let tracks = grid_tracks(&[0.0, 0.0, 0.0], params.sigma);
    for asked in [0, 4, 100] {
        match reference_positions(&tracks, asked, &params) {
            Err(MarkersError::ReferenceFramesTooMany { asked: a, frames }) => {
                assert_eq!((a, frames), (asked, 3));
            }
            other => panic!("{asked}: {other:?}"),
        }
    }
}

#[test]
fn a_marker_hidden_in_the_reference_frames_is_bound_at_its_first_position() {
    let params = MarkersParams::default();
    let mut tracks = grid_tracks(&[0.0, 0.0, 0.0], params.sigma);
    tracks.frames[0].positions[2] = None;
    tracks.frames[1].positions[2] = None;
    let r = reference_positions(&tracks, 2, &params).unwrap();
    assert_eq!(r.counts[2], 1);
    assert_eq!(Some(r.positions[2]), tracks.frames[2].positions[2]);
    tracks.frames[2].positions[2] = None;
    let err = reference_positions(&tracks, 2, &params).unwrap_err();
    assert!(
        matches!(err, MarkersError::MarkerNeverVisible { ref name } if name == "m2"),
        "{err}"
    );
}

#[test]
fn a_track_file_without_frames_is_an_error() {
    for text in ["frame,marker,x,y,z\n", "frame,marker,x,y,z\n\n"] {
        assert!(matches!(read_tracks_str(text), Err(TracksError::NoFrames)));
    }
    let motive = "Format Version,1.23,Length Units,Millimeters\n,Name,a,a,a\nFrame,Time,X,Y,Z\n";
    assert!(matches!(
        read_motive_str(motive),
        Err(TracksError::NoFrames)
    ));
}

#[test]
fn motive_length_units_include_inches_and_an_unknown_one_names_the_accepted() {
    let motive = |unit: &str| {
        format!(
            "Format Version,1.23,Length Units,{unit}\n,Name,a,a,a\nFrame,Time,X,Y,Z\n0,0,1,2,3\n"
        )
    };
    for (unit, scale) in [("Inches", 0.0254), ("Meters", 1.0), ("Centimeters", 0.01)] {
        let t = read_motive_str(&motive(unit)).unwrap();
        assert_eq!(
            t.frames[0].positions[0],
            Some([scale, 2.0 * scale, 3.0 * scale])
        );
    }
    let err = read_motive_str(&motive("Feet")).unwrap_err();
    assert!(
        matches!(err, TracksError::LengthUnit { ref unit } if unit == "Feet"),
        "{err}"
    );
    assert!(err.to_string().contains("Inches"), "{err}");
}

#[test]
fn candidates_off_the_surface_are_refused_by_name_and_an_empty_file_is_an_error() {
    let mesh = TetMesh::structured_box([0.0; 3], [0.1, 0.02, 0.02], [10, 2, 2]).unwrap();
    let near = 0.02 + 0.8 * MAX_CANDIDATE_DISTANCE;
    let ok = format!("name,x,y,z,directions\ntop,0.05,0.01,{near},normal\n");
    assert_eq!(parse_candidates(&ok, &mesh).unwrap().len(), 1);
    let far = format!("{ok}away,3.0,0.01,0.02,normal\ninside,0.05,0.01,0.01,3d\n");
    match parse_candidates(&far, &mesh) {
        Err(MarkersError::CandidatesOffSurface { candidates, .. }) => {
            assert!(
                candidates.contains("away (line 3, 2900.0 mm)"),
                "{candidates}"
            );
            // 10 mm deep in a 20 mm bar: 10 mm from its nearest face.
            assert!(candidates.contains("inside (line 4"), "{candidates}");
            assert!(!candidates.contains("top"), "{candidates}");
        }
        other => panic!("{other:?}"),
    }
    for empty in ["", "name,x,y,z,directions\n", "\n\n"] {
        let err = parse_candidates(empty, &mesh).unwrap_err();
        assert!(
            matches!(err, MarkersError::NoCandidates),
            "{empty:?}: {err}"
        );
    }
}
