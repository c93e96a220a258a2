//! Colour maps (a sequential viridis-like one and a blue-white-red diverging one), the
//! colour bar that explains them, and number formatting for labels.

use super::canvas::{Canvas, Rgb, BLACK, GREY};
use super::font::text_size;

/// A map from a number in `[0, 1]` to a colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ColorMap {
    /// Dark purple → blue → green → yellow; luminance rises monotonically, so it reads in
    /// grey print and for colour-blind viewers. For magnitudes.
    #[default]
    Sequential,
    /// Blue → white → red, white at 0.5. For signed values such as residuals; use a range
    /// symmetric about zero ([`symmetric_range`]) so that white means zero.
    Diverging,
}

/// Control points of the sequential map (our own, chosen for monotone luminance).
const SEQUENTIAL: [Rgb; 6] = [
    [68, 1, 84],
    [65, 63, 134],
    [44, 113, 142],
    [33, 157, 137],
    [111, 204, 88],
    [250, 230, 35],
];

/// Control points of the diverging map.
const DIVERGING: [Rgb; 5] = [
    [40, 90, 170],
    [120, 170, 212],
    [246, 246, 246],
    [232, 140, 100],
    [175, 30, 45],
];

fn lerp_points(points: &[Rgb], t: f64) -> Rgb {
    let n = points.len() - 1;
    let x = t.clamp(0.0, 1.0) * n as f64;
    let i = (x.floor() as usize).min(n - 1);
    let f = x - i as f64;
    let (a, b) = (points[i], points[i + 1]);
    [0, 1, 2].map(|k| (f64::from(a[k]) * (1.0 - f) + f64::from(b[k]) * f).round() as u8)
}

impl ColorMap {
    /// The colour at `t` (clamped to `[0, 1]`); NaN gives [`GREY`].
    pub fn at(self, t: f64) -> Rgb {
        if t.is_nan() {
            return GREY;
        }
        match self {
            ColorMap::Sequential => lerp_points(&SEQUENTIAL, t),
            ColorMap::Diverging => lerp_points(&DIVERGING, t),
        }
    }

    /// The colour of `value` on the range `[lo, hi]` (clamped at the ends). NaN values give
    /// [`GREY`]; an empty or invalid range maps everything to the middle colour.
    pub fn map(self, value: f64, range: [f64; 2]) -> Rgb {
        if value.is_nan() {
            return GREY;
        }
        let [lo, hi] = range;
        let span = hi - lo;
        if !(span > 0.0 && span.is_finite()) {
            return self.at(0.5);
        }
        self.at((value - lo) / span)
    }
}

/// The smallest and largest finite values, or `None` when there are none.
pub fn finite_range(values: &[f64]) -> Option<[f64; 2]> {
    values
        .iter()
        .filter(|v| v.is_finite())
        .fold(None, |r: Option<[f64; 2]>, &v| match r {
            None => Some([v, v]),
            Some([lo, hi]) => Some([lo.min(v), hi.max(v)]),
        })
}

/// `[-m, m]` with `m` the largest finite magnitude (1 when there is none or it is 0), for
/// the diverging map.
pub fn symmetric_range(values: &[f64]) -> [f64; 2] {
    let m = values
        .iter()
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let m = if m > 0.0 { m } else { 1.0 };
    [-m, m]
}

/// A short label for a number: three significant digits, trailing zeros dropped,
/// scientific notation outside `[1e-3, 1e5)`, and `NaN`, `inf`, `-inf` spelled out.
pub fn format_value(v: f64) -> String {
    if v.is_nan() {
        return "NaN".into();
    }
    if v.is_infinite() {
        return if v > 0.0 { "inf".into() } else { "-inf".into() };
    }
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        return format!("{v:.2e}");
    }
    let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" {
        "0".into()
    } else {
        s
    }
}

/// Draws a vertical colour bar: the gradient in the box `[x, y, w, h]` (top-left corner,
/// width and height in pixels; top = `range[1]`, bottom = `range[0]`), framed, with the max, middle and min values
/// written to its right and `label` (units) above it. Needs about `w + 60` pixels of width
/// and 14 pixels above the box.
pub fn colorbar(canvas: &mut Canvas, bar: [i64; 4], map: ColorMap, range: [f64; 2], label: &str) {
    // Far beyond any canvas, and small enough that the sums below cannot overflow.
    let [x, y, w, h] = bar.map(|v| v.clamp(-(1 << 40), 1 << 40));
    if w <= 0 || h <= 1 {
        return;
    }
    // Only the rows on the canvas: the box may be huge.
    let first = y.saturating_neg().clamp(0, h);
    let last = i64::from(canvas.height()).saturating_sub(y).clamp(0, h);
    for row in first..last {
        let t = 1.0 - row as f64 / (h - 1) as f64;
        canvas.fill_rect(x, y.saturating_add(row), w, 1, map.at(t));
    }
    canvas.rect(x - 1, y - 1, w + 2, h + 2, BLACK, 1);
    let [lo, hi] = range;
    let tx = x.saturating_add(w).saturating_add(5);
    for (t, v) in [(0.0, hi), (0.5, 0.5 * (lo + hi)), (1.0, lo)] {
        let ty = y.saturating_add((t * (h - 1) as f64) as i64);
        canvas.fill_rect(x.saturating_add(w), ty, 3, 1, BLACK);
        canvas.text(tx, ty.saturating_sub(3), &format_value(v), BLACK, 1);
    }
    let (lw, _) = text_size(label, 1);
    canvas.text(
        x.saturating_add(w / 2 - i64::from(lw) / 2),
        y.saturating_sub(14),
        label,
        BLACK,
        1,
    );
}
