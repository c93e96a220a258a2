//! The track files of marker-based sensing ([`crate::recording::tracks`], re-exported so
//! `markers::tracks` stays the one place a markers user looks) and the hidden-marker rule.

pub use crate::recording::tracks::{
    read_motive, read_motive_str, read_tracks, read_tracks_str, write_tracks, write_tracks_string,
    MarkerTracks, TrackFrame, TracksError,
};

use super::motion::MotionTracker;
use super::MarkersParams;

/// The hidden markers of each frame (frames x markers): missing, or more than
/// `params.hidden_jump` from where the marker is expected (thesis 4.7.1: a tracker that
/// swapped or lost a marker reports a point far from where the marker should be). The
/// expected position is the marker's last accepted position moved by the displacement of
/// its neighbours accepted in the same frame, closest first
/// ([`super::motion::MotionTracker`]): a marker that moves with the body under a large load
/// is kept, one that jumps off the body's motion is hidden. A marker's first visible
/// position is accepted as it is.
pub fn flag_hidden(tracks: &MarkerTracks, params: &MarkersParams) -> Vec<Vec<bool>> {
    let n = tracks.names.len();
    let mut tracker = MotionTracker::new(n);
    let mut out = Vec::with_capacity(tracks.frames.len());
    for f in &tracks.frames {
        let points: Vec<[f64; 3]> = f.positions.iter().map(|p| p.unwrap_or([0.0; 3])).collect();
        let matched =
            tracker.match_step(&points, |m| f.positions[m].map(|_| m), params.hidden_jump);
        let accepted: Vec<Option<[f64; 3]>> = (0..n)
            .map(|m| match (f.positions[m], tracker.last_position(m)) {
                (Some(p), None) => Some(p),
                (Some(p), Some(_)) if matched[m].is_some() => Some(p),
                _ => None,
            })
            .collect();
        tracker.record(&accepted);
        out.push(accepted.iter().map(Option::is_none).collect());
    }
    out
}
