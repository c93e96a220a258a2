//! The catheter's environment: a path (a centreline built from straight and circular
//! pieces), a tube of given radius around it (rigid, or soft: [`super::soft_wall`]),
//! rigid point and segment obstacles inside it, and node-based collision detection with an alarm distance (thesis 5.2:
//! contacts act at FE nodes).

use super::soft_wall::{SoftWall, SoftWallParams};
use super::{CatheterError, CatheterResult};
use crate::math::{cross, dot, norm, sub, unit};
use serde::{Deserialize, Serialize};

/// One piece of a centreline, in the frame of the piece before it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum Piece {
    /// A straight run of `length` m.
    Straight {
        /// Length (m).
        length: f64,
    },
    /// A circular bend of `radius` m through `angle` rad, turning about the axis
    /// `plane` rad about the tangent from the current normal.
    Arc {
        /// Bend radius (m).
        radius: f64,
        /// Turned angle (rad, > 0).
        angle: f64,
        /// Which way it turns: the bend's normal rotated this much about the tangent from
        /// the current normal (rad; 0 turns towards the current normal).
        plane: f64,
    },
}

/// A point on a centreline: arc length, position and unit tangent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurvePoint {
    /// Arc length from the start (m).
    pub s: f64,
    /// Position (m).
    pub point: [f64; 3],
    /// Unit tangent, continuous along the curve (interpolated between samples).
    pub tangent: [f64; 3],
}

/// A curve sampled densely: positions with exact tangents at the samples.
#[derive(Clone, Debug)]
pub struct Centreline {
    points: Vec<[f64; 3]>,
    tangents: Vec<[f64; 3]>,
    arc: Vec<f64>,
}

/// Rotate `v` about the axis `k` by `angle`.
fn rotate(v: [f64; 3], k: [f64; 3], angle: f64) -> [f64; 3] {
    let axis = nalgebra::Unit::new_normalize(nalgebra::Vector3::from(k));
    (nalgebra::Rotation3::from_axis_angle(&axis, angle) * nalgebra::Vector3::from(v)).into()
}

fn add_scaled(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [a[0] + t * b[0], a[1] + t * b[1], a[2] + t * b[2]]
}

impl Centreline {
    /// A polyline with its tangents at the samples (unit; checked finite, lengths > 0).
    pub fn new(points: Vec<[f64; 3]>, tangents: Vec<[f64; 3]>) -> CatheterResult<Self> {
        if points.len() < 2 || tangents.len() != points.len() {
            return Err(CatheterError::Path(format!(
                "a centreline needs at least 2 points with one tangent each (got {} points, {} tangents)",
                points.len(),
                tangents.len()
            )));
        }
        let mut arc = vec![0.0];
        for (i, w) in points.windows(2).enumerate() {
            let l = norm(sub(w[1], w[0]));
            if !(l > 0.0) || !l.is_finite() {
                return Err(CatheterError::Path(format!(
                    "centreline segment {i} has length {l} (points must be distinct and finite)"
                )));
            }
            arc.push(arc[i] + l);
        }
        if tangents
            .iter()
            .any(|&t| !(norm(t) > 0.0) || !norm(t).is_finite())
        {
            return Err(CatheterError::Path(
                "a centreline tangent is zero or not finite".into(),
            ));
        }
        let tangents = tangents.into_iter().map(unit).collect();
        Ok(Self {
            points,
            tangents,
            arc,
        })
    }

