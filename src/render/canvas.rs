//! The RGB8 raster and its drawing primitives.
//!
//! Pixel `(x, y)` has its centre at the integer coordinates `(x, y)` (column, row; y down),
//! the convention of the pinhole model `u = fx·x/z + cx` with `cx = (width − 1)/2`.
//! Shapes take `f64` coordinates and are anti-aliased by coverage: a pixel's alpha is
//! `clamp(half_width + 0.5 − distance, 0, 1)`. Every call clips to the canvas; coordinates
//! that are NaN or infinite draw nothing, huge finite ones are clipped, never looped over.

use super::font;
use super::RenderError;
use std::path::Path;

/// An sRGB colour, 8 bits per channel.
pub type Rgb = [u8; 3];

/// The largest canvas accepted, in pixels (guards allocations from untrusted sizes).
pub const MAX_PIXELS: u64 = 1 << 26;
/// The largest side accepted, in pixels.
pub const MAX_SIDE: u32 = 1 << 15;

/// Black.
pub const BLACK: Rgb = [0, 0, 0];
/// White.
pub const WHITE: Rgb = [255, 255, 255];
/// The grey used for missing values and hidden items.
pub const GREY: Rgb = [128, 128, 128];

/// An RGB8 image, row-major, top row first, with the boxes of the text drawn on it. Two
/// canvases are equal when their pixels are: the boxes are a record, not the picture.
#[derive(Clone, Debug)]
pub struct Canvas {
    width: u32,
    height: u32,
    pixels: Vec<Rgb>,
    text_boxes: Vec<TextBox>,
}

impl PartialEq for Canvas {
    fn eq(&self, other: &Self) -> bool {
        (self.width, self.height) == (other.width, other.height) && self.pixels == other.pixels
    }
}

impl Eq for Canvas {}

/// The box a piece of text covers (a label's includes its backing), in pixels: top-left
/// corner, width and height. Pictures are checked for overlapping text through these.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextBox {
    /// Left column.
    pub x: i64,
    /// Top row.
    pub y: i64,
    /// Width.
    pub width: i64,
    /// Height.
    pub height: i64,
}

impl TextBox {
    /// Whether the two boxes share a pixel.
    pub fn overlaps(&self, other: &TextBox) -> bool {
        self.x < other.x.saturating_add(other.width)
            && other.x < self.x.saturating_add(self.width)
            && self.y < other.y.saturating_add(other.height)
            && other.y < self.y.saturating_add(self.height)
    }

    /// The box moved by `(dx, dy)`.
    pub fn shifted(&self, dx: i64, dy: i64) -> TextBox {
        TextBox {
            x: self.x.saturating_add(dx),
            y: self.y.saturating_add(dy),
            ..*self
        }
    }
}

fn check_size(width: u32, height: u32) -> Result<usize, RenderError> {
    let n = u64::from(width) * u64::from(height);
    if width > MAX_SIDE || height > MAX_SIDE || n > MAX_PIXELS {
        return Err(RenderError::TooLarge { width, height });
    }
    Ok(n as usize)
}

impl Canvas {
    /// A `width` x `height` canvas filled with `background`; 0 x 0 is allowed (draws nothing).
    pub fn new(width: u32, height: u32, background: Rgb) -> Result<Self, RenderError> {
        let n = check_size(width, height)?;
        Ok(Canvas {
            width,
            height,
            pixels: vec![background; n],
            text_boxes: Vec::new(),
        })
    }

    /// Wraps row-major pixels; errors when their count is not `width * height`.
    pub fn from_rgb(width: u32, height: u32, pixels: Vec<Rgb>) -> Result<Self, RenderError> {
        let n = check_size(width, height)?;
        if pixels.len() != n {
            return Err(RenderError::Length {
                what: "pixels",
                expected: n,
                got: pixels.len(),
            });
        }
        Ok(Canvas {
            width,
            height,
            pixels,
            text_boxes: Vec::new(),
        })
    }

