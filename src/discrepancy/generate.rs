//! Hidden-effect datasets on the scene generator: a truth model equal to the nominal one
//! (or, with [`DatasetSpec::truth`], a body that is not the model: [`super::truth`]) plus
//! hidden effects with random parameters, frames under varied cable inputs, the truth
//! written to a separate file the workflow never reads.

use super::body::Body;
use super::effects::{apply_model, rotation, rotation_vector, tet_legs, Effect, EffectKind};
use super::{load_candidates, DiscrepancyError, DiscrepancyResult};
use crate::fem::model::Model;
use crate::fem::solve::Problem;
use crate::math::rand::{normal, uniform};
use crate::recording::schema::TruthModel;
use crate::recording::RecordingWriter;
use crate::scene::camera::CameraSpec;
use crate::scene::sensor::SensorModel;
use crate::scene::truth::TruthRanges;
use crate::scene::{
    render_frame, CableInput, CavityInput, FrameInput, LoadInput, LoadKind, Scene, SceneSpec,
};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A hidden effect: one of the library's, or one outside it.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "hidden", rename_all = "snake_case")]
pub enum Hidden {
    /// A library effect with its true parameters.
    Library(Effect),
    /// A point load whose force changes from frame to frame (out of the library).
    VaryingLoad {
        /// The node.
        node: usize,
        /// Force per frame (N).
        forces: Vec<[f64; 3]>,
    },
    /// Stiffening with the actuation: Young's modulus × (1 + beta · total tension in N)
    /// (out of the library: the stiffness differs per frame).
    Stiffening {
        /// Relative stiffening per newton of total cable tension.
        beta: f64,
    },
}

/// Effect types the generator draws from.
pub const EFFECT_TYPES: [&str; 10] = [
    "gravity",
    "young",
    "leg_stiffness",
    "point_load",
    "actuator_offset",
    "camera_pose",
    "depth",
    "poisson",
    "varying_load",
    "stiffening",
];

/// What to generate.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DatasetSpec {
    /// The nominal model file.
    pub model: PathBuf,
    /// Number of frames.
    pub frames: usize,
    /// Random seed (effects, inputs and sensor noise).
    pub seed: u64,
    /// Effect types to hide (names from [`EFFECT_TYPES`]); empty for a null dataset.
    pub effects: Vec<String>,
    /// Magnitude in [0, 1]: 0 barely above noise, 1 large.
    pub magnitude: f64,
    /// The recorded camera.
    pub camera: CameraSpec,
    /// The sensor model.
    pub sensor: SensorModel,
    /// Range of the recorded cable tensions (N).
    pub tension: [f64; 2],
    /// Range of the recorded cavity pressures (Pa); default 0 to 20 kPa (the PneuNet's tip
    /// moves by about a tenth of its length at 15 kPa).
    #[serde(default = "default_pressure")]
    pub pressure: [f64; 2],
    /// The body the frames are rendered from when it is not the model: a scene file's
    /// `[truth]` keys (numbers, or ranges `[lo, hi]` drawn from `seed`), its mesh path
    /// absolute. Default none: the model itself ([`super::truth::parse_truth`] reads it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<TruthRanges>,
}

impl Default for DatasetSpec {
    fn default() -> Self {
        Self {
            model: PathBuf::from("meshes/models/robot.toml"),
            frames: 8,
            seed: 1,
            effects: Vec::new(),
            magnitude: 0.5,
            camera: small_camera(),
            sensor: SensorModel::default(),
            tension: [0.0, 2.0],
            pressure: default_pressure(),
            truth: None,
        }
    }
}

fn default_pressure() -> [f64; 2] {
    [0.0, 20e3]
}

/// A 400x300 crop of the default D415-like camera (same focal length): the robot fills it
/// and it renders in half the time of 640x480.
pub fn small_camera() -> CameraSpec {
    CameraSpec {
        width: 400,
        height: 300,
        cx: 199.5,
        cy: 149.5,
        ..CameraSpec::default()
    }
}

