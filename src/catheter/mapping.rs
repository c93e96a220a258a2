//! The mapping component (thesis 5.4.1, Algorithm 5.1): the tip's nearest point P on the
//! desired path, the local frame Pxyz there, and the 3-D tip error and effector rows
//! mapped onto the bending plane Pyz. Insertion (along Px) is left to the physician.
//!
//! Where the thesis is silent, these defaults hold (docs/catheter.md):
//! - the tip on the path (|δ_e P| below `on_path` m) leaves Pz undefined: the previous
//!   step's Pz, made normal to the new Px, is kept; at the first step, the fixed
//!   `reference` axis made normal to Px is used;
//! - P is the nearest point of the whole path, ties to the smaller arc length; beyond the
//!   path's ends P is the end point and Px the end tangent.

use super::tube::Centreline;
use crate::math::{cross, dot, norm, sub, unit};
use nalgebra::DMatrix;
use serde::Serialize;

/// Options of the mapping component.
#[derive(Clone, Copy, Debug)]
pub struct MappingParams {
    /// Tip-to-path distance below which Pz is carried over from the last step (m; 1e-9).
    pub on_path: f64,
    /// The axis Pz is taken from at the first step when the tip is on the path (unit;
    /// [0, 0, 1]; when nearly parallel to Px, [0, 1, 0] is used).
    pub reference: [f64; 3],
}

impl Default for MappingParams {
    fn default() -> Self {
        Self {
            on_path: 1e-9,
            reference: [0.0, 0.0, 1.0],
        }
    }
}

/// The local frame at the desired point P (Algorithm 5.1, step 1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LocalFrame {
    /// The nearest path point to the tip: the desired position (m).
    pub p: [f64; 3],
    /// Its arc length along the path (m).
    pub s: f64,
    /// Px: the path's unit tangent at P (insertion direction).
    pub x: [f64; 3],
    /// Py: the unit projection axis, normal to Px and Pz (the error lies along it).
    pub y: [f64; 3],
    /// Pz: the unit normal axis, normal to Px and to the tip-to-P vector.
    pub z: [f64; 3],
}

impl LocalFrame {
    /// The 3-D tip error δ_e − P mapped onto the plane Pyz (Algorithm 5.1, step 2).
    pub fn error_2d(&self, tip: [f64; 3]) -> [f64; 2] {
        let e = sub(tip, self.p);
        [dot(e, self.y), dot(e, self.z)]
    }

    /// Three rows in global x, y, z (3 x n: effector rows of W, or a 3-D Jacobian) mapped
    /// onto Pyz (Algorithm 5.1, step 3): 2 x n.
    pub fn rows_2d(&self, rows: &DMatrix<f64>) -> DMatrix<f64> {
        assert_eq!(rows.nrows(), 3, "rows_2d maps three global rows");
        let basis = DMatrix::from_row_slice(
            2,
            3,
            &[
                self.y[0], self.y[1], self.y[2], self.z[0], self.z[1], self.z[2],
            ],
        );
        basis * rows
    }
}

/// The mapping with the state it carries between steps (the last Pz).
#[derive(Clone, Debug, Default)]
pub struct Mapping {
    /// Options.
    pub params: MappingParams,
    last_z: Option<[f64; 3]>,
}

/// `v` made normal to the unit `x`, normalised; `None` when nothing is left.
fn normal_part(v: [f64; 3], x: [f64; 3]) -> Option<[f64; 3]> {
    let d = dot(v, x);
    let w = [v[0] - d * x[0], v[1] - d * x[1], v[2] - d * x[2]];
    let n = norm(w);
    (n > 1e-6 * norm(v).max(f64::MIN_POSITIVE)).then(|| [w[0] / n, w[1] / n, w[2] / n])
}

impl Mapping {
    /// A mapping with `params` and no history.
    pub fn new(params: MappingParams) -> Self {
        Self {
            params,
            last_z: None,
        }
    }

    /// The local frame for the tip at `tip` on `path` (Algorithm 5.1, step 1).
    pub fn frame(&mut self, path: &Centreline, tip: [f64; 3]) -> LocalFrame {
        let c = path.nearest(tip);
        let x = c.tangent;
        let to_p = sub(c.point, tip);
        let z = if norm(to_p) > self.params.on_path {
            normal_part(cross(x, to_p), x)
        } else {
            None
        };
        let z = z
            .or_else(|| self.last_z.and_then(|z| normal_part(z, x)))
            .or_else(|| normal_part(self.params.reference, x))
            .or_else(|| normal_part([0.0, 1.0, 0.0], x))
            .expect("[0,0,1] and [0,1,0] cannot both be parallel to a unit vector");
        let y = unit(cross(z, x));
        self.last_z = Some(z);
        LocalFrame {
            p: c.point,
            s: c.s,
            x,
            y,
            z,
        }
    }
}
