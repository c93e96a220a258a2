//! `softsense sense --membrane`: an inflated membrane seen from inside, pushed from outside
//! (docs/real-data.md).

use super::sense::SenseArgs;
use super::{CliError, CliResult};
use clap::Args;
use softsense::cloud::PointCloud;
use softsense::fem::model::Model;
use softsense::recording::Recording;
use softsense::sense::membrane::{
    FitFrame, MembraneCamera, MembraneEstimate, MembraneParams, MembraneSensor, MembraneStatus,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The membrane mode's options (with `--reference-frames`, `--pose`, `--model`, `--json`).
#[derive(Debug, Args)]
pub struct MembraneArgs {
    /// Sense an inflated membrane seen from inside (a soft bubble with its camera in it):
    /// each seen node of the membrane is read along its camera ray against the reference
    /// frames (--reference-frames N, unloaded, at least 1), and the load is a non-negative
    /// inward push at every node of the outer face, with the pressure change from the
    /// reference frames (the recorded inputs' cavity pressure) as a known load. Prints per
    /// frame the net force, its magnitude and one sigma, the centre of pressure and the
    /// contact patch. The model must be a shell ([mesh] shell) without cables.
    #[arg(long, help_heading = "Membrane", requires = "reference_frames")]
    pub membrane: bool,
    /// The camera file of every frame (intrinsics.json, possibly naming a ray table), for a
    /// recording read in place whose folder has none.
    #[arg(long, value_name = "CAMERA.json", help_heading = "Membrane")]
    pub camera: Option<PathBuf>,
    /// The recorded inputs (inputs.json format) kept outside the folder: each frame's
    /// membrane pressure is its one cavity pressure (Pa). A frame without one is
    /// "no_pressure".
    #[arg(long, value_name = "INPUTS.json", help_heading = "Membrane")]
    pub inputs: Option<PathBuf>,
    /// Unloaded frames FIRST-LAST whose scatter is each node's noise and whose sensed
    /// magnitudes are the sigma's floor (default: the reference frames).
    #[arg(long, value_name = "FIRST-LAST", value_parser = parse_range, help_heading = "Membrane")]
    pub still_frames: Option<(usize, usize)>,
    /// Fit the membrane's stiffness (one factor on the model's modulus and pre-tension) to
    /// these frames' known force magnitudes: a JSON list of {"frame", "magnitude" (N)}. The
    /// loaded ones (at least a quarter of the largest) also set the sigma's model error.
    #[arg(long, value_name = "LOADS.json", help_heading = "Membrane")]
    pub fit_stiffness: Option<PathBuf>,
    /// Write the stiffness fit and sigma calibration here (JSON).
    #[arg(
        long,
        value_name = "FIT.json",
        help_heading = "Membrane",
        requires = "fit_stiffness"
    )]
    pub fit_out: Option<PathBuf>,
    /// Measured force magnitudes to compare with (same format as --fit-stiffness): shown
    /// beside the estimates ("measured") and in --timeline, never used by the estimate.
    #[arg(long, value_name = "LOADS.json", help_heading = "Membrane")]
    pub measured: Option<PathBuf>,
    /// Draw the estimated |F| with its 2-sigma band (and the measured |F|) over the frames
    /// into this PNG.
    #[arg(long, value_name = "OUT.png", help_heading = "Membrane")]
    pub timeline: Option<PathBuf>,
}

fn parse_range(s: &str) -> Result<(usize, usize), String> {
    let (a, b) = s
        .split_once('-')
        .ok_or_else(|| format!("{s:?}: expected FIRST-LAST, e.g. 5-60"))?;
    let a: usize = a.trim().parse().map_err(|e| format!("{a:?}: {e}"))?;
    let b: usize = b.trim().parse().map_err(|e| format!("{b:?}: {e}"))?;
    if b < a {
        return Err(format!("{s:?}: the last frame comes before the first"));
    }
    Ok((a, b))
}

/// What one frame was read as.
enum Read {
    Motions(Vec<Option<f64>>),
    Failed(MembraneStatus, String),
}

fn lib(e: impl Into<softsense::Error>) -> CliError {
    CliError::Lib(e.into())
}

