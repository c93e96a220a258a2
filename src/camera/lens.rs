//! What a real lens adds to the pinhole: Brown-Conrady distortion, or a per-pixel ray table.
//!
//! Every lens maps both ways, and the two directions are each other's inverse:
//! [`Lens::ray`] takes a pixel `(u, v)` to its normalised ray `(x/z, y/z)` (back-projection:
//! the point at depth `z` is `(x/z·z, y/z·z, z)`), and [`Lens::project`] takes a
//! camera-frame point to its pixel (rendering, registration). Where one direction has a
//! closed form the other is solved by Newton's method to 1e-15 in normalised units.
//!
//! - [`Lens::Pinhole`]: `x/z = (u − cx)/fx`; bit for bit the pinhole of [`super::project`].
//! - [`Lens::Distorted`]: the Brown-Conrady polynomial `D` (OpenCV's `plumb_bob`,
//!   RealSense's `Brown Conrady`) maps an undistorted ray to where the lens images it, so
//!   projecting applies `D` and back-projecting inverts it. RealSense's `Inverse Brown
//!   Conrady` is the same polynomial the other way round: back-projecting applies `D`.
//! - [`Lens::Rays`]: a table of one ray per pixel (as `rays.npy` of the Punyo recording),
//!   bilinear between pixel centres; projecting inverts the interpolant by Newton's method
//!   from a pinhole fitted to the table.

// `!(a < b)` is meant: a NaN must fail these checks, which `a >= b` would let through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::PinholeIntrinsics;
use std::sync::Arc;
use thiserror::Error;

/// A lens model that cannot be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum LensError {
    /// The distortion model's name is not one we implement.
    #[error(
        "unknown distortion model {0:?} (known: brown_conrady or plumb_bob, \
         inverse_brown_conrady, none)"
    )]
    UnknownModel(String),
    /// A distortion coefficient is NaN or infinite.
    #[error("distortion coefficient {name} must be finite, got {value}")]
    NotFinite {
        /// `k1`, `k2`, `p1`, `p2` or `k3`.
        name: &'static str,
        /// The value found.
        value: f64,
    },
    /// The ray table's length is not its width times height.
    #[error("the ray table has {found} rays for {width}x{height} pixels")]
    TableLength {
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
        /// Rays given.
        found: usize,
    },
    /// A ray is infinite, or the table has fewer than two finite rays in either direction.
    #[error("the ray table {0}")]
    BadTable(String),
}

/// Which way the Brown-Conrady polynomial goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DistortionModel {
    /// Projection applies the polynomial (OpenCV `plumb_bob`, RealSense `Brown Conrady`).
    BrownConrady,
    /// Back-projection applies the polynomial (RealSense `Inverse Brown Conrady`).
    InverseBrownConrady,
}

impl DistortionModel {
    /// The model named `name` (case-insensitive; spaces and dashes read as `_`);
    /// `Ok(None)` for `none`.
    pub fn parse(name: &str) -> Result<Option<Self>, LensError> {
        let key = name.trim().to_ascii_lowercase().replace([' ', '-'], "_");
        match key.as_str() {
            "none" => Ok(None),
            "brown_conrady" | "plumb_bob" | "radtan" => Ok(Some(Self::BrownConrady)),
            "inverse_brown_conrady" => Ok(Some(Self::InverseBrownConrady)),
            _ => Err(LensError::UnknownModel(name.to_string())),
        }
    }
}

/// Brown-Conrady coefficients in OpenCV's and RealSense's order `k1, k2, p1, p2, k3`
/// (dimensionless, on normalised coordinates `x/z`, `y/z`; all 0 is the pinhole).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Distortion {
    /// Which direction applies the polynomial.
    pub model: DistortionModel,
    /// `[k1, k2, p1, p2, k3]`: radial r², r⁴, tangential, tangential, radial r⁶.
    pub coeffs: [f64; 5],
}

