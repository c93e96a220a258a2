//! Legend boxes and the bar colours of the charts.

use super::canvas::{Canvas, Rgb, BLACK, GREY, WHITE};
use super::font::text_size;

/// Bar colour.
pub const BAR: Rgb = [70, 110, 170];
/// Colour of the highlighted bar (e.g. the chosen candidate).
pub const BAR_HIGHLIGHT: Rgb = [215, 95, 30];

/// The mark drawn before a legend entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Swatch {
    /// A filled square.
    Fill(Rgb),
    /// A filled disc.
    Disc(Rgb),
    /// A circle outline.
    Ring(Rgb),
    /// An "x".
    Cross(Rgb),
    /// A short line.
    Line(Rgb),
    /// A short arrow.
    Arrow(Rgb),
    /// An arrow this many pixels long: a length scale.
    Scale(Rgb, u16),
}

impl Swatch {
    /// The width of the swatch's column in a legend row, in pixels.
    fn width(&self) -> i64 {
        match *self {
            Swatch::Scale(_, len) => i64::from(len).max(12) + 8,
            _ => 20,
        }
    }
}

/// The row height of a legend, in pixels.
fn legend_row() -> i64 {
    i64::from(text_size("Ag", 1).1) + 3
}

/// The size of the box [`legend`] draws for `entries`, in pixels (0 x 0 when empty).
pub fn legend_size(entries: &[(Swatch, &str)]) -> (i64, i64) {
    if entries.is_empty() {
        return (0, 0);
    }
    let w = entries
        .iter()
        .map(|(s, t)| s.width() + i64::from(text_size(t, 1).0))
        .max()
        .unwrap_or(0);
    (w + 14, entries.len() as i64 * legend_row() + 8)
}

/// Draws a legend box with its top-left corner at `(x, y)`: one row per entry, a swatch
/// and its text, on translucent white with a thin frame. Returns the box size in pixels.
pub fn legend(canvas: &mut Canvas, x: i64, y: i64, entries: &[(Swatch, &str)]) -> (i64, i64) {
    if entries.is_empty() {
        return (0, 0);
    }
    // Far beyond any canvas, and small enough that the sums below cannot overflow.
    let (x, y) = (x.clamp(-(1 << 40), 1 << 40), y.clamp(-(1 << 40), 1 << 40));
    let row = legend_row();
    let (bw, bh) = legend_size(entries);
    canvas.blend_rect(x, y, bw, bh, WHITE, 0.85);
    canvas.rect(x, y, bw, bh, GREY, 1);
    for (i, (swatch, text)) in entries.iter().enumerate() {
        let cy = y + 4 + i as i64 * row + row / 2;
        let (sx, syf) = (x as f64 + 13.0, cy as f64);
        match *swatch {
            Swatch::Fill(c) => canvas.fill_rect(x + 7, cy - 5, 12, 11, c),
            Swatch::Disc(c) => {
                canvas.disc([sx, syf], 5.0, BLACK);
                canvas.disc([sx, syf], 4.0, c);
            }
            Swatch::Ring(c) => canvas.circle([sx, syf], 5.0, c, 2.0),
            Swatch::Cross(c) => {
                canvas.cross([sx, syf], 4.0, BLACK, 3.5);
                canvas.cross([sx, syf], 4.0, c, 1.5);
            }
            Swatch::Line(c) => canvas.line([sx - 7.0, syf], [sx + 7.0, syf], c, 2.0),
            Swatch::Arrow(c) => canvas.arrow([sx - 8.0, syf], [sx + 8.0, syf], c, 2.0),
            Swatch::Scale(c, len) => {
                let x0 = x as f64 + 6.0;
                canvas.arrow([x0, syf], [x0 + f64::from(len), syf], c, 2.0);
            }
        }
        let th = i64::from(text_size(text, 1).1);
        canvas.text(x + 6 + swatch.width(), cy - th / 2, text, BLACK, 1);
    }
    (bw, bh)
}