fn result(what: &Path, e: impl std::fmt::Display) -> CliError {
    CliError::Result(format!("{}: {e}", what.display()))
}

/// Reads a list of {"frame", "magnitude"}.
fn read_loads(path: &Path) -> Result<BTreeMap<usize, f64>, CliError> {
    #[derive(serde::Deserialize)]
    struct Load {
        frame: usize,
        magnitude: Option<f64>,
    }
    let text = std::fs::read_to_string(path).map_err(|e| result(path, e))?;
    let loads: Vec<Load> = serde_json::from_str(&text).map_err(|e| {
        result(
            path,
            format!("{e} (expected [{{\"frame\", \"magnitude\"}}])"),
        )
    })?;
    Ok(loads
        .into_iter()
        .filter_map(|l| Some((l.frame, l.magnitude.filter(|m| m.is_finite())?)))
        .collect())
}

/// The membrane's pressure in `frame` (Pa): its one cavity pressure.
fn pressure_of(rec: &Recording, frame: usize) -> f64 {
    let Some(input) = rec.recorded.as_ref().and_then(|r| r.get(frame)) else {
        return f64::NAN;
    };
    match input.cavities.as_slice() {
        [one] => one.pressure.unwrap_or(f64::NAN),
        _ => f64::NAN,
    }
}

fn map_frames<T: Send>(frames: &[usize], f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        frames.par_iter().map(|&k| f(k)).collect()
    }
    #[cfg(not(feature = "parallel"))]
    frames.iter().map(|&k| f(k)).collect()
}

/// The recording, its model and camera, and every frame number the folder or the inputs
/// know of (one missing from the folder is a status).
struct Opened {
    rec: Recording,
    model: Model,
    model_path: PathBuf,
    pose: softsense::math::pose::Pose,
    camera: softsense::camera::PinholeIntrinsics,
    lens: softsense::camera::lens::Lens,
    frames: Vec<usize>,
}

fn open(args: &SenseArgs) -> Result<Opened, CliError> {
    let m = &args.membrane;
    let unsupported = [
        (args.render.is_some(), "--render"),
        (args.rerun.is_some(), "--rerun"),
        (args.track, "--track"),
        (args.hold, "--hold"),
        (
            args.known_load.is_some(),
            "--known-load (use --fit-stiffness)",
        ),
        (args.modulus_from_sag, "--modulus-from-sag"),
        (args.cameras.is_some(), "--cameras"),
    ];
    let given: Vec<&str> = unsupported.iter().filter(|u| u.0).map(|u| u.1).collect();
    if !given.is_empty() {
        return Err(CliError::Usage(format!(
            "--membrane does not take {}",
            given.join(", ")
        )));
    }
    let rec = Recording::open_with_camera(&args.scene_dir, m.camera.as_deref()).map_err(lib)?;
    let rec = match &args.pose {
        Some(p) => rec.with_pose_file(p).map_err(lib)?,
        None => rec,
    };
    let rec = match &m.inputs {
        Some(p) => rec.with_inputs_file(p).map_err(lib)?,
        None => rec,
    };
    for w in &rec.warnings {
        eprintln!("warning: {w}");
    }
    let Some(model_path) = args.model.clone().or_else(|| rec.model_path()) else {
        return Err(CliError::Usage(
            "give the membrane's model: --model MODEL.toml".into(),
        ));
    };
    let model = Model::load(&model_path, None).map_err(lib)?;
    let pose = rec.robot_from_camera.ok_or_else(|| {
        CliError::Usage(format!(
            "{}: no camera pose: give --pose POSE.json",
            args.scene_dir.display()
        ))
    })?;
    let first = rec.frames[0];
    let camera = rec.camera_of(first).map_err(lib)?.intrinsics;
    let lens = rec.lens_of(first).map_err(lib)?.clone();
    let inputs_len = rec.recorded.as_ref().map_or(0, |r| r.entries.len());
    let mut frames: Vec<usize> = rec.frames.clone();
    frames.extend(0..inputs_len);
    frames.sort_unstable();
    frames.dedup();
    Ok(Opened {
        rec,
        model,
        model_path,
        pose,
        camera,
        lens,
        frames,
    })
}

