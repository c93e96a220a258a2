//! The filter chain: TOML parameters, stage composition, sequences.

use softsense::cloud::PointCloud;
use softsense::filter::*;
use softsense::pipeline::*;

fn scene() -> PointCloud {
    // A dense 2 cm patch at z = 1 (41 x 41 points, 0.5 mm apart), one far point,
    // one isolated point inside the crop, one NaN.
    let mut pts = Vec::new();
    for i in 0..41 {
        for j in 0..41 {
            pts.push([i as f32 * 0.0005, j as f32 * 0.0005, 1.0]);
        }
    }
    pts.push([0.0, 0.0, 5.0]);
    pts.push([0.3, 0.3, 1.0]);
    pts.push([f32::NAN; 3]);
    PointCloud::from_positions(pts)
}

#[test]
fn chain_params_round_trip_through_toml_and_reject_unknown_keys() {
    let p = ChainParams::thesis();
    let back = ChainParams::from_toml_str(&p.to_toml_string()).unwrap();
    // (user_filter_value is NaN, so compare the serialised forms.)
    assert_eq!(back.to_toml_string(), p.to_toml_string());
    assert_eq!(back.voxel, p.voxel);
    assert_eq!(
        ChainParams::from_toml_str("").unwrap(),
        ChainParams::default()
    );
    assert!(matches!(
        ChainParams::from_toml_str("[voxl]\nleaf_size = 1"),
        Err(PipelineError::Config(_))
    ));
}

#[test]
fn step_equals_the_stages_applied_by_hand_and_tracks_input_indices() {
    let cloud = scene();
    let params = ChainParams {
        crop: vec![PassThroughParams::new(Field::Z, 0.0, 2.0)],
        voxel: Some(VoxelGridParams::new(0.002)),
        radius_outlier: Some(RadiusOutlierParams {
            radius: 0.005,
            min_neighbors: 3,
            ..Default::default()
        }),
        statistical_outlier: None,
        normals: Some(softsense::features::NormalParams::knn(8)),
    };
    let out = Pipeline::new(params.clone()).step(&cloud).unwrap();
    let a = pass_through(&cloud, &params.crop[0]).unwrap();
    let b = voxel_grid(&a.cloud, params.voxel.as_ref().unwrap()).unwrap();
    let c = radius_outlier_removal(&b.cloud, params.radius_outlier.as_ref().unwrap()).unwrap();
    assert_eq!(out.cloud.positions, c.cloud.positions);
    assert_eq!(out.indices.len(), out.cloud.len());
    assert!(
        !out.indices.contains(&(41 * 41 + 1)),
        "the isolated point is removed"
    );
    for (k, &i) in out.indices.iter().enumerate() {
        // The representative input point lies in the same 2 mm voxel as the output point.
        let (p, q) = (cloud.positions[i], out.cloud.positions[k]);
        assert!((0..3).all(|a| (p[a] - q[a]).abs() < 0.002));
    }
    let stages: Vec<&str> = out.timings.iter().map(|t| t.stage).collect();
    assert_eq!(stages, ["crop", "voxel", "radius_outlier", "normals"]);
    assert!(out
        .cloud
        .normals
        .as_ref()
        .unwrap()
        .iter()
        .all(|n| (n[2] + 1.0).abs() < 1e-4));
}

#[test]
fn a_bad_stage_parameter_is_an_error_not_a_pass_through() {
    let params = ChainParams {
        voxel: Some(VoxelGridParams::new(0.0)),
        ..ChainParams::default()
    };
    assert!(matches!(
        Pipeline::new(params).step(&scene()),
        Err(PipelineError::Filter(FilterError::InvalidLeafSize { .. }))
    ));
}

#[test]
fn a_sequence_is_streamed_to_one_output_per_frame() {
    let dir = tempfile::tempdir().unwrap();
    let (inp, out) = (dir.path().join("in"), dir.path().join("out"));
    std::fs::create_dir_all(&inp).unwrap();
    for k in 0..3 {
        softsense::io::write_cloud(
            inp.join(format!("frame_{k}.pcd")),
            &scene(),
            softsense::io::Encoding::Binary,
        )
        .unwrap();
    }
    std::fs::write(inp.join("notes.txt"), "not a frame").unwrap();
    let frames = list_frames(&inp).unwrap();
    assert_eq!(frames.len(), 3);
    assert_eq!(list_frames(&inp.join("frame_1*.pcd")).unwrap().len(), 1);
    assert!(matches!(
        list_frames(&inp.join("nope_*.pcd")),
        Err(PipelineError::NoFrames { .. })
    ));
    let mut chain = Pipeline::new(ChainParams::default());
    let summary = run_sequence(&mut chain, &frames, &out, 1, false).unwrap();
    assert_eq!(summary.len(), 3);
    let single = Pipeline::new(ChainParams::default())
        .step(&scene())
        .unwrap();
    for s in &summary {
        let written = softsense::io::read_cloud(&s.output).unwrap();
        assert_eq!(written.positions, single.cloud.positions);
        assert_eq!(s.points_out, single.cloud.len());
    }
}

#[test]
fn fused_crop_and_voxel_equal_the_stages_run_one_after_the_other_frame_after_frame() {
    // Two crops (their kept indices are intersected without building the cropped cloud),
    // a voxel grid, and the same Pipeline reused on two frames (buffers kept between them).
    let mut frame = scene();
    frame.colors = Some((0..frame.len()).map(|i| [(i % 251) as u8, 7, 9]).collect());
    let params = ChainParams {
        crop: vec![
            PassThroughParams::new(Field::Z, 0.5, 2.0),
            PassThroughParams::new(Field::X, 0.0, 0.012),
        ],
        voxel: Some(VoxelGridParams::new(0.0015)),
        radius_outlier: None,
        statistical_outlier: None,
        normals: None,
    };
    let by_hand = |c: &PointCloud| {
        let a = pass_through(c, &params.crop[0]).unwrap();
        let b = pass_through(&a.cloud, &params.crop[1]).unwrap();
        let v = voxel_grid(&b.cloud, params.voxel.as_ref().unwrap()).unwrap();
        let idx: Vec<usize> = v.indices.iter().map(|&k| a.indices[b.indices[k]]).collect();
        (v.cloud, idx)
    };
    let mut chain = Pipeline::new(params.clone());
    let mut second = frame.clone();
    second.positions.truncate(900);
    second.colors.as_mut().unwrap().truncate(900);
    second.width = 900;
    for f in [&frame, &second, &frame] {
        let out = chain.step(f).unwrap();
        let (cloud, idx) = by_hand(f);
        assert!(cloud.len() > 10);
        assert_eq!(out.cloud, cloud);
        assert_eq!(out.indices, idx);
    }
}
