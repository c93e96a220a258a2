//! Times one softsense stage on one file for `tools/bench/run.sh`.
//!
//! ```text
//! cargo run --release --example bench_stages -- STAGE INPUT REPEAT [PARAMS_JSON]
//! ```
//!
//! Prints one JSON line: `{"stage", "input", "ok", "error", "points", "timings_ms"}`, one
//! timing per repetition, the stage alone (the input is read once beforehand, except for
//! `load`, where reading is the stage). To add a stage, add an arm to [`run_stage`] and an
//! entry to `tools/bench/stages.json`. The `sense` stage is special: INPUT is a recording
//! folder, there is one timing per frame and pass, and the line also has `stage_ms`, the
//! median milliseconds of each stage of the chain as `[name, ms]` pairs in chain order (see
//! [`run_sense`]); its PARAMS_JSON may set `dense_points` (`sense --dense-points`).
//!
//! Like the oracles' timing loops (PCL's `filter(kept)` / `filter(out)` reuse the caller's
//! `kept` / `out` across repetitions), the selecting filters write into one output reused
//! across repetitions ([`State`]), and the chain is one `Pipeline` run frame after frame.

use serde_json::{json, Value};
use softsense::cloud::PointCloud;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

/// What a caller keeps between frames: the selecting filters' output and the chain.
#[derive(Default)]
struct State {
    out: softsense::filter::FilterOutput,
    chain: Option<softsense::pipeline::Pipeline>,
}