/// Newton's stopping residual, normalised units.
const NEWTON_TOL: f64 = 1e-15;
/// Newton's iteration cap; the solves here converge in under 10 from their first guesses.
const NEWTON_ITERS: usize = 60;

impl Distortion {
    /// Checks the coefficients are finite.
    pub fn new(model: DistortionModel, coeffs: [f64; 5]) -> Result<Self, LensError> {
        for (name, value) in ["k1", "k2", "p1", "p2", "k3"].into_iter().zip(coeffs) {
            if !value.is_finite() {
                return Err(LensError::NotFinite { name, value });
            }
        }
        Ok(Distortion { model, coeffs })
    }

    /// The polynomial `D(x, y)` and its Jacobian.
    fn polynomial(&self, [x, y]: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
        let [k1, k2, p1, p2, k3] = self.coeffs;
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        // d(radial)/d(r²).
        let dr = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
        let f = [
            x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
        ];
        let j = [
            [
                radial + 2.0 * x * x * dr + 2.0 * p1 * y + 6.0 * p2 * x,
                2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y,
            ],
            [
                2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y,
                radial + 2.0 * y * y * dr + 6.0 * p1 * y + 2.0 * p2 * x,
            ],
        ];
        (f, j)
    }

    /// `D⁻¹(target)` by Newton's method from `target`; `None` when it does not converge
    /// (far outside the field where the polynomial is one-to-one).
    fn invert(&self, target: [f64; 2]) -> Option<[f64; 2]> {
        newton(target, target, |p| Some(self.polynomial(p)))
    }

    /// Where the lens images the undistorted normalised ray `n` (normalised coordinates).
    pub fn distort(&self, n: [f64; 2]) -> Option<[f64; 2]> {
        match self.model {
            DistortionModel::BrownConrady => Some(self.polynomial(n).0),
            DistortionModel::InverseBrownConrady => self.invert(n),
        }
    }

    /// The undistorted normalised ray imaged at normalised coordinates `d`.
    pub fn undistort(&self, d: [f64; 2]) -> Option<[f64; 2]> {
        match self.model {
            DistortionModel::BrownConrady => self.invert(d),
            DistortionModel::InverseBrownConrady => Some(self.polynomial(d).0),
        }
    }
}

/// Solves `f(p) = target` from `start` by Newton's method; `f` gives the value and the
/// Jacobian, or `None` where it is undefined (a step that lands there is halved, up to
/// 30 times: a ray table's holes sit right beside rays that are fine).
fn newton(
    target: [f64; 2],
    start: [f64; 2],
    f: impl Fn([f64; 2]) -> Option<([f64; 2], [[f64; 2]; 2])>,
) -> Option<[f64; 2]> {
    let mut p = start;
    let (mut value, mut j) = f(p)?;
    for _ in 0..NEWTON_ITERS {
        let r = [value[0] - target[0], value[1] - target[1]];
        if r[0].abs().max(r[1].abs()) <= NEWTON_TOL * (1.0 + target[0].abs() + target[1].abs()) {
            return Some(p);
        }
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        if !(det.abs() > 1e-300) {
            return None;
        }
        let step = [
            (j[1][1] * r[0] - j[0][1] * r[1]) / det,
            (j[0][0] * r[1] - j[1][0] * r[0]) / det,
        ];
        let mut t = 1.0;
        loop {
            let q = [p[0] - t * step[0], p[1] - t * step[1]];
            if let Some(next) = f(q).filter(|_| q[0].is_finite() && q[1].is_finite()) {
                (p, (value, j)) = (q, next);
                break;
            }
            t *= 0.5;
            if t < 1e-9 {
                return None;
            }
        }
    }
    None
}

/// One normalised ray `(x/z, y/z)` per pixel, row-major; NaN where the pixel has no ray.
#[derive(Debug, Clone, PartialEq)]
pub struct RayTable {
    width: u32,
    height: u32,
    rays: Vec<[f32; 2]>,
    // A pinhole fitted to the table: Newton's first guess when projecting.
    fit: [f64; 4],
}

