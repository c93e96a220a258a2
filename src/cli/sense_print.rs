//! What `softsense sense` prints: each frame's line, the run's summary against the truth,
//! and the hint when no frame showed the robot.

use super::CliResult;
use softsense::sense::{
    median_timings, CameraState, FrameReport, FrameStatus, LoadError, Rig, StageTimings,
    COLOUR_HINT, POSE_HINT,
};

/// Whether no camera has a colour image for any frame (the robot is found by its colour).
pub(super) fn colourless(rig: &Rig) -> bool {
    rig.frames.iter().all(|&f| {
        rig.cameras.iter().all(|c| {
            c.recording
                .files_of(f)
                .map_or(true, |files| files.color.is_none())
        })
    })
}

/// Where every frame read had no robot, what to check: with no point at all in the box
/// around the robot, the camera pose; with points there but too few of the robot's
/// colour, the colour, or the colour images if there are none.
pub(super) fn no_robot_hint(reports: &[FrameReport], colourless: bool) -> String {
    let read: Vec<&FrameReport> = reports
        .iter()
        .filter(|r| !matches!(r.status, FrameStatus::Unreadable(_)))
        .collect();
    if read.is_empty() || !read.iter().all(|r| r.status == FrameStatus::NoRobot) {
        return String::new();
    }
    // A rig's cameras without a robot kept their points out of the frame's counts.
    let in_box = |r: &FrameReport| {
        let left_out: usize = (r.cameras.iter())
            .map(|c| match c.state {
                CameraState::NoRobot { object_points } => object_points,
                _ => 0,
            })
            .sum();
        r.robot_points + r.object_points + left_out
    };
    if read.iter().all(|r| in_box(r) == 0) {
        format!("; no point of any frame falls in the box around the robot: {POSE_HINT}")
    } else if colourless {
        "; the recording has no colour images (color_NNNN.png), and softsense finds the \
         robot by its colour: record the colour stream too (softsense import takes it by \
         --colour-topic)"
            .into()
    } else {
        format!("; the box around the robot holds points, but too few of the robot's colour: {COLOUR_HINT}")
    }
}

pub(super) fn print_human(r: &FrameReport) -> CliResult {
    let mut status = r.status.to_string();
    if r.tracked {
        status.push_str(" (tracked)");
    }
    outln!(
        "frame {:>4}: {status}, robot {} pts, objects {} pts, features {}/{}, residual {:.3} mm, {} FE updates, {:.0} ms",
        r.frame,
        r.robot_points,
        r.object_points,
        r.features_visible,
        r.features,
        r.residual_rms * 1e3,
        r.updates,
        r.ms
    )?;
    if !r.cameras.is_empty() {
        let each: Vec<String> = r.cameras.iter().map(|c| c.to_string()).collect();
        outln!("  cameras: {}", each.join("; "))?;
    }
    for (i, f) in r.forces.iter().enumerate() {
        outln!(
            "  force {i} ({}{}): at ({:.1}, {:.1}, {:.1}) mm, F = ({:.3}, {:.3}, {:.3}) N, |F| = {:.3} ± {:.4} N (3-D ± {:.4} N)",
            f.source,
            f.node.map(|n| format!(", node {n}")).unwrap_or_default(),
            f.location[0] * 1e3,
            f.location[1] * 1e3,
            f.location[2] * 1e3,
            f.force[0],
            f.force[1],
            f.force[2],
            f.magnitude,
            f.sigma,
            f.sigma_max
        )?;
        if let Some(s) = f.location_sigma.filter(|s| *s > 0.0) {
            let alts: Vec<String> = f
                .alternatives
                .iter()
                .map(|a| format!("node {} (misfit {:.1})", a.node, a.misfit))
                .collect();
            outln!(
                "    location ± {:.1} mm; other locations that fit: {}",
                s * 1e3,
                alts.join(", ")
            )?;
        }
    }
    for h in &r.held {
        outln!(
            "  held since frame {} ({} frames fused): |F| = {:.3} ± {:.3} N, F = ({:.3}, {:.3}, {:.3}) N",
            h.since,
            h.frames,
            h.magnitude,
            h.sigma,
            h.force[0],
            h.force[1],
            h.force[2]
        )?;
    }
    if !r.actuators.is_empty() {
        let a: Vec<String> = r
            .actuators
            .iter()
            .map(|(n, f)| format!("{n} {f:.3}"))
            .collect();
        outln!("  actuator forces (N): {}", a.join(", "))?;
    }
    for w in &r.warnings {
        outln!("  warning: {w}")?;
    }
    for (k, e) in r.errors.iter().flatten().enumerate() {
        let t = e.truth_force;
        let outcome = if e.estimate.is_some() {
            format!(
                "location error {:.1} mm, force error {:.1}%, magnitude error {:.1}%",
                e.location_error * 1e3,
                100.0 * e.force_error,
                100.0 * e.magnitude_error
            )
        } else {
            "no estimate (counted as 100% off)".to_string()
        };
        outln!(
            "  truth {k}: F = ({:.3}, {:.3}, {:.3}) N at ({:.1}, {:.1}, {:.1}) mm -> {outcome}",
            t[0],
            t[1],
            t[2],
            e.truth_at[0] * 1e3,
            e.truth_at[1] * 1e3,
            e.truth_at[2] * 1e3,
        )?;
    }
    Ok(())
}