/// The recorded camera for a model: [`small_camera`] when it frames the body (every rest
/// node in the picture, spanning at least [`MIN_SPAN`] of its width or height, as the
/// four-legged robot does), else one aimed at the body ([`aimed_camera`]).
pub fn camera_for(model: &Model) -> DiscrepancyResult<CameraSpec> {
    let small = small_camera();
    let x = &model.problem.mesh.nodes_in_rest;
    let cam = small
        .camera()
        .ok_or_else(|| DiscrepancyError::Data("the default camera is degenerate".into()))?;
    let (w, h) = (f64::from(small.width), f64::from(small.height));
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let mut inside = true;
    for p in x {
        match cam.project_robot(*p) {
            Some((uv, _)) if (0.0..w).contains(&uv[0]) && (0.0..h).contains(&uv[1]) => {
                (0..2).for_each(|k| {
                    lo[k] = lo[k].min(uv[k]);
                    hi[k] = hi[k].max(uv[k]);
                });
            }
            _ => inside = false,
        }
    }
    let spans = hi[0] - lo[0] >= MIN_SPAN * w || hi[1] - lo[1] >= MIN_SPAN * h;
    if inside && spans {
        return Ok(small);
    }
    aimed_camera(model)
}

/// Least share of the picture's width or height a body framed by [`small_camera`] spans.
pub const MIN_SPAN: f64 = 0.4;

/// [`small_camera`]'s intrinsics looking at the bounding-box centre of the rest body from
/// across its axis ([`Body::axis`]): from the default camera's direction made perpendicular
/// to the axis, at the distance where the body fills 70% of the picture (room for it to
/// bend).
pub fn aimed_camera(model: &Model) -> DiscrepancyResult<CameraSpec> {
    let small = small_camera();
    let axis = Body::of(&model.problem)?.axis();
    let d0 = crate::math::sub(small.eye, small.target);
    let along = crate::math::dot(d0, axis);
    let mut back = [0, 1, 2].map(|k| d0[k] - along * axis[k]);
    if crate::math::norm(back) < 1e-6 {
        back = crate::math::tangents(axis).0;
    }
    // Robot z stays up in the picture unless the view is along it.
    let back = crate::math::unit(back);
    let up = if back[2].abs() > 0.99 {
        axis
    } else {
        [0.0, 0.0, 1.0]
    };
    let tan = [
        0.35 * f64::from(small.width) / small.fx,
        0.35 * f64::from(small.height) / small.fy,
    ];
    let (_, eye) = crate::camera::framing(&model.problem.mesh.nodes_in_rest, back, up, tan)
        .ok_or_else(|| DiscrepancyError::Data("no camera frames the body".into()))?;
    let b = model.problem.mesh.bbox();
    Ok(CameraSpec {
        eye,
        target: [0, 1, 2].map(|k| 0.5 * (b[0][k] + b[1][k])),
        up,
        ..small
    })
}

/// The truth file of a dataset.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DatasetTruth {
    /// The spec it was made from.
    pub spec: DatasetSpec,
    /// The hidden effects with their true parameters.
    pub hidden: Vec<Hidden>,
    /// The inputs actually applied per frame (recorded ones differ by any actuator offset).
    pub applied: Vec<FrameInput>,
    /// The body the frames were rendered from, when it is not the model (`spec.truth`
    /// drawn); the hidden effects are on top of it. Absent: the model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth_model: Option<TruthModel>,
}

impl DatasetTruth {
    /// The hidden effects that are in the library (out-of-library ones left out).
    pub fn library_effects(&self) -> Vec<Effect> {
        self.hidden
            .iter()
            .filter_map(|h| match h {
                Hidden::Library(e) => Some(e.clone()),
                _ => None,
            })
            .collect()
    }
}

struct Rng {
    seed: u64,
    n: u64,
}

impl Rng {
    fn u(&mut self) -> f64 {
        self.n += 1;
        uniform(self.seed, 7_777, self.n, 3)
    }
    fn g(&mut self) -> f64 {
        self.n += 1;
        normal(self.seed, 7_777, self.n, 5)
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.u()
    }
    fn sign(&mut self) -> f64 {
        if self.u() < 0.5 {
            -1.0
        } else {
            1.0
        }
    }
    fn dir(&mut self) -> [f64; 3] {
        let v = [self.g(), self.g(), self.g()];
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-12);
        v.map(|c| c / l)
    }
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t.clamp(0.0, 1.0)
}