/// Runs `stage` once on `cloud` (already read from `input`); returns the output size.
fn run_stage(
    stage: &str,
    input: &Path,
    cloud: &PointCloud,
    params: &Value,
    state: &mut State,
) -> Result<usize, String> {
    use softsense::features::{estimate_normals, Neighbourhood, NormalMode, NormalParams};
    use softsense::filter::*;
    let f = |k: &str, d: f64| params.get(k).and_then(Value::as_f64).unwrap_or(d);
    let u = |k: &str, d: usize| {
        params
            .get(k)
            .and_then(Value::as_u64)
            .map_or(d, |v| v as usize)
    };
    let open3d = params.get("mode").and_then(Value::as_str) == Some("open3d");
    let (vmode, omode) = if open3d {
        (VoxelMode::Open3d, OutlierMode::Open3d)
    } else {
        (VoxelMode::Pcl, OutlierMode::Pcl)
    };
    let err = |e: FilterError| e.to_string();
    match stage {
        // --- segment stages (owned by the `segment` work) ---
        "region_growing_rgb" => {
            let d = softsense::segment::RegionGrowingParams::default();
            let p = softsense::segment::RegionGrowingParams {
                distance_m: f("distance", d.distance_m),
                point_color: f("point_color", d.point_color),
                region_color: f("region_color", d.region_color),
                min_cluster_size: f("min_cluster", d.min_cluster_size as f64) as usize,
                ..d
            };
            softsense::segment::region_growing_rgb(cloud, &p)
                .map(|s| s.segments.len())
                .map_err(|e| e.to_string())
        }
        "euclidean" => {
            let p = softsense::segment::EuclideanParams {
                tolerance: f("tolerance", 0.0),
                min_size: f("min", 1.0) as usize,
                max_size: params
                    .get("max")
                    .and_then(Value::as_u64)
                    .map_or(usize::MAX, |m| m as usize),
                ..Default::default()
            };
            softsense::segment::euclidean_clusters(&cloud.positions, &p)
                .map(|c| c.len())
                .map_err(|e| e.to_string())
        }
        // --- end of segment stages ---
        "load" => softsense::io::pcd::read_pcd(input)
            .map(|c| c.len())
            .map_err(|e| e.to_string()),
        "passthrough" | "passthrough_indices" => {
            let field: Field = params
                .get("field")
                .and_then(Value::as_str)
                .unwrap_or("z")
                .parse()
                .map_err(err)?;
            let p = PassThroughParams::new(field, f("min", 0.0) as f32, f("max", 1.0) as f32);
            if stage == "passthrough_indices" {
                // The work PCL's and Open3D's oracles time: kept indices, no output cloud.
                pass_through_indices_into(cloud, &p, &mut state.out.indices).map_err(err)?;
                Ok(state.out.indices.len())
            } else {
                pass_through_into(cloud, &p, &mut state.out).map_err(err)?;
                Ok(state.out.cloud.len())
            }
        }
        "crop_box" | "crop_box_indices" => {
            let corner = |k: &str| -> [f64; 3] {
                let v = params.get(k).and_then(Value::as_array);
                std::array::from_fn(|a| {
                    v.and_then(|v| v.get(a))
                        .and_then(Value::as_f64)
                        .unwrap_or(0.0)
                })
            };
            let p = CropBoxParams {
                min: corner("min"),
                max: corner("max"),
                invert: false,
            };
            if stage == "crop_box_indices" {
                // The work PCL's oracle times: CropBox::filter(indices), no output cloud.
                crop_box_indices_into(&cloud.positions, &p, &mut state.out.indices).map_err(err)?;
                Ok(state.out.indices.len())
            } else {
                crop_box_into(cloud, &p, &mut state.out).map_err(err)?;
                Ok(state.out.cloud.len())
            }
        }
        "voxel" => {
            let p = VoxelGridParams {
                mode: vmode,
                ..VoxelGridParams::new(f("leaf", 0.005))
            };
            voxel_grid(cloud, &p).map(|o| o.cloud.len()).map_err(err)
        }
        "radius_outlier" => {
            let p = RadiusOutlierParams {
                radius: f("radius", 0.005),
                min_neighbors: u("min_neighbors", 5),
                mode: omode,
                ..Default::default()
            };
            radius_outlier_removal(cloud, &p)
                .map(|o| o.cloud.len())
                .map_err(err)
        }
        "statistical_outlier" => {
            let p = StatisticalOutlierParams {
                k: u("k", 20),
                std_ratio: f("std_ratio", 2.0),
                mode: omode,
                ..Default::default()
            };
            statistical_outlier_removal(cloud, &p)
                .map(|o| o.cloud.len())
                .map_err(err)
        }
        "normals" => {
            let neighbourhood = match params.get("radius").and_then(Value::as_f64) {
                Some(r) => Neighbourhood::Radius(r),
                None => Neighbourhood::Knn(u("k", 10)),
            };
            let mode = if open3d {
                NormalMode::Open3d
            } else {
                NormalMode::Pcl
            };
            let p = NormalParams {
                neighbourhood,
                mode,
                ..NormalParams::knn(1)
            };
            estimate_normals(cloud, &p)
                .map(|n| n.normals.len())
                .map_err(|e| e.to_string())
        }
        "chain" => {
            // crop z to [min, max], PCL voxel grid, PCL radius outlier removal; one
            // Pipeline for all repetitions, as for the frames of a stream.
            let chain = state.chain.get_or_insert_with(|| {
                softsense::pipeline::Pipeline::new(softsense::pipeline::ChainParams {
                    crop: vec![PassThroughParams::new(
                        Field::Z,
                        f("min", 0.0) as f32,
                        f("max", 1.5) as f32,
                    )],
                    voxel: Some(VoxelGridParams::new(f("leaf", 0.005))),
                    radius_outlier: Some(RadiusOutlierParams {
                        radius: f("radius", 0.01),
                        min_neighbors: u("min_neighbors", 5),
                        ..Default::default()
                    }),
                    statistical_outlier: None,
                    normals: None,
                })
            });
            chain
                .step(cloud)
                .map(|o| o.cloud.len())
                .map_err(|e| e.to_string())
        }
        other => Err(format!("softsense has no bench stage `{other}` yet")),
    }
}