    /// The curve of `pieces` starting at `start` along the unit `direction`, with `normal`
    /// (perpendicular to it) as the first bend's reference, sampled every `step` m or finer.
    pub fn from_pieces(
        start: [f64; 3],
        direction: [f64; 3],
        normal: [f64; 3],
        pieces: &[Piece],
        step: f64,
    ) -> CatheterResult<Self> {
        if !(step > 0.0) {
            return Err(CatheterError::Path(format!(
                "sampling step {step} m must be > 0"
            )));
        }
        let mut t = unit(direction);
        let normal_part = sub(normal, scale(t, dot(normal, t)));
        let mut n = unit(normal_part);
        let usable = norm(direction) > 0.0 && norm(normal_part) > 1e-9 * norm(normal);
        if !usable || !n.iter().chain(&t).all(|v| v.is_finite()) {
            return Err(CatheterError::Path(
                "the start direction and normal must be non-zero and not parallel".into(),
            ));
        }
        let (mut points, mut tangents) = (vec![start], vec![t]);
        let mut at = start;
        for (i, piece) in pieces.iter().enumerate() {
            match *piece {
                Piece::Straight { length } => {
                    check_positive(i, "length", length)?;
                    let k = (length / step).ceil().max(1.0) as usize;
                    for j in 1..=k {
                        points.push(add_scaled(at, t, length * j as f64 / k as f64));
                        tangents.push(t);
                    }
                    at = *points.last().expect("pushed above");
                }
                Piece::Arc {
                    radius,
                    angle,
                    plane,
                } => {
                    check_positive(i, "radius", radius)?;
                    check_positive(i, "angle", angle)?;
                    let bend_normal = rotate(n, t, plane);
                    let centre = add_scaled(at, bend_normal, radius);
                    let axis = cross(t, bend_normal);
                    let k = (radius * angle / step).ceil().max(1.0) as usize;
                    let from_centre = sub(at, centre);
                    for j in 1..=k {
                        let a = angle * j as f64 / k as f64;
                        let r = rotate(from_centre, axis, a);
                        points.push([centre[0] + r[0], centre[1] + r[1], centre[2] + r[2]]);
                        tangents.push(rotate(t, axis, a));
                    }
                    at = *points.last().expect("pushed above");
                    n = rotate(n, axis, angle);
                    t = rotate(t, axis, angle);
                }
            }
        }
        Self::new(points, tangents)
    }

    /// Total arc length (m).
    pub fn length(&self) -> f64 {
        *self.arc.last().expect("at least two points")
    }

    /// The samples.
    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// The point at arc length `s`, clamped to the curve.
    pub fn at(&self, s: f64) -> CurvePoint {
        let s = s.clamp(0.0, self.length());
        let i = self
            .arc
            .partition_point(|&a| a <= s)
            .clamp(1, self.points.len() - 1)
            - 1;
        let u = (s - self.arc[i]) / (self.arc[i + 1] - self.arc[i]);
        self.point_on(i, u)
    }

    /// The nearest point of the curve to `p`; ties go to the smaller arc length.
    pub fn nearest(&self, p: [f64; 3]) -> CurvePoint {
        let mut best = (f64::INFINITY, 0, 0.0);
        for (i, w) in self.points.windows(2).enumerate() {
            let d = sub(w[1], w[0]);
            let u = (dot(sub(p, w[0]), d) / dot(d, d)).clamp(0.0, 1.0);
            let q = add_scaled(w[0], d, u);
            let dist2 = dot(sub(p, q), sub(p, q));
            if dist2 < best.0 {
                best = (dist2, i, u);
            }
        }
        self.point_on(best.1, best.2)
    }

    fn point_on(&self, i: usize, u: f64) -> CurvePoint {
        let (a, b) = (self.points[i], self.points[i + 1]);
        let (ta, tb) = (self.tangents[i], self.tangents[i + 1]);
        CurvePoint {
            s: self.arc[i] + u * (self.arc[i + 1] - self.arc[i]),
            point: add_scaled(a, sub(b, a), u),
            tangent: unit(add_scaled(scale(ta, 1.0 - u), tb, u)),
        }
    }
}

fn scale(a: [f64; 3], t: f64) -> [f64; 3] {
    [a[0] * t, a[1] * t, a[2] * t]
}

fn check_positive(piece: usize, what: &str, v: f64) -> CatheterResult<()> {
    if v > 0.0 && v.is_finite() {
        Ok(())
    } else {
        Err(CatheterError::Path(format!(
            "piece {piece}: {what} {v} must be > 0"
        )))
    }
}

