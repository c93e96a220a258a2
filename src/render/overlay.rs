//! What `sense` saw, drawn over the colour frame: robot segment, registered feature
//! points, contacts and force arrows; and panels side by side for before/after pictures.

use super::canvas::{label_pad, Canvas, Rgb, TextBox, BLACK, WHITE};
use super::chart::{legend, legend_size, Swatch};
use super::colormap::format_value;
use super::font::text_size;
use super::project::{project_with, Pose};
use super::RenderError;
use crate::camera::PinholeIntrinsics;

/// Tint of robot-segment pixels.
pub const ROBOT_TINT: Rgb = [0, 190, 255];
/// Visible (registered) feature points.
pub const FEATURE_VISIBLE: Rgb = [255, 215, 0];
/// The line from a feature point to its matched measurement point.
pub const MATCH_LINE: Rgb = [20, 60, 230];
/// Hidden feature points (drawn with a black outline).
pub const FEATURE_HIDDEN: Rgb = [255, 255, 255];
/// Contact rings and labels.
pub const CONTACT: Rgb = [230, 40, 200];
/// Force arrows.
pub const FORCE: Rgb = [235, 35, 35];

/// A feature point of the FE surface as seen in the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeatureMark {
    /// The feature point's pixel.
    pub pixel: [f64; 2],
    /// Whether registration found a measurement for it.
    pub visible: bool,
    /// The matched measurement point's pixel, when visible.
    pub matched: Option<[f64; 2]>,
}

/// A detected contact.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactMark {
    /// The contact's pixel.
    pub pixel: [f64; 2],
    /// Text written beside it (e.g. "c1 node 412").
    pub label: String,
}

/// An estimated force, drawn as an arrow from its point of application.
#[derive(Clone, Debug, PartialEq)]
pub struct ForceArrow {
    /// Point of application in the camera frame (m).
    pub start_in_camera: [f64; 3],
    /// Force vector in the camera frame (N).
    pub force_in_camera: [f64; 3],
    /// Text at the arrow head; `None` writes the magnitude, e.g. "0.66 N".
    pub label: Option<String>,
}

impl ForceArrow {
    /// An arrow from a force given in the robot frame (as the inverse model reports it),
    /// moved into the camera frame by `camera_from_robot`.
    pub fn from_robot(
        camera_from_robot: &Pose,
        start_in_robot: [f64; 3],
        force_in_robot: [f64; 3],
        label: Option<String>,
    ) -> Self {
        ForceArrow {
            start_in_camera: camera_from_robot.apply(start_in_robot),
            force_in_camera: camera_from_robot.rotate(force_in_robot),
            label,
        }
    }
}

/// Everything drawn over one frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct SenseOverlay<'a> {
    /// Title written in the top-left corner.
    pub title: &'a str,
    /// One flag per pixel (row-major), true on the robot segment; tinted when given.
    pub robot_mask: Option<&'a [bool]>,
    /// Feature points.
    pub features: &'a [FeatureMark],
    /// Contacts.
    pub contacts: &'a [ContactMark],
    /// Force arrows.
    pub forces: &'a [ForceArrow],
}

/// How [`sense_overlay`] draws.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OverlayParams {
    /// The colour camera's pinhole model, to project force arrows.
    pub intrinsics: PinholeIntrinsics,
    /// Arrow length per newton (m/N), in the camera frame before projection; `None` picks
    /// it so that the longest arrow, seen parallel to the image, spans `arrow_fraction`.
    pub metres_per_newton: Option<f64>,
    /// The longest arrow's length as a fraction of the frame's shorter side, when
    /// `metres_per_newton` is `None` (default 0.18).
    pub arrow_fraction: f64,
    /// How much the frame is faded towards white (0 none, 1 white) so marks stand out.
    pub fade: f64,
    /// Opacity of the robot tint.
    pub mask_alpha: f64,
    /// Draw a legend of what is drawn, with the arrows' length scale, in the bottom-left
    /// corner.
    pub legend: bool,
}

impl Default for OverlayParams {
    fn default() -> Self {
        OverlayParams {
            intrinsics: PinholeIntrinsics::default(),
            metres_per_newton: None,
            arrow_fraction: 0.18,
            fade: 0.3,
            mask_alpha: 0.35,
            legend: true,
        }
    }
}