    /// Reads a PNG (any bit depth or colour type; converted to RGB8, alpha dropped).
    pub fn from_png(path: impl AsRef<Path>) -> Result<Self, RenderError> {
        let path = path.as_ref();
        let err = |message: String| RenderError::Image {
            path: path.display().to_string(),
            message,
        };
        let reader = image::ImageReader::open(path)
            .map_err(|e| err(e.to_string()))?
            .with_guessed_format()
            .map_err(|e| err(e.to_string()))?;
        let (w, h) = reader.into_dimensions().map_err(|e| err(e.to_string()))?;
        check_size(w, h)?;
        let img = image::ImageReader::open(path)
            .map_err(|e| err(e.to_string()))?
            .with_guessed_format()
            .map_err(|e| err(e.to_string()))?
            .decode()
            .map_err(|e| err(e.to_string()))?
            .to_rgb8();
        let (w, h) = img.dimensions();
        let pixels = img.pixels().map(|p| p.0).collect();
        Self::from_rgb(w, h, pixels)
    }

    /// Writes the canvas as an 8-bit RGB PNG. A 0-pixel canvas cannot be a PNG: error.
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<(), RenderError> {
        let path = path.as_ref();
        let err = |message: String| RenderError::Image {
            path: path.display().to_string(),
            message,
        };
        if self.pixels.is_empty() {
            return Err(err("an empty (0-pixel) canvas cannot be written".into()));
        }
        let bytes: Vec<u8> = self.pixels.iter().flatten().copied().collect();
        let img = image::RgbImage::from_raw(self.width, self.height, bytes)
            .ok_or_else(|| err("the canvas's pixels do not fill its size".into()))?;
        Ok(crate::io::atomic::write_png(
            path,
            &image::DynamicImage::ImageRgb8(img),
        )?)
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixels, row-major, top row first.
    pub fn pixels(&self) -> &[Rgb] {
        &self.pixels
    }

    /// The boxes of the text drawn so far, in drawing order (see [`TextBox`]).
    pub fn text_boxes(&self) -> &[TextBox] {
        &self.text_boxes
    }

    /// The pixels, consumed.
    pub fn into_pixels(self) -> Vec<Rgb> {
        self.pixels
    }

    fn index(&self, x: i64, y: i64) -> Option<usize> {
        (x >= 0 && y >= 0 && x < i64::from(self.width) && y < i64::from(self.height))
            .then(|| y as usize * self.width as usize + x as usize)
    }

    /// The colour at `(x, y)`, or `None` outside the canvas.
    pub fn get(&self, x: i64, y: i64) -> Option<Rgb> {
        self.index(x, y).map(|i| self.pixels[i])
    }

    /// Sets `(x, y)` to `rgb`; outside the canvas does nothing.
    pub fn set(&mut self, x: i64, y: i64, rgb: Rgb) {
        if let Some(i) = self.index(x, y) {
            self.pixels[i] = rgb;
        }
    }

    /// Mixes `rgb` over `(x, y)` with opacity `alpha` (clamped to 0..=1; NaN does nothing).
    pub fn blend(&mut self, x: i64, y: i64, rgb: Rgb, alpha: f64) {
        if alpha.is_nan() || alpha <= 0.0 {
            return;
        }
        let a = alpha.min(1.0);
        if let Some(i) = self.index(x, y) {
            let p = &mut self.pixels[i];
            for k in 0..3 {
                let v = f64::from(p[k]) * (1.0 - a) + f64::from(rgb[k]) * a;
                p[k] = v.round().clamp(0.0, 255.0) as u8;
            }
        }
    }

    /// Clamped integer pixel ranges `[lo, hi]` of columns and rows covering the box
    /// `[x0, x1] x [y0, y1]` (inclusive, f64), or `None` when it misses the canvas.
    fn clip_box(&self, x0: f64, x1: f64, y0: f64, y1: f64) -> Option<[i64; 4]> {
        if [x0, x1, y0, y1].iter().any(|v| v.is_nan()) || self.width == 0 || self.height == 0 {
            return None;
        }
        let w = f64::from(self.width - 1);
        let h = f64::from(self.height - 1);
        let (xa, xb) = (x0.ceil().max(0.0), x1.floor().min(w));
        let (ya, yb) = (y0.ceil().max(0.0), y1.floor().min(h));
        (xa <= xb && ya <= yb).then_some([xa as i64, xb as i64, ya as i64, yb as i64])
    }

    /// Fills the integer box with top-left `(x, y)`, `w` columns and `h` rows.
    pub fn fill_rect(&mut self, x: i64, y: i64, w: i64, h: i64, rgb: Rgb) {
        self.blend_rect(x, y, w, h, rgb, 1.0);
    }

    /// Mixes `rgb` with opacity `alpha` over the integer box (see [`Canvas::fill_rect`]).
    pub fn blend_rect(&mut self, x: i64, y: i64, w: i64, h: i64, rgb: Rgb, alpha: f64) {
        let x1 = x.saturating_add(w).saturating_sub(1);
        let y1 = y.saturating_add(h).saturating_sub(1);
        let Some([xa, xb, ya, yb]) = self.clip_box(x as f64, x1 as f64, y as f64, y1 as f64) else {
            return;
        };
        for yy in ya..=yb {
            for xx in xa..=xb {
                self.blend(xx, yy, rgb, alpha);
            }
        }
    }

    /// Outlines the integer box (see [`Canvas::fill_rect`]) with lines `thickness` pixels
    /// wide, drawn inside the box.
    pub fn rect(&mut self, x: i64, y: i64, w: i64, h: i64, rgb: Rgb, thickness: u32) {
        if w <= 0 || h <= 0 || thickness == 0 {
            return;
        }
        let t = i64::from(thickness).min(w).min(h);
        self.fill_rect(x, y, w, t, rgb);
        self.fill_rect(x, y.saturating_add(h - t), w, t, rgb);
        self.fill_rect(x, y, t, h, rgb);
        self.fill_rect(x.saturating_add(w - t), y, t, h, rgb);
    }

    /// An anti-aliased line `width` pixels wide with round caps; its end pixels get the
    /// full colour.
    pub fn line(&mut self, from: [f64; 2], to: [f64; 2], rgb: Rgb, width: f64) {
        if !(width > 0.0) || ![from, to].iter().flatten().all(|c| c.is_finite()) {
            return;
        }
        let hw = (width * 0.5).min(f64::from(MAX_SIDE));
        let reach = hw + 1.0;
        let margin = reach + 1.0;
        let lo = [-margin, -margin];
        let hi = [
            f64::from(self.width) + margin,
            f64::from(self.height) + margin,
        ];
        let Some((a, b)) = clip_segment(from, to, lo, hi) else {
            return;
        };
        let d = [b[0] - a[0], b[1] - a[1]];
        let Some([_, _, ya, yb]) = self.clip_box(
            f64::NEG_INFINITY,
            f64::INFINITY,
            a[1].min(b[1]) - reach,
            a[1].max(b[1]) + reach,
        ) else {
            return;
        };
        for y in ya..=yb {
            let yc = y as f64;
            // Parameters t where the segment is within `reach` rows of this one.
            let (t0, t1) = if d[1].abs() > 1e-12 {
                let p = (yc - reach - a[1]) / d[1];
                let q = (yc + reach - a[1]) / d[1];
                (p.min(q).max(0.0), p.max(q).min(1.0))
            } else if (a[1] - yc).abs() <= reach {
                (0.0, 1.0)
            } else {
                continue;
            };
            if t0 > t1 {
                continue;
            }
            let xa = a[0] + t0 * d[0];
            let xb = a[0] + t1 * d[0];
            let Some([x0, x1, _, _]) =
                self.clip_box(xa.min(xb) - reach, xa.max(xb) + reach, yc, yc)
            else {
                continue;
            };
            for x in x0..=x1 {
                let dist = segment_distance([x as f64, yc], a, b);
                self.blend(x, y, rgb, hw + 0.5 - dist);
            }
        }
    }

    /// A line from `from` to `to` ending in a filled triangular head at `to`. The head is
    /// `max(8, 4·width)` pixels long (at most 60% of the arrow); arrows shorter than a pixel
    /// draw a dot.
    pub fn arrow(&mut self, from: [f64; 2], to: [f64; 2], rgb: Rgb, width: f64) {
        if !(width > 0.0) || ![from, to].iter().flatten().all(|c| c.is_finite()) {
            return;
        }
        let d = [to[0] - from[0], to[1] - from[1]];
        let len = d[0].hypot(d[1]);
        if !len.is_finite() {
            // Too long to represent: clip first, the head is off-canvas anyway.
            self.line(from, to, rgb, width);
            return;
        }
        if len < 1.0 {
            self.disc(to, width.max(1.5), rgb);
            return;
        }
        let u = [d[0] / len, d[1] / len];
        let head = (4.0 * width).max(8.0).min(0.6 * len);
        let half = head * 0.45;
        let base = [to[0] - u[0] * head, to[1] - u[1] * head];
        self.line(from, [base[0] + u[0], base[1] + u[1]], rgb, width);
        let n = [-u[1], u[0]];
        self.fill_triangle(
            to,
            [base[0] + n[0] * half, base[1] + n[1] * half],
            [base[0] - n[0] * half, base[1] - n[1] * half],
            rgb,
        );
    }

    /// Fills a triangle (either winding), anti-aliased along its edges.
    pub fn fill_triangle(&mut self, a: [f64; 2], b: [f64; 2], c: [f64; 2], rgb: Rgb) {
        if ![a, b, c].iter().flatten().all(|v| v.is_finite()) {
            return;
        }
        let area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area2 == 0.0 || !area2.is_finite() {
            return;
        }
        let s = area2.signum();
        let xs = [a[0], b[0], c[0]];
        let ys = [a[1], b[1], c[1]];
        let min = |v: [f64; 3]| v[0].min(v[1]).min(v[2]);
        let max = |v: [f64; 3]| v[0].max(v[1]).max(v[2]);
        let Some([x0, x1, y0, y1]) =
            self.clip_box(min(xs) - 1.0, max(xs) + 1.0, min(ys) - 1.0, max(ys) + 1.0)
        else {
            return;
        };
        let edges = [(a, b), (b, c), (c, a)];
        for y in y0..=y1 {
            for x in x0..=x1 {
                let p = [x as f64, y as f64];
                // Signed distance to each edge line, positive inside.
                let inside = edges
                    .iter()
                    .map(|(p0, p1)| {
                        let e = [p1[0] - p0[0], p1[1] - p0[1]];
                        let l = e[0].hypot(e[1]);
                        s * (e[0] * (p[1] - p0[1]) - e[1] * (p[0] - p0[0])) / l
                    })
                    .fold(f64::INFINITY, f64::min);
                self.blend(x, y, rgb, inside + 0.5);
            }
        }
    }

    /// A filled, anti-aliased disc of `radius` pixels around `centre`.
    pub fn disc(&mut self, centre: [f64; 2], radius: f64, rgb: Rgb) {
        if radius >= 0.0 {
            self.radial(centre, radius, rgb, |d| radius + 0.5 - d);
        }
    }

    /// A circle outline of `radius` pixels, `width` pixels wide, anti-aliased.
    pub fn circle(&mut self, centre: [f64; 2], radius: f64, rgb: Rgb, width: f64) {
        if width > 0.0 && radius >= 0.0 {
            let hw = width * 0.5;
            self.radial(centre, radius + hw, rgb, |d| hw + 0.5 - (d - radius).abs());
        }
    }

    /// Blends `rgb` with alpha `coverage(distance to centre)` over the pixels within
    /// `extent + 1` of `centre`.
    fn radial(&mut self, centre: [f64; 2], extent: f64, rgb: Rgb, coverage: impl Fn(f64) -> f64) {
        if !(centre[0].is_finite() && centre[1].is_finite() && extent.is_finite()) {
            return;
        }
        let reach = extent + 1.0;
        let Some([x0, x1, y0, y1]) = self.clip_box(
            centre[0] - reach,
            centre[0] + reach,
            centre[1] - reach,
            centre[1] + reach,
        ) else {
            return;
        };
        for y in y0..=y1 {
            for x in x0..=x1 {
                let dist = (x as f64 - centre[0]).hypot(y as f64 - centre[1]);
                self.blend(x, y, rgb, coverage(dist));
            }
        }
    }

    /// A small "x" of half-size `size` pixels.
    pub fn cross(&mut self, centre: [f64; 2], size: f64, rgb: Rgb, width: f64) {
        let [x, y] = centre;
        self.line([x - size, y - size], [x + size, y + size], rgb, width);
        self.line([x - size, y + size], [x + size, y - size], rgb, width);
    }

    /// Draws `text` with its box's top-left corner at `(x, y)`, 12 pixels high at `scale`
    /// 1 and 5 more per step (scale 0 is taken as 1); `\n` starts a new line. The text covers
    /// exactly [`text_size`](super::text_size) pixels from `(x, y)`, and that box is
    /// recorded in [`Canvas::text_boxes`].
    pub fn text(&mut self, x: i64, y: i64, text: &str, rgb: Rgb, scale: u32) {
        self.text_px(x, y, text, rgb, font::px(scale), 0);
    }

    /// Draws `text` `size` pixels high, turned clockwise by `quarter_turns` quarter turns
    /// about its box's top-left corner, which lands at `(x, y)`: the box of a text turned
    /// by one or three quarters is as wide as the text is high. Returns that box, which is
    /// also recorded.
    pub(crate) fn text_px(
        &mut self,
        x: i64,
        y: i64,
        text: &str,
        rgb: Rgb,
        size: f32,
        quarter_turns: u8,
    ) -> TextBox {
        let (w, h) = font::text_size_px(text, size);
        let (w, h) = (i64::from(w), i64::from(h));
        let turns = quarter_turns % 4;
        font::rasterise(text, size, |gx, gy, cov| {
            let (px, py) = match turns {
                0 => (gx, gy),
                1 => (h - 1 - gy, gx),
                2 => (w - 1 - gx, h - 1 - gy),
                _ => (gy, w - 1 - gx),
            };
            self.blend(
                x.saturating_add(px),
                y.saturating_add(py),
                rgb,
                f64::from(cov),
            );
        });
        let (bw, bh) = if turns % 2 == 1 { (h, w) } else { (w, h) };
        let b = TextBox {
            x,
            y,
            width: bw,
            height: bh,
        };
        if bw > 0 && bh > 0 {
            self.text_boxes.push(b);
        }
        b
    }

    /// Text on a translucent box (`pad` pixels around it) so it reads over any picture;
    /// the recorded box is the backing's, padding included.
    pub fn label(&mut self, x: i64, y: i64, text: &str, fg: Rgb, bg: Rgb, scale: u32) {
        let (w, h) = font::text_size(text, scale);
        if w == 0 {
            return;
        }
        let pad = label_pad(scale);
        self.blend_rect(
            x.saturating_sub(pad),
            y.saturating_sub(pad),
            i64::from(w) + 2 * pad,
            i64::from(h) + 2 * pad,
            bg,
            0.8,
        );
        self.text(x, y, text, fg, scale);
        if let Some(b) = self.text_boxes.last_mut() {
            *b = TextBox {
                x: x.saturating_sub(pad),
                y: y.saturating_sub(pad),
                width: i64::from(w) + 2 * pad,
                height: i64::from(h) + 2 * pad,
            };
        }
    }

    /// Copies `other` onto this canvas with its top-left corner at `(x, y)`, clipped; its
    /// text boxes come along, moved.
    pub fn blit(&mut self, other: &Canvas, x: i64, y: i64) {
        self.text_boxes
            .extend(other.text_boxes.iter().map(|b| b.shifted(x, y)));
        for oy in 0..i64::from(other.height) {
            let ty = y.saturating_add(oy);
            if ty < 0 || ty >= i64::from(self.height) {
                continue;
            }
            for ox in 0..i64::from(other.width) {
                let tx = x.saturating_add(ox);
                if let Some(i) = other.index(ox, oy) {
                    self.set(tx, ty, other.pixels[i]);
                }
            }
        }
    }
}

/// The padding around a label's text at `scale`, in pixels.
pub(crate) fn label_pad(scale: u32) -> i64 {
    2 * i64::from(scale.clamp(1, 64))
}

/// Distance from `p` to the segment `a`-`b`.
fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * d[0]).hypot(p[1] - a[1] - t * d[1])
}

/// Liang-Barsky clip of the segment `a`-`b` to the box `[lo, hi]`; works in units of the
/// largest coordinate so that huge finite inputs do not overflow.
fn clip_segment(
    a: [f64; 2],
    b: [f64; 2],
    lo: [f64; 2],
    hi: [f64; 2],
) -> Option<([f64; 2], [f64; 2])> {
    let s = [a[0], a[1], b[0], b[1], lo[0], lo[1], hi[0], hi[1]]
        .iter()
        .fold(1.0f64, |m, v| m.max(v.abs()));
    let sc = |p: [f64; 2]| [p[0] / s, p[1] / s];
    let (a2, b2, lo2, hi2) = (sc(a), sc(b), sc(lo), sc(hi));
    let d = [b2[0] - a2[0], b2[1] - a2[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..2 {
        for (p, q) in [(-d[k], a2[k] - lo2[k]), (d[k], hi2[k] - a2[k])] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: f64| [(a2[0] + t * d[0]) * s, (a2[1] + t * d[1]) * s];
    // Keep the exact end points when they were not clipped.
    let p0 = if t0 == 0.0 { a } else { at(t0) };
    let p1 = if t1 == 1.0 { b } else { at(t1) };
    Some((p0, p1))
}
