//! Marker-based force sensing (thesis 4.4, 4.6.1, 4.7.1): a few tracked markers on the body,
//! bound to the FE surface as effectors, and the forces at candidate locations that explain
//! their displacements.
//!
//! - [`tracks`]: marker track files (softsense's `frame,marker,x,y,z` CSV and OptiTrack
//!   Motive CSV exports) and the hidden-marker rule ([`tracks::flag_hidden`]).
//! - [`motion`]: where a marker is expected in a new frame, from the motion of its
//!   neighbours ([`motion::MotionTracker`]), for the hidden-marker rule and detection.
//! - [`bind`]: markers at their nearest surface-triangle point ([`BoundMarker`]); candidate
//!   force locations snapped to surface nodes with their allowed directions
//!   ([`CandidateLocation`]).
//! - [`solve`]: per frame, the analytic least squares (4.9) iterated with the FE model
//!   ([`MarkerSensor::solve_frame`]), with actuators held at the model's inputs; the status,
//!   the forces, their covariance σ²(W_efᵀW_ef)⁻¹, I_w and I_e.
//! - [`layout`]: marker layouts minimising I_w from the pool's compliance at the free
//!   equilibrium (greedy, then exchanges; [`layout::propose_layout`]).
//! - [`detect`]: coloured markers found in RGB-D frames (colour blobs, their centre on the
//!   surface, identities across frames; [`detect::detect_recording`]).
//! - [`locate`]: candidates "found" by a stated threshold rule and the intensity-weighted
//!   centre of each group of found candidates (4.11-4.13, Corollary 2).
//! - [`calib`]: the tracker-to-robot transform fitted to the markers' rest positions
//!   ([`calib::fit_robot_from_tracker`]).
//! - [`reference`](mod@reference): where each marker is bound, from the first frames,
//!   refused when one of them is loaded ([`reference::reference_positions`]).
//! - [`refine`]: a located force moved to the nearby surface node where one force explains
//!   the markers best ([`refine::refine_located`]).
//!
//! Everything is SI (m, N) and `f64` inside; tracks are in the model frame, or mapped into it
//! by a [`calib::MarkerCalibration`].
//!
//! ```
//! use softsense::markers::tracks::{read_tracks_str, write_tracks_string};
//! let text = "frame,marker,x,y,z\n0,a,0.1,0.2,0.0\n0,b,,,\n";
//! let tracks = read_tracks_str(text)?;
//! assert_eq!(tracks.names, ["a", "b"]);
//! assert!(tracks.frames[0].positions[1].is_none()); // b is hidden in frame 0
//! assert_eq!(read_tracks_str(&write_tracks_string(&tracks))?, tracks);
//! # Ok::<(), softsense::markers::MarkersError>(())
//! ```

pub mod bind;
pub mod calib;
pub mod detect;
pub mod layout;
pub mod locate;
pub mod motion;
pub mod reference;
pub mod refine;
pub mod solve;
pub mod tracks;

pub use crate::fem::bind::{bind_markers, BoundMarker};
pub use bind::{CandidateLocation, Directions};
pub use locate::{locate_forces, LocatedForce};
pub use refine::refine_located;
pub use solve::{MarkerFrame, MarkerSensor, MarkersStatus};
pub use tracks::{MarkerTracks, TrackFrame};

use thiserror::Error;

