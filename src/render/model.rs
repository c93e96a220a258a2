//! The picture of `softsense model check --picture`: a model's body seen from the top
//! (x, y), the front (x, z) and the side (y, z), all at one scale, with its fixed nodes,
//! cable paths, cavities, effectors and force points; the fourth quarter holds the legend
//! (what is drawn, nothing else), a length scale bar and notes.
//!
//! The body is drawn by its outline in each view: the surface edges on the silhouette
//! (one face towards the viewer, the other away) and the creases (faces meeting at more
//! than [`CREASE_DEG`]); every surface edge would grey a fine mesh out.

use super::canvas::{Canvas, Rgb, BLACK, WHITE};
use super::chart::{legend, Swatch};
use super::font::text_size;
use super::overlay::LabelPlacer;
use super::RenderError;
use crate::fem::model::Model;
use std::collections::HashMap;

/// The body's projected area.
pub const BODY_FILL: Rgb = [234, 234, 234];
/// The body's outline.
pub const BODY_EDGE: Rgb = [140, 140, 140];
/// Fixed nodes.
pub const FIXED: Rgb = [30, 90, 220];
/// Cavity faces.
pub const CAVITY: Rgb = [250, 205, 130];
/// Cavity outlines.
pub const CAVITY_EDGE: Rgb = [215, 125, 20];
/// Effectors (crosses).
pub const EFFECTOR: Rgb = [170, 0, 140];
/// Force points (rings).
pub const FORCE_POINT: Rgb = [0, 140, 60];
/// Cable colours, in turn.
pub const CABLES: [Rgb; 5] = [
    [220, 30, 30],
    [130, 50, 190],
    [0, 150, 160],
    [140, 80, 20],
    [190, 150, 0],
];
/// Faces meeting at more than this angle (deg) make a crease that is drawn.
pub const CREASE_DEG: f64 = 30.0;

/// A triangle surface: points and faces over them (m).
#[derive(Debug, Clone, Default)]
pub struct Faces {
    /// Name (for the legend).
    pub name: String,
    /// Vertex positions (m).
    pub points: Vec<[f64; 3]>,
    /// Triangles over `points`, consistently oriented.
    pub triangles: Vec<[usize; 3]>,
}

/// A named polyline or point (m).
#[derive(Debug, Clone, Default)]
pub struct Named {
    /// Name.
    pub name: String,
    /// Points: a cable's pull point, then its attach points; one point for a marker.
    pub points: Vec<[f64; 3]>,
}

/// Everything the picture shows (m, model frame).
#[derive(Debug, Clone, Default)]
pub struct ModelPicture {
    /// Title above the views.
    pub title: String,
    /// The body's surface.
    pub body: Faces,
    /// Fixed node positions.
    pub fixed: Vec<[f64; 3]>,
    /// Cables: pull point, then attach points.
    pub cables: Vec<Named>,
    /// Cavities.
    pub cavities: Vec<Faces>,
    /// Effectors.
    pub effectors: Vec<Named>,
    /// Force points.
    pub force_points: Vec<Named>,
    /// Lines of text under the legend (e.g. counts and the sag).
    pub notes: Vec<String>,
}

impl ModelPicture {
    /// The picture of a loaded model at rest, titled `title`, with no notes.
    pub fn of(model: &Model, title: &str) -> Self {
        let p = &model.problem;
        let x = &p.mesh.nodes_in_rest;
        let s = p.mesh.surface();
        let named = |name: &str, points: Vec<[f64; 3]>| Named {
            name: name.to_string(),
            points,
        };
        let at = |e: &crate::fem::model::Effector| named(&e.name, vec![e.point.position(x)]);
        Self {
            title: title.to_string(),
            body: Faces {
                name: "body".into(),
                points: x.clone(),
                triangles: s.triangles,
            },
            fixed: p.fixed.iter().map(|&v| x[v]).collect(),
            cables: (p.cables.iter())
                .map(|c| {
                    let mut pts = vec![c.pull];
                    pts.extend(c.attach.iter().map(|a| a.position(x)));
                    named(&c.name, pts)
                })
                .collect(),
            cavities: (p.cavities.iter())
                .map(|c| Faces {
                    name: c.name.clone(),
                    points: c.positions(x),
                    triangles: c.faces.clone(),
                })
                .collect(),
            effectors: model.effectors.iter().map(at).collect(),
            force_points: model.force_points.iter().map(at).collect(),
            notes: Vec::new(),
        }
    }

