//! The point cloud: columnar (structure-of-arrays) storage in `f32`.
//!
//! A [`PointCloud`] holds positions and, optionally, colours, alpha, normals, curvature and
//! labels, each as its own `Vec` of the same length. An organized cloud (an image-shaped
//! cloud from a depth camera) keeps its `width x height`; invalid pixels are NaN points,
//! as in PCL. Every stage that removes points also returns the kept indices, so that
//! results can be traced back to the input ([`PointCloud::select`]).
//!
//! ```
//! use softsense::cloud::PointCloud;
//! let mut cloud = PointCloud::from_positions(vec![[0.0, 0.0, 1.0], [f32::NAN, 0.0, 0.0], [1.0, 2.0, 3.0]]);
//! cloud.colors = Some(vec![[255, 0, 0], [0, 255, 0], [0, 0, 255]]);
//! let finite = cloud.finite_indices();
//! assert_eq!(finite, vec![0, 2]);
//! let dense = cloud.select(&finite);
//! assert_eq!(dense.len(), 2);
//! assert_eq!(dense.colors.as_ref().unwrap()[1], [0, 0, 255]);
//! ```

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors of point-cloud operations.
#[derive(Debug, Error, PartialEq)]
pub enum CloudError {
    /// An attribute column does not have one entry per point.
    #[error("attribute `{field}` has {got} entries but the cloud has {expected} points")]
    LengthMismatch {
        /// The attribute's name.
        field: &'static str,
        /// Number of points in the cloud.
        expected: usize,
        /// Number of entries in the attribute.
        got: usize,
    },
    /// `width * height` does not equal the number of points.
    #[error("organized size {width}x{height} does not match {points} points")]
    BadOrganization {
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// Number of points.
        points: usize,
    },
    /// An index refers past the end of the cloud.
    #[error("index {index} is out of range for a cloud of {len} points")]
    IndexOutOfRange {
        /// The offending index.
        index: usize,
        /// Number of points.
        len: usize,
    },
}

/// The sensor pose stored with a cloud (PCD `VIEWPOINT`): translation and a unit
/// quaternion `(w, x, y, z)`. PCL orients normals towards `origin` by default.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Viewpoint {
    /// Sensor origin in the cloud's frame, metres.
    pub origin: [f32; 3],
    /// Sensor orientation as a quaternion `(w, x, y, z)`.
    pub orientation: [f32; 4],
}

impl Default for Viewpoint {
    fn default() -> Self {
        Viewpoint {
            origin: [0.0; 3],
            orientation: [1.0, 0.0, 0.0, 0.0],
        }
    }
}

/// A point cloud in columnar layout. All present attribute columns have `len()` entries.
///
/// Frames are the caller's to name (`points_in_camera`, `points_in_robot`); the cloud
/// itself only carries the sensor [`Viewpoint`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointCloud {
    /// Point positions, metres. Invalid points are NaN in all three coordinates.
    pub positions: Vec<[f32; 3]>,
    /// Colours as 8-bit RGB.
    pub colors: Option<Vec<[u8; 3]>>,
    /// The alpha byte of PCL's packed `rgba`/`rgb` field, kept so files round-trip.
    pub alpha: Option<Vec<u8>>,
    /// Unit normals (NaN where undefined).
    pub normals: Option<Vec<[f32; 3]>>,
    /// Surface curvature `λ0 / (λ0 + λ1 + λ2)` (PCL's definition).
    pub curvature: Option<Vec<f32>>,
    /// Integer labels (segment ids, ground-truth labels).
    pub labels: Option<Vec<u32>>,
    /// Organized width: the number of columns; for an unorganized cloud, `len()`.
    pub width: u32,
    /// Organized height: the number of rows; 1 for an unorganized cloud.
    pub height: u32,
    /// Sensor pose the cloud was acquired from.
    pub viewpoint: Viewpoint,
}

impl PointCloud {
    /// An unorganized cloud of the given positions, with no other attributes.
    pub fn from_positions(positions: Vec<[f32; 3]>) -> Self {
        let width = u32::try_from(positions.len()).unwrap_or(u32::MAX);
        PointCloud {
            positions,
            width,
            height: 1,
            ..Default::default()
        }
    }

    /// Number of points (including NaN points).
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True when the cloud has no points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// True when the cloud is image-shaped (`height > 1`), as PCL defines it.
    pub fn is_organized(&self) -> bool {
        self.height > 1
    }

    /// True when a point's three coordinates are all finite.
    #[inline]
    pub fn is_finite_point(p: &[f32; 3]) -> bool {
        p[0].is_finite() && p[1].is_finite() && p[2].is_finite()
    }

    /// Number of points with finite coordinates.
    pub fn count_finite(&self) -> usize {
        self.positions
            .iter()
            .filter(|p| Self::is_finite_point(p))
            .count()
    }

    /// True when every point is finite (PCL's `is_dense`).
    pub fn is_dense(&self) -> bool {
        self.positions.iter().all(Self::is_finite_point)
    }

    /// Indices of the points with finite coordinates, ascending.
    pub fn finite_indices(&self) -> Vec<usize> {
        self.positions
            .iter()
            .enumerate()
            .filter(|(_, p)| Self::is_finite_point(p))
            .map(|(i, _)| i)
            .collect()
    }