/// Frame `f` as a cloud, or the status and message of why not.
fn read_cloud(rec: &Recording, f: usize) -> Result<PointCloud, (MembraneStatus, String)> {
    let depth = rec.files_of(f).map(|files| files.depth.clone());
    match &depth {
        Ok(d) if !d.exists() => {
            let why = format!("{}: missing", d.display());
            return Err((MembraneStatus::MissingFrame, why));
        }
        Err(_) => return Err((MembraneStatus::MissingFrame, "no depth image".into())),
        Ok(_) => {}
    }
    rec.read_frame(f)
        .map_err(|e| (MembraneStatus::Unreadable, e.to_string()))
}

/// The sensor from the reference frames (which must all be read) and the still frames
/// (those that cannot be read are left out).
fn build_sensor(args: &SenseArgs, o: &Opened, still: &[usize]) -> Result<MembraneSensor, CliError> {
    let rest_frames: Vec<usize> = o
        .frames
        .iter()
        .copied()
        .take(args.reference_frames)
        .collect();
    let rest_clouds = map_frames(&rest_frames, |f| read_cloud(&o.rec, f))
        .into_iter()
        .map(|r| r.map_err(|(_, e)| CliError::Result(format!("reference frame: {e}"))))
        .collect::<Result<Vec<_>, _>>()?;
    let still_clouds: Vec<PointCloud> = map_frames(still, |f| read_cloud(&o.rec, f))
        .into_iter()
        .filter_map(|r| {
            r.map_err(|(_, e)| eprintln!("warning: still frame left out: {e}"))
                .ok()
        })
        .collect();
    let rest: Vec<(&PointCloud, f64)> = (rest_clouds.iter().zip(&rest_frames))
        .map(|(c, &f)| (c, pressure_of(&o.rec, f)))
        .collect();
    let still_refs: Vec<&PointCloud> = still_clouds.iter().collect();
    let view = MembraneCamera {
        intrinsics: &o.camera,
        lens: &o.lens,
        robot_from_camera: &o.pose,
    };
    MembraneSensor::new(
        &o.model,
        view,
        &rest,
        &still_refs,
        MembraneParams::default(),
    )
    .map_err(|e| result(&args.scene_dir, e))
}

/// Fits the stiffness (with --fit-stiffness) and the sigma; the fit as JSON (null without).
fn calibrate(
    m: &MembraneArgs,
    o: &Opened,
    sensor: &mut MembraneSensor,
    motions: &dyn Fn(usize) -> Option<Vec<Option<f64>>>,
    still: &[usize],
) -> Result<serde_json::Value, CliError> {
    let still_frames: Vec<(Vec<Option<f64>>, f64)> = (still.iter())
        .filter_map(|&f| Some((motions(f)?, pressure_of(&o.rec, f))))
        .collect();
    let Some(path) = &m.fit_stiffness else {
        let sigma = sensor.calibrate_sigma(&still_frames, &[], 0.25);
        let sigma = sigma.map_err(|e| result(&o.rec.dir, e))?;
        eprintln!(
            "warning: sigma = {:.3} N, the still frames' scatter alone: without --fit-stiffness \
             it has no model-error term",
            sigma.floor
        );
        return Ok(serde_json::Value::Null);
    };
    let loads = read_loads(path)?;
    let fit_frames: Vec<FitFrame> = (loads.iter())
        .filter_map(|(&frame, &known)| {
            Some(FitFrame {
                frame,
                motions: motions(frame)?,
                pressure: pressure_of(&o.rec, frame),
                known,
            })
        })
        .collect();
    let fit = (sensor.fit_stiffness(&fit_frames)).map_err(|e| result(path, e))?;
    let sigma =
        (sensor.calibrate_sigma(&still_frames, &fit_frames, 0.25)).map_err(|e| result(path, e))?;
    let (tension, thickness) =
        (o.model.problem.shell).map_or((0.0, 0.0), |s| (s.tension, s.thickness));
    let young = fit.scale * o.model.problem.material.young();
    eprintln!(
        "stiffness: x{:.3} of the model's (tension {:.1} N/m, E {young:.4e} Pa at {thickness} m) \
         on {} frames, RMS {:.3} N; sigma = {:.3} N (+) {:.3} |F|",
        fit.scale,
        fit.scale * tension,
        fit.frames.len(),
        fit.rms,
        sigma.floor,
        sigma.model_error
    );
    Ok(serde_json::json!({
        "scale": fit.scale,
        "tension_n_per_m": fit.scale * tension,
        "young_pa": young,
        "thickness_m": thickness,
        "rms_n": fit.rms,
        "frames": fit.frames,
        "sigma_floor_n": sigma.floor,
        "model_error": sigma.model_error,
        "rounds": fit.rounds,
    }))
}

