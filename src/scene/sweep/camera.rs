//! The cameras of a sweep's scenes: drawn from the sweep file's `[camera]` ranges as a
//! [`DrawRecord`], and placed around the target as camera specs.

use super::spec::stream;
use super::{CameraDraw, CameraRanges, DrawRecord, Draws};
use crate::scene::camera::{CameraSpec, NamedCameraSpec};
use crate::scene::{SceneError, SceneResult};

/// A camera drawn from `c`'s ranges, as a record (see [`camera_of`]).
pub(super) fn draw_camera(r: &mut Draws, c: &CameraRanges) -> SceneResult<DrawRecord> {
    let (distance, az, el) = (
        r.within(c.distance),
        r.within(c.azimuth_deg),
        r.within(c.elevation_deg),
    );
    let stream_name = c.streams[r.pick(c.streams.len())].clone();
    if stream(&stream_name).is_none() {
        return Err(SceneError::Spec(format!("unknown stream {stream_name}")));
    }
    Ok(DrawRecord {
        index: 0,
        attempts: 0,
        rejected: Vec::new(),
        distance,
        azimuth_deg: az,
        elevation_deg: el,
        stream: stream_name,
        occluded: 0.0,
        more_cameras: Vec::new(),
        truth: None,
    })
}

/// The second and later cameras (`c.count` - 1), the first at azimuth `first_azimuth_deg`.
/// Drawn after everything else of an attempt, so that adding cameras to a sweep keeps each
/// attempt's first camera, probes and occluder.
pub(super) fn draw_more_cameras(
    r: &mut Draws,
    c: &CameraRanges,
    first_azimuth_deg: f64,
) -> Vec<CameraDraw> {
    (1..c.count)
        .map(|k| CameraDraw {
            distance: r.within(c.distance),
            azimuth_deg: first_azimuth_deg + k as f64 * c.azimuth_spacing_deg,
            elevation_deg: r.within(c.elevation_deg),
        })
        .collect()
}

/// The camera spec of a drawn record, looking at `target`.
pub(super) fn camera_of(rec: &DrawRecord, target: [f64; 3]) -> SceneResult<CameraSpec> {
    let first = CameraDraw {
        distance: rec.distance,
        azimuth_deg: rec.azimuth_deg,
        elevation_deg: rec.elevation_deg,
    };
    place_camera(&rec.stream, &first, target)
}

/// The camera of stream `stream_name` placed as `at` says, looking at `target`.
fn place_camera(stream_name: &str, at: &CameraDraw, target: [f64; 3]) -> SceneResult<CameraSpec> {
    let mut cam = stream(stream_name)
        .ok_or_else(|| SceneError::Spec(format!("unknown stream {stream_name}")))?;
    let (a, e, dist) = (
        at.azimuth_deg.to_radians(),
        at.elevation_deg.to_radians(),
        at.distance,
    );
    cam.target = target;
    cam.eye = [
        target[0] + dist * e.cos() * a.sin(),
        target[1] - dist * e.cos() * a.cos(),
        target[2] + dist * e.sin(),
    ];
    cam.up = [0.0, 0.0, 1.0];
    Ok(cam)
}

/// The cameras of a scene with several (`cam0` = `first`, then `record.more_cameras`);
/// empty for one camera.
pub(super) fn rig_cameras(
    record: &DrawRecord,
    first: &CameraSpec,
    target: [f64; 3],
) -> SceneResult<Vec<NamedCameraSpec>> {
    if record.more_cameras.is_empty() {
        return Ok(Vec::new());
    }
    let mut cameras = vec![NamedCameraSpec {
        name: "cam0".into(),
        camera: first.clone(),
    }];
    for (k, at) in record.more_cameras.iter().enumerate() {
        cameras.push(NamedCameraSpec {
            name: format!("cam{}", k + 1),
            camera: place_camera(&record.stream, at, target)?,
        });
    }
    Ok(cameras)
}
