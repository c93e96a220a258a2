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

pub fn run(args: &SenseArgs) -> CliResult {
    let m = &args.membrane;
    let clock = std::time::Instant::now();
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
    let model_path = match (args.model.clone(), rec.model_path()) {
        (Some(p), _) | (None, Some(p)) => p,
        (None, None) => {
            return Err(CliError::Usage(
                "give the membrane's model: --model MODEL.toml".into(),
            ))
        }
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
    // Every frame the folder or the inputs know of: one missing from the folder is a status.
    let inputs_len = rec.recorded.as_ref().map_or(0, |r| r.entries.len());
    let mut frames: Vec<usize> = rec.frames.clone();
    frames.extend(0..inputs_len);
    frames.sort_unstable();
    frames.dedup();
    let read_cloud = |f: usize| -> Result<PointCloud, (MembraneStatus, String)> {
        let depth = rec.files_of(f).map(|files| files.depth.clone());
        if let Some(path) = depth.as_ref().ok().filter(|d| !d.exists()) {
            return Err((
                MembraneStatus::MissingFrame,
                format!("{}: missing", path.display()),
            ));
        }
        if depth.is_err() {
            return Err((MembraneStatus::MissingFrame, "no depth image".into()));
        }
        rec.read_frame(f)
            .map_err(|e| (MembraneStatus::Unreadable, e.to_string()))
    };
    let rest_frames: Vec<usize> = frames.iter().copied().take(args.reference_frames).collect();
    let still: Vec<usize> = match m.still_frames {
        Some((a, b)) => frames
            .iter()
            .copied()
            .filter(|f| (a..=b).contains(f))
            .collect(),
        None => rest_frames.clone(),
    };
    let load = |list: &[usize]| -> Result<Vec<(usize, PointCloud)>, CliError> {
        map_frames(list, |f| read_cloud(f).map(|c| (f, c)))
            .into_iter()
            .map(|r| r.map_err(|(_, e)| CliError::Result(format!("reference frame: {e}"))))
            .collect()
    };
    let rest_clouds = load(&rest_frames)?;
    // A still frame that cannot be read is left out of the noise, not fatal.
    let still_clouds: Vec<(usize, PointCloud)> =
        map_frames(&still, |f| read_cloud(f).map(|c| (f, c)))
            .into_iter()
            .filter_map(|r| {
                r.map_err(|(_, e)| eprintln!("warning: still frame left out: {e}"))
                    .ok()
            })
            .collect();
    let rest: Vec<(&PointCloud, f64)> = (rest_clouds.iter())
        .map(|(f, c)| (c, pressure_of(&rec, *f)))
        .collect();
    let still_refs: Vec<&PointCloud> = still_clouds.iter().map(|(_, c)| c).collect();
    let view = MembraneCamera {
        intrinsics: &camera,
        lens: &lens,
        robot_from_camera: &pose,
    };
    let mut sensor =
        MembraneSensor::new(&model, view, &rest, &still_refs, MembraneParams::default())
            .map_err(|e| result(&args.scene_dir, e))?;
    drop((rest_clouds, still_clouds));
    eprintln!(
        "{}: {} frames, model {}, {} nodes read along their rays, {} pushes, rest frames {:.2} mm from the model (median)",
        args.scene_dir.display(),
        frames.len(),
        super::shown_path(&model_path).display(),
        sensor.refs.len(),
        sensor.pushed.len(),
        1e3 * sensor.pose_offset
    );
    let reads: Vec<Read> = map_frames(&frames, |f| match read_cloud(f) {
        Ok(c) => Read::Motions(sensor.observe(&c)),
        Err((s, e)) => Read::Failed(s, e),
    });
    let motions = |f: usize| match &reads[frames.binary_search(&f).ok()?] {
        Read::Motions(m) => Some(m.clone()),
        Read::Failed(..) => None,
    };
    let mut fit_json = serde_json::Value::Null;
    let still_frames: Vec<(Vec<Option<f64>>, f64)> = (still.iter())
        .filter_map(|&f| Some((motions(f)?, pressure_of(&rec, f))))
        .collect();
    if let Some(path) = &m.fit_stiffness {
        let loads = read_loads(path)?;
        let fit_frames: Vec<FitFrame> = (loads.iter())
            .filter_map(|(&frame, &known)| {
                Some(FitFrame {
                    frame,
                    motions: motions(frame)?,
                    pressure: pressure_of(&rec, frame),
                    known,
                })
            })
            .collect();
        let fit = sensor
            .fit_stiffness(&fit_frames)
            .map_err(|e| result(path, e))?;
        let sigma = (sensor.calibrate_sigma(&still_frames, &fit_frames, 0.25))
            .map_err(|e| result(path, e))?;
        let (tension, thickness) =
            (model.problem.shell).map_or((0.0, 0.0), |s| (s.tension, s.thickness));
        eprintln!(
            "stiffness: x{:.3} of the model's (tension {:.1} N/m, E {:.4e} Pa at {} m) on {} frames, RMS {:.3} N; sigma = {:.3} N (+) {:.3} |F|",
            fit.scale,
            fit.scale * tension,
            fit.scale * model.problem.material.young(),
            thickness,
            fit.frames.len(),
            fit.rms,
            sigma.floor,
            sigma.model_error
        );
        fit_json = serde_json::json!({
            "scale": fit.scale,
            "tension_n_per_m": fit.scale * tension,
            "young_pa": fit.scale * model.problem.material.young(),
            "thickness_m": thickness,
            "rms_n": fit.rms,
            "frames": fit.frames,
            "sigma_floor_n": sigma.floor,
            "model_error": sigma.model_error,
            "rounds": fit.rounds,
        });
    } else {
        let sigma = sensor.calibrate_sigma(&still_frames, &[], 0.25);
        if let Err(e) = sigma {
            eprintln!("warning: sigma without a model error: {e}");
        }
    }
    if let Some(path) = &m.fit_out {
        std::fs::write(path, format!("{fit_json:#}\n")).map_err(|e| result(path, e))?;
    }
    let measured = match &m.measured {
        Some(p) => read_loads(p)?,
        None => BTreeMap::new(),
    };
    let estimates: Vec<(MembraneEstimate, Option<String>)> = frames
        .iter()
        .zip(&reads)
        .map(|(&f, r)| match r {
            Read::Motions(mo) => (sensor.estimate(mo, pressure_of(&rec, f)), None),
            Read::Failed(s, e) => (MembraneEstimate::failed(*s), Some(e.clone())),
        })
        .collect();
    let seconds = clock.elapsed().as_secs_f64();
    print_frames(args, &frames, &estimates, &measured)?;
    if let Some(path) = &m.timeline {
        super::sense_membrane_plot::timeline(path, &frames, &estimates, &measured)?;
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
