//! `softsense scene`: synthetic RGB-D truth from a scene file (the direct model).

use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use softsense::scene::sweep::{self, Sweep};
use softsense::scene::{generate, Scene};
use std::path::PathBuf;

/// Synthetic scenes: solve the FE model under known loads and render RGB-D frames.
#[derive(Args, Debug)]
pub struct SceneArgs {
    #[command(subcommand)]
    command: SceneCommand,
}

#[derive(Subcommand, Debug)]
enum SceneCommand {
    /// Render every frame of SCENE into OUT_DIR (depth/colour PNGs, intrinsics, pose, truth).
    #[command(long_about = GENERATE_LONG)]
    Generate {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Output folder: new or empty (created; written beside it and renamed into place
        /// when done, so a failed run leaves nothing).
        out_dir: PathBuf,
        #[arg(long, help = super::FORCE_HELP)]
        force: bool,
    },
    /// Draw COUNT random physical scenes from the ranges in SWEEP and render each into
    /// OUT_DIR/scene_NNNN (for `sense` and `score`).
    #[command(long_about = SWEEP_LONG)]
    Sweep {
        /// Sweep file (TOML): the ranges scenes are drawn from.
        sweep: PathBuf,
        /// Output folder: new or empty (created; written beside it and renamed into place
        /// when done, so a failed run leaves nothing).
        out_dir: PathBuf,
        #[arg(long, help = super::FORCE_HELP)]
        force: bool,
        /// Number of scenes.
        #[arg(long, value_parser = super::parse_positive)]
        count: usize,
        /// Seed of the draws (scene i depends only on the file, the seed and i).
        #[arg(long)]
        seed: u64,
    },
}

/// `scene sweep --help`.
const SWEEP_LONG: &str = "\
Draw COUNT random scenes from the ranges in SWEEP and render each (one loaded frame) into
OUT_DIR/scene_NNNN, with its scene file OUT_DIR/scene_NNNN.toml, the sweep file with every
default filled in (OUT_DIR/sweep.toml) and what was drawn per scene (OUT_DIR/draws.json).

Each scene: a camera on a sphere around the robot (distance, azimuth, elevation, stream);
1-4 probes on surface nodes the camera sees at rest, at least min_separation apart, each
pushing within a cone about the inward normal; optionally a sphere halfway to the camera
hiding a drawn share of the robot's pixels (never a probe). A draw whose solved scene
pushes the surface or a probe through the table, nearly inverts an element
(validity.min_volume_ratio), overlaps two probes or does not converge is redrawn; the
reasons are in draws.json. Scene i depends only on the sweep file, the seed and i.

The sweep file (TOML; metres, degrees, newtons, robot frame). Only `model` is required;
the other keys show their defaults:

  model = \"../meshes/models/robot.toml\"  # FE model, relative to this file
  table_half = 0.3         # table under the robot's lowest point (0: none)
  # young = 180000.0       # optional Young's modulus override (Pa)
  reference_frames = 0     # unloaded frames (same camera, body, cables) written before
                           # each scene's loaded frame, 0-16: sense them as a tare
                           # with `sense --reference-frames N`
  held_frames = 1          # times each scene's loaded frame is written (1-64), each
                           # with its own noise: `sense --hold`, `score --held`