/// The `sense` stage: the whole chain (read, crop, segment, contacts, registration, location
/// mapping, QP, FE updates) on every frame of the recording folder `dir`, `repeat` passes
/// with one [`Sensor`](softsense::sense::Sensor) (a stream: its caches persist, the
/// first frame pays the free FE solve). One timing per frame and pass, plus the median
/// milliseconds of each stage over them (`stage_ms`, `[name, ms]` pairs in chain order).
fn run_sense(
    dir: &Path,
    repeat: usize,
    params: &Value,
) -> Result<(Vec<f64>, Value, usize), String> {
    use softsense::sense::{median_timings, CameraFrames, FrameStatus, Rig, SenseParams, Sensor};
    let rec = Rig::open(dir).map_err(|e| e.to_string())?;
    let model_path = (rec.shared().model_path())
        .ok_or_else(|| format!("{}: no truth.json naming the model", dir.display()))?;
    let model = softsense::fem::model::Model::load(&model_path, None).map_err(|e| e.to_string())?;
    let mut sense_params = SenseParams::default();
    if let Some(n) = params.get("dense_points") {
        sense_params.dense_rows.max_points = (n.as_u64().filter(|&n| n > 0))
            .ok_or_else(|| format!("dense_points must be a positive integer, got {n}"))?
            as usize;
    }
    let sensor_of = |rig: &Rig| {
        Sensor::for_rig(model.clone(), rig, sense_params.clone()).map_err(|e| e.to_string())
    };
    let sensor = sensor_of(&rec)?;
    // With several cameras, the first camera alone on the same frames, alternated frame by
    // frame with all of them so a slow stretch of the machine hits both.
    let first = match rec.cameras.len() {
        1 => None,
        _ => {
            let rig = rec.clone().keep_cameras(&[rec.cameras[0].name.clone()]);
            let rig = rig.map_err(|e| e.to_string())?;
            Some((sensor_of(&rig)?, rig))
        }
    };
    let mut timings = Vec::new();
    let mut stages = Vec::new();
    let mut first_total = Vec::new();
    let mut sensed = 0;
    for _ in 0..repeat {
        for &frame in &rec.frames {
            let t0 = Instant::now();
            let obs = sensor.observe(&rec, frame).map_err(|e| e.to_string())?;
            let report = sensor.sense(frame, &obs, rec.inputs_of(frame).as_ref());
            timings.push(t0.elapsed().as_secs_f64() * 1e3);
            stages.push(report.timings);
            sensed += usize::from(report.status == FrameStatus::Sensed);
            if let Some((sensor, rig)) = &first {
                let obs = sensor.observe(rig, frame).map_err(|e| e.to_string())?;
                let report = sensor.sense(frame, &obs, rig.inputs_of(frame).as_ref());
                first_total.push(report.timings);
            }
        }
    }
    // [name, ms] pairs: a JSON object would lose the chain order.
    let mut medians: Vec<Value> = median_timings(&stages)
        .into_iter()
        .map(|(k, v)| json!([k, v]))
        .collect();
    if first.is_some() {
        let total = median_timings(&first_total).last().map(|t| t.1);
        medians.push(json!(["first_camera_total", total]));
        medians.push(json!(["cameras", rec.cameras.len()]));
    }
    // Throughput as a stream: the same passes with `Sensor::sense_frames`, as many frames
    // at a time as threads (the `sense` command's default), wall ms per frame.
    let window = softsense::sense::default_window();
    let mut stream = Vec::new();
    for _ in 0..repeat {
        let t0 = Instant::now();
        sensor.sense_frames(&rec, &rec.frames, window, |_, _| Ok::<(), String>(()))?;
        stream.push(t0.elapsed().as_secs_f64() * 1e3 / rec.frames.len().max(1) as f64);
    }
    stream.sort_by(f64::total_cmp);
    medians.push(json!(["stream", stream[stream.len() / 2]]));
    // The same stream on one thread, one frame at a time: the work per frame on one core,
    // and with the line above how the stream scales with the cores (frames are
    // independent, so more cores sense more frames side by side).
    #[cfg(feature = "parallel")]
    {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .map_err(|e| e.to_string())?;
        let mut one = Vec::new();
        for _ in 0..repeat {
            let t0 = Instant::now();
            pool.install(|| {
                sensor.sense_frames(&rec, &rec.frames, 1, |_, _| Ok::<(), String>(()))
            })?;
            one.push(t0.elapsed().as_secs_f64() * 1e3 / rec.frames.len().max(1) as f64);
        }
        one.sort_by(f64::total_cmp);
        medians.push(json!(["stream_one_thread", one[one.len() / 2]]));
    }
    // As a tracked stream (`Sensor::track_frames`, `sense --track`): wall ms per frame of
    // whole passes (the first frame of each starts cold), and the median wall ms from one
    // emitted frame to the next over the frames that started from the one before (`null`
    // when none did: frames whose contacts jump are sensed as untracked ones).
    let mut track = Vec::new();
    let mut steady = Vec::new();
    for _ in 0..repeat {
        let t0 = Instant::now();
        let mut last = t0;
        sensor.track_frames(&rec, &rec.frames, |_, report| {
            let now = Instant::now();
            if report.tracked {
                steady.push((now - last).as_secs_f64() * 1e3);
            }
            last = now;
            Ok::<(), String>(())
        })?;
        track.push(t0.elapsed().as_secs_f64() * 1e3 / rec.frames.len().max(1) as f64);
    }
    track.sort_by(f64::total_cmp);
    steady.sort_by(f64::total_cmp);
    medians.push(json!(["track", track[track.len() / 2]]));
    medians.push(json!(["track_steady", steady.get(steady.len() / 2)]));
    Ok((timings, Value::Array(medians), sensed))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 || args.len() > 4 {
        eprintln!("usage: bench_stages STAGE INPUT REPEAT [PARAMS_JSON]");
        return ExitCode::from(2);
    }
    let (stage, input) = (args[0].as_str(), Path::new(&args[1]));
    let repeat: usize = match args[2].parse() {
        Ok(n) if n > 0 => n,
        _ => {
            eprintln!("REPEAT must be a positive integer, got `{}`", args[2]);
            return ExitCode::from(2);
        }
    };
    let params: Value = match args.get(3).map(|p| serde_json::from_str(p)) {
        None => json!({}),
        Some(Ok(v)) => v,
        Some(Err(e)) => {
            eprintln!("PARAMS_JSON: {e}");
            return ExitCode::from(2);
        }
    };
    if stage == "sense" {
        let (ok, line) = match run_sense(input, repeat, &params) {
            Ok((timings, stage_ms, sensed)) => (
                true,
                json!({"stage": stage, "input": input, "ok": true, "error": null,
                       "points": sensed, "timings_ms": timings, "stage_ms": stage_ms}),
            ),
            Err(e) => (
                false,
                json!({"stage": stage, "input": input, "ok": false, "error": e,
                       "points": null, "timings_ms": []}),
            ),
        };
        println!("{line}");
        return if ok {
            ExitCode::SUCCESS
        } else {
            ExitCode::FAILURE
        };
    }
    let mut timings = Vec::with_capacity(repeat);
    let mut points = None;
    let mut error = None;
    // Every stage but `load` works on the cloud read once, outside the timing.
    let cloud = if stage == "load" {
        Ok(PointCloud::default())
    } else {
        softsense::io::read_cloud(input).map_err(|e| e.to_string())
    };
    match cloud {
        Err(e) => error = Some(e),
        Ok(cloud) => {
            let mut state = State::default();
            for _ in 0..repeat {
                let t0 = Instant::now();
                let out = run_stage(stage, input, &cloud, &params, &mut state);
                let ms = t0.elapsed().as_secs_f64() * 1e3;
                match out {
                    Ok(n) => {
                        points = Some(n);
                        timings.push(ms);
                    }
                    Err(e) => {
                        error = Some(e);
                        break;
                    }
                }
            }
        }
    }
    let ok = error.is_none();
    let line = json!({"stage": stage, "input": input, "ok": ok, "error": error,
                      "points": points, "timings_ms": timings});
    println!("{line}");
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
