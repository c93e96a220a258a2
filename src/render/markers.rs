//! One frame of `softsense markers --render`: the body's surface seen from the top (x, y)
//! and from the side (x, z), the markers at rest and now with their displacements (scaled),
//! hidden markers, the candidates and the located forces with their values.

use super::canvas::{Canvas, Rgb, BLACK, GREY, WHITE};
use super::font::text_size;
use super::overlay::{side_by_side, LabelPlacer, FORCE};
use super::RenderError;

/// Markers at rest (rings) and now (discs).
pub const MARKER: Rgb = [20, 60, 230];
/// Hidden markers (a cross at their rest position).
pub const MARKER_HIDDEN: Rgb = [255, 140, 0];
/// Candidate force locations (small squares).
pub const CANDIDATE: Rgb = [0, 150, 60];

/// A marker in one frame (m, model frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarkerMark {
    /// Its bound position at rest (the free equilibrium).
    pub rest: [f64; 3],
    /// Its measured position, when visible.
    pub current: Option<[f64; 3]>,
    /// Whether its rows were left out in this frame.
    pub hidden: bool,
}

/// Everything one frame's picture shows (m and N, model frame).
#[derive(Clone, Copy, Debug)]
pub struct MarkerPicture<'a> {
    /// Title written above the panels.
    pub title: &'a str,
    /// Surface triangles (node indices into `positions`), drawn as grey edges.
    pub triangles: &'a [[usize; 3]],
    /// Node positions of the frame's FE state.
    pub positions: &'a [[f64; 3]],
    /// The markers.
    pub markers: &'a [MarkerMark],
    /// The candidate force locations.
    pub candidates: &'a [[f64; 3]],
    /// The located forces: (point, force).
    pub forces: &'a [([f64; 3], [f64; 3])],
}

/// Fraction of a panel's smaller side the largest marker displacement is drawn at.
const DISPLACEMENT_SHARE: f64 = 0.12;
/// Fraction of a panel's smaller side the largest force arrow is drawn at.
const FORCE_SHARE: f64 = 0.3;

/// A view: two model axes onto the panel's right and up, fitted to the positions.
struct View {
    axes: [usize; 2],
    min: [f64; 2],
    scale: f64,
    size: [f64; 2],
}

impl View {
    fn fit(axes: [usize; 2], points: &[[f64; 3]], size: [f64; 2]) -> Self {
        let mut min = [f64::INFINITY; 2];
        let mut max = [f64::NEG_INFINITY; 2];
        for p in points.iter().filter(|p| p.iter().all(|v| v.is_finite())) {
            for k in 0..2 {
                min[k] = min[k].min(p[axes[k]]);
                max[k] = max[k].max(p[axes[k]]);
            }
        }
        let span = [0, 1].map(|k| (max[k] - min[k]).max(1e-6));
        // Room around the body for arrows and labels.
        let scale = (0.7 * size[0] / span[0]).min(0.7 * size[1] / span[1]);
        let centre = [0, 1].map(|k| 0.5 * (min[k] + max[k]));
        let min = [0, 1].map(|k| centre[k] - 0.5 * size[k] / scale);
        View {
            axes,
            min,
            scale,
            size,
        }
    }

    fn pixel(&self, p: [f64; 3]) -> [f64; 2] {
        let u = (p[self.axes[0]] - self.min[0]) * self.scale;
        let v = (p[self.axes[1]] - self.min[1]) * self.scale;
        [u, self.size[1] - v]
    }