pub(super) fn summary(reports: &[FrameReport], wall_ms: f64, window: usize, track: bool) {
    let sensed = reports
        .iter()
        .filter(|r| matches!(r.status, FrameStatus::Sensed))
        .count();
    let errors: Vec<_> = reports
        .iter()
        .flat_map(|r| r.errors.iter().flatten())
        .collect();
    let ms: f64 = reports.iter().map(|r| r.ms).sum::<f64>() / reports.len().max(1) as f64;
    let unreliable = reports
        .iter()
        .filter(|r| matches!(r.status, FrameStatus::Sensed) && !r.reliable)
        .count();
    let flagged = if unreliable > 0 {
        format!(" ({unreliable} unreliable: see their warnings)")
    } else {
        String::new()
    };
    let how = if track {
        let tracked = reports.iter().filter(|r| r.tracked).count();
        format!(
            "tracked, {tracked} of {} from the frame before",
            reports.len()
        )
    } else {
        format!("{window} at a time")
    };
    eprintln!(
        "{sensed}/{} frames sensed{flagged}, {ms:.0} ms per frame; stream {:.1} frames/s ({how}, wall clock)",
        reports.len(),
        1e3 * reports.len() as f64 / wall_ms.max(1e-9)
    );
    let timings: Vec<StageTimings> = reports.iter().map(|r| r.timings).collect();
    let medians = median_timings(&timings);
    let stages: Vec<String> = medians
        .iter()
        .map(|(name, v)| format!("{name} {v:.1}"))
        .collect();
    let total = medians.last().map_or(f64::NAN, |m| m.1);
    eprintln!(
        "median ms per frame by stage: {} ({:.1} frames/s; thesis: 10 Hz image processing, 7 Hz FE update)",
        stages.join(", "),
        1e3 / total
    );
    if !errors.is_empty() {
        eprintln!("{}", truth_summary(&errors));
    }
}

/// The errors of all loads against the truth in one line. A load with no estimate (its
/// frame was not sensed, or no force was found) counts as 100% off in the force and
/// magnitude errors; the location error is over the loads that have an estimate.
pub(super) fn truth_summary(errors: &[&LoadError]) -> String {
    let stats = |v: Vec<f64>| {
        let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
        (mean, v.iter().copied().fold(0.0, f64::max))
    };
    let (force_mean, force_max) = stats(errors.iter().map(|e| 100.0 * e.force_error).collect());
    let (mag_mean, mag_max) = stats(errors.iter().map(|e| 100.0 * e.magnitude_error).collect());
    let located: Vec<f64> = errors
        .iter()
        .filter(|e| e.estimate.is_some())
        .map(|e| 1e3 * e.location_error)
        .collect();
    let missing = errors.len() - located.len();
    let loads = if missing == 0 {
        format!("{} loads", errors.len())
    } else {
        format!(
            "{} loads, {missing} with no estimate, counted as 100% off",
            errors.len()
        )
    };
    let location = if located.is_empty() {
        "no load located".to_string()
    } else {
        let (mean, max) = stats(located);
        format!("location error mean {mean:.1} mm max {max:.1} mm")
    };
    format!(
        "against truth.json ({loads}): force error mean {force_mean:.2}% max {force_max:.2}%, magnitude error mean {mag_mean:.2}% max {mag_max:.2}%, {location}"
    )
}