fn draw(
    name: &str,
    rng: &mut Rng,
    m: f64,
    model: &Model,
    frames: usize,
) -> DiscrepancyResult<Hidden> {
    let lib = |kind, params| Ok(Hidden::Library(Effect { kind, params }));
    match name {
        "gravity" => lib(EffectKind::Gravity, vec![rng.sign() * lerp(0.08, 0.6, m)]),
        "young" => lib(EffectKind::Young, vec![rng.sign() * lerp(0.04, 0.3, m)]),
        "leg_stiffness" => {
            let leg = (rng.u() * 4.0) as usize % 4;
            lib(
                EffectKind::LegStiffness { leg },
                vec![rng.sign() * lerp(0.1, 0.5, m)],
            )
        }
        "point_load" | "varying_load" => {
            let cands = load_candidates(
                &model.problem,
                &Body::of(&model.problem)?,
                super::DiscrepancyParams::default().load_candidates,
            );
            let node = cands
                .get((rng.u() * cands.len() as f64) as usize % cands.len().max(1))
                .copied()
                .ok_or_else(|| DiscrepancyError::Data("no load candidate".into()))?;
            let f = lerp(0.03, 0.3, m);
            if name == "point_load" {
                lib(
                    EffectKind::PointLoad { node },
                    rng.dir().map(|c| c * f).to_vec(),
                )
            } else {
                let forces = (0..frames)
                    .map(|_| rng.dir().map(|c| c * f * rng.u()))
                    .collect();
                Ok(Hidden::VaryingLoad { node, forces })
            }
        }
        "actuator_offset" => lib(
            EffectKind::ActuatorOffset,
            (0..model.problem.cables.len())
                .map(|_| rng.sign() * lerp(0.03, 0.2, m) * rng.range(0.5, 1.0))
                .collect(),
        ),
        "camera_pose" => {
            let w = rng.dir().map(|c| c * lerp(0.15, 1.0, m).to_radians());
            let t = rng.dir().map(|c| c * lerp(0.5, 4.0, m) * 1e-3);
            lib(
                EffectKind::CameraPose,
                vec![w[0], w[1], w[2], t[0], t[1], t[2]],
            )
        }
        "depth" => lib(
            EffectKind::Depth,
            vec![
                rng.sign() * lerp(0.003, 0.03, m),
                rng.sign() * lerp(0.3, 3.0, m) * 1e-3,
            ],
        ),
        "poisson" => lib(EffectKind::Poisson, vec![-lerp(0.03, 0.15, m)]),
        "stiffening" => Ok(Hidden::Stiffening {
            beta: lerp(0.1, 0.5, m),
        }),
        _ => Err(DiscrepancyError::Data(format!(
            "unknown effect type {name:?}"
        ))),
    }
}

/// The true camera for a camera-pose error (ω, t) such that points back-projected with
/// the recorded pose are R(ω) p + t.
fn true_camera(nominal: &CameraSpec, w: [f64; 3], t: [f64; 3]) -> DiscrepancyResult<CameraSpec> {
    // Measured = R p + t with R = R_n R_tᵀ, t = e_n − R e_t, so R_t = Rᵀ R_n and
    // e_t = Rᵀ (e_n − t): the true camera is the nominal one moved by the inverse map.
    let r = rotation(w);
    let inv = |p: [f64; 3]| -> [f64; 3] {
        let d = [p[0] - t[0], p[1] - t[1], p[2] - t[2]];
        [0, 1, 2].map(|k| (0..3).map(|m| r[m][k] * d[m]).sum())
    };
    let rot_t =
        |v: [f64; 3]| -> [f64; 3] { [0, 1, 2].map(|k| (0..3).map(|m| r[m][k] * v[m]).sum()) };
    let mut s = nominal.clone();
    s.eye = inv(nominal.eye);
    s.target = inv(nominal.target);
    s.up = rot_t(nominal.up);
    s.camera()
        .ok_or_else(|| DiscrepancyError::Data("degenerate true camera".into()))?;
    Ok(s)
}