    /// The pixel offset of a vector `d` drawn `gain` pixels per unit.
    fn offset(&self, from: [f64; 2], d: [f64; 3], gain: f64) -> [f64; 2] {
        [
            from[0] + gain * d[self.axes[0]],
            from[1] - gain * d[self.axes[1]],
        ]
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Draws one panel with `view`; `gains` are pixels per metre of displacement and per newton.
fn panel(
    pic: &MarkerPicture,
    view: &View,
    gains: (f64, f64),
    labels: [&str; 2],
) -> Result<Canvas, RenderError> {
    let mut c = Canvas::new(view.size[0] as u32, view.size[1] as u32, WHITE)?;
    for t in pic.triangles {
        let [a, b, d] = t.map(|v| view.pixel(pic.positions[v]));
        c.line(a, b, GREY, 1.0);
        c.line(b, d, GREY, 1.0);
        c.line(d, a, GREY, 1.0);
    }
    for p in pic.candidates {
        let q = view.pixel(*p);
        c.fill_rect(q[0] as i64 - 3, q[1] as i64 - 3, 7, 7, CANDIDATE);
    }
    for m in pic.markers {
        let r = view.pixel(m.rest);
        if m.hidden {
            c.cross(r, 6.0, MARKER_HIDDEN, 2.0);
            continue;
        }
        c.circle(r, 4.0, MARKER, 1.5);
        if let Some(now) = m.current {
            let d = [0, 1, 2].map(|a| now[a] - m.rest[a]);
            let to = view.offset(r, d, gains.0);
            c.arrow(r, to, MARKER, 1.5);
            c.disc(to, 3.0, MARKER);
        }
    }
    let mut placer = LabelPlacer::default();
    let below = view.size[1] as i64 - i64::from(text_size(labels[1], 1).1) - 4;
    for (x, y, text) in [(6, 6, labels[0]), (6, below, labels[1])] {
        c.label(x, y, text, BLACK, WHITE, 1);
        if let Some(b) = c.text_boxes().last() {
            placer.block(*b);
        }
    }
    // Arrows first, then their magnitudes, so that no arrow covers a magnitude.
    let tips: Vec<([f64; 2], f64)> = (pic.forces.iter())
        .map(|(p, f)| {
            let from = view.pixel(*p);
            let to = view.offset(from, *f, gains.1);
            c.arrow(from, to, FORCE, 3.0);
            (to, norm(*f))
        })
        .collect();
    for (to, magnitude) in tips {
        if to.iter().all(|v| v.is_finite()) {
            let (x, y) = (to[0].clamp(-1e9, 1e9) as i64, to[1].clamp(-1e9, 1e9) as i64);
            // A magnitude with no free spot is left out; the arrow still shows the force.
            placer.place(&mut c, x + 4, y + 4, &format!("{magnitude:.3} N"), FORCE, 2);
        }
    }
    Ok(c)
}

/// The picture of one frame: top and side panels, each `width` x `height` pixels, with the
/// scales and a legend in the panels' labels.
pub fn marker_picture(pic: &MarkerPicture, width: u32, height: u32) -> Result<Canvas, RenderError> {
    let size = [f64::from(width.max(64)), f64::from(height.max(64))];
    let top = View::fit([0, 1], pic.positions, size);
    let side = View::fit([0, 2], pic.positions, size);
    let px = top.scale.min(side.scale);
    let largest_d = (pic.markers.iter())
        .filter(|m| !m.hidden)
        .filter_map(|m| m.current.map(|c| norm([0, 1, 2].map(|a| c[a] - m.rest[a]))))
        .fold(0.0, f64::max);
    let largest_f = pic.forces.iter().map(|(_, f)| norm(*f)).fold(0.0, f64::max);
    let short = size[0].min(size[1]);
    // Displacements are drawn magnified to a readable length (the factor is printed).
    let magnify = if largest_d > 0.0 {
        (DISPLACEMENT_SHARE * short / (largest_d * px)).max(1.0)
    } else {
        1.0
    };
    let per_newton = if largest_f > 0.0 {
        FORCE_SHARE * short / largest_f
    } else {
        0.0
    };
    let gains = (magnify * px, per_newton);
    let scale = format!("top (x, y), displacements x{magnify:.0}");
    let a = panel(
        pic,
        &top,
        gains,
        [&scale, "blue: o rest, * now; orange x: hidden"],
    )?;
    let b = panel(
        pic,
        &side,
        gains,
        ["side (x, z)", "green: candidates; red: forces"],
    )?;
    side_by_side(&[(pic.title, &a), ("", &b)], WHITE)
}
