//! Charts laid out by plotters (axes, ticks, captions, legends) and drawn on a [`Canvas`]
//! through plotters' backend trait, so they get the canvas's anti-aliased shapes, its
//! font and its record of text boxes.

use super::canvas::{Canvas, Rgb, TextBox, BLACK, GREY, WHITE};
use super::chart::{legend, legend_size, Swatch, BAR, BAR_HIGHLIGHT};
use super::colormap::format_value;
use super::font;
use super::RenderError;
use plotters::coord::ranged1d::SegmentValue;
use plotters::prelude::*;
use plotters_backend::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind, FontTransform,
};
use std::convert::Infallible;

/// A [`Canvas`] as a plotters drawing backend.
struct CanvasBackend<'a>(&'a mut Canvas);

type BackendResult = Result<(), DrawingErrorKind<Infallible>>;

fn rgb(c: &BackendColor) -> Rgb {
    [c.rgb.0, c.rgb.1, c.rgb.2]
}

fn point(p: BackendCoord) -> [f64; 2] {
    [f64::from(p.0), f64::from(p.1)]
}

impl DrawingBackend for CanvasBackend<'_> {
    type ErrorType = Infallible;

    fn get_size(&self) -> (u32, u32) {
        (self.0.width(), self.0.height())
    }

    fn ensure_prepared(&mut self) -> BackendResult {
        Ok(())
    }

    fn present(&mut self) -> BackendResult {
        Ok(())
    }

    fn draw_pixel(&mut self, p: BackendCoord, color: BackendColor) -> BackendResult {
        self.0
            .blend(i64::from(p.0), i64::from(p.1), rgb(&color), color.alpha);
        Ok(())
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> BackendResult {
        let c = style.color();
        if c.alpha > 0.0 {
            let width = f64::from(style.stroke_width().max(1));
            self.0.line(point(from), point(to), rgb(&c), width);
        }
        Ok(())
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> BackendResult {
        let c = style.color();
        let (x0, y0) = (i64::from(upper_left.0), i64::from(upper_left.1));
        let (w, h) = (
            i64::from(bottom_right.0) - x0 + 1,
            i64::from(bottom_right.1) - y0 + 1,
        );
        if fill {
            self.0.blend_rect(x0, y0, w, h, rgb(&c), c.alpha);
        } else if c.alpha > 0.0 {
            self.0
                .rect(x0, y0, w, h, rgb(&c), style.stroke_width().max(1));
        }
        Ok(())
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> BackendResult {
        let c = style.color();
        if fill {
            self.0.disc(point(center), f64::from(radius), rgb(&c));
        } else {
            let w = f64::from(style.stroke_width().max(1));
            self.0.circle(point(center), f64::from(radius), rgb(&c), w);
        }
        Ok(())
    }

    fn draw_text<T: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &T,
        pos: BackendCoord,
    ) -> BackendResult {
        let turns = match style.transform() {
            FontTransform::None => 0,
            FontTransform::Rotate90 => 1,
            FontTransform::Rotate180 => 2,
            FontTransform::Rotate270 => 3,
        };
        let size = style.size() as f32;
        let (w, h) = font::text_size_px(text, size);
        let (w, h) = if turns % 2 == 1 { (h, w) } else { (w, h) };
        let (w, h) = (i64::from(w), i64::from(h));
        let anchor = style.anchor();
        let x = i64::from(pos.0)
            - match anchor.h_pos {
                HPos::Left => 0,
                HPos::Center => w / 2,
                HPos::Right => w,
            };
        let y = i64::from(pos.1)
            - match anchor.v_pos {
                VPos::Top => 0,
                VPos::Center => h / 2,
                VPos::Bottom => h,
            };
        self.0.text_px(x, y, text, rgb(&style.color()), size, turns);
        Ok(())
    }

    fn estimate_text_size<T: BackendTextStyle>(
        &self,
        text: &str,
        style: &T,
    ) -> Result<(u32, u32), DrawingErrorKind<Infallible>> {
        Ok(font::text_size_px(text, style.size() as f32))
    }
}

fn colour(c: Rgb) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// Text sizes of the charts, in pixels.
const CAPTION_PX: f64 = 16.0;
const LABEL_PX: f64 = 12.0;

fn plot_error(e: impl std::fmt::Display) -> RenderError {
    RenderError::Plot(e.to_string())
}

/// Writes `message` under the title of a chart with nothing to plot.
fn no_data(c: &mut Canvas, title: &str, message: &str) {
    let b: TextBox = c.text_px(8, 6, title, BLACK, CAPTION_PX as f32, 0);
    c.text(8, 10 + b.height, message, GREY, 1);
}

/// A horizontal bar chart, `width` x `height` pixels: one row per label (the first on
/// top), bars from the zero line (so negative values point left), each value written
/// beside its bar, the value axis below. Row `highlight` is drawn in [`BAR_HIGHLIGHT`]
/// with a `*` before its label. NaN values get no bar and the text `NaN`; infinite ones
/// run to the plot edge and read `inf`. Errors when `labels` and `values` differ in
/// length or the size is too large; a canvas too small for the axes keeps its title only.
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
    if labels.is_empty() {
        no_data(&mut c, title, "(no data)");
        return Ok(c);
    }
    let finite = values.iter().copied().filter(|v| v.is_finite());
    // Halves keep the span finite for values near ±f64::MAX.
    let lo = finite.clone().fold(0.0f64, f64::min) * 0.5;
    let mut hi = finite.fold(0.0f64, f64::max) * 0.5;
    if hi == lo {
        hi = lo + 0.5;
    }
    let n = labels.len() as i32;
    let names: Vec<String> = labels
        .iter()
        .enumerate()
        .map(|(i, l)| format!("{}{l}", if highlight == Some(i) { "*" } else { "" }))
        .collect();
    let label_w = names
        .iter()
        .map(|l| font::text_size_px(l, LABEL_PX as f32).0)
        .max()
        .unwrap_or(0)
        .min(width * 2 / 5)
        + 10;
    let value_w = values
        .iter()
        .map(|v| font::text_size_px(&format_value(*v), LABEL_PX as f32).0)
        .max()
        .unwrap_or(0)
        + 12;
    let drawn = draw_bars(
        &mut c,
        title,
        &names,
        values,
        highlight,
        [lo, hi],
        [label_w, value_w],
        n,
    );
    if drawn.is_err() {
        // Too small for plotters' layout: the title alone says what it was.
        c = Canvas::new(width, height, WHITE)?;
        no_data(&mut c, title, "(too small)");
    }
    Ok(c)
}

