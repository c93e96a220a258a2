//! A line chart: several x-y series on shared axes, shaded x ranges, a legend.

use super::canvas::{Canvas, Rgb, BLACK, GREY, WHITE};
use super::chart::{legend, Swatch};
use super::colormap::format_value;
use super::RenderError;

/// One series of a line chart.
#[derive(Debug, Clone)]
pub struct Series<'a> {
    /// Legend text.
    pub label: &'a str,
    /// Colour.
    pub color: Rgb,
    /// Points (x, y); non-finite ones break the line.
    pub points: Vec<[f64; 2]>,
}

/// A line chart, `width` x `height` pixels, with the axis titles, the ends of both axes
/// written, `shade` x ranges in light grey (e.g. steps without a measurement) and a legend.
/// An empty chart reads "(no data)".
pub fn line_chart(
    title: &str,
    axes: [&str; 2],
    series: &[Series],
    shade: &[[f64; 2]],
    width: u32,
    height: u32,
) -> Result<Canvas, RenderError> {
    let mut c = Canvas::new(width, height, WHITE)?;
    c.text(8, 6, title, BLACK, 2);
    let (w, h) = (f64::from(width), f64::from(height));
    let (left, right, top, bottom) = (64.0, w - 12.0, 30.0, h - 34.0);
    let finite = series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|p| p[0].is_finite() && p[1].is_finite());
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in finite {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if !(lo[0].is_finite() && right > left + 4.0 && bottom > top + 4.0) {
        c.text(8, 30, "(no data)", GREY, 1);
        return Ok(c);
    }
    for k in 0..2 {
        if hi[k] - lo[k] < 1e-12 * (1.0 + hi[k].abs()) {
            lo[k] -= 0.5;
            hi[k] += 0.5;
        }
    }
    let px = |x: f64| left + (x - lo[0]) / (hi[0] - lo[0]) * (right - left);
    let py = |y: f64| bottom - (y - lo[1]) / (hi[1] - lo[1]) * (bottom - top);
    for r in shade {
        let (a, b) = (px(r[0].max(lo[0])), px(r[1].min(hi[0])));
        if b > a {
            c.blend_rect(
                a as i64,
                top as i64,
                (b - a).ceil() as i64,
                (bottom - top) as i64,
                GREY,
                0.2,
            );
        }
    }
    c.line([left, bottom], [right, bottom], BLACK, 1.0);
    c.line([left, bottom], [left, top], BLACK, 1.0);
    c.text(
        left as i64,
        bottom as i64 + 6,
        &format_value(lo[0]),
        BLACK,
        1,
    );
    let xhi = format_value(hi[0]);
    c.text(
        right as i64 - 6 * xhi.len() as i64,
        bottom as i64 + 6,
        &xhi,
        BLACK,
        1,
    );
    c.text(
        (left + right) as i64 / 2 - 3 * axes[0].len() as i64,
        bottom as i64 + 18,
        axes[0],
        BLACK,
        1,
    );
    c.text(4, bottom as i64 - 4, &format_value(lo[1]), BLACK, 1);
    c.text(4, top as i64, &format_value(hi[1]), BLACK, 1);
    c.text(4, ((top + bottom) / 2.0) as i64, axes[1], BLACK, 1);
    for s in series {
        for pair in s.points.windows(2) {
            let ok = pair.iter().all(|p| p[0].is_finite() && p[1].is_finite());
            if ok {
                c.line(
                    [px(pair[0][0]), py(pair[0][1])],
                    [px(pair[1][0]), py(pair[1][1])],
                    s.color,
                    1.5,
                );
            }
        }
    }
    let entries: Vec<(Swatch, &str)> = series
        .iter()
        .map(|s| (Swatch::Line(s.color), s.label))
        .collect();
    legend(&mut c, right as i64 - 150, top as i64 + 4, &entries);
    Ok(c)
}