/// Errors of marker-based sensing: bad track or candidate files, markers off the surface,
/// FE failures.
#[derive(Debug, Error)]
pub enum MarkersError {
    /// A track file could not be read or written.
    #[error(transparent)]
    Tracks(#[from] crate::recording::tracks::TracksError),
    /// An output file could not be written (it names the file).
    #[error(transparent)]
    Write(#[from] crate::io::atomic::AtomicError),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    File {
        /// The file.
        path: String,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// A candidate-file line without the 5 cells name,x,y,z,directions (1-based line).
    #[error("line {line}: {cells} cells, expected name,x,y,z,directions")]
    CandidateCells {
        /// The 1-based line number.
        line: usize,
        /// Cells found.
        cells: usize,
    },
    /// A candidate-file coordinate that is not a finite number.
    #[error("line {line}: {cell:?} is not a finite number")]
    CandidateNumber {
        /// The 1-based line number.
        line: usize,
        /// The cell as written.
        cell: String,
    },
    /// A candidate-file directions cell other than normal or 3d.
    #[error("line {line}: directions {cell:?}: expected normal or 3d")]
    CandidateDirections {
        /// The 1-based line number.
        line: usize,
        /// The cell as written (lower-cased).
        cell: String,
    },
    /// Candidates farther than [`bind::MAX_CANDIDATE_DISTANCE`] from the model's surface.
    #[error("candidates off the model's surface (more than {:.1} mm from it): {candidates}; give candidates on the body, in metres in the model frame", 1e3 * max_distance)]
    CandidatesOffSurface {
        /// Each one's name, line and distance, `, `-separated.
        candidates: String,
        /// The largest distance accepted (m).
        max_distance: f64,
    },
    /// A candidate file without a candidate line.
    #[error("no candidates: the file has no line name,x,y,z,directions (m, model frame; directions normal or 3d)")]
    NoCandidates,
    /// More reference frames asked for than the tracks have (or none).
    #[error("--reference-frames {asked}: the tracks have {frames} frames; the reference is the first frames, which must show the body unloaded: give from 1 to the number of unloaded frames at the start")]
    ReferenceFramesTooMany {
        /// Reference frames asked for.
        asked: usize,
        /// Frames in the tracks.
        frames: usize,
    },
    /// A reference frame whose markers moved more than the noise explains: a loaded frame.
    #[error("--reference-frames {asked}: frame {frame} is loaded: its markers moved {:.3} mm RMS from their first reference position, more than {} times the {:.3} mm the noise (--sigma-mm) explains; give --reference-frames {index} (the frames before it), or a larger --sigma-mm if the body did not move", 1e3 * moved, reference::LOADED_RATIO, 1e3 * expected)]
    ReferenceFrameLoaded {
        /// The frame's number as written.
        frame: u64,
        /// Its index in the tracks (the unloaded frames before it).
        index: usize,
        /// Reference frames asked for.
        asked: usize,
        /// Its markers' RMS distance from their first reference position (m).
        moved: f64,
        /// What the noise explains (m): √6 σ.
        expected: f64,
    },
    /// A marker with no position in any frame.
    #[error("marker {name} is never visible in the tracks: it cannot be bound to the model (leave it out of the file)")]
    MarkerNeverVisible {
        /// Its name.
        name: String,
    },
    /// An error in a file, with the file's name.
    #[error("{path}: {source}")]
    InFile {
        /// The file.
        path: String,
        /// What is wrong in it.
        source: Box<MarkersError>,
    },
    /// A detection option out of its range.
    #[error("marker detection: {field} must be {expected}, got {value}")]
    DetectOption {
        /// The [`detect::DetectParams`] field.
        field: &'static str,
        /// Its allowed range.
        expected: &'static str,
        /// The value given.
        value: String,
    },
    /// A frame whose colours or points do not fill its image.
    #[error(
        "marker detection: {colours} colours and {points} points for a {width}x{height} image"
    )]
    DetectImage {
        /// Colours given.
        colours: usize,
        /// Points given.
        points: usize,
        /// Image width (pixels).
        width: u32,
        /// Image height (pixels).
        height: u32,
    },
    /// A recording without the camera pose that puts the markers in the robot frame.
    #[error("marker detection: {dir}: no camera pose (camera_pose.json or calibration.json): the markers cannot be put in the robot frame")]
    NoCameraPose {
        /// The recording's directory.
        dir: String,
    },
    /// A recording frame (or its camera) that could not be read.
    #[error("marker detection: frame {frame}: {source}")]
    DetectFrame {
        /// The frame number.
        frame: usize,
        /// Why it could not be read.
        source: crate::recording::RecordingError,
    },
    /// A recording frame without a colour image.
    #[error("marker detection: frame {frame}: no colour image")]
    NoColour {
        /// The frame number.
        frame: usize,
    },
    /// The model has no surface to put a candidate on.
    #[error("the model has no surface")]
    NoSurface,
    /// A tracker-to-robot fit from fewer than 3 markers.
    #[error("marker calibration: {markers} markers: a rigid fit needs at least 3 not on one line")]
    CalibrationTooFew {
        /// Markers given.
        markers: usize,
    },
    /// A tracker-to-robot fit from markers on one line: the rotation about it is free.
    #[error("marker calibration: the {markers} markers lie on one line (spread {:.3} mm off it, below {:.3} mm): the rotation about it is not determined", 1e3 * spread, 1e3 * min_spread)]
    CalibrationOnALine {
        /// Markers given.
        markers: usize,
        /// Their second principal spread (m).
        spread: f64,
        /// The least spread accepted (m).
        min_spread: f64,
    },
    /// The rigid fit failed on non-finite marker positions.
    #[error("marker calibration: the rigid fit failed (non-finite data)")]
    CalibrationNonFinite,
    /// A calibration file that does not parse as one.
    #[error("marker calibration: {path}: not a marker calibration: {source}")]
    NotACalibration {
        /// The file.
        path: String,
        /// The JSON error.
        source: serde_json::Error,
    },
    /// A layout of too few markers for the unknowns (Corollary 1: rows >= unknowns).
    #[error("{markers} markers give {} rows for {unknowns} force unknowns: Corollary 1 needs rows >= unknowns, so at least {} markers", 3 * markers, unknowns.div_ceil(3).max(1))]
    TooFewMarkers {
        /// Markers asked for.
        markers: usize,
        /// Force unknowns.
        unknowns: usize,
    },
    /// A layout pool smaller than the markers asked for.
    #[error("the pool has {pool} nodes for {markers} markers")]
    PoolTooSmall {
        /// Nodes in the pool.
        pool: usize,
        /// Markers asked for.
        markers: usize,
    },
    /// The FE model failed (a solve, a factorization).
    #[error(transparent)]
    Fem(#[from] crate::fem::FemError),
}

impl crate::io::InFile for MarkersError {
    fn names_file(&self) -> bool {
        matches!(
            self,
            MarkersError::File { .. }
                | MarkersError::InFile { .. }
                | MarkersError::Write(_)
                | MarkersError::Tracks(_)
        )
    }