impl RayTable {
    /// A `width x height` table (rays row-major). Refuses a wrong length, an infinite ray,
    /// or fewer than two distinct finite rays along either axis (nothing to fit).
    pub fn new(width: u32, height: u32, rays: Vec<[f32; 2]>) -> Result<Self, LensError> {
        if rays.len() as u64 != u64::from(width) * u64::from(height) || width < 2 || height < 2 {
            return Err(LensError::TableLength {
                width,
                height,
                found: rays.len(),
            });
        }
        if rays.iter().flatten().any(|c| c.is_infinite()) {
            return Err(LensError::BadTable("has an infinite ray".into()));
        }
        let fit = fit_pinhole(width, &rays)?;
        Ok(RayTable {
            width,
            height,
            rays,
            fit,
        })
    }

    /// Columns.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pinhole fitted to the table by least squares, `[fx, fy, cx, cy]` (pixels).
    pub fn fitted_pinhole(&self) -> [f64; 4] {
        self.fit
    }

    /// The stored ray of pixel `(u, v)` (NaN where it has none); `None` outside the table.
    pub fn at(&self, u: u32, v: u32) -> Option<[f32; 2]> {
        (u < self.width && v < self.height)
            .then(|| self.rays[v as usize * self.width as usize + u as usize])
    }

    /// The ray at (sub-)pixel `(u, v)`, bilinear between the four stored rays around it, and
    /// its derivatives along u and v; `None` outside the table or next to a NaN ray.
    fn bilinear(&self, u: f64, v: f64) -> Option<([f64; 2], [[f64; 2]; 2])> {
        let (w, h) = (f64::from(self.width - 1), f64::from(self.height - 1));
        if !((0.0..=w).contains(&u) && (0.0..=h).contains(&v)) {
            return None;
        }
        let (i, j) = (u.floor().min(w - 1.0), v.floor().min(h - 1.0));
        let (fu, fv) = (u - i, v - j);
        let at = |du: u32, dv: u32| {
            self.at(i as u32 + du, j as u32 + dv)
                .map(|r| r.map(f64::from))
        };
        let (r00, r10, r01, r11) = (at(0, 0)?, at(1, 0)?, at(0, 1)?, at(1, 1)?);
        let mut value = [0.0; 2];
        let mut jac = [[0.0; 2]; 2];
        for c in 0..2 {
            value[c] = (1.0 - fv) * ((1.0 - fu) * r00[c] + fu * r10[c])
                + fv * ((1.0 - fu) * r01[c] + fu * r11[c]);
            jac[c][0] = (1.0 - fv) * (r10[c] - r00[c]) + fv * (r11[c] - r01[c]);
            jac[c][1] = (1.0 - fu) * (r01[c] - r00[c]) + fu * (r11[c] - r10[c]);
        }
        value.iter().all(|c| c.is_finite()).then_some((value, jac))
    }

    /// The ray through (sub-)pixel `(u, v)`; `None` outside the table or next to a NaN ray.
    pub fn ray(&self, u: f64, v: f64) -> Option<[f64; 2]> {
        self.bilinear(u, v).map(|(r, _)| r)
    }