    /// Names of the fields present, in PCD order (`x y z`, then `rgb`, normals, ...).
    pub fn field_names(&self) -> Vec<&'static str> {
        let mut f = vec!["x", "y", "z"];
        if self.colors.is_some() {
            f.push(if self.alpha.is_some() { "rgba" } else { "rgb" });
        }
        if self.normals.is_some() {
            f.extend(["normal_x", "normal_y", "normal_z"]);
        }
        if self.curvature.is_some() {
            f.push("curvature");
        }
        if self.labels.is_some() {
            f.push("label");
        }
        f
    }

    /// Axis-aligned bounds `(min, max)` of the finite points, or `None` if there are none.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        let mut it = self.positions.iter().filter(|p| Self::is_finite_point(p));
        let first = *it.next()?;
        let (mut lo, mut hi) = (first, first);
        for p in it {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        Some((lo, hi))
    }

    /// Checks that every attribute column has one entry per point and that
    /// `width * height == len()`.
    pub fn validate(&self) -> Result<(), CloudError> {
        let n = self.len();
        let check = |field: &'static str, got: Option<usize>| match got {
            Some(got) if got != n => Err(CloudError::LengthMismatch {
                field,
                expected: n,
                got,
            }),
            _ => Ok(()),
        };
        check("rgb", self.colors.as_ref().map(Vec::len))?;
        check("alpha", self.alpha.as_ref().map(Vec::len))?;
        check("normals", self.normals.as_ref().map(Vec::len))?;
        check("curvature", self.curvature.as_ref().map(Vec::len))?;
        check("label", self.labels.as_ref().map(Vec::len))?;
        if (self.width as u64) * (self.height as u64) != n as u64 {
            return Err(CloudError::BadOrganization {
                width: self.width,
                height: self.height,
                points: n,
            });
        }
        Ok(())
    }

    /// A new unorganized cloud of the points at `indices`, in that order, with every
    /// attribute carried along. Panics if an index is out of range (a programmer error);
    /// use [`PointCloud::try_select`] for untrusted indices.
    pub fn select(&self, indices: &[usize]) -> PointCloud {
        self.try_select(indices)
            .expect("PointCloud::select: index out of range")
    }

    /// Like [`PointCloud::select`], but returns an error for an out-of-range index.
    pub fn try_select(&self, indices: &[usize]) -> Result<PointCloud, CloudError> {
        let len = self.len();
        if let Some(&index) = indices.iter().find(|&&i| i >= len) {
            return Err(CloudError::IndexOutOfRange { index, len });
        }
        fn pick<T: Copy>(col: &Option<Vec<T>>, idx: &[usize]) -> Option<Vec<T>> {
            col.as_ref().map(|c| idx.iter().map(|&i| c[i]).collect())
        }
        Ok(PointCloud {
            positions: indices.iter().map(|&i| self.positions[i]).collect(),
            colors: pick(&self.colors, indices),
            alpha: pick(&self.alpha, indices),
            normals: pick(&self.normals, indices),
            curvature: pick(&self.curvature, indices),
            labels: pick(&self.labels, indices),
            width: u32::try_from(indices.len()).unwrap_or(u32::MAX),
            height: 1,
            viewpoint: self.viewpoint,
        })
    }

    /// [`PointCloud::select`] into `out`, reusing its column buffers (a stream of frames
    /// allocates nothing once they have grown). `out`'s columns become those of `self`.
    /// Panics if an index is out of range (a programmer error).
    pub fn select_into(&self, indices: &[usize], out: &mut PointCloud) {
        fn pick<T: Copy>(col: &Option<Vec<T>>, idx: &[usize], dst: &mut Option<Vec<T>>) {
            match col {
                None => *dst = None,
                Some(c) => {
                    let d = dst.get_or_insert_with(Vec::new);
                    d.clear();
                    d.extend(idx.iter().map(|&i| c[i]));
                }
            }
        }
        out.positions.clear();
        out.positions
            .extend(indices.iter().map(|&i| self.positions[i]));
        pick(&self.colors, indices, &mut out.colors);
        pick(&self.alpha, indices, &mut out.alpha);
        pick(&self.normals, indices, &mut out.normals);
        pick(&self.curvature, indices, &mut out.curvature);
        pick(&self.labels, indices, &mut out.labels);
        out.width = u32::try_from(indices.len()).unwrap_or(u32::MAX);
        out.height = 1;
        out.viewpoint = self.viewpoint;
    }

    /// The same cloud with non-finite points removed, and the kept indices.
    /// The result is unorganized unless every point was finite, in which case the
    /// organization is kept (PCL's `removeNaNFromPointCloud` does the same).
    pub fn remove_non_finite(&self) -> (PointCloud, Vec<usize>) {
        let idx = self.finite_indices();
        if idx.len() == self.len() {
            return (self.clone(), idx);
        }
        (self.select(&idx), idx)
    }
}

/// The indices in `0..len` that are not in `indices` (which need not be sorted), ascending.
pub fn complement(indices: &[usize], len: usize) -> Vec<usize> {
    let mut keep = vec![true; len];
    for &i in indices {
        if i < len {
            keep[i] = false;
        }
    }
    (0..len).filter(|&i| keep[i]).collect()
}

/// Maps indices into a selection back to indices into the original cloud:
/// `result[k] = selection[inner[k]]`. Use it to chain stages: if stage 1 kept
/// `selection` of the input and stage 2 kept `inner` of stage 1's output, the input
/// indices kept by both are `remap(selection, inner)`.
pub fn remap(selection: &[usize], inner: &[usize]) -> Vec<usize> {
    inner.iter().map(|&k| selection[k]).collect()
}