    fn wrap_in_file(self, path: &std::path::Path) -> Self {
        MarkersError::InFile {
            path: path.display().to_string(),
            source: Box::new(self),
        }
    }
}

/// `Result` with [`MarkersError`].
pub type MarkersResult<T> = std::result::Result<T, MarkersError>;

/// Options of marker-based sensing.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkersParams {
    /// One-sigma noise of each tracked marker coordinate (m; default 1e-4, OptiTrack's 0.1 mm).
    pub sigma: f64,
    /// A marker farther than this from where it is expected is hidden: its last accepted
    /// position moved by its accepted neighbours' displacement ([`motion`]) (m; default
    /// 0.005; the thesis's 4.7.1 threshold, which it does not quantify).
    pub hidden_jump: f64,
    /// Largest distance from a marker to the surface when binding it (m; default 0.005).
    pub max_bind_distance: f64,
    /// Most FE updates per frame (default 10).
    pub max_updates: usize,
    /// Converged when every force update is below this (N; default 1e-5).
    pub force_tol: f64,
    /// Or when the markers' residual RMS changes by less than this fraction (default 1e-3).
    pub residual_tol: f64,
    /// A candidate is found only when its force magnitude exceeds this many σ (default 5).
    pub found_sigmas: f64,
    /// A candidate is found only above this fraction of the largest force magnitude (default 0.2).
    pub found_fraction: f64,
    /// Found candidates closer than this form one located force (m; default 0.03).
    pub group_radius: f64,
    /// A located force is moved to the surface node within this distance of its candidates
    /// where one force explains the markers best (m; default 0.03; 0 keeps the centre).
    pub refine_radius: f64,
}

impl Default for MarkersParams {
    fn default() -> Self {
        Self {
            sigma: 1e-4,
            hidden_jump: 0.005,
            max_bind_distance: 0.005,
            max_updates: 10,
            force_tol: 1e-5,
            residual_tol: 1e-3,
            found_sigmas: 5.0,
            found_fraction: 0.2,
            group_radius: 0.03,
            refine_radius: 0.03,
        }
    }
}
