//! What a frame shows: its points in the robot frame, cropped to the robot's working box and
//! split by a colour model into robot and objects, camera by camera ([`Observation`]), and
//! where the objects touch the robot ([`Sensor::contacts`]).

use super::cameras::{CameraFrames, CameraReport, CameraState};
use super::timings::ms;
use super::SenseError;
use super::{Recording, SenseParams, SenseResult, Sensor};
use crate::contact::{detect_contacts, Contact};
use crate::math::pose::Pose;
use std::ops::Range;

/// Points of one frame in the robot frame, split by the colour model: every camera's that
/// saw it, one after another ([`View`]).
#[derive(Clone, Debug, Default)]
pub struct Observation {
    /// Robot points (m, robot frame), camera after camera.
    pub robot: Vec<[f64; 3]>,
    /// Other points inside the crop: what may touch the robot (m, robot frame), camera after
    /// camera.
    pub objects: Vec<[f32; 3]>,
    /// What each camera that read the frame saw, in camera order.
    pub views: Vec<View>,
    /// Every camera's part in the frame, for a sensor of several cameras (empty for one).
    pub cameras: Vec<CameraReport>,
    /// Time spent reading, cropping and segmenting this frame (the other stages are zero).
    pub timings: super::StageTimings,
}

/// One camera's part of an [`Observation`].
#[derive(Clone, Debug, Default)]
pub struct View {
    /// The camera's index in [`Sensor::cameras`].
    pub camera: usize,
    /// Its robot points: `Observation::robot[robot]`.
    pub robot: Range<usize>,
    /// Its object points: `Observation::objects[objects]`.
    pub objects: Range<usize>,
    /// Pixel index of each of its robot points.
    pub robot_pixels: Vec<usize>,
    /// Pixel index of each of its object points.
    pub object_pixels: Vec<usize>,
    /// Image size.
    pub width: u32,
    /// Image size.
    pub height: u32,
    /// The colour frame, row-major.
    pub color: Vec<[u8; 3]>,
}

impl Sensor {
    /// Reads `frame` of every camera of `source` that has it, cropped to the robot's box
    /// and split by the colour model. With one camera, its error is the frame's; with
    /// several, a camera without the frame, with unreadable files or without a robot point
    /// ([`CameraState::NoRobot`]) is left out and named in [`Observation::cameras`], and the
    /// frame fails only when no camera could read it.
    pub fn observe(&self, source: &impl CameraFrames, frame: usize) -> SenseResult<Observation> {
        self.check_cameras(source)?;
        let shared = source.camera_recording(0);
        // Without its inputs the frame would be sensed against the wrong cable state.
        if let Some(recorded) = &shared.recorded {
            if let Some(Err(problem)) = recorded.entries.get(frame) {
                return Err(SenseError::Inputs {
                    path: recorded.path.clone(),
                    frame,
                    problem: problem.clone(),
                });
            }
        }
        let mut obs = Observation::default();
        if self.cameras.len() == 1 {
            let pose = &self.cameras[0].robot_from_camera;
            observe(shared, frame, pose, &self.params, self.bounds, &mut obs)?;
            obs.views[0].camera = 0;
            return Ok(obs);
        }
        for (k, camera) in self.cameras.iter().enumerate() {
            let rec = source.camera_recording(k);
            let state = if !rec.has_frame(frame) {
                CameraState::Missing
            } else {
                let pose = &camera.robot_from_camera;
                let (robot, objects) = (obs.robot.len(), obs.objects.len());
                match observe(rec, frame, pose, &self.params, self.bounds, &mut obs) {
                    Ok(()) if obs.robot.len() == robot => {
                        // Its objects are as misplaced as its robot: leave the view out.
                        obs.views.pop();
                        let object_points = obs.objects.len() - objects;
                        obs.objects.truncate(objects);
                        CameraState::NoRobot { object_points }
                    }
                    Ok(()) => {
                        obs.views.last_mut().expect("a view was added").camera = k;
                        CameraState::Seen {
                            robot_points: obs.robot.len() - robot,
                            object_points: obs.objects.len() - objects,
                        }
                    }
                    Err(e) => CameraState::Unreadable {
                        message: e.to_string(),
                    },
                }
            };
            obs.cameras.push(CameraReport {
                name: camera.name.clone(),
                state,
            });
        }
        // Cameras that read the frame but saw no robot make a frame without a robot, as one
        // camera's would; a frame no camera could read is an error.
        let read = (obs.cameras.iter()).any(|c| matches!(c.state, CameraState::NoRobot { .. }));
        if obs.views.is_empty() && !read {
            return Err(SenseError::NoCamera {
                cameras: obs.cameras,
            });
        }
        Ok(obs)
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

/// Reads `frame` of `rec`, splits its points (robot frame, cropped to `bounds`) into robot
/// and objects by the colour model of `params`, and appends them to `obs` as a new view.
fn observe(
    rec: &Recording,
    frame: usize,
    robot_from_camera: &Pose,
    params: &SenseParams,
    bounds: [[f64; 3]; 2],
    obs: &mut Observation,
) -> SenseResult<()> {
    let t0 = std::time::Instant::now();
    let mut cloud = rec.read_frame(frame)?;
    let colors = cloud.colors.take().unwrap_or_default();
    let t1 = std::time::Instant::now();
    let kept = crop(&cloud.positions, robot_from_camera, bounds);
    let t2 = std::time::Instant::now();
    // Segment: robot points by the colour model, the rest are objects.
    let mut is_robot = params.color.classifier();
    let mut view = View {
        width: cloud.width,
        height: cloud.height,
        robot: obs.robot.len()..obs.robot.len(),
        objects: obs.objects.len()..obs.objects.len(),
        ..Default::default()
    };
    for (i, q) in kept {
        let robot = colors.get(i).is_some_and(|&c| is_robot.is_robot(c));
        if robot {
            obs.robot.push(q);
            view.robot_pixels.push(i);
        } else {
            obs.objects.push(q.map(|c| c as f32));
            view.object_pixels.push(i);
        }
    }
    view.robot.end = obs.robot.len();
    view.objects.end = obs.objects.len();
    view.color = colors;
    obs.views.push(view);
    let t3 = std::time::Instant::now();
    obs.timings.read += ms(t1 - t0);
    obs.timings.crop += ms(t2 - t1);
    obs.timings.segment += ms(t3 - t2);
    Ok(())
}

/// Filter: the finite points in the robot frame (`t`, robot from camera) inside `bounds`,
/// with their pixel indices.
fn crop(
    positions: &[[f32; 3]],
    robot_from_camera: &Pose,
    [lo, hi]: [[f64; 3]; 2],
) -> Vec<(usize, [f64; 3])> {
    positions
        .iter()
        .enumerate()
        .filter(|(_, p)| p.iter().all(|c| c.is_finite()))
        .map(|(i, p)| (i, robot_from_camera.apply(p.map(|c| c as f64))))
        .filter(|(_, q)| (0..3).all(|k| q[k] >= lo[k] && q[k] <= hi[k]))
        .collect()
}
