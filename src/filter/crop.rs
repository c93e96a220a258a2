//! Pass-through (PCL `PassThrough`) and the axis-aligned crop box (Open3D `crop`).

use super::mask::Mask;
use super::{FilterError, FilterOutput};
use crate::cloud::PointCloud;
use serde::{Deserialize, Serialize};

/// A per-point scalar a pass-through can test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Field {
    /// Position x, metres.
    X,
    /// Position y, metres.
    Y,
    /// Position z, metres.
    Z,
    /// Normal x component.
    NormalX,
    /// Normal y component.
    NormalY,
    /// Normal z component.
    NormalZ,
    /// Curvature.
    Curvature,
    /// Integer label, compared as `f32` (an extension: PCL refuses non-float fields).
    Label,
    /// Red channel 0..=255 (an extension: PCL only filters the packed float).
    R,
    /// Green channel 0..=255.
    G,
    /// Blue channel 0..=255.
    B,
}

impl Field {
    /// The PCD field name.
    pub fn name(self) -> &'static str {
        match self {
            Field::X => "x",
            Field::Y => "y",
            Field::Z => "z",
            Field::NormalX => "normal_x",
            Field::NormalY => "normal_y",
            Field::NormalZ => "normal_z",
            Field::Curvature => "curvature",
            Field::Label => "label",
            Field::R => "r",
            Field::G => "g",
            Field::B => "b",
        }
    }

    /// The field's values as `f32`, or an error if the cloud lacks the field.
    fn values(self, cloud: &PointCloud) -> Result<Vec<f32>, FilterError> {
        let missing = || FilterError::MissingField { field: self.name() };
        let n = |a: usize| -> Result<Vec<f32>, FilterError> {
            let v = cloud.normals.as_ref().ok_or_else(missing)?;
            Ok(v.iter().map(|p| p[a]).collect())
        };
        let c = |a: usize| -> Result<Vec<f32>, FilterError> {
            let v = cloud.colors.as_ref().ok_or_else(missing)?;
            Ok(v.iter().map(|p| p[a] as f32).collect())
        };
        match self {
            Field::X | Field::Y | Field::Z => {
                let a = self as usize;
                Ok(cloud.positions.iter().map(|p| p[a]).collect())
            }
            Field::NormalX => n(0),
            Field::NormalY => n(1),
            Field::NormalZ => n(2),
            Field::Curvature => Ok(cloud.curvature.as_ref().ok_or_else(missing)?.clone()),
            Field::Label => Ok(cloud
                .labels
                .as_ref()
                .ok_or_else(missing)?
                .iter()
                .map(|&l| l as f32)
                .collect()),
            Field::R => c(0),
            Field::G => c(1),
            Field::B => c(2),
        }
    }
}

impl std::str::FromStr for Field {
    type Err = FilterError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "x" => Field::X,
            "y" => Field::Y,
            "z" => Field::Z,
            "normal_x" | "nx" => Field::NormalX,
            "normal_y" | "ny" => Field::NormalY,
            "normal_z" | "nz" => Field::NormalZ,
            "curvature" => Field::Curvature,
            "label" => Field::Label,
            "r" | "red" => Field::R,
            "g" | "green" => Field::G,
            "b" | "blue" => Field::B,
            _ => return Err(FilterError::UnknownField(s.to_string())),
        })
    }
}

/// Parameters of [`pass_through`] (PCL `PassThrough`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PassThroughParams {
    /// Field to test; `None` only removes points with a non-finite coordinate.
    pub field: Option<Field>,
    /// Lower bound, inclusive, compared in `f32`.
    pub min: f32,
    /// Upper bound, inclusive, compared in `f32`.
    pub max: f32,
    /// Keep the points outside `[min, max]` instead (bounds themselves are removed).
    pub negative: bool,
    /// Return the whole cloud with removed points' xyz set to `user_filter_value`.
    pub keep_organized: bool,
    /// Value written into removed points' xyz when `keep_organized` (NaN by default).
    pub user_filter_value: f32,
}

impl Default for PassThroughParams {
    fn default() -> Self {
        PassThroughParams {
            field: None,
            min: -f32::MAX,
            max: f32::MAX,
            negative: false,
            keep_organized: false,
            user_filter_value: f32::NAN,
        }
    }
}

impl PassThroughParams {
    /// Keep `min ≤ field ≤ max`.
    pub fn new(field: Field, min: f32, max: f32) -> Self {
        PassThroughParams {
            field: Some(field),
            min,
            max,
            ..Default::default()
        }
    }
}

