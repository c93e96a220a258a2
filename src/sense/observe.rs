//! What a frame shows: its points in the robot frame, cropped to the robot's working box and
//! split by a colour model into robot and objects ([`Observation`]), and where the objects
//! touch the robot ([`Sensor::contacts`]).

use super::report::ms;
use super::SenseError;
use super::{Recording, SenseParams, SenseResult, Sensor};
use crate::contact::{detect_contacts, Contact};
use crate::math::pose::Pose;

/// Points of one frame in the robot frame, split by the colour model.
#[derive(Clone, Debug, Default)]
pub struct Observation {
    /// Robot points (m, robot frame).
    pub robot: Vec<[f64; 3]>,
    /// Other points inside the crop: what may touch the robot (m, robot frame).
    pub objects: Vec<[f32; 3]>,
    /// Pixel index of each robot point.
    pub robot_pixels: Vec<usize>,
    /// Pixel index of each object point.
    pub object_pixels: Vec<usize>,
    /// Image size.
    pub width: u32,
    /// Image size.
    pub height: u32,
    /// The colour frame, row-major.
    pub color: Vec<[u8; 3]>,
    /// Time spent reading, cropping and segmenting this frame (the other stages are zero).
    pub timings: super::StageTimings,
}

impl Sensor {
    /// Reads `frame` of `rec`, cropped to the robot's box, split by the colour model.
    pub fn observe(&self, rec: &Recording, frame: usize) -> SenseResult<Observation> {
        observe(
            rec,
            frame,
            &self.robot_from_camera,
            &self.params,
            Some(self.bounds),
        )
    }

    /// Where objects touch the robot in `obs` (robot frame): the contacts a frame is sensed
    /// with (`SenseParams::contact`), none when no object point is in the crop.
    pub fn contacts(
        &self,
        obs: &Observation,
    ) -> Result<Vec<Contact>, crate::segment::SegmentError> {
        if obs.objects.is_empty() {
            return Ok(Vec::new());
        }
        let robot: Vec<[f32; 3]> = obs.robot.iter().map(|p| p.map(|c| c as f32)).collect();
        detect_contacts(&robot, &obs.objects, &self.params.contact)
    }
}

/// Reads `frame` of `rec` and splits its points (robot frame, cropped to `bounds` when
/// given) into robot and objects by the colour model of `params`.
fn observe(
    rec: &Recording,
    frame: usize,
    robot_from_camera: &Pose,
    params: &SenseParams,
    bounds: Option<[[f64; 3]; 2]>,
) -> SenseResult<Observation> {
    // Without its inputs the frame would be sensed against the wrong cable state.
    if let Some(problem) = rec.input_problem(frame) {
        return Err(SenseError::Inputs(problem));
    }
    let t0 = std::time::Instant::now();
    let mut cloud = rec.read_frame(frame)?;
    let colors = cloud.colors.take().unwrap_or_default();
    let t1 = std::time::Instant::now();
    let kept = crop(&cloud.positions, robot_from_camera, bounds);
    let t2 = std::time::Instant::now();
    // Segment: robot points by the colour model, the rest are objects.
    let mut is_robot = params.color.classifier();
    let mut obs = Observation {
        width: cloud.width,
        height: cloud.height,
        ..Default::default()
    };
    for (i, q) in kept {
        let robot = colors.get(i).is_some_and(|&c| is_robot.is_robot(c));
        if robot {
            obs.robot.push(q);
            obs.robot_pixels.push(i);
        } else {
            obs.objects.push(q.map(|c| c as f32));
            obs.object_pixels.push(i);
        }
    }
    obs.color = colors;
    let t3 = std::time::Instant::now();
    obs.timings.read = ms(t1 - t0);
    obs.timings.crop = ms(t2 - t1);
    obs.timings.segment = ms(t3 - t2);
    Ok(obs)
}

/// Filter: the finite points in the robot frame (`t`, robot from camera), cropped to
/// `bounds` when given, with their pixel indices.
fn crop(
    positions: &[[f32; 3]],
    robot_from_camera: &Pose,
    bounds: Option<[[f64; 3]; 2]>,
) -> Vec<(usize, [f64; 3])> {
    positions
        .iter()
        .enumerate()
        .filter(|(_, p)| p.iter().all(|c| c.is_finite()))
        .filter_map(|(i, p)| {
            let q = robot_from_camera.apply(p.map(|c| c as f64));
            match bounds {
                Some([lo, hi]) if (0..3).any(|k| q[k] < lo[k] || q[k] > hi[k]) => None,
                _ => Some((i, q)),
            }
        })
        .collect()
}