/// The plotters part of [`bar_chart`]; `half_range` is the value range halved.
#[allow(clippy::too_many_arguments)]
fn draw_bars(
    c: &mut Canvas,
    title: &str,
    names: &[String],
    values: &[f64],
    highlight: Option<usize>,
    half_range: [f64; 2],
    [label_w, value_w]: [u32; 2],
    n: i32,
) -> Result<(), RenderError> {
    let root = CanvasBackend(c).into_drawing_area();
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", CAPTION_PX))
        .margin(6)
        .margin_right(value_w)
        .x_label_area_size(22)
        .y_label_area_size(label_w)
        .build_cartesian_2d(half_range[0]..half_range[1], (0..n - 1).into_segmented())
        .map_err(plot_error)?;
    let row_of = |k: usize| n - 1 - k as i32;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(5)
        .x_label_formatter(&|v| format_value(*v * 2.0))
        .y_labels(names.len())
        .y_label_formatter(&|v| match v {
            SegmentValue::CenterOf(r) if (0..n).contains(r) => names[(n - 1 - r) as usize].clone(),
            _ => String::new(),
        })
        .label_style(("sans-serif", LABEL_PX))
        .light_line_style(colour([235, 235, 235]))
        .draw()
        .map_err(plot_error)?;
    let [lo, hi] = half_range;
    let end = |v: f64| match v {
        v if v.is_nan() => 0.0,
        f64::INFINITY => hi,
        f64::NEG_INFINITY => lo,
        v => v * 0.5,
    };
    let bars = values.iter().enumerate().map(|(k, &v)| {
        let fill = if highlight == Some(k) {
            BAR_HIGHLIGHT
        } else {
            BAR
        };
        let r = row_of(k);
        let mut bar = Rectangle::new(
            [
                (0.0, SegmentValue::Exact(r)),
                (end(v), SegmentValue::Exact(r + 1)),
            ],
            colour(fill).filled(),
        );
        bar.set_margin(3, 3, 0, 0);
        bar
    });
    chart.draw_series(bars).map_err(plot_error)?;
    let zero = PathElement::new(
        vec![(0.0, SegmentValue::Exact(0)), (0.0, SegmentValue::Exact(n))],
        BLACK_LINE,
    );
    chart.draw_series([zero]).map_err(plot_error)?;
    let texts = values.iter().enumerate().map(|(k, &v)| {
        let at = if v < 0.0 { 0.0 } else { end(v) };
        let style = ("sans-serif", LABEL_PX)
            .into_font()
            .color(&colour(if v.is_nan() { GREY } else { BLACK }))
            .pos(Pos::new(HPos::Left, VPos::Center));
        Text::new(
            format!(" {}", format_value(v)),
            (at, SegmentValue::CenterOf(row_of(k))),
            style,
        )
    });
    chart.draw_series(texts).map_err(plot_error)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

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

impl Series<'_> {
    /// The runs of consecutive finite points that draw a line (two points or more).
    fn runs(&self) -> Vec<&[[f64; 2]]> {
        self.points
            .split(|p| !(p[0].is_finite() && p[1].is_finite()))
            .filter(|r| r.len() >= 2)
            .collect()
    }
}