  [camera]
  distance = [0.4, 0.6]          # from the target (m)
  azimuth_deg = [-180.0, 180.0]  # about +z; 0 = the bundled scenes' side (-y)
  elevation_deg = [20.0, 45.0]   # looking down
  streams = [\"640x480\"]        # and/or \"1280x720\" (D415-like intrinsics)
  # target = [0.0, 0.0, 0.06]    # default: centre of the robot's bounding box
  count = 1                      # cameras per scene (1-8); with more, each next one
  azimuth_spacing_deg = 90.0     # this much further in azimuth, its own distance and
                                 # elevation drawn; scene_NNNN/camK/ per camera

  [probes]
  count = [1, 1]           # probes per scene, inclusive
  force = [0.25, 0.9]      # magnitude (N)
  cone_deg = 15.0          # angle to the inward normal, uniform over the cone
  radius = [0.006, 0.010]  # probe sphere (m)
  min_separation = 0.04    # between probes (m)
  min_facing = 0.3         # cosine between normal and direction to the camera
  min_height = 0.015       # above the table (m)

  [occluder]
  fraction = [0.0, 0.0]    # share of robot pixels hidden (e.g. [0.3, 0.3])

  [sensor]                 # as in `scene generate --help`, for the 640x480 stream;
                           # 1280x720 gets the same disparity noise (depth_k * 615/fx)

  [validity]
  min_volume_ratio = 0.1   # least deformed/rest element volume
  max_attempts = 200       # draws per scene before giving up

  [truth]                  # optional: scenes rendered from a body that is not the model,
                           # keys as in `scene generate --help`, drawn per scene on a
                           # stream of their own (the cameras and probes stay the same)
  young_factor = 1.0       # or a range drawn uniformly per scene: [0.85, 1.15]
  # poisson = [0.40, 0.49]       # likewise; default the model's
  # formulation = \"neo-hookean\"  # the same for every scene
  # mesh = \"fine/robot.vtu\"      # relative to this file; the same for every scene
  # base_stiffness = [1.0e5, 1.0e6]  # N/m, likewise: a slightly compliant base

Examples:
  softsense scene sweep tools/sweeps/robot_one_probe.toml /tmp/sw --count 100 --seed 7
  for d in /tmp/sw/scene_*/; do softsense sense \"$d\" --json > \"$d/sense.json\"; done
  softsense score /tmp/sw";

/// `scene generate --help`: what it writes and the scene file, every key with its default.
const GENERATE_LONG: &str = "\
Render every frame of SCENE into OUT_DIR: the FE model is solved under each frame's loads
and cable inputs, then the deformed robot, the probes and the table are ray-cast into
depth_NNNN.png (16-bit, in depth_unit) and color_NNNN.png, with intrinsics.json (Open3D
format plus depth_scale), camera_pose.json, actuators.json (with cavities: inputs.json
too) and truth.json (every load,
location and parameter used; `sense` reports its errors against it), and with [markers]
markers_truth.csv (the painted markers' true positions per frame).

OUT_DIR is new or empty; one that holds a recording is replaced whole with --force (no
stale frame of the old one is left), and one holding other files, or the scene or model
file, is refused. The frames are written beside OUT_DIR and renamed into place at the end:
a run that fails leaves nothing.

The scene file (TOML; lengths in metres, forces in newtons, robot frame). Only `model` and
`frames` are required. Below, the other keys show their defaults, except `young` (default:
the model's own) and the example frame:

  model = \"../../meshes/models/robot.toml\"  # FE model, relative to this file
  young = 250000.0         # optional: Young's modulus override (Pa)
  seed = 0                 # sensor-noise seed (the same seed gives the same frames)
  table_half = 0.3         # half side of the table (0: none)
  # table_z = 0.0          # height of the table top; default: the model's lowest point

  [colors]                 # sRGB 0-255
  robot = [40, 200, 60]
  probe = [220, 40, 40]
  table = [150, 150, 160]
  occluder = [90, 90, 95]

  [camera]                 # RealSense D415-like, 0.5 m away, looking down at 30 degrees
  width = 640
  height = 480
  fx = 615.0
  fy = 615.0
  cx = 319.5
  cy = 239.5
  eye = [0.0, -0.433, 0.31]
  target = [0.0, 0.0, 0.06]
  up = [0.0, 0.0, 1.0]

  # [[cameras]]           # instead of [camera], any number: each renders every
  # name = \"side\"         # frame into OUT_DIR/NAME/ (images, intrinsics.json,
  # eye = [0.433, 0.0, 0.31]  # camera_pose.json) with its own noise draw; the other
                           # keys as in [camera], same defaults; truth.json and
                           # actuators.json stay in OUT_DIR (clouds/scenes/two_cameras.toml)

  [sensor]
  enabled = true           # false: exact depth, still quantised to depth_unit
  depth_k = 0.002          # depth noise sigma = depth_k * z^2 (0.5 mm at 0.5 m)
  depth_unit = 0.001       # metres per PNG unit (0.001: millimetres)
  grazing_deg = 80.0       # steeper incidence gives holes
  edge_jump = 0.02         # a depth jump above this marks a silhouette edge...
  edge_hole_probability = 0.5  # ...whose pixels become holes with this probability
  color_sigma = 3.0        # colour noise per channel
                           # opt-in artefacts, off by default (fitted values: docs/sensor.md)
  depth_sigma_floor = 0.0  # sigma floor added to depth_k * z^2 (m)
  depth_sigma_incidence = 0.0  # sigma times 1 + g (1/cos(incidence) - 1)
  depth_step_k = 0.0       # quantisation step max(depth_unit, depth_step_k * z^2)
  hole_probability = 0.0   # random dropout of any pixel
  flying_probability = 0.0 # a depth-edge pixel mixes with its neighbour across the edge
  flying_spread = 1.0      # mixing fraction uniform in 1/2 +- spread/2

  [markers]                # optional: painted marker discs that move with the surface
  colour = [30, 60, 230]   # sRGB 0-255 (keep it unlike the robot's and the probe's)
  radius = 0.003           # disc radius (m)
  count = 16               # spread over flat surface facing the camera (farthest points)
  # at = [[0.0, 0.0, 0.004]]  # or: these points, snapped to the surface (instead of count)
                           # writes markers_truth.csv (frame,marker,x,y,z, robot frame)

  [truth]                  # optional: render a body that is not the model (the
                           # recording still names the model; truth.json's
                           # truth_model says what the body was). Defaults: the model's
  young_factor = 1.0       # the body's Young's modulus over the model's (0-10]
  # poisson = 0.45         # the body's Poisson ratio, in (-1, 0.5)
  # formulation = \"neo-hookean\"  # or \"corotational\": the body's element law
  # mesh = \"fine/robot.vtu\"  # another volume mesh of the same shape (relative to
                           # this file; the model file's units): points move by position,
                           # node indices to the nearest node. A 2x finer robot:
                           # python3 tools/mesh/gen_meshes.py DIR --robot-h 4.4 --only robot
  # base_stiffness = 1.0e5  # N/m, each axis: the base on springs of this total
                           # stiffness, shared by the model's fixed nodes (default clamped)

  [[occluders]]            # optional, any number: a sphere hiding part of the view
  center = [0.1, -0.2, 0.2]
  radius = 0.03

  [[frames]]               # one table per frame; a frame without loads is a reference
  [[frames.cables]]        # optional; unlisted cables keep the model's input
  name = \"north\"
  shorten = 0.01           # or: force = 2.0 (tension, N)
  # [[frames.cavities]]    # optional, for a model with [[cavities]]; unlisted keep theirs
  # name = \"cavity\"
  # pressure = 10000.0     # Pa; or: volume = 5.0e-7 (volume change, m^3)
  [[frames.loads]]
  kind = \"probe\"           # a sphere pressing on the surface node nearest to `at`
  at = [0.05, -0.013, 0.083]  # metres, robot frame at rest; at most 20 mm off the surface
  force = [0.07, 0.78, 0.05]
  radius = 0.008
  [[frames.loads]]
  kind = \"weight\"          # hanging from `at` by a string (not rendered)
  at = [0.0, 0.0, 0.125]
  force = [0.0, 0.0, -0.66]

Examples:
  softsense scene generate clouds/scenes/tip_weight.toml /tmp/tip_weight
  softsense sense /tmp/tip_weight";

/// Runs the subcommand.
pub fn run(args: SceneArgs) -> Result<(), Box<dyn std::error::Error>> {
    match args.command {
        SceneCommand::Generate {
            scene,
            out_dir,
            force,
        } => {
            let scene_path = scene;
            let scene = Scene::load(&scene_path)?;
            let inputs = [scene_path.as_path(), scene.model_path.as_path()];
            let staged = super::staged_output_dir(&out_dir, &inputs, force)?;
            let bar = ProgressBar::new(scene.spec.frames.len() as u64);
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {pos}/{len} frames {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            // The scene's frames and sensor come from its file: name it.
            let truth = generate(&scene, staged.path(), |done, _| {
                bar.set_position(done as u64)
            })
            .map_err(|e| format!("{}: {e}", scene_path.display()))?;
            bar.finish_and_clear();
            staged.commit().map_err(super::output_error)?;
            for f in &truth.frames {
                eprintln!(
                    "frame {}: {} loads, {} Newton iterations, robot/probe/table pixels {:?}",
                    f.frame,
                    f.loads.len(),
                    f.newton_iterations,
                    f.pixels
                );
            }
            let cameras: Vec<String> = (scene.views().into_iter()).filter_map(|v| v.name).collect();
            let into = match cameras.is_empty() {
                true => String::new(),
                false => format!(" of {} cameras ({})", cameras.len(), cameras.join(", ")),
            };
            eprintln!(
                "wrote {} frames{into} to {}",
                truth.frames.len(),
                out_dir.display()
            );
            Ok(())
        }
        SceneCommand::Sweep {
            sweep,
            out_dir,
            count,
            seed,
            force,
        } => run_sweep(&sweep, &out_dir, count, seed, force),
    }
}

fn run_sweep(
    path: &std::path::Path,
    out: &std::path::Path,
    count: usize,
    seed: u64,
    force: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let sweep = Sweep::load(path)?;
    let staged = super::staged_output_dir(out, &[path, &sweep.model_path], force)?;
    let bar = ProgressBar::new(count as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} scenes {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let records = sweep::run(&sweep, staged.path(), count, seed, |done, _| {
        bar.set_position(done as u64)
    })
    .map_err(|e| format!("{}: {e}", path.display()))?;
    bar.finish_and_clear();
    staged.commit().map_err(super::output_error)?;
    let redrawn = records.iter().filter(|r| r.attempts > 1).count();
    eprintln!(
        "wrote {} scenes to {} ({redrawn} redrawn at least once; reasons in draws.json)",
        records.len(),
        out.display()
    );
    Ok(())
}