/// A robot mask for [`SenseOverlay::robot_mask`] from pixel indices (`row * width + col`,
/// e.g. the indices of an organized cloud's robot segment); indices outside the image are
/// ignored.
pub fn mask_from_indices(width: u32, height: u32, indices: &[usize]) -> Vec<bool> {
    let n = (width as usize).saturating_mul(height as usize);
    let mut mask = vec![false; n];
    for &i in indices {
        if let Some(m) = mask.get_mut(i) {
            *m = true;
        }
    }
    mask
}

/// Draws `overlay` on a copy of `frame`. Errors when the mask length is not the frame's
/// pixel count. Marks outside the frame are clipped; a force whose start is behind the
/// camera is skipped, one whose tip would be is shortened to stay in front. No two texts
/// overlap: labels avoid the title, the legend and each other, and a label with no free
/// spot in the frame is written in a band added below it.
pub fn sense_overlay(
    frame: &Canvas,
    overlay: &SenseOverlay<'_>,
    params: &OverlayParams,
) -> Result<Canvas, RenderError> {
    let mut c = frame.clone();
    let (w, h) = (i64::from(c.width()), i64::from(c.height()));
    let mut drawn = Drawn::default();
    if let Some(mask) = overlay.robot_mask {
        let n = c.pixels().len();
        if mask.len() != n {
            return Err(RenderError::Length {
                what: "robot mask (one flag per pixel)",
                expected: n,
                got: mask.len(),
            });
        }
    }
    c.blend_rect(0, 0, w, h, WHITE, params.fade);
    if let Some(mask) = overlay.robot_mask {
        for (i, _) in mask.iter().enumerate().filter(|&(_, &m)| m) {
            let (x, y) = (i as i64 % w.max(1), i as i64 / w.max(1));
            c.blend(x, y, ROBOT_TINT, params.mask_alpha);
            drawn.robot = true;
        }
    }
    draw_features(&mut c, overlay.features, &mut drawn);
    // Labels are placed after every mark, so no mark hides one.
    let mut labels: Vec<PendingLabel> = Vec::new();
    for ct in overlay.contacts {
        c.circle(ct.pixel, 10.0, WHITE, 4.0);
        c.circle(ct.pixel, 10.0, CONTACT, 2.0);
        drawn.contact |= near_canvas(&c, ct.pixel, 12.0);
        if ct.pixel.iter().all(|v| v.is_finite()) {
            labels.push(PendingLabel {
                x: ct.pixel[0].clamp(-1e9, 1e9) as i64 + 13,
                y: ct.pixel[1].clamp(-1e9, 1e9) as i64 - 30,
                text: ct.label.clone(),
                colour: CONTACT,
            });
        }
    }
    let scale = arrow_scale(overlay.forces, params, &c);
    if let Some(scale) = &scale {
        for f in overlay.forces {
            if let Some((l, start)) = draw_force(&mut c, f, params, scale.metres_per_newton) {
                drawn.force |= near_canvas(&c, start, 4.0);
                labels.push(l);
            }
        }
    }
    let mut placer = LabelPlacer::default();
    if !overlay.title.is_empty() {
        let size = if i64::from(text_size(overlay.title, 2).0) + 12 <= w {
            2
        } else {
            1
        };
        c.label(6, 6, overlay.title, BLACK, WHITE, size);
        if let Some(b) = c.text_boxes().last() {
            placer.block(*b);
        }
    }
    if params.legend {
        let entries = drawn.legend(scale.as_ref().filter(|_| drawn.force));
        let refs: Vec<(Swatch, &str)> = entries.iter().map(|(s, t)| (*s, t.as_str())).collect();
        let (bw, bh) = legend_size(&refs);
        let b = TextBox {
            x: 6,
            y: h - bh - 6,
            width: bw,
            height: bh,
        };
        // A frame too small for both keeps the title.
        if !refs.is_empty() && !placer.placed.iter().any(|p| p.overlaps(&b)) {
            legend(&mut c, b.x, b.y, &refs);
            placer.block(b);
        }
    }
    let mut overflow: Vec<&PendingLabel> = Vec::new();
    for l in &labels {
        if placer
            .place(&mut c, l.x, l.y, &l.text, l.colour, 2)
            .is_none()
        {
            overflow.push(l);
        }
    }
    with_overflow_band(c, &overflow)
}