/// A line chart, `width` x `height` pixels: the series on shared axes with their titles,
/// `shade` x ranges in light grey (e.g. steps without a measurement), and a legend of the
/// series that draw a line. An empty chart reads "(no data)".
pub fn line_chart(
    title: &str,
    axes: [&str; 2],
    series: &[Series],
    shade: &[[f64; 2]],
    width: u32,
    height: u32,
) -> Result<Canvas, RenderError> {
    let mut c = Canvas::new(width, height, WHITE)?;
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for s in series {
        for p in s.runs().into_iter().flatten() {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    if !lo[0].is_finite() {
        no_data(&mut c, title, "(no data)");
        return Ok(c);
    }
    for k in 0..2 {
        if hi[k] - lo[k] < 1e-12 * (1.0 + hi[k].abs()) {
            lo[k] -= 0.5;
            hi[k] += 0.5;
        }
    }
    match draw_lines(&mut c, title, axes, series, shade, [lo, hi]) {
        Ok([right, top]) => {
            // Our legend, not plotters': it sizes its box with our font's metrics.
            let entries: Vec<(Swatch, &str)> = (series.iter())
                .filter(|s| !s.label.is_empty() && !s.runs().is_empty())
                .map(|s| (Swatch::Line(s.color), s.label))
                .collect();
            let (bw, _) = legend_size(&entries);
            legend(&mut c, right - bw - 6, top + 6, &entries);
        }
        Err(_) => {
            c = Canvas::new(width, height, WHITE)?;
            no_data(&mut c, title, "(too small)");
        }
    }
    Ok(c)
}

/// The plotters part of [`line_chart`]; returns the plot area's top-right pixel.
fn draw_lines(
    c: &mut Canvas,
    title: &str,
    axes: [&str; 2],
    series: &[Series],
    shade: &[[f64; 2]],
    [lo, hi]: [[f64; 2]; 2],
) -> Result<[i64; 2], RenderError> {
    let root = CanvasBackend(c).into_drawing_area();
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", CAPTION_PX))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(lo[0]..hi[0], lo[1]..hi[1])
        .map_err(plot_error)?;
    chart
        .configure_mesh()
        .x_desc(axes[0])
        .y_desc(axes[1])
        .x_labels(6)
        .y_labels(6)
        .x_label_formatter(&|v| format_value(*v))
        .y_label_formatter(&|v| format_value(*v))
        .label_style(("sans-serif", LABEL_PX))
        .axis_desc_style(("sans-serif", LABEL_PX))
        .bold_line_style(colour([215, 215, 215]))
        .light_line_style(TRANSPARENT)
        .draw()
        .map_err(plot_error)?;
    let shaded = shade
        .iter()
        .map(|r| [r[0].max(lo[0]), r[1].min(hi[0])])
        .filter(|r| r[1] > r[0])
        .map(|r| {
            Rectangle::new(
                [(r[0], lo[1]), (r[1], hi[1])],
                colour(GREY).mix(0.2).filled(),
            )
        });
    chart.draw_series(shaded).map_err(plot_error)?;
    for s in series {
        let style = Color::stroke_width(&colour(s.color), 2);
        for run in s.runs() {
            let line = LineSeries::new(run.iter().map(|p| (p[0], p[1])), style);
            chart.draw_series(line).map_err(plot_error)?;
        }
    }
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    root.present().map_err(plot_error)?;
    Ok([xs.end, ys.start].map(i64::from))
}

/// The zero line of bar charts.
const BLACK_LINE: RGBColor = RGBColor(0, 0, 0);