/// PCL `PassThrough`: keeps points with `min ≤ v ≤ max` (or, in negative mode, `v < min`
/// or `v > max`), compared in `f32`. A point with a non-finite x, y or z or a
/// non-finite field value is removed in both modes. Output is in input order; if every
/// point survives, the output is the input unchanged (organization kept), otherwise it
/// is unorganized, unless `keep_organized`, which returns the whole cloud with removed
/// points' xyz set to `user_filter_value` (the indices still list the kept points).
pub fn pass_through(
    cloud: &PointCloud,
    params: &PassThroughParams,
) -> Result<FilterOutput, FilterError> {
    let mut out = FilterOutput::default();
    pass_through_into(cloud, params, &mut out)?;
    Ok(out)
}

/// [`pass_through`] into `out`, reusing its buffers (for a stream of frames: no
/// allocation once they have grown to the frame size). On error `out` is unspecified.
pub fn pass_through_into(
    cloud: &PointCloud,
    params: &PassThroughParams,
    out: &mut FilterOutput,
) -> Result<(), FilterError> {
    let mask = pass_through_mask(cloud, params)?;
    mask.indices_into(&mut out.indices);
    let indices = &out.indices;
    if params.keep_organized {
        out.cloud.clone_from(cloud);
        let mut keep = vec![false; cloud.len()];
        indices.iter().for_each(|&i| keep[i] = true);
        let v = params.user_filter_value;
        for (p, k) in out.cloud.positions.iter_mut().zip(&keep) {
            if !k {
                *p = [v, v, v];
            }
        }
    } else if indices.len() == cloud.len() {
        out.cloud.clone_from(cloud);
    } else {
        mask.select_into(cloud, &mut out.cloud);
    }
    Ok(())
}

/// The kept indices of [`pass_through`] alone (the work PCL's `PassThrough::filter(indices)`
/// does), written into `out` (cleared first, its allocation reused), without building the
/// output cloud.
pub fn pass_through_indices_into(
    cloud: &PointCloud,
    params: &PassThroughParams,
    out: &mut Vec<usize>,
) -> Result<(), FilterError> {
    pass_through_mask(cloud, params)?.indices_into(out);
    Ok(())
}

/// The points [`pass_through`] keeps, as a bit mask.
fn pass_through_mask(cloud: &PointCloud, params: &PassThroughParams) -> Result<Mask, FilterError> {
    cloud.validate()?;
    let pos = &cloud.positions;
    let (lo, hi, negative) = (params.min, params.max, params.negative);
    // Non-short-circuit `&`: no branches, so the per-64-points mask loop stays straight.
    let test = |v: f32| finite(v) & ((lo <= v) & (v <= hi) != negative);
    let point_ok = |p: &[f32; 3]| finite(p[0]) & finite(p[1]) & finite(p[2]);
    // `-MAX ≤ v ≤ MAX` is `v.is_finite()`, and `finite(v) & lo ≤ v ≤ hi` is
    // `max(lo, -MAX) ≤ v ≤ min(hi, MAX)` (a NaN bound stays NaN: nothing passes).
    let finite_within = |lo: f32, hi: f32| {
        let clamp = |b: f32, f: fn(f32, f32) -> f32, l: f32| if b.is_nan() { b } else { f(b, l) };
        (
            clamp(lo, f32::max, -f32::MAX),
            clamp(hi, f32::min, f32::MAX),
        )
    };
    Ok(match params.field {
        None => Mask::in_box(pos, [-f32::MAX; 3], [f32::MAX; 3], false),
        Some(field @ (Field::X | Field::Y | Field::Z)) if !negative => {
            let (mut lo3, mut hi3) = ([-f32::MAX; 3], [f32::MAX; 3]);
            (lo3[field as usize], hi3[field as usize]) = finite_within(lo, hi);
            Mask::in_box(pos, lo3, hi3, false)
        }
        Some(field @ (Field::X | Field::Y | Field::Z)) => {
            let a = field as usize;
            Mask::from_fn(pos, |p| point_ok(p) & test(p[a]))
        }
        Some(field) => {
            let values = field.values(cloud)?;
            let ok: Vec<bool> = pos
                .iter()
                .zip(&values)
                .map(|(p, &v)| point_ok(p) & test(v))
                .collect();
            Mask::from_fn(&ok, |&k| k)
        }
    })
}