/// The world a dataset is rendered from: the truth model and what differs from the
/// recorded inputs and camera.
struct TrueWorld {
    /// The nominal model with the hidden model effects.
    model: Model,
    /// Inputs actually applied per frame.
    applied: Vec<FrameInput>,
    /// The true camera.
    camera: CameraSpec,
    /// Depth error: relative scale and offset (m).
    depth: (f64, f64),
    /// Stiffening per newton of total tension, if hidden.
    stiffening: Option<f64>,
}

/// Generates a dataset: frames into `frames_dir`, the truth into `truth_path` (keep it
/// outside `frames_dir`).
pub fn generate_dataset(
    spec: &DatasetSpec,
    frames_dir: &Path,
    truth_path: &Path,
) -> DiscrepancyResult<DatasetTruth> {
    if spec.frames == 0 || spec.frames > super::data::MAX_FRAMES {
        return Err(DiscrepancyError::Data("frames must be 1..=1000".into()));
    }
    let writer = RecordingWriter::create(frames_dir)?;
    let nominal = Model::load(&spec.model, None)?;
    let mut rng = Rng {
        seed: spec.seed,
        n: 0,
    };
    let hidden = spec
        .effects
        .iter()
        .map(|e| draw(e, &mut rng, spec.magnitude, &nominal, spec.frames))
        .collect::<DiscrepancyResult<Vec<_>>>()?;
    let recorded = recorded_inputs(spec, &nominal, &mut rng)?;
    // The truth's draws are on a stream of their own (as a sweep's), so a dataset with a
    // `--truth` hides the same effects under the same inputs as one without.
    let drawn = (spec.truth.as_ref()).map(|t| t.draw(spec.seed, 0, None));
    let body = match &drawn {
        Some(t) => super::truth::truth_body(&spec.model, &nominal, t)?,
        None => nominal.clone(),
    };
    let world = true_world(spec, &nominal, &body, &hidden, &recorded)?;
    render_frames(spec, &world, &writer)?;
    let recorded_cam = spec.camera.camera().ok_or_else(|| {
        DiscrepancyError::Data(
            spec.camera
                .check()
                .err()
                .unwrap_or_else(|| "camera: no camera can be made from the spec".into()),
        )
    })?;
    writer.write_camera(&recorded_cam, spec.sensor.depth_unit)?;
    writer.write_json("sensor.json", &spec.sensor)?;
    writer.write_json("inputs.json", &recorded)?;
    let truth = DatasetTruth {
        spec: spec.clone(),
        hidden,
        truth_model: (drawn.as_ref()).map(|t| t.record(&body, mesh_shown(t, &spec.model))),
        applied: world.applied,
    };
    crate::recording::write_json(truth_path, &truth)?;
    Ok(truth)
}

/// Least movement (fraction of the free length, [`Body::length`]) of the body between an
/// actuator's lowest and highest recorded input; a range that moves it less is stretched.
pub const MIN_STROKE: f64 = 0.1;

/// The inputs of the recorded actuators (the cables' then the cavities') as a frame: each
/// at the bottom of its range but actuator `i` at `top`.
fn one_up(p: &Problem, spec: &DatasetSpec, i: Option<usize>, top: f64) -> FrameInput {
    let at = |k: usize, r: [f64; 2]| if Some(k) == i { top } else { r[0] };
    FrameInput {
        cables: (p.cables.iter().enumerate())
            .map(|(k, c)| CableInput {
                name: c.name.clone(),
                shorten: None,
                force: Some(at(k, spec.tension)),
            })
            .collect(),
        cavities: (p.cavities.iter().enumerate())
            .map(|(k, c)| CavityInput {
                name: c.name.clone(),
                pressure: Some(at(p.cables.len() + k, spec.pressure)),
                volume: None,
            })
            .collect(),
        loads: Vec::new(),
    }
}