/// A tube: a centreline and an inner radius, with obstacles inside and, optionally, a soft
/// wall.
#[derive(Clone, Debug)]
pub struct Tube {
    /// The tube's axis.
    pub centreline: Centreline,
    /// Inner radius (m).
    pub radius: f64,
    /// Rigid obstacles the catheter can also touch (none by default).
    pub obstacles: Vec<Obstacle>,
    /// The wall's FE model when the tube is soft (none: a rigid wall).
    pub soft: Option<std::sync::Arc<SoftWall>>,
}

/// A rigid obstacle: the points within `radius` of the segment from `a` to `b` (a sphere
/// when they coincide, a capsule otherwise), such as a wire or a ridge across the tube.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Obstacle {
    /// One end of the axis (m).
    pub a: [f64; 3],
    /// The other end (m; `a` for a point obstacle).
    pub b: [f64; 3],
    /// Radius round the axis (m, ≥ 0).
    pub radius: f64,
}

/// What a contact row pushes against.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Surface {
    /// The tube's wall.
    #[default]
    Wall,
    /// The tube's obstacle of this index.
    Obstacle(usize),
}

/// A catheter node near the wall or an obstacle: a contact row of the LCP (5.4).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NodeContact {
    /// The catheter node.
    pub node: usize,
    /// What it touches; a node may touch the wall and obstacles at once, one row each.
    pub surface: Surface,
    /// Gap along `normal` at the current configuration (m; negative: penetration).
    pub gap: f64,
    /// Unit direction in which the surface pushes the node (towards the axis for the wall,
    /// away from an obstacle's axis).
    pub normal: [f64; 3],
    /// Arc length of the path point nearest the node (m).
    pub s: f64,
}

impl Obstacle {
    /// The nearest point of the axis to `p`.
    pub fn nearest(&self, p: [f64; 3]) -> [f64; 3] {
        let d = sub(self.b, self.a);
        let dd = dot(d, d);
        match dd > 0.0 {
            true => add_scaled(self.a, d, (dot(sub(p, self.a), d) / dd).clamp(0.0, 1.0)),
            false => self.a,
        }
    }

    fn check(&self, i: usize) -> CatheterResult<()> {
        let finite = self.a.iter().chain(&self.b).all(|v| v.is_finite());
        if !finite || !(self.radius >= 0.0) || !self.radius.is_finite() {
            return Err(CatheterError::Path(format!(
                "obstacle {i}: its ends must be finite and its radius >= 0 (got {self:?})"
            )));
        }
        Ok(())
    }
}

impl Tube {
    /// A tube around `centreline` of inner `radius` m (> 0).
    pub fn new(centreline: Centreline, radius: f64) -> CatheterResult<Self> {
        if !(radius > 0.0) || !radius.is_finite() {
            return Err(CatheterError::Path(format!(
                "tube radius {radius} m must be > 0"
            )));
        }
        Ok(Self {
            centreline,
            radius,
            obstacles: Vec::new(),
            soft: None,
        })
    }

    /// The tube with a soft wall of `params` round its radius (meshed and its compliance
    /// computed here, once).
    pub fn with_soft_wall(mut self, params: &SoftWallParams) -> CatheterResult<Self> {
        let wall = SoftWall::new(&self.centreline, self.radius, params)?;
        self.soft = Some(std::sync::Arc::new(wall));
        Ok(self)
    }