pub fn run(args: &SenseArgs) -> CliResult {
    let m = &args.membrane;
    let clock = std::time::Instant::now();
    let o = open(args)?;
    let frames = &o.frames;
    let still: Vec<usize> = match m.still_frames {
        Some((a, b)) => (frames.iter().copied())
            .filter(|f| (a..=b).contains(f))
            .collect(),
        None => frames.iter().copied().take(args.reference_frames).collect(),
    };
    let mut sensor = build_sensor(args, &o, &still)?;
    eprintln!(
        "{}: {} frames, model {}, {} nodes read along their rays, {} pushes, rest frames \
         {:.2} mm from the model (median)",
        args.scene_dir.display(),
        frames.len(),
        super::shown_path(&o.model_path).display(),
        sensor.refs.len(),
        sensor.pushed.len(),
        1e3 * sensor.pose_offset
    );
    let reads: Vec<Read> = map_frames(frames, |f| match read_cloud(&o.rec, f) {
        Ok(c) => Read::Motions(sensor.observe(&c)),
        Err((s, e)) => Read::Failed(s, e),
    });
    let motions = |f: usize| match &reads[frames.binary_search(&f).ok()?] {
        Read::Motions(m) => Some(m.clone()),
        Read::Failed(..) => None,
    };
    let fit_json = calibrate(m, &o, &mut sensor, &motions, &still)?;
    if let Some(path) = &m.fit_out {
        std::fs::write(path, format!("{fit_json:#}\n")).map_err(|e| result(path, e))?;
    }
    let measured = match &m.measured {
        Some(p) => read_loads(p)?,
        None => BTreeMap::new(),
    };
    let estimates: Vec<(MembraneEstimate, Option<String>)> = (frames.iter().zip(&reads))
        .map(|(&f, r)| match r {
            Read::Motions(mo) => (sensor.estimate(mo, pressure_of(&o.rec, f)), None),
            Read::Failed(s, e) => (MembraneEstimate::failed(*s), Some(e.clone())),
        })
        .collect();
    let seconds = clock.elapsed().as_secs_f64();
    print_frames(args, frames, &estimates, &measured)?;
    if let Some(path) = &m.timeline {
        super::sense_membrane_plot::timeline(path, frames, &estimates, &measured)?;
    }
    eprintln!(
        "{} frames in {seconds:.1} s ({:.1} frames/s, all included)",
        frames.len(),
        frames.len() as f64 / seconds
    );
    Ok(())
}

fn print_frames(
    args: &SenseArgs,
    frames: &[usize],
    estimates: &[(MembraneEstimate, Option<String>)],
    measured: &BTreeMap<usize, f64>,
) -> CliResult {
    if !args.json {
        super::out(format_args!(
            "frame  status          |F| (N)  sigma (N)  measured (N)  nodes  dp (Pa)\n"
        ))?;
    }
    for (&f, (e, detail)) in frames.iter().zip(estimates) {
        if args.json {
            let mut v = serde_json::to_value(e).map_err(|e| CliError::Result(e.to_string()))?;
            v["frame"] = f.into();
            if let Some(d) = detail {
                v["detail"] = d.clone().into();
            }
            if let Some(m) = measured.get(&f) {
                v["measured"] = (*m).into();
            }
            super::print_json(&v)?;
        } else {
            let status = serde_json::to_value(e.status).unwrap_or_default();
            let meas = measured.get(&f).map_or("-".into(), |m| format!("{m:.3}"));
            super::out(format_args!(
                "{f:5}  {:<14} {:8.3} {:10.3} {:>13}  {:5} {:8.1}\n",
                status.as_str().unwrap_or("?"),
                e.magnitude,
                e.sigma,
                meas,
                e.nodes_read,
                e.pressure_change
            ))?;
        }
    }
    Ok(())
}