/// Each actuator's recorded range: `spec.tension` (cables) or `spec.pressure` (cavities),
/// its top raised until the actuator alone moves some node by [`MIN_STROKE`] of the free
/// length (a stiff body, such as the SOFA finger at 18 MPa, hardly bends at 2 N, and its
/// hidden effects would stay below the noise). Linear in the input; never lowered.
pub fn input_ranges(spec: &DatasetSpec, nominal: &Model) -> DiscrepancyResult<Vec<[f64; 2]>> {
    let p = &nominal.problem;
    let ranges: Vec<[f64; 2]> = (p.cables.iter().map(|_| spec.tension))
        .chain(p.cavities.iter().map(|_| spec.pressure))
        .collect();
    let solve = |input: &FrameInput| -> DiscrepancyResult<Vec<[f64; 3]>> {
        let q = super::frame_problem(nominal, input)?;
        Ok(q.solve_static(&nominal.newton)?.positions)
    };
    let bottom = solve(&one_up(p, spec, None, 0.0))?;
    let stroke = MIN_STROKE * Body::of(p)?.length();
    let mut out = Vec::with_capacity(ranges.len());
    for (i, r) in ranges.iter().enumerate() {
        let top = solve(&one_up(p, spec, Some(i), r[1]))?;
        let moved = (top.iter().zip(&bottom))
            .map(|(a, b)| crate::math::dist(*a, *b))
            .fold(0.0, f64::max);
        let scale = if moved > 0.0 {
            (stroke / moved).max(1.0)
        } else {
            1.0
        };
        out.push([r[0], r[0] + (r[1] - r[0]) * scale]);
    }
    Ok(out)
}

/// Recorded inputs from a Latin hypercube over [`input_ranges`]: force-controlled cables,
/// then pressure-controlled cavities.
fn recorded_inputs(
    spec: &DatasetSpec,
    nominal: &Model,
    rng: &mut Rng,
) -> DiscrepancyResult<Vec<FrameInput>> {
    // Every cable sweeps the whole range once (one frame per stratum, in its own random
    // order), so the cables vary independently and the design stays well conditioned for
    // any number of frames (independent uniform draws can leave a cable nearly constant
    // or two cables nearly collinear over 8 frames, hiding per-cable effects).
    let n = spec.frames;
    let p = &nominal.problem;
    let values: Vec<Vec<f64>> = (input_ranges(spec, nominal)?.into_iter())
        .map(|range| {
            let mut order: Vec<usize> = (0..n).collect();
            for i in (1..n).rev() {
                let j = ((rng.u() * (i + 1) as f64) as usize).min(i);
                order.swap(i, j);
            }
            order
                .iter()
                .map(|&s| {
                    let t = (s as f64 + rng.u()) / n as f64;
                    lerp(range[0], range[1], t)
                })
                .collect()
        })
        .collect();
    Ok((0..n)
        .map(|i| FrameInput {
            cables: (p.cables.iter().zip(&values))
                .map(|(c, t)| CableInput {
                    name: c.name.clone(),
                    shorten: None,
                    force: Some(t[i]),
                })
                .collect(),
            cavities: (p.cavities.iter().zip(&values[p.cables.len()..]))
                .map(|(c, v)| CavityInput {
                    name: c.name.clone(),
                    pressure: Some(v[i]),
                    volume: None,
                })
                .collect(),
            loads: Vec::new(),
        })
        .collect())
}

/// The truth's mesh file as `truth_hidden.json` names it: its own, or the model's.
fn mesh_shown(t: &crate::scene::truth::TruthSpec, model: &Path) -> String {
    (t.mesh.clone())
        .or_else(|| {
            Model::mesh_file(model)
                .ok()
                .map(|m| m.display().to_string())
        })
        .unwrap_or_default()
}

/// The true world: the hidden effects applied to the body (the nominal model, or the
/// `--truth` body), the recorded inputs and the recorded camera.
fn true_world(
    spec: &DatasetSpec,
    nominal: &Model,
    body: &Model,
    hidden: &[Hidden],
    recorded: &[FrameInput],
) -> DiscrepancyResult<TrueWorld> {
    let mut w = TrueWorld {
        model: body.clone(),
        applied: recorded.to_vec(),
        camera: spec.camera.clone(),
        depth: (0.0, 0.0),
        stiffening: None,
    };
    // The legs of the body's own tetrahedra: its mesh may not be the model's.
    let legs = tet_legs(&body.problem, &Body::of(&body.problem)?);
    for h in hidden {
        match h {
            Hidden::Library(e) => match e.kind {
                EffectKind::ActuatorOffset => {
                    for f in &mut w.applied {
                        for (c, off) in f.cables.iter_mut().zip(&e.params) {
                            c.force = c.force.map(|v| v + off);
                        }
                    }
                }
                EffectKind::CameraPose => {
                    let p = &e.params;
                    w.camera = true_camera(&w.camera, [p[0], p[1], p[2]], [p[3], p[4], p[5]])?;
                }
                EffectKind::Depth => w.depth = (e.params[0], e.params[1]),
                _ => {
                    let e = super::truth::onto_body(e, nominal, body);
                    apply_model(&mut w.model.problem, std::slice::from_ref(&e), &legs)?
                }
            },
            Hidden::VaryingLoad { node, forces } => {
                let at = nominal.problem.mesh.nodes_in_rest[*node];
                for (f, force) in w.applied.iter_mut().zip(forces) {
                    f.loads.push(LoadInput {
                        kind: LoadKind::Weight,
                        at,
                        force: *force,
                        radius: 0.008,
                    });
                }
            }
            Hidden::Stiffening { beta } => w.stiffening = Some(*beta),
        }
    }
    Ok(w)
}