/// What [`sense_overlay`] drew, for a legend of only that.
#[derive(Default)]
struct Drawn {
    robot: bool,
    registered: bool,
    hidden: bool,
    matched: bool,
    contact: bool,
    force: bool,
}

impl Drawn {
    /// The legend entries, the arrows' length scale last.
    fn legend(&self, scale: Option<&ArrowScale>) -> Vec<(Swatch, String)> {
        let mut out = Vec::new();
        let mut add = |on: bool, s: Swatch, t: &str| {
            if on {
                out.push((s, t.to_string()));
            }
        };
        add(self.robot, Swatch::Fill(ROBOT_TINT), "robot segment");
        add(
            self.registered,
            Swatch::Disc(FEATURE_VISIBLE),
            "feature, registered",
        );
        add(
            self.hidden,
            Swatch::Cross(FEATURE_HIDDEN),
            "feature, hidden",
        );
        add(self.matched, Swatch::Line(MATCH_LINE), "match");
        add(self.contact, Swatch::Ring(CONTACT), "contact");
        add(self.force, Swatch::Arrow(FORCE), "force");
        if let Some(s) = scale {
            let text = format!(
                "{} N parallel to the image at {} m",
                format_value(s.bar_newtons),
                format_value(s.depth)
            );
            out.push((Swatch::Scale(FORCE, s.bar_px.round() as u16), text));
        }
        out
    }
}

/// Whether `p` is within `margin` pixels of the canvas.
fn near_canvas(c: &Canvas, p: [f64; 2], margin: f64) -> bool {
    p[0] >= -margin
        && p[1] >= -margin
        && p[0] <= f64::from(c.width()) + margin
        && p[1] <= f64::from(c.height()) + margin
}

/// The feature points: hidden ones first, so registered ones stay on top.
fn draw_features(c: &mut Canvas, features: &[FeatureMark], drawn: &mut Drawn) {
    for f in features.iter().filter(|f| !f.visible) {
        c.cross(f.pixel, 3.5, BLACK, 3.5);
        c.cross(f.pixel, 3.5, FEATURE_HIDDEN, 1.5);
        drawn.hidden |= near_canvas(c, f.pixel, 4.0);
    }
    for f in features.iter().filter(|f| f.visible) {
        if let Some(m) = f.matched {
            // A match shorter than the disc's radius is hidden under it: not drawn.
            if (m[0] - f.pixel[0]).hypot(m[1] - f.pixel[1]) > 4.5 {
                c.line(f.pixel, m, MATCH_LINE, 1.5);
                c.disc(m, 1.8, BLACK);
                drawn.matched |= near_canvas(c, m, 2.0);
            }
        }
        c.disc(f.pixel, 4.0, BLACK);
        c.disc(f.pixel, 3.0, FEATURE_VISIBLE);
        drawn.registered |= near_canvas(c, f.pixel, 4.0);
    }
}

/// `c` with `overflow`'s labels written one per row in a band below it.
fn with_overflow_band(c: Canvas, overflow: &[&PendingLabel]) -> Result<Canvas, RenderError> {
    if overflow.is_empty() {
        return Ok(c);
    }
    let rows: Vec<i64> = overflow
        .iter()
        .map(|l| i64::from(text_size(&l.text, 1).1) + 4)
        .collect();
    let band = rows.iter().sum::<i64>() + 8;
    let mut out = Canvas::new(c.width(), c.height().saturating_add(band as u32), WHITE)?;
    out.blit(&c, 0, 0);
    let mut y = i64::from(c.height()) + 4;
    for (l, row) in overflow.iter().zip(rows) {
        out.text(6, y, &l.text, l.colour, 1);
        y += row;
    }
    Ok(out)
}

/// A label waiting for [`LabelPlacer`].
struct PendingLabel {
    x: i64,
    y: i64,
    text: String,
    colour: Rgb,
}