    /// The soft wall's compliance between the contact `rows` of a catheter of
    /// `catheter_radius` whose nodes are at `x` (m/N; zero where a row is not on the wall),
    /// the H2 K2⁻¹ H2ᵀ to add to the catheter's own in the contact block; none for a
    /// rigid wall. A row pushes the wall where the node's section meets the undeformed
    /// wall: from the node, against the push, by the catheter's radius plus `rows`' gap
    /// (the rigid wall's).
    pub fn wall_compliance(
        &self,
        rows: &[NodeContact],
        x: &[[f64; 3]],
        catheter_radius: f64,
    ) -> Option<nalgebra::DMatrix<f64>> {
        let soft = self.soft.as_ref()?;
        let on_wall: Vec<usize> = (0..rows.len())
            .filter(|&i| rows[i].surface == Surface::Wall)
            .collect();
        let points: Vec<([f64; 3], f64)> = (on_wall.iter())
            .map(|&i| {
                let c = &rows[i];
                let reach = catheter_radius + c.gap;
                (add_scaled(x[c.node], c.normal, -reach), c.s)
            })
            .collect();
        let c = soft.compliance(&points);
        let mut full = nalgebra::DMatrix::zeros(rows.len(), rows.len());
        for (a, &i) in on_wall.iter().enumerate() {
            for (b, &j) in on_wall.iter().enumerate() {
                full[(i, j)] = c[(a, b)];
            }
        }
        Some(full)
    }

    /// The tube with `obstacles` inside (checked finite, radii ≥ 0).
    pub fn with_obstacles(mut self, obstacles: Vec<Obstacle>) -> CatheterResult<Self> {
        for (i, o) in obstacles.iter().enumerate() {
            o.check(i)?;
        }
        self.obstacles = obstacles;
        Ok(self)
    }

    /// The gap of a catheter cross-section of `catheter_radius` centred at `p` to
    /// `surface`, with its push direction; an obstacle's direction is undefined on its
    /// axis, and any unit vector normal to the path is returned there.
    pub fn gap_to(&self, surface: Surface, p: [f64; 3], catheter_radius: f64) -> NodeContact {
        let o = match surface {
            Surface::Wall => return self.gap(p, catheter_radius),
            Surface::Obstacle(i) => &self.obstacles[i],
        };
        let c = self.centreline.nearest(p);
        let off = sub(p, o.nearest(p));
        let d = norm(off);
        let normal = match d > 1e-12 {
            true => scale(off, 1.0 / d),
            false => crate::math::tangents(c.tangent).0,
        };
        NodeContact {
            node: usize::MAX,
            surface,
            gap: d - o.radius - catheter_radius,
            normal,
            s: c.s,
        }
    }

    /// The gap of a catheter cross-section of `catheter_radius` centred at `p`, and the
    /// wall's push direction. On the axis itself the direction is undefined; any unit
    /// normal to the tangent is returned there (the gap is then the largest possible).
    pub fn gap(&self, p: [f64; 3], catheter_radius: f64) -> NodeContact {
        let c = self.centreline.nearest(p);
        let off = sub(p, c.point);
        let off = sub(off, scale(c.tangent, dot(off, c.tangent)));
        let d = norm(off);
        let normal = if d > 1e-12 * self.radius {
            scale(off, -1.0 / d)
        } else {
            crate::math::tangents(c.tangent).0
        };
        NodeContact {
            node: usize::MAX,
            surface: Surface::Wall,
            gap: self.radius - catheter_radius - d,
            normal,
            s: c.s,
        }
    }

    /// Node-based collision detection: every node whose gap to the wall or to an obstacle
    /// is below `alarm` m becomes a contact row (thesis 5.2), by node, the wall's first.
    /// Nodes beyond the tube's ends have no wall.
    pub fn contacts(
        &self,
        nodes: &[[f64; 3]],
        catheter_radius: f64,
        alarm: f64,
    ) -> Vec<NodeContact> {
        let end = self.centreline.length();
        let mut rows = Vec::new();
        for (node, &p) in nodes.iter().enumerate() {
            // The wall, then each obstacle; a range, not a list, as this runs every round.
            let surfaces = std::iter::once(Surface::Wall)
                .chain((0..self.obstacles.len()).map(Surface::Obstacle));
            for surface in surfaces {
                let c = self.gap_to(surface, p, catheter_radius);
                let beyond = surface == Surface::Wall && !(c.s > 0.0 && c.s < end);
                if !beyond && c.gap < alarm {
                    rows.push(NodeContact { node, ..c });
                }
            }
        }
        rows
    }
}