/// Renders every frame of the true world into the recording (depth and colour PNGs).
fn render_frames(
    spec: &DatasetSpec,
    w: &TrueWorld,
    writer: &RecordingWriter,
) -> DiscrepancyResult<()> {
    // Render at a 16x finer depth unit, apply any depth error, then quantise once to the
    // recorded unit: quantising twice would add noise the sensor model does not have.
    let mut fine_sensor = spec.sensor.clone();
    fine_sensor.depth_unit = spec.sensor.depth_unit / 16.0;
    let scene = Scene {
        spec: SceneSpec {
            model: spec.model.display().to_string(),
            young: None,
            seed: spec.seed,
            table_half: 0.3,
            table_z: None,
            occluders: Vec::new(),
            colors: Default::default(),
            markers: None,
            truth: None,
            camera: w.camera.clone(),
            cameras: Vec::new(),
            sensor: fine_sensor.clone(),
            frames: w.applied.clone(),
        },
        model_path: spec.model.clone(),
        truth_mesh: None,
    };
    let depth = w.depth;
    for (i, input) in w.applied.iter().enumerate() {
        let mut m = w.model.clone();
        if let Some(beta) = w.stiffening {
            let total: f64 = input.cables.iter().filter_map(|c| c.force).sum();
            let e = m.problem.material;
            m.problem.material =
                crate::fem::material::Material::new(e.young() * (1.0 + beta * total), e.poisson())?;
        }
        let r = render_frame(&scene, &m, i)?;
        let [view] = &r.views[..] else {
            unreachable!("a scene without [[cameras]] renders one view")
        };
        let unit = spec.sensor.depth_unit;
        let d: Vec<u16> = view
            .depth
            .iter()
            .map(|&v| {
                if v == 0 {
                    return 0;
                }
                let z = v as f64 * fine_sensor.depth_unit * (1.0 + depth.0) + depth.1;
                (z / unit).round().clamp(0.0, 65535.0) as u16
            })
            .collect();
        writer.write_frame(i, [w.camera.width, w.camera.height], d, &view.color)?;
    }
    Ok(())
}

/// The rotation vector of a camera-pose truth (for checks): the measured-from-true rotation
/// between two camera specs.
pub fn pose_error(nominal: &CameraSpec, truth: &CameraSpec) -> Option<[f64; 6]> {
    let rn = nominal.camera()?.robot_from_camera().to_matrix();
    let rt = truth.camera()?.robot_from_camera().to_matrix();
    let mut r = [[0.0; 3]; 3];
    for (i, ri) in r.iter_mut().enumerate() {
        for (j, rij) in ri.iter_mut().enumerate() {
            *rij = (0..3).map(|k| rn[i][k] * rt[j][k]).sum();
        }
    }
    let w = rotation_vector(&r);
    let et = [rt[0][3], rt[1][3], rt[2][3]];
    let tv = [0, 1, 2].map(|i| rn[i][3] - (0..3).map(|k| r[i][k] * et[k]).sum::<f64>());
    Some([w[0], w[1], w[2], tv[0], tv[1], tv[2]])
}

/// Default truth path for a dataset folder `dir`: `dir/truth_hidden.json` beside
/// `dir/frames/`.
pub fn layout(dir: &Path) -> (PathBuf, PathBuf) {
    (dir.join("frames"), dir.join("truth_hidden.json"))
}