/// Places text labels so that no two boxes overlap, nor a label and a blocked area (a
/// title, a legend). A label goes where it was asked if that is free and inside the
/// canvas, else to the nearest free spot inside it (searched on a grid of a few pixels);
/// when there is none, or the label is larger than the canvas, it is not drawn and
/// [`LabelPlacer::place`] says so.
#[derive(Default, Debug, Clone)]
pub struct LabelPlacer {
    /// Boxes already placed or blocked, padding included.
    placed: Vec<TextBox>,
}

impl LabelPlacer {
    /// Keeps labels out of `area`.
    pub fn block(&mut self, area: TextBox) {
        self.placed.push(area);
    }

    /// Draws `text` at `(x, y)` or the nearest free spot, and returns the top-left corner
    /// of the text used; `None` when no spot inside the canvas is free (nothing drawn).
    pub fn place(
        &mut self,
        c: &mut Canvas,
        x: i64,
        y: i64,
        text: &str,
        fg: Rgb,
        scale: u32,
    ) -> Option<(i64, i64)> {
        let (w, h) = text_size(text, scale);
        let pad = label_pad(scale);
        let (bw, bh) = (i64::from(w) + 2 * pad, i64::from(h) + 2 * pad);
        let (cw, ch) = (i64::from(c.width()), i64::from(c.height()));
        if w == 0 || bw > cw || bh > ch {
            return None;
        }
        let (xs, ys) = ([pad, cw - bw + pad], [pad, ch - bh + pad]);
        let (x0, y0) = (x.clamp(xs[0], xs[1]), y.clamp(ys[0], ys[1]));
        let free = |tx: i64, ty: i64| {
            let b = TextBox {
                x: tx - pad,
                y: ty - pad,
                width: bw,
                height: bh,
            };
            !self.placed.iter().any(|p| p.overlaps(&b))
        };
        let spot = if free(x0, y0) {
            Some((x0, y0))
        } else {
            // Every grid spot, nearest first; the grid keeps the search to 257² spots.
            let step = (cw.max(ch) / 256).max(2);
            let axis = |lo: i64, hi: i64, at: i64| {
                let below = (0..)
                    .map(move |k| at - k * step)
                    .take_while(move |v| *v >= lo);
                let above = (1..)
                    .map(move |k| at + k * step)
                    .take_while(move |v| *v <= hi);
                below.chain(above).chain([lo, hi])
            };
            let mut spots: Vec<(i64, i64)> = axis(xs[0], xs[1], x0)
                .flat_map(|tx| axis(ys[0], ys[1], y0).map(move |ty| (tx, ty)))
                .collect();
            spots.sort_by_key(|&(tx, ty)| ((tx - x0).pow(2) + (ty - y0).pow(2), ty, tx));
            spots.into_iter().find(|&(tx, ty)| free(tx, ty))
        };
        let (tx, ty) = spot?;
        c.label(tx, ty, text, fg, WHITE, scale);
        self.placed.push(TextBox {
            x: tx - pad,
            y: ty - pad,
            width: bw,
            height: bh,
        });
        Some((tx, ty))
    }
}

/// The arrows' length per newton and the scale drawn in the legend.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ArrowScale {
    /// Arrow length per newton in the camera frame (m/N).
    metres_per_newton: f64,
    /// The force the scale arrow stands for (N): 1, 2 or 5 times a power of ten.
    bar_newtons: f64,
    /// Its length in pixels, parallel to the image at `depth`.
    bar_px: f64,
    /// The depth the scale holds at (m): that of the force which sets it.
    depth: f64,
}

