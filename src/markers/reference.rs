//! The markers' reference: where each marker is bound, from the first frames of its
//! tracks, which must show the body unloaded ([`reference_positions`]). A loaded frame
//! averaged in would move every later force by its own (thesis 4.7.2 binds the effectors at
//! the markers' rest positions), so the reference frames are checked against each other.

use super::tracks::{flag_hidden, MarkerTracks};
use super::{MarkersError, MarkersParams, MarkersResult};
use crate::math::{norm, sub};

/// A reference frame whose markers moved more than this many times what the noise
/// explains, RMS from their first reference position, is taken as loaded. Two frames of
/// noise σ differ by √6 σ RMS per marker; twice that is far beyond the noise for a few
/// markers (for 4 markers the chance is about 1e-10) and well below a load that moves
/// them by a millimetre.
pub const LOADED_RATIO: f64 = 2.0;

/// Where each marker is bound (m, the tracks' frame) and how many frames that averages.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    /// Each marker's bound position, in [`MarkerTracks::names`] order.
    pub positions: Vec<[f64; 3]>,
    /// How many frames each position averages (1 for a marker not seen in the reference
    /// frames, bound at its first position).
    pub counts: Vec<usize>,
}

/// Each marker's reference position: the mean of its entries in the first `frames` frames,
/// those the hidden-marker rule accepts ([`flag_hidden`]), else its first visible entry.
///
/// More frames than the tracks have is [`MarkersError::ReferenceFramesTooMany`]; a frame
/// among them whose markers moved more than [`LOADED_RATIO`] times what `params.sigma`
/// explains from their first position is [`MarkersError::ReferenceFrameLoaded`], naming it;
/// a marker never visible is [`MarkersError::MarkerNeverVisible`].
pub fn reference_positions(
    tracks: &MarkerTracks,
    frames: usize,
    params: &MarkersParams,
) -> MarkersResult<Reference> {
    let hidden = check_reference_frames(tracks, frames, params)?;
    let accepted = |k: usize, m: usize| tracks.frames[k].positions[m].filter(|_| !hidden[k][m]);
    let mut positions = Vec::with_capacity(tracks.names.len());
    let mut counts = Vec::with_capacity(tracks.names.len());
    for (m, name) in tracks.names.iter().enumerate() {
        let seen: Vec<[f64; 3]> = (0..frames).filter_map(|k| accepted(k, m)).collect();
        if seen.is_empty() {
            let first = (tracks.frames.iter()).find_map(|f| f.positions[m]);
            positions.push(
                first.ok_or_else(|| MarkersError::MarkerNeverVisible { name: name.clone() })?,
            );
            counts.push(1);
            continue;
        }
        let n = seen.len() as f64;
        positions.push([0, 1, 2].map(|a| seen.iter().map(|p| p[a]).sum::<f64>() / n));
        counts.push(seen.len());
    }
    Ok(Reference { positions, counts })
}

/// Checks that the first `frames` frames can be the reference, as [`reference_positions`]
/// does, and returns the hidden-marker flags ([`flag_hidden`]) it read them with.
pub fn check_reference_frames(
    tracks: &MarkerTracks,
    frames: usize,
    params: &MarkersParams,
) -> MarkersResult<Vec<Vec<bool>>> {
    if frames == 0 || frames > tracks.frames.len() {
        return Err(MarkersError::ReferenceFramesTooMany {
            asked: frames,
            frames: tracks.frames.len(),
        });
    }
    let hidden = flag_hidden(tracks, params);
    let accepted = |k: usize, m: usize| tracks.frames[k].positions[m].filter(|_| !hidden[k][m]);
    check_unloaded(tracks, frames, params, &accepted)?;
    Ok(hidden)
}

/// Refuses the first of the `frames` reference frames whose markers (`accepted(frame,
/// marker)`) moved from their first reference position by more than noise explains.
fn check_unloaded(
    tracks: &MarkerTracks,
    frames: usize,
    params: &MarkersParams,
    accepted: &dyn Fn(usize, usize) -> Option<[f64; 3]>,
) -> MarkersResult<()> {
    let markers = tracks.names.len();
    let mut first: Vec<Option<[f64; 3]>> = (0..markers).map(|m| accepted(0, m)).collect();
    let expected = 6f64.sqrt() * params.sigma;
    for k in 1..frames {
        let (mut sum, mut n) = (0.0, 0usize);
        for (m, at) in first.iter_mut().enumerate() {
            match (*at, accepted(k, m)) {
                (Some(a), Some(p)) => {
                    sum += norm(sub(p, a)).powi(2);
                    n += 1;
                }
                (None, p) => *at = p,
                (Some(_), None) => {}
            }
        }
        let moved = (sum / n.max(1) as f64).sqrt();
        if n > 0 && (moved.is_nan() || moved > LOADED_RATIO * expected) {
            return Err(MarkersError::ReferenceFrameLoaded {
                frame: tracks.frames[k].frame,
                index: k,
                asked: frames,
                moved,
                expected,
            });
        }
    }
    Ok(())
}