/// `v.is_finite()` as a bit test (no branch).
#[inline]
fn finite(v: f32) -> bool {
    v.to_bits() & 0x7fff_ffff < 0x7f80_0000
}

/// Parameters of [`crop_box`] (Open3D `crop` with an axis-aligned box).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CropBoxParams {
    /// Lower corner, metres, inclusive (infinite values are allowed).
    pub min: [f64; 3],
    /// Upper corner, metres, inclusive.
    pub max: [f64; 3],
    /// Keep the points outside the box instead (and the non-finite ones, as Open3D does).
    pub invert: bool,
}

impl Default for CropBoxParams {
    fn default() -> Self {
        CropBoxParams {
            min: [f64::NEG_INFINITY; 3],
            max: [f64::INFINITY; 3],
            invert: false,
        }
    }
}

/// Open3D's axis-aligned crop: keeps points with `min ≤ p ≤ max` on all three axes,
/// compared in `f64`. Non-finite points fail the test, so they are removed, and kept
/// when `invert`. Output is unorganized, in input order. Unlike Open3D, a zero-thickness
/// box is allowed; `min > max` or a NaN bound is an error (Open3D swaps silently).
pub fn crop_box(cloud: &PointCloud, params: &CropBoxParams) -> Result<FilterOutput, FilterError> {
    let mut out = FilterOutput::default();
    crop_box_into(cloud, params, &mut out)?;
    Ok(out)
}

/// [`crop_box`] into `out`, reusing its buffers. On error `out` is unspecified.
pub fn crop_box_into(
    cloud: &PointCloud,
    params: &CropBoxParams,
    out: &mut FilterOutput,
) -> Result<(), FilterError> {
    cloud.validate()?;
    let mask = crop_box_mask(&cloud.positions, params)?;
    mask.indices_into(&mut out.indices);
    mask.select_into(cloud, &mut out.cloud);
    Ok(())
}

/// The kept indices of [`crop_box`] alone (the work PCL's `CropBox::filter(indices)`
/// does), without building the output cloud.
pub fn crop_box_indices(
    positions: &[[f32; 3]],
    params: &CropBoxParams,
) -> Result<Vec<usize>, FilterError> {
    let mut out = Vec::new();
    crop_box_indices_into(positions, params, &mut out)?;
    Ok(out)
}

/// [`crop_box_indices`] into `out` (cleared first, its allocation reused).
pub fn crop_box_indices_into(
    positions: &[[f32; 3]],
    params: &CropBoxParams,
    out: &mut Vec<usize>,
) -> Result<(), FilterError> {
    crop_box_mask(positions, params)?.indices_into(out);
    Ok(())
}

/// The points [`crop_box`] keeps, as a bit mask.
///
/// PERF: the `f64` bounds are replaced by the equivalent `f32` bounds (the smallest
/// `f32` ≥ `min`, the largest `f32` ≤ `max`), so the test is exact in `f32`.
fn crop_box_mask(positions: &[[f32; 3]], params: &CropBoxParams) -> Result<Mask, FilterError> {
    let (lo, hi) = (params.min, params.max);
    if (0..3).any(|a| lo[a].is_nan() || hi[a].is_nan() || lo[a] > hi[a]) {
        return Err(FilterError::InvalidBox { min: lo, max: hi });
    }
    let lo32: [f32; 3] = std::array::from_fn(|a| f32_at_least(lo[a]));
    let hi32: [f32; 3] = std::array::from_fn(|a| f32_at_most(hi[a]));
    Ok(Mask::in_box(positions, lo32, hi32, params.invert))
}

/// The smallest `f32` whose value is ≥ `v` (`v` not NaN); `x as f64 >= v` ⇔ `x >= it`.
fn f32_at_least(v: f64) -> f32 {
    let r = v as f32;
    if (r as f64) < v {
        next_up(r)
    } else {
        r
    }
}

/// The largest `f32` whose value is ≤ `v` (`v` not NaN); `x as f64 <= v` ⇔ `x <= it`.
fn f32_at_most(v: f64) -> f32 {
    let r = v as f32;
    if (r as f64) > v {
        -next_up(-r)
    } else {
        r
    }
}

/// The next `f32` towards +∞ (`x` itself for NaN and +∞).
fn next_up(x: f32) -> f32 {
    if x.is_nan() || x == f32::INFINITY {
        x
    } else if x == 0.0 {
        f32::from_bits(1)
    } else if x > 0.0 {
        f32::from_bits(x.to_bits() + 1)
    } else {
        f32::from_bits(x.to_bits() - 1)
    }
}
