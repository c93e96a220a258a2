//! Text through a real font rasteriser: ab_glyph's outlines of Hack, an open-licence face
//! (MIT and Bitstream Vera licences) embedded by `epaint_default_fonts`.
//!
//! Hack is monospaced and made for 8-14 pixel text, the sizes of picture labels; it covers
//! Latin, Greek and the symbols labels need (`±µ°σχΔ≤≥→`). Text at `scale` k is
//! [`px`]`(k)` pixels high (ascent to descent). A line's box runs from the top of its
//! ascent to the bottom of its descent; glyph coverage outside the box is not drawn, so
//! the text covers exactly [`text_size`] pixels.

use ab_glyph::{Font, FontRef, GlyphId, PxScale, ScaleFont};
use std::sync::OnceLock;

/// The pixel height of text at scale 1.
pub const BASE_PX: f32 = 12.0;

/// Extra pixels between lines.
const LINE_GAP: f32 = 2.0;

/// The embedded face, parsed once.
fn face() -> Option<&'static FontRef<'static>> {
    static FACE: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    FACE.get_or_init(|| FontRef::try_from_slice(epaint_default_fonts::HACK_REGULAR).ok())
        .as_ref()
}

/// Pixels added per scale step above 1.
const STEP_PX: f32 = 5.0;

/// The pixel size of text at `scale`: [`BASE_PX`] at 1, 5 pixels more per step (0 is
/// taken as 1, more than 64 as 64). Steps, not multiples: a title at 2 is 17 pixels.
pub fn px(scale: u32) -> f32 {
    BASE_PX + STEP_PX * (scale.clamp(1, 64) - 1) as f32
}

/// Whether the face has a glyph for `c`; other characters are drawn as `?`.
pub fn has_glyph(c: char) -> bool {
    face().is_some_and(|f| f.glyph_id(c) != GlyphId(0))
}

/// The glyph drawn for `c`: its own, or `?`'s when the face has none.
fn glyph_of(font: &FontRef<'static>, c: char) -> GlyphId {
    match font.glyph_id(c) {
        GlyphId(0) => font.glyph_id('?'),
        id => id,
    }
}

/// Vertical metrics at `size` pixels: (ascent, line height, line advance), rounded up.
fn metrics(font: &FontRef<'static>, size: f32) -> (f32, u32, f32) {
    let sf = font.as_scaled(PxScale::from(size));
    let height = (sf.ascent() - sf.descent()).ceil();
    (sf.ascent(), height as u32, height + LINE_GAP)
}

/// The glyphs of one line at `size` pixels, each with its caret (x, pixels), kerning
/// included, and the line's width (rounded up).
fn layout(font: &FontRef<'static>, size: f32, line: &str) -> (Vec<(GlyphId, f32)>, u32) {
    let sf = font.as_scaled(PxScale::from(size));
    let mut caret = 0.0f32;
    let mut prev: Option<GlyphId> = None;
    let mut glyphs = Vec::with_capacity(line.len());
    for c in line.chars() {
        let id = glyph_of(font, c);
        if let Some(p) = prev {
            caret += sf.kern(p, id);
        }
        glyphs.push((id, caret));
        caret += sf.h_advance(id);
        prev = Some(id);
    }
    (glyphs, caret.ceil().max(0.0) as u32)
}

/// Size in pixels of `text` at `size` pixels high: the widest line by all lines, the gap
/// between lines included but none after the last. Empty text is 0 x 0.
pub fn text_size_px(text: &str, size: f32) -> (u32, u32) {
    let Some(font) = face() else {
        return (0, 0);
    };
    if text.is_empty() || !(size > 0.0) {
        return (0, 0);
    }
    let (_, height, advance) = metrics(font, size);
    let lines = text.split('\n').count() as u32;
    let widest = text
        .split('\n')
        .map(|l| layout(font, size, l).1)
        .max()
        .unwrap_or(0);
    let h = (lines - 1) as f32 * advance + height as f32;
    (widest, h.ceil() as u32)
}

/// Size in canvas pixels of `text` drawn at `scale`: the widest line by all lines, the gap
/// between lines included but none after the last. Empty text is 0 x 0.
pub fn text_size(text: &str, scale: u32) -> (u32, u32) {
    text_size_px(text, px(scale))
}

/// Calls `plot(x, y, coverage)` for every pixel that `text` covers, with its box's
/// top-left corner at (0, 0), `size` pixels high; pixels outside the box are skipped.
pub(crate) fn rasterise(text: &str, size: f32, mut plot: impl FnMut(i64, i64, f32)) {
    let Some(font) = face() else {
        return;
    };
    let (w, h) = text_size_px(text, size);
    let (ascent, _, advance) = metrics(font, size);
    for (row, line) in text.split('\n').enumerate() {
        let baseline = ascent + row as f32 * advance;
        for (id, caret) in layout(font, size, line).0 {
            let glyph = id.with_scale_and_position(size, ab_glyph::point(caret, baseline));
            let Some(outlined) = font.outline_glyph(glyph) else {
                continue;
            };
            let min = outlined.px_bounds().min;
            outlined.draw(|gx, gy, coverage| {
                let x = min.x as i64 + i64::from(gx);
                let y = min.y as i64 + i64::from(gy);
                if x >= 0 && y >= 0 && x < i64::from(w) && y < i64::from(h) {
                    plot(x, y, coverage);
                }
            });
        }
    }
}
