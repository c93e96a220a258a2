//! What `sense` saw, drawn over the colour frame: robot segment, registered feature
//! points, contacts and force arrows; and panels side by side for before/after pictures.

use super::canvas::{Canvas, Rgb, BLACK, WHITE};
use super::chart::{legend, Swatch};
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
    /// Arrow length per newton (m/N), in the camera frame before projection.
    pub metres_per_newton: f64,
    /// How much the frame is faded towards white (0 none, 1 white) so marks stand out.
    pub fade: f64,
    /// Opacity of the robot tint.
    pub mask_alpha: f64,
    /// Draw a legend in the bottom-left corner.
    pub legend: bool,
}

impl Default for OverlayParams {
    fn default() -> Self {
        OverlayParams {
            intrinsics: PinholeIntrinsics::default(),
            metres_per_newton: 0.05,
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
/// camera is skipped, one whose tip would be is shortened to stay in front.
pub fn sense_overlay(
    frame: &Canvas,
    overlay: &SenseOverlay<'_>,
    params: &OverlayParams,
) -> Result<Canvas, RenderError> {
    let mut c = frame.clone();
    let (w, h) = (i64::from(c.width()), i64::from(c.height()));
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
        }
    }
    for f in overlay.features.iter().filter(|f| !f.visible) {
        c.cross(f.pixel, 3.5, BLACK, 3.5);
        c.cross(f.pixel, 3.5, FEATURE_HIDDEN, 1.5);
    }
    for f in overlay.features.iter().filter(|f| f.visible) {
        if let Some(m) = f.matched {
            c.line(f.pixel, m, MATCH_LINE, 1.5);
            c.disc(m, 1.8, BLACK);
        }
        c.disc(f.pixel, 4.0, BLACK);
        c.disc(f.pixel, 3.0, FEATURE_VISIBLE);
    }
    // Labels are placed after every mark, so no mark hides one and none covers another.
    let mut labels: Vec<PendingLabel> = Vec::new();
    for ct in overlay.contacts {
        c.circle(ct.pixel, 10.0, WHITE, 4.0);
        c.circle(ct.pixel, 10.0, CONTACT, 2.0);
        if ct.pixel.iter().all(|v| v.is_finite()) {
            let x = ct.pixel[0].clamp(-1e9, 1e9) as i64 + 13;
            let y = ct.pixel[1].clamp(-1e9, 1e9) as i64 - 30;
            labels.push(PendingLabel {
                x,
                y,
                text: ct.label.clone(),
                colour: CONTACT,
            });
        }
    }
    for f in overlay.forces {
        if let Some(l) = draw_force(&mut c, f, params) {
            labels.push(l);
        }
    }
    let mut placer = LabelPlacer::default();
    for l in &labels {
        placer.place(&mut c, l.x, l.y, &l.text, l.colour, 2);
    }
    if !overlay.title.is_empty() {
        let scale = if i64::from(text_size(overlay.title, 2).0) + 12 <= w {
            2
        } else {
            1
        };
        c.label(6, 6, overlay.title, BLACK, WHITE, scale);
    }
    if params.legend {
        let entries = [
            (Swatch::Fill(ROBOT_TINT), "robot segment"),
            (Swatch::Disc(FEATURE_VISIBLE), "feature, registered"),
            (Swatch::Cross(FEATURE_HIDDEN), "feature, hidden"),
            (Swatch::Line(MATCH_LINE), "match"),
            (Swatch::Ring(CONTACT), "contact"),
            (Swatch::Arrow(FORCE), "force"),
        ];
        let bh = entries.len() as i64 * 15 + 8;
        legend(&mut c, 6, h - bh - 6, &entries);
    }
    Ok(c)
}

/// A label waiting for [`LabelPlacer`].
struct PendingLabel {
    x: i64,
    y: i64,
    text: String,
    colour: Rgb,
}

/// Places text labels so that their boxes do not overlap: a label that would cover an
/// earlier one moves down or up (alternately, one box height plus a gap at a time, at
/// most 8 steps each way) to the nearest free spot; if none is free it stays where asked.
/// A label is first moved sideways into the canvas where it fits there, so that no text is
/// cut at its left or right edge; spots above or below the canvas are skipped.
#[derive(Default, Debug, Clone)]
pub struct LabelPlacer {
    /// Boxes already placed: (x, y, width, height) in pixels, padding included.
    placed: Vec<[i64; 4]>,
}

impl LabelPlacer {
    /// Draws `text` at `(x, y)` or the nearest free spot above or below it, and returns
    /// the top-left corner used.
    pub fn place(
        &mut self,
        c: &mut Canvas,
        x: i64,
        y: i64,
        text: &str,
        fg: Rgb,
        scale: u32,
    ) -> (i64, i64) {
        let (w, h) = text_size(text, scale);
        let pad = 2 * i64::from(scale.clamp(1, 64));
        let (bw, bh) = (i64::from(w) + 2 * pad, i64::from(h) + 2 * pad);
        let (cw, ch) = (i64::from(c.width()), i64::from(c.height()));
        // Into the canvas sideways when the box fits its width (else as asked).
        let x = if bw <= cw {
            x.clamp(pad, cw - bw + pad)
        } else {
            x
        };
        let inside = |ty: i64| bh > ch || (ty - pad >= 0 && ty - pad + bh <= ch);
        let free = |ty: i64, placed: &[[i64; 4]]| {
            let b = [x - pad, ty - pad, bw, bh];
            !placed.iter().any(|p| {
                b[0] < p[0] + p[2] && p[0] < b[0] + b[2] && b[1] < p[1] + p[3] && p[1] < b[1] + b[3]
            })
        };
        let step = bh + 2;
        let ty = (0..=16i64)
            .map(|i| {
                let k = (i + 1) / 2;
                if i % 2 == 1 {
                    y + k * step
                } else {
                    y - k * step
                }
            })
            .find(|&ty| inside(ty) && free(ty, &self.placed))
            .unwrap_or(y);
        self.placed.push([x - pad, ty - pad, bw, bh]);
        c.label(x, ty, text, fg, WHITE, scale);
        (x, ty)
    }
}

/// Draws the arrow and returns its label for placement.
fn draw_force(c: &mut Canvas, f: &ForceArrow, params: &OverlayParams) -> Option<PendingLabel> {
    let s = f.start_in_camera;
    let mut d = f.force_in_camera.map(|v| v * params.metres_per_newton);
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
    let (tw, _) = text_size(&text, 2);
    // Beyond the head, on the side the arrow points to.
    let dir = [b[0] - a[0], b[1] - a[1]];
    let len = dir[0].hypot(dir[1]).max(1e-9);
    let tx = b[0] + 10.0 * dir[0] / len - if dir[0] < 0.0 { f64::from(tw) } else { 0.0 };
    let ty = b[1] + 10.0 * dir[1] / len - 7.0;
    (tx.is_finite() && ty.is_finite()).then(|| PendingLabel {
        x: tx.clamp(-1e9, 1e9) as i64,
        y: ty.clamp(-1e9, 1e9) as i64,
        text,
        colour: FORCE,
    })
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