    /// The (sub-)pixel whose interpolated ray is `n`; `None` when no pixel of the table
    /// sees it (outside the table's field, or where its rays are NaN).
    pub fn project(&self, n: [f64; 2]) -> Option<[f64; 2]> {
        let [fx, fy, cx, cy] = self.fit;
        // The fitted pinhole misses the table's rays by up to a few pixels, so its guess
        // may sit in a hole of the table although the point is seen: start from the
        // nearest defined cell within 4 pixels.
        let (w, h) = (f64::from(self.width - 1), f64::from(self.height - 1));
        let guess = [
            (fx * n[0] + cx).clamp(0.0, w),
            (fy * n[1] + cy).clamp(0.0, h),
        ];
        let mut offsets: Vec<[f64; 2]> = (-4..=4)
            .flat_map(|dv| (-4..=4).map(move |du| [f64::from(du), f64::from(dv)]))
            .collect();
        offsets.sort_by(|a, b| (a[0].hypot(a[1])).total_cmp(&b[0].hypot(b[1])));
        let start = offsets
            .iter()
            .map(|d| {
                [
                    (guess[0] + d[0]).clamp(0.0, w),
                    (guess[1] + d[1]).clamp(0.0, h),
                ]
            })
            .find(|p| self.bilinear(p[0], p[1]).is_some())?;
        newton(n, start, |p| {
            // A step outside the table is no point of it: halved back in by `newton`.
            self.bilinear(p[0], p[1])
        })
    }
}

/// Least squares `u = fx·x + cx`, `v = fy·y + cy` over the finite rays.
fn fit_pinhole(width: u32, rays: &[[f32; 2]]) -> Result<[f64; 4], LensError> {
    // Sums of t, t², pixel and t·pixel per axis.
    let mut s = [[0.0f64; 4]; 2];
    let mut n = 0.0;
    for (i, r) in rays.iter().enumerate() {
        if !(r[0].is_finite() && r[1].is_finite()) {
            continue;
        }
        let pix = [(i % width as usize) as f64, (i / width as usize) as f64];
        for c in 0..2 {
            let t = f64::from(r[c]);
            s[c][0] += t;
            s[c][1] += t * t;
            s[c][2] += pix[c];
            s[c][3] += t * pix[c];
        }
        n += 1.0;
    }
    let mut fit = [0.0; 4];
    for c in 0..2 {
        let [st, stt, sp, stp] = s[c];
        let det = n * stt - st * st;
        if !(det > 1e-12 * n * n) {
            return Err(LensError::BadTable(
                "has fewer than two distinct finite rays along an axis".into(),
            ));
        }
        fit[c] = (n * stp - st * sp) / det;
        fit[c + 2] = (sp - fit[c] * st) / n;
    }
    Ok(fit)
}

/// The lens in front of a camera's pinhole.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum Lens {
    /// No distortion: the pinhole of the intrinsics.
    #[default]
    Pinhole,
    /// Brown-Conrady distortion on top of the intrinsics' pinhole.
    Distorted(Distortion),
    /// A per-pixel ray table; the intrinsics give only the image size.
    Rays(Arc<RayTable>),
}

impl Lens {
    /// The normalised ray `(x/z, y/z)` through pixel `(u, v)`; `None` where the lens has
    /// none (a NaN in the ray table, a distortion that does not invert there).
    pub fn ray(&self, k: &PinholeIntrinsics, u: f64, v: f64) -> Option<[f64; 2]> {
        let d = [(u - k.cx) / k.fx, (v - k.cy) / k.fy];
        match self {
            Lens::Pinhole => Some(d),
            Lens::Distorted(dist) => dist.undistort(d),
            Lens::Rays(table) => table.ray(u, v),
        }
    }

    /// The pixel `[u, v]` of camera-frame point `p` (m); `None` when it is behind the
    /// camera (`z <= NEAR_Z`) or the lens does not image it.
    pub fn project(&self, k: &PinholeIntrinsics, p: [f64; 3]) -> Option<[f64; 2]> {
        let n = [p[0] / p[2], p[1] / p[2]];
        let uv = match self {
            Lens::Pinhole => return super::project(p, k),
            _ if !(p[2] > super::NEAR_Z) => return None,
            Lens::Distorted(dist) => {
                let d = dist.distort(n)?;
                [k.fx * d[0] + k.cx, k.fy * d[1] + k.cy]
            }
            Lens::Rays(table) => table.project(n)?,
        };
        (uv[0].is_finite() && uv[1].is_finite()).then_some(uv)
    }
}