/// The arrow scale of `forces` on `c`, or `None` when no force can be drawn (none, all
/// zero, all behind the camera, or a non-positive given scale).
fn arrow_scale(forces: &[ForceArrow], params: &OverlayParams, c: &Canvas) -> Option<ArrowScale> {
    let k = &params.intrinsics;
    let focal = 0.5 * (k.fx + k.fy);
    // Pixels per newton, parallel to the image, at each force's depth for 1 m/N.
    let (reach, depth, newtons) = forces
        .iter()
        .filter_map(|f| {
            let z = f.start_in_camera[2];
            let n = f.force_in_camera.iter().map(|v| v * v).sum::<f64>().sqrt();
            (z > 0.0 && n > 0.0 && n.is_finite() && focal.is_finite()).then_some((
                n * focal / z,
                z,
                n,
            ))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))?;
    let side = f64::from(c.width().min(c.height()));
    let mpn = match params.metres_per_newton {
        Some(m) if m > 0.0 && m.is_finite() => m,
        Some(_) => return None,
        None => params.arrow_fraction.clamp(0.01, 1.0) * side / reach,
    };
    let bar_newtons = nice_floor(newtons);
    Some(ArrowScale {
        metres_per_newton: mpn,
        bar_newtons,
        bar_px: (bar_newtons * mpn * focal / depth).min(side),
        depth,
    })
}

/// The largest 1, 2 or 5 times a power of ten that is at most `x` (> 0).
fn nice_floor(x: f64) -> f64 {
    let p = 10f64.powf(x.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * p)
        .find(|v| *v <= x * (1.0 + 1e-12))
        .unwrap_or(p)
}

/// Draws the arrow and returns its label for placement and the arrow's start pixel.
fn draw_force(
    c: &mut Canvas,
    f: &ForceArrow,
    params: &OverlayParams,
    metres_per_newton: f64,
) -> Option<(PendingLabel, [f64; 2])> {
    let s = f.start_in_camera;
    let mut d = f.force_in_camera.map(|v| v * metres_per_newton);
    let k = &params.intrinsics;
    let a = project_with(k, s)?;
    // Keep the tip in front of the camera: at most 90% of the way to the camera plane.
    let end_z = s[2] + d[2];
    if end_z < 0.1 * s[2] && d[2] < 0.0 {
        let t = 0.9 * s[2] / -d[2];
        d = d.map(|v| v * t);
    }
    let b = project_with(k, [s[0] + d[0], s[1] + d[1], s[2] + d[2]])?;
    c.arrow(a, b, WHITE, 5.0);
    c.arrow(a, b, FORCE, 3.0);
    c.disc(a, 3.5, FORCE);
    let magnitude = f.force_in_camera.iter().map(|v| v * v).sum::<f64>().sqrt();
    let text = f
        .label
        .clone()
        .unwrap_or_else(|| format!("{magnitude:.2} N"));
    let (tw, th) = text_size(&text, 2);
    // Beyond the head, on the side the arrow points to.
    let dir = [b[0] - a[0], b[1] - a[1]];
    let len = dir[0].hypot(dir[1]).max(1e-9);
    let tx = b[0] + 10.0 * dir[0] / len - if dir[0] < 0.0 { f64::from(tw) } else { 0.0 };
    let ty = b[1] + 10.0 * dir[1] / len - f64::from(th) / 2.0;
    let label = PendingLabel {
        x: tx.clamp(-1e9, 1e9) as i64,
        y: ty.clamp(-1e9, 1e9) as i64,
        text,
        colour: FORCE,
    };
    (tx.is_finite() && ty.is_finite()).then_some((label, a))
}

/// Places `panels` left to right on `background`, each under its title, 8 pixels apart;
/// the height is the tallest panel's plus a 28-pixel title band.
pub fn side_by_side(panels: &[(&str, &Canvas)], background: Rgb) -> Result<Canvas, RenderError> {
    let gap = 8u32;
    let band = 28u32;
    let width = panels
        .iter()
        .map(|(_, p)| p.width())
        .fold(0u32, |a, b| a.saturating_add(b))
        .saturating_add(gap.saturating_mul(panels.len().saturating_sub(1) as u32));
    let height = panels
        .iter()
        .map(|(_, p)| p.height())
        .max()
        .unwrap_or(0)
        .saturating_add(band);
    let mut out = Canvas::new(width, height, background)?;
    let mut x = 0i64;
    for (title, p) in panels {
        out.blit(p, x, i64::from(band));
        let (tw, _) = text_size(title, 2);
        let tx = x + (i64::from(p.width()) - i64::from(tw)).max(0) / 2;
        out.text(
            tx,
            4,
            title,
            if background == BLACK { WHITE } else { BLACK },
            2,
        );
        x += i64::from(p.width()) + i64::from(gap);
    }
    Ok(out)
}
