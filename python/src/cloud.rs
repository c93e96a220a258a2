//! Clouds: read, write and filter, with positions and attributes as bytes.

use crate::error;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use softsense::filter::{
    crop_box, pass_through, radius_outlier_removal, statistical_outlier_removal, voxel_grid,
    CropBoxParams, FilterError, FilterOutput, PassThroughParams, RadiusOutlierParams,
    StatisticalOutlierParams, VoxelGridParams,
};
use softsense::io::Encoding;
use softsense::PointCloud;

/// A point cloud held by the library (the `softsense.Cloud` arrays are built from it).
#[pyclass(module = "softsense._softsense", frozen)]
pub struct NativeCloud(pub PointCloud);

/// `bytes` as `n` groups of `K` values of `size` bytes each, decoded by `read`.
fn columns<T, const K: usize>(
    bytes: &[u8],
    size: usize,
    name: &str,
    read: impl Fn(&[u8]) -> T,
) -> PyResult<Vec<[T; K]>> {
    if bytes.len() % (size * K) != 0 {
        return Err(error(format!(
            "{name}: {} bytes is not a whole number of {K}-value rows",
            bytes.len()
        )));
    }
    Ok(bytes
        .chunks_exact(size * K)
        .map(|row| std::array::from_fn(|i| read(&row[i * size..(i + 1) * size])))
        .collect())
}

fn f32_le(b: &[u8]) -> f32 {
    f32::from_le_bytes([b[0], b[1], b[2], b[3]])
}

fn flat<T: Copy, const K: usize>(rows: &[[T; K]], bytes: impl Fn(T) -> Vec<u8>) -> Vec<u8> {
    rows.iter().flatten().flat_map(|&v| bytes(v)).collect()
}

#[pymethods]
impl NativeCloud {
    /// A cloud from little-endian bytes: positions N x 3 f32, colours N x 3 u8, normals
    /// N x 3 f32, labels N u32, curvature N f32; `width` x `height` for an organised cloud
    /// (`height` 1 otherwise).
    #[new]
    #[pyo3(signature = (positions, colors=None, normals=None, labels=None, curvature=None, width=None, height=1))]
    fn new(
        positions: &[u8],
        colors: Option<&[u8]>,
        normals: Option<&[u8]>,
        labels: Option<&[u8]>,
        curvature: Option<&[u8]>,
        width: Option<u32>,
        height: u32,
    ) -> PyResult<Self> {
        let mut cloud =
            PointCloud::from_positions(columns::<f32, 3>(positions, 4, "positions", f32_le)?);
        cloud.colors = colors
            .map(|c| columns::<u8, 3>(c, 1, "colors", |b| b[0]))
            .transpose()?;
        cloud.normals = normals
            .map(|n| columns::<f32, 3>(n, 4, "normals", f32_le))
            .transpose()?;
        cloud.labels = labels
            .map(|l| {
                columns::<u32, 1>(l, 4, "labels", |b| {
                    u32::from_le_bytes([b[0], b[1], b[2], b[3]])
                })
            })
            .transpose()?
            .map(|v| v.into_iter().map(|[x]| x).collect());
        cloud.curvature = curvature
            .map(|c| columns::<f32, 1>(c, 4, "curvature", f32_le))
            .transpose()?
            .map(|v| v.into_iter().map(|[x]| x).collect());
        cloud.height = height;
        cloud.width = width.unwrap_or(cloud.positions.len() as u32 / height.max(1));
        cloud.validate().map_err(error)?;
        Ok(NativeCloud(cloud))
    }

    /// Number of points.
    fn __len__(&self) -> usize {
        self.0.len()
    }

