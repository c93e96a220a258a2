//! The track files of marker-based sensing ([`crate::recording::tracks`], re-exported so
//! `markers::tracks` stays the one place a markers user looks) and the hidden-marker rule.

pub use crate::recording::tracks::{
    read_motive, read_motive_str, read_tracks, read_tracks_str, write_tracks, write_tracks_string,
    MarkerTracks, TrackFrame, TracksError,
};

use super::MarkersParams;

/// The hidden markers of each frame (frames x markers): missing, or moved more than
/// `params.hidden_jump` from the marker's last accepted position (thesis 4.7.1: a tracker
/// that swapped or lost a marker reports a point far from where the marker was). A
/// marker's first visible position is accepted as it is.
pub fn flag_hidden(tracks: &MarkerTracks, params: &MarkersParams) -> Vec<Vec<bool>> {
    let mut last: Vec<Option<[f64; 3]>> = vec![None; tracks.names.len()];
    let mut out = Vec::with_capacity(tracks.frames.len());
    for f in &tracks.frames {
        let flags = f
            .positions
            .iter()
            .zip(last.iter_mut())
            .map(|(p, l)| match (p, *l) {
                (None, _) => true,
                (Some(p), Some(q))
                    if crate::math::norm(crate::math::sub(*p, q)) > params.hidden_jump =>
                {
                    true
                }
                (Some(p), _) => {
                    *l = Some(*p);
                    false
                }
            })
            .collect();
        out.push(flags);
    }
    out
}