    /// Every finite point drawn, to fit the views to.
    fn all_points(&self) -> Vec<[f64; 3]> {
        let mut v = self.body.points.clone();
        for n in (self.cables.iter())
            .chain(&self.effectors)
            .chain(&self.force_points)
        {
            v.extend(&n.points);
        }
        for c in &self.cavities {
            v.extend(&c.points);
        }
        v.retain(|p| p.iter().all(|x| x.is_finite()));
        v
    }
}

/// One orthographic view: model axes `axes` onto the panel's right and up.
struct View {
    axes: [usize; 2],
    /// The model coordinates at the panel's centre.
    centre: [f64; 2],
    /// Pixels per metre.
    scale: f64,
    size: [f64; 2],
}

impl View {
    fn pixel(&self, p: [f64; 3]) -> [f64; 2] {
        let u = (p[self.axes[0]] - self.centre[0]) * self.scale + 0.5 * self.size[0];
        let v = (p[self.axes[1]] - self.centre[1]) * self.scale;
        [u, 0.5 * self.size[1] - v]
    }

    /// The axis looked along.
    fn depth(&self) -> usize {
        3 - self.axes[0] - self.axes[1]
    }
}

/// The picture, `width` x `height` pixels: title, three views and the legend quarter.
pub fn model_picture(pic: &ModelPicture, width: u32, height: u32) -> Result<Canvas, RenderError> {
    let mut out = Canvas::new(width, height, WHITE)?;
    let (band, gap) = (30.0, 8.0);
    let cell = [
        ((f64::from(width) - 3.0 * gap) / 2.0).floor().max(16.0),
        ((f64::from(height) - band - 3.0 * gap) / 2.0)
            .floor()
            .max(16.0),
    ];
    out.text(8, 8, &pic.title, BLACK, 2);
    let views = [
        ([0, 1], "top (x right, y up)"),
        ([0, 2], "front (x right, z up)"),
        ([1, 2], "side (y right, z up)"),
    ];
    let (lo, hi) = bounds(pic);
    // One scale for all three views, so that the scale bar holds for each.
    let scale = (views.iter())
        .flat_map(|(a, _)| (0..2).map(|k| 0.85 * cell[k] / (hi[a[k]] - lo[a[k]]).max(1e-9)))
        .fold(f64::INFINITY, f64::min);
    let corner = |i: usize| {
        [
            gap + (i % 2) as f64 * (cell[0] + gap),
            band + gap + (i / 2) as f64 * (cell[1] + gap),
        ]
    };
    for (i, (axes, label)) in views.iter().enumerate() {
        let view = View {
            axes: *axes,
            centre: [0, 1].map(|k| 0.5 * (lo[axes[k]] + hi[axes[k]])),
            scale,
            size: cell,
        };
        let panel = draw_view(pic, &view, label)?;
        let [x, y] = corner(i);
        out.blit(&panel, x as i64, y as i64);
    }
    let key = legend_panel(pic, scale, cell)?;
    let [x, y] = corner(3);
    out.blit(&key, x as i64, y as i64);
    Ok(out)
}

