//! A horizontal bar chart and a legend box.

use super::canvas::{Canvas, Rgb, BLACK, GREY, WHITE};
use super::colormap::format_value;
use super::font::text_size;
use super::RenderError;

/// Bar colour.
pub const BAR: Rgb = [70, 110, 170];
/// Colour of the highlighted bar (e.g. the chosen candidate).
pub const BAR_HIGHLIGHT: Rgb = [215, 95, 30];

/// A horizontal bar chart, `width` x `height` pixels: one row per label, bars from the zero
/// line (so negative values point left), each value written beside its bar, the value
/// axis with its ends and 0 below. Row `highlight` is drawn in [`BAR_HIGHLIGHT`] with a
/// `*` before its label. NaN values get no bar and the text `NaN`; infinite values run to
/// the plot edge and read `inf`. Errors when `labels` and `values` differ in length or
/// the size is too large.
pub fn bar_chart(
    title: &str,
    labels: &[&str],
    values: &[f64],
    highlight: Option<usize>,
    width: u32,
    height: u32,
) -> Result<Canvas, RenderError> {
    if labels.len() != values.len() {
        return Err(RenderError::Length {
            what: "bar chart values (one per label)",
            expected: labels.len(),
            got: values.len(),
        });
    }
    let mut c = Canvas::new(width, height, WHITE)?;
    let (w, h) = (i64::from(width), i64::from(height));
    let title_scale = if text_size(title, 2).0 as i64 + 16 <= w {
        2
    } else {
        1
    };
    c.text(8, 6, title, BLACK, title_scale);
    let top = 12 + 9 * i64::from(title_scale);
    let bottom = h - 22;
    let n = labels.len() as i64;
    if n == 0 {
        c.text(8, top + 4, "(no data)", GREY, 1);
        return Ok(c);
    }
    // Label column: the widest label, at most 40% of the width.
    let max_label = (w * 2 / 5).max(12);
    let label_w = labels
        .iter()
        .map(|l| i64::from(text_size(l, 1).0) + 8)
        .max()
        .unwrap_or(0)
        .min(max_label);
    let left = 8 + label_w + 6;
    let right = w - 56;
    if right <= left + 4 || bottom <= top + 2 {
        return Ok(c);
    }
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let lo = finite.iter().copied().fold(0.0f64, f64::min);
    let mut hi = finite.iter().copied().fold(0.0f64, f64::max);
    if hi == lo {
        hi = lo + 1.0;
    }
    let bars = Bars {
        left,
        right,
        top,
        bottom,
        lo,
        hi,
        label_w,
        row_h: ((bottom - top) / n).max(1),
    };
    for (i, (label, &v)) in labels.iter().zip(values).enumerate() {
        bars.draw_bar(&mut c, i, label, v, highlight == Some(i));
    }
    bars.draw_axis(&mut c, w);
    Ok(c)
}

/// The plot area of a [`bar_chart`] (pixels) and its value range.
struct Bars {
    left: i64,
    right: i64,
    top: i64,
    bottom: i64,
    lo: f64,
    hi: f64,
    label_w: i64,
    row_h: i64,
}

impl Bars {
    /// The x pixel of value `v`. Halves keep the span finite for values near ±f64::MAX.
    fn to_x(&self, v: f64) -> i64 {
        let (lo, hi) = (self.lo, self.hi);
        let t = ((v * 0.5 - lo * 0.5) / (hi * 0.5 - lo * 0.5)).clamp(0.0, 1.0);
        self.left + (t * (self.right - self.left) as f64).round() as i64
    }

    /// Row `i`: its label (`*` and highlighted when `hl`), its bar from zero, its value.
    fn draw_bar(&self, c: &mut Canvas, i: usize, label: &str, v: f64, hl: bool) {
        let (left, right) = (self.left, self.right);
        let zero = self.to_x(0.0);
        let bar_h = (self.row_h * 7 / 10).max(1);
        let y = self.top + i as i64 * self.row_h;
        let mid = y + self.row_h / 2;
        let colour = if hl { BAR_HIGHLIGHT } else { BAR };
        let text = fit_text(
            &format!("{}{label}", if hl { "*" } else { "" }),
            self.label_w - 8,
        );
        let tw = i64::from(text_size(&text, 1).0);
        c.text(
            left - 6 - tw,
            mid - 3,
            &text,
            if hl { BAR_HIGHLIGHT } else { BLACK },
            1,
        );
        let end = if v.is_nan() {
            zero
        } else if v == f64::INFINITY {
            right
        } else if v == f64::NEG_INFINITY {
            left
        } else {
            self.to_x(v)
        };
        let (a, b) = (zero.min(end), zero.max(end));
        c.fill_rect(a, mid - bar_h / 2, (b - a).max(1), bar_h, colour);
        let value_text = format_value(v);
        let vx = if v >= 0.0 || v.is_nan() {
            b + 4
        } else {
            zero + 4
        };
        c.text(
            vx,
            mid - 3,
            &value_text,
            if v.is_nan() { GREY } else { BLACK },
            1,
        );
    }

    /// The zero line and the value axis with its ticks (`w`: the canvas width).
    fn draw_axis(&self, c: &mut Canvas, w: i64) {
        let (left, right, top, bottom) = (self.left, self.right, self.top, self.bottom);
        let zero = self.to_x(0.0);
        c.fill_rect(zero, top - 2, 1, bottom - top + 4, BLACK);
        c.fill_rect(left, bottom + 2, right - left + 1, 1, BLACK);
        let mut ticks = vec![(left, self.lo), (right, self.hi)];
        if zero - left > 30 && right - zero > 30 {
            ticks.push((zero, 0.0));
        }
        for (x, v) in ticks {
            c.fill_rect(x, bottom + 2, 1, 4, BLACK);
            let t = format_value(v);
            let tw = i64::from(text_size(&t, 1).0);
            c.text(
                (x - tw / 2).clamp(0, (w - tw).max(0)),
                bottom + 9,
                &t,
                BLACK,
                1,
            );
        }
    }
}

/// `text` shortened with a trailing `..` so that it is at most `max_w` pixels wide at
/// scale 1.
pub(crate) fn fit_text(text: &str, max_w: i64) -> String {
    if i64::from(text_size(text, 1).0) <= max_w {
        return text.to_string();
    }
    let keep = ((max_w + 1) / 6 - 2).max(0) as usize;
    let mut s: String = text.chars().take(keep).collect();
    s.push_str("..");
    s
}

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
}

/// Draws a legend box with its top-left corner at `(x, y)`: one row per entry, a swatch
/// and its text, on translucent white with a thin frame. Returns the box size in pixels.
pub fn legend(canvas: &mut Canvas, x: i64, y: i64, entries: &[(Swatch, &str)]) -> (i64, i64) {
    if entries.is_empty() {
        return (0, 0);
    }
    // Far beyond any canvas, and small enough that the sums below cannot overflow.
    let (x, y) = (x.clamp(-(1 << 40), 1 << 40), y.clamp(-(1 << 40), 1 << 40));
    let row = 15i64;
    let text_w = entries
        .iter()
        .map(|(_, t)| i64::from(text_size(t, 1).0))
        .max()
        .unwrap_or(0);
    let (bw, bh) = (text_w + 34, entries.len() as i64 * row + 8);
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
        }
        canvas.text(x + 26, cy - 3, text, BLACK, 1);
    }
    (bw, bh)
}