    /// The columns as little-endian bytes, `None` for an absent attribute, and the shape:
    /// `(positions, colors, normals, labels, curvature, width, height)`.
    fn parts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        let c = &self.0;
        let le32 = |v: f32| v.to_le_bytes().to_vec();
        let bytes = |b: Vec<u8>| PyBytes::new(py, &b);
        let positions = bytes(flat(&c.positions, le32));
        let colors = c.colors.as_ref().map(|v| bytes(flat(v, |x| vec![x])));
        let normals = c.normals.as_ref().map(|v| bytes(flat(v, le32)));
        let labels = c
            .labels
            .as_ref()
            .map(|v| bytes(v.iter().flat_map(|x| x.to_le_bytes()).collect()));
        let curvature = c
            .curvature
            .as_ref()
            .map(|v| bytes(v.iter().flat_map(|x| x.to_le_bytes()).collect()));
        (
            positions, colors, normals, labels, curvature, c.width, c.height,
        )
            .into_pyobject(py)
    }
}

/// Reads a PCD, PLY or XYZ file (by extension).
#[pyfunction]
fn read_cloud(py: Python<'_>, path: std::path::PathBuf) -> PyResult<NativeCloud> {
    py.detach(|| softsense::io::read_cloud(&path))
        .map(NativeCloud)
        .map_err(error)
}

/// Writes a cloud by extension (PCD, PLY, XYZ), all or nothing; `encoding` is "binary",
/// "ascii" or "binary_compressed".
#[pyfunction]
#[pyo3(signature = (path, cloud, encoding="binary"))]
fn write_cloud(
    py: Python<'_>,
    path: std::path::PathBuf,
    cloud: &NativeCloud,
    encoding: &str,
) -> PyResult<()> {
    let encoding = match encoding {
        "binary" => Encoding::Binary,
        "ascii" => Encoding::Ascii,
        "binary_compressed" => Encoding::BinaryCompressed,
        other => {
            return Err(error(format!(
                "encoding {other:?}: use \"binary\", \"ascii\" or \"binary_compressed\""
            )))
        }
    };
    py.detach(|| softsense::io::write_cloud(&path, &cloud.0, encoding))
        .map_err(error)
}

/// Runs the filter `name` with `params` (a JSON object of the library's parameter
/// names; absent ones take the library's defaults). Returns the filtered cloud and, as
/// little-endian u64 bytes, the input index of each output point.
#[pyfunction]
#[pyo3(signature = (name, cloud, params=None))]
fn filter<'py>(
    py: Python<'py>,
    name: &str,
    cloud: &NativeCloud,
    params: Option<&str>,
) -> PyResult<(NativeCloud, Bound<'py, PyBytes>)> {
    let input = &cloud.0;
    // Each filter's parameters from the JSON, then the filter with the GIL released.
    fn run<P>(
        py: Python<'_>,
        input: &PointCloud,
        name: &str,
        params: Option<&str>,
        f: impl Fn(&PointCloud, &P) -> Result<FilterOutput, FilterError> + Sync,
    ) -> PyResult<Result<FilterOutput, FilterError>>
    where
        P: Default + serde::Serialize + serde::de::DeserializeOwned + Sync,
    {
        let p = crate::params::<P>(params, name)?;
        Ok(py.detach(|| f(input, &p)))
    }
    let out = match name {
        "voxel_grid" => run::<VoxelGridParams>(py, input, name, params, voxel_grid)?,
        "statistical_outlier_removal" => {
            run::<StatisticalOutlierParams>(py, input, name, params, statistical_outlier_removal)?
        }
        "radius_outlier_removal" => {
            run::<RadiusOutlierParams>(py, input, name, params, radius_outlier_removal)?
        }
        "crop_box" => run::<CropBoxParams>(py, input, name, params, crop_box)?,
        "pass_through" => run::<PassThroughParams>(py, input, name, params, pass_through)?,
        other => return Err(error(format!("no filter named {other:?}"))),
    }
    .map_err(error)?;
    let indices: Vec<u8> = out
        .indices
        .iter()
        .flat_map(|&i| (i as u64).to_le_bytes())
        .collect();
    Ok((NativeCloud(out.cloud), PyBytes::new(py, &indices)))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeCloud>()?;
    m.add_function(wrap_pyfunction!(read_cloud, m)?)?;
    m.add_function(wrap_pyfunction!(write_cloud, m)?)?;
    m.add_function(wrap_pyfunction!(filter, m)?)?;
    Ok(())
}