/// The bounding box of every point drawn (m); a unit box when there is none.
fn bounds(pic: &ModelPicture) -> ([f64; 3], [f64; 3]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in pic.all_points() {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if !lo[0].is_finite() {
        return ([0.0; 3], [1.0; 3]);
    }
    (lo, hi)
}

/// One view's panel: body, cavities, fixed nodes, cables, effectors and force points.
fn draw_view(pic: &ModelPicture, view: &View, label: &str) -> Result<Canvas, RenderError> {
    let mut c = Canvas::new(view.size[0] as u32, view.size[1] as u32, WHITE)?;
    fill(&mut c, view, &pic.body, BODY_FILL);
    for cav in &pic.cavities {
        fill(&mut c, view, cav, CAVITY);
    }
    outline(&mut c, view, &pic.body, BODY_EDGE);
    for cav in &pic.cavities {
        outline(&mut c, view, cav, CAVITY_EDGE);
    }
    for p in &pic.fixed {
        c.disc(view.pixel(*p), 2.5, FIXED);
    }
    // Names are placed after every mark, so that none covers another.
    let mut labels: Vec<(f64, f64, &str, Rgb)> = Vec::new();
    for (i, cable) in pic.cables.iter().enumerate() {
        let colour = CABLES[i % CABLES.len()];
        let px: Vec<[f64; 2]> = cable.points.iter().map(|p| view.pixel(*p)).collect();
        for w in px.windows(2) {
            c.line(w[0], w[1], colour, 2.0);
        }
        if let Some((pull, attach)) = px.split_first() {
            c.circle(*pull, 4.5, colour, 2.0);
            for a in attach {
                c.disc(*a, 3.5, colour);
            }
            let end = attach.last().unwrap_or(pull);
            labels.push((end[0] + 6.0, end[1] - 3.0, cable.name.as_str(), colour));
        }
    }
    for e in &pic.effectors {
        for p in &e.points {
            let q = view.pixel(*p);
            c.cross(q, 5.0, EFFECTOR, 2.0);
            labels.push((q[0] + 7.0, q[1] + 4.0, e.name.as_str(), EFFECTOR));
        }
    }
    for f in &pic.force_points {
        for p in &f.points {
            c.circle(view.pixel(*p), 5.0, FORCE_POINT, 2.0);
        }
    }
    c.rect(0, 0, view.size[0] as i64, view.size[1] as i64, BODY_EDGE, 1);
    c.label(6, 6, label, BLACK, WHITE, 1);
    let mut placer = LabelPlacer::default();
    if let Some(b) = c.text_boxes().last() {
        placer.block(*b);
    }
    // A name with no free spot is left out: the legend names every cable and effector.
    for (x, y, text, colour) in labels {
        if x.is_finite() && y.is_finite() {
            let (x, y) = (x.clamp(-1e9, 1e9) as i64, y.clamp(-1e9, 1e9) as i64);
            placer.place(&mut c, x, y, text, colour, 1);
        }
    }
    Ok(c)
}

/// The projected area of `faces`, flat.
fn fill(c: &mut Canvas, view: &View, faces: &Faces, colour: Rgb) {
    for t in &faces.triangles {
        let [a, b, d] = t.map(|v| view.pixel(faces.points[v]));
        c.fill_triangle(a, b, d, colour);
    }
}

/// The silhouette and crease edges of `faces` seen along the view's depth axis; edges of
/// one face (a rim) or more than two are drawn as well.
fn outline(c: &mut Canvas, view: &View, faces: &Faces, colour: Rgb) {
    let normal = |t: &[usize; 3]| {
        let [a, b, d] = t.map(|v| faces.points[v]);
        let (u, w) = (
            [0, 1, 2].map(|k| b[k] - a[k]),
            [0, 1, 2].map(|k| d[k] - a[k]),
        );
        let n = [
            u[1] * w[2] - u[2] * w[1],
            u[2] * w[0] - u[0] * w[2],
            u[0] * w[1] - u[1] * w[0],
        ];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        n.map(|v| if l > 0.0 { v / l } else { 0.0 })
    };
    let normals: Vec<[f64; 3]> = faces.triangles.iter().map(normal).collect();
    let mut edges: HashMap<[usize; 2], Vec<usize>> = HashMap::new();
    for (f, t) in faces.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.entry([a.min(b), a.max(b)]).or_default().push(f);
        }
    }
    let crease = CREASE_DEG.to_radians().cos();
    let depth = view.depth();
    for (e, f) in &edges {
        let drawn = match f.as_slice() {
            [a, b] => {
                let (na, nb) = (normals[*a], normals[*b]);
                let dot = na[0] * nb[0] + na[1] * nb[1] + na[2] * nb[2];
                dot < crease || (na[depth] > 0.0) != (nb[depth] > 0.0)
            }
            _ => true,
        };
        if drawn {
            let [a, b] = e.map(|v| view.pixel(faces.points[v]));
            c.line(a, b, colour, 1.0);
        }
    }
}

/// The legend of what is drawn, the scale bar (`scale` pixels per metre) and the notes.
fn legend_panel(pic: &ModelPicture, scale: f64, size: [f64; 2]) -> Result<Canvas, RenderError> {
    let mut c = Canvas::new(size[0] as u32, size[1] as u32, WHITE)?;
    let mut entries: Vec<(Swatch, String)> = vec![(
        Swatch::Line(BODY_EDGE),
        "body (outline and creases)".to_string(),
    )];
    if !pic.fixed.is_empty() {
        let n = pic.fixed.len();
        entries.push((Swatch::Disc(FIXED), format!("fixed nodes ({n})")));
    }
    for (i, cable) in pic.cables.iter().enumerate() {
        let text = format!("cable {}: o pull, * attach", cable.name);
        entries.push((Swatch::Line(CABLES[i % CABLES.len()]), text));
    }
    for cav in &pic.cavities {
        entries.push((Swatch::Fill(CAVITY), format!("cavity {}", cav.name)));
    }
    if !pic.effectors.is_empty() {
        entries.push((Swatch::Cross(EFFECTOR), "effector".to_string()));
    }
    if !pic.force_points.is_empty() {
        entries.push((Swatch::Ring(FORCE_POINT), "force point".to_string()));
    }
    let refs: Vec<(Swatch, &str)> = entries.iter().map(|(s, t)| (*s, t.as_str())).collect();
    let (_, h) = legend(&mut c, 8, 8, &refs);
    let y = 8 + h + 24;
    let (metres, text) = scale_bar_length(0.4 * size[0] / scale);
    let len = metres * scale;
    c.line([12.0, y as f64], [12.0 + len, y as f64], BLACK, 3.0);
    for x in [12.0, 12.0 + len] {
        c.line([x, y as f64 - 5.0], [x, y as f64 + 5.0], BLACK, 2.0);
    }
    c.text(
        20 + len as i64,
        y - i64::from(text_size("Ag", 1).1) / 2,
        &format!("{text} (all views)"),
        BLACK,
        1,
    );
    // Hack is monospaced: one character's advance gives the characters per line.
    let advance = f64::from(text_size("0000000000", 1).0.max(10)) / 10.0;
    let chars = ((size[0] - 24.0) / advance).max(8.0) as usize;
    let row = i64::from(text_size("Ag", 1).1) + 2;
    let lines = pic.notes.iter().flat_map(|n| wrap(n, chars));
    for (i, line) in lines.enumerate() {
        c.text(12, y + 24 + row * i as i64, &line, BLACK, 1);
    }
    Ok(c)
}

/// `text` in lines of at most `chars` characters, broken at spaces (runs of spaces read
/// as one), continuation lines indented.
fn wrap(text: &str, chars: usize) -> Vec<String> {
    let mut lines = vec![String::new()];
    for word in text.split_whitespace() {
        let line = lines.last_mut().expect("one line");
        if !line.trim().is_empty() && line.len() + 1 + word.len() > chars {
            lines.push(format!("  {word}"));
        } else {
            if !line.is_empty() {
                line.push(' ');
            }
            line.push_str(word);
        }
    }
    lines
}

/// The largest 1, 2 or 5 times a power of ten not above `at_most` (m), and its text in
/// mm below a metre.
fn scale_bar_length(at_most: f64) -> (f64, String) {
    if !(at_most > 0.0 && at_most.is_finite()) {
        return (0.0, String::new());
    }
    let p = 10f64.powf(at_most.log10().floor());
    let m = [5.0, 2.0, 1.0]
        .into_iter()
        .find(|m| m * p <= at_most)
        .unwrap_or(1.0)
        * p;
    let text = if m < 1.0 {
        format!("{} mm", round_text(m * 1e3))
    } else {
        format!("{} m", round_text(m))
    };
    (m, text)
}

/// A 1-2-5 value without float noise (0.1 not 0.10000000000000001).
fn round_text(v: f64) -> String {
    let s = format!("{v:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}
