//! Geometric segmentation (our own mode, not PCL's): support-plane removal, smooth region
//! growing on normals and curvature, and a convexity and colour merge of the regions.
//!
//! PCL's `RegionGrowingRGB` with the thesis parameters finds fewer than half of the
//! objects of the mOSD scenes: colour alone neither separates equally coloured touching
//! objects nor keeps a printed box in one piece. This mode uses the geometry instead:
//!
//! 1. normals and curvature by PCA over a radius ([`crate::features::estimate_normals`],
//!    oriented towards the viewpoint);
//! 2. the dominant plane (RANSAC with a fixed seed, least-squares refit) is the support
//!    (the table) when it holds enough of the points; its inliers (close to the plane
//!    *and* with a normal along it) are split into connected parts that become segments
//!    of their own, flagged as support;
//! 3. the remaining points are grown into smooth regions in ascending curvature order
//!    (as PCL `RegionGrowing`): a neighbour joins when its normal is within the
//!    smoothness angle of the current point's, and continues the growth only when its
//!    curvature is low, so creases stop the growth;
//! 4. regions below the minimum area join the neighbouring region they share the most
//!    neighbour pairs with (crease fragments), isolated ones are dropped;
//! 5. adjacent regions merge unless their junction is concave: with region normals
//!    `nA`, `nB` and the unit vectors `d` from an `A` point to a neighbouring `B` point,
//!    the mean of `(nA - nB)·d` is positive for a concave junction (two objects, or an
//!    object on another) and negative for a convex one (two faces of one box, a lid on a
//!    can). Clearly convex junctions merge whatever the colours (printed faces differ);
//!    flat ones (coplanar regions) merge only when their mean colours are close in
//!    CIELAB, so two flush objects of different colour stay apart.
//!
//! Every threshold is a physical quantity (metres, degrees, square metres, ΔE); point
//! counts are derived from the measured point spacing, so the same parameters serve raw
//! sensor frames and voxel-filtered clouds. [`GeometricParams::default`] documents why
//! each value was chosen.
//!
//! ```
//! use softsense::segment::geometric::{segment_geometric, GeometricParams};
//! use softsense::PointCloud;
//! // A 30 cm table 1 m in front of the camera (z = 1 m) and a 6 cm cube standing on it,
//! // off the optical axis so that its top and two faces (x = 0.04, y = 0.04) are seen.
//! let s = 0.005f32;
//! let mut pts = Vec::new();
//! for i in 0..60 { for j in 0..60 { pts.push([-0.1 + i as f32 * s, -0.1 + j as f32 * s, 1.0]); } }
//! for i in 0..12 { for j in 0..12 { pts.push([0.04 + i as f32 * s, 0.04 + j as f32 * s, 0.94]); } }
//! for i in 0..12 { for k in 1..12 {
//!     pts.push([0.04 + i as f32 * s, 0.04, 0.94 + k as f32 * s]);
//!     pts.push([0.04, 0.04 + i as f32 * s, 0.94 + k as f32 * s]);
//! } }
//! let mut cloud = PointCloud::from_positions(pts);
//! cloud.colors = Some(vec![[200, 200, 200]; cloud.len()]);
//! let out = segment_geometric(&cloud, &GeometricParams::default()).unwrap();
//! assert_eq!(out.support.len(), 1);
//! assert_eq!(out.segmentation.segments.len(), 2); // the table and the cube
//! ```

use super::color::rgb_to_lab;
use super::region_growing_rgb::{describe, Segmentation};
use super::{check_distance, check_threshold, SegmentError, UNSEGMENTED};
use crate::cloud::PointCloud;
use crate::features::{estimate_normals, Neighbourhood, NormalParams};
use crate::search::{map_indices, KdTree, Parallelism, RadiusQuery};

mod plane;
mod regions;
use plane::{plane_members, support_plane};
use regions::Regions;

/// Parameters of [`segment_geometric`]. The defaults are set once from the sensor and
/// the object sizes (Kinect-class RGB-D at 0.5-1.5 m, tabletop objects of a few cm and
/// more), not fitted to any data set.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct GeometricParams {
    /// Radius (m) of the PCA neighbourhood for normals and curvature. 15 mm: three
    /// times a 5 mm voxel and about ten times the Kinect depth noise at 1 m (~1.5-3 mm),
    /// so normals are not noise, while a 5 cm object face still has a flat interior.
    pub normal_radius_m: f64,
    /// Radius (m) within which two points are neighbours for growing and adjacency.
    /// 10 mm: the thesis' region-growing distance; two 5 mm voxels, five raw pixels at 1 m.
    pub connect_radius_m: f64,
    /// Closest neighbours kept per point within `connect_radius_m` (bounds memory).
    pub max_neighbours: usize,
    /// Support plane inlier distance (m). 10 mm: three sigma of the depth noise at
    /// 1.5 m; an object's base closer than this to the table is lost only where its
    /// normal also lies along the table's.
    pub plane_distance_m: f64,
    /// Largest angle (degrees) between a point's normal and the plane normal for the
    /// point to belong to the support. 25 degrees: noisy normals of a flat table, not
    /// the vertical faces of objects standing on it.
    pub plane_normal_deg: f64,
    /// Smallest share of the points the dominant plane must hold to be taken as the
    /// support (0.2: a table filling a fifth of the view).
    pub plane_min_fraction: f64,
    /// RANSAC iterations (500: a plane holding 20% of the points is sampled with
    /// probability 1 - (1 - 0.2^3)^500 > 0.98).
    pub ransac_iterations: usize,
    /// Largest angle (degrees) between neighbouring normals for smooth growth. 10
    /// degrees: above the normal noise of a 15 mm patch, below the turn of a 5 mm step
    /// across a 90 degree crease.
    pub smoothness_deg: f64,
    /// Largest curvature (`λ0/Σλ`) of a point that continues the growth. 0.03 is a
    /// plane with ~1 mm noise over a 15 mm patch; creases reach 0.1-0.3.
    pub curvature_max: f64,
    /// Concavity tolerance (degrees): adjacent regions whose mean `(nA - nB)·d` exceeds
    /// `sin` of this are a concave junction and stay apart; below `-sin` of it the
    /// junction is convex and they merge (LCCP's 10 degrees).
    pub concavity_deg: f64,
    /// Largest CIELAB ΔE between mean colours for merging regions across a flat
    /// junction. 15: plainly different colours (same-surface shading differences are a
    /// few units).
    pub flat_merge_delta_e: f64,
    /// Smallest neighbour pairs between two regions for them to count as adjacent.
    pub min_boundary_pairs: usize,
    /// Smallest segment area (m²). 10 cm² (a 3 x 3 cm face): smaller regions join a
    /// neighbour or are dropped. Converted to points with the measured point spacing.
    pub min_area_m2: f64,
    /// Threads for neighbour searches and normals (results do not depend on it).
    #[serde(skip)]
    pub parallelism: Parallelism,
}

impl Default for GeometricParams {
    fn default() -> Self {
        GeometricParams {
            normal_radius_m: 0.015,
            connect_radius_m: 0.01,
            max_neighbours: 32,
            plane_distance_m: 0.01,
            plane_normal_deg: 25.0,
            plane_min_fraction: 0.2,
            ransac_iterations: 500,
            smoothness_deg: 10.0,
            curvature_max: 0.03,
            concavity_deg: 10.0,
            flat_merge_delta_e: 15.0,
            min_boundary_pairs: 3,
            min_area_m2: 0.001,
            parallelism: Parallelism::default(),
        }
    }
}

/// The result of [`segment_geometric`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GeometricSegmentation {
    /// Segments (support parts included) by size descending, and per-point labels.
    pub segmentation: Segmentation,
    /// Indices into the segments of the support-plane parts.
    pub support: Vec<usize>,
    /// The support plane `(a, b, c, d)` with `ax + by + cz + d = 0`, unit normal
    /// towards the viewpoint, when one was found.
    pub plane: Option<[f64; 4]>,
    /// Point spacing (m) measured on the cloud (median nearest-neighbour distance).
    pub spacing_m: f64,
    /// Smallest segment in points (`min_area_m2 / spacing²`).
    pub min_points: usize,
}

fn validate(p: &GeometricParams) -> Result<(), SegmentError> {
    check_distance("normal_radius_m", p.normal_radius_m)?;
    check_distance("connect_radius_m", p.connect_radius_m)?;
    check_distance("plane_distance_m", p.plane_distance_m)?;
    check_distance("min_area_m2", p.min_area_m2)?;
    for (name, v) in [
        ("plane_normal_deg", p.plane_normal_deg),
        ("plane_min_fraction", p.plane_min_fraction),
        ("smoothness_deg", p.smoothness_deg),
        ("curvature_max", p.curvature_max),
        ("concavity_deg", p.concavity_deg),
        ("flat_merge_delta_e", p.flat_merge_delta_e),
    ] {
        check_threshold(name, v)?;
    }
    for (name, v, max) in [
        ("max_neighbours", p.max_neighbours, 1000),
        ("ransac_iterations", p.ransac_iterations, 1_000_000),
    ] {
        if v == 0 || v > max {
            return Err(SegmentError::InvalidCount {
                name,
                value: v,
                min: 1,
                max,
            });
        }
    }
    Ok(())
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f64; 3] {
    [
        a[0] as f64 - b[0] as f64,
        a[1] as f64 - b[1] as f64,
        a[2] as f64 - b[2] as f64,
    ]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn widen(a: [f32; 3]) -> [f64; 3] {
    a.map(|v| v as f64)
}

/// Segments a cloud by geometry (see the module docs). Colours are optional (without
/// them flat junctions always merge). Non-finite points get [`UNSEGMENTED`].
pub fn segment_geometric(
    cloud: &PointCloud,
    params: &GeometricParams,
) -> Result<GeometricSegmentation, SegmentError> {
    cloud.validate()?;
    validate(params)?;
    let finite = cloud.finite_indices();
    let pts: Vec<[f32; 3]> = finite.iter().map(|&i| cloud.positions[i]).collect();
    let m = pts.len();
    let mut labels = vec![UNSEGMENTED; cloud.len()];
    if m < 3 {
        return Ok(GeometricSegmentation {
            segmentation: Segmentation {
                segments: Vec::new(),
                labels,
                grown_segments: 0,
                colour_regions: 0,
            },
            support: Vec::new(),
            plane: None,
            spacing_m: 0.0,
            min_points: 0,
        });
    }
    // Step 1: normals, curvature, neighbours and spacing.
    let (geo, spacing) = point_geometry(cloud, &finite, &pts, params)?;
    let min_points = ((params.min_area_m2 / (spacing * spacing)).ceil() as usize).max(3);
    // Step 2: the support plane.
    let plane = support_plane(&pts, &geo.nrm, params);
    let on_plane = plane_members(&pts, &geo.nrm, plane, params);
    // Steps 3 to 5: smooth regions, small ones joined, convex and flat junctions merged.
    let mut regions = Regions::grow(&geo, &on_plane, params);
    let grown = regions.count as usize;
    regions.merge_small(&geo.nbrs, min_points);
    let labs: Option<Vec<[f64; 3]>> = cloud
        .colors
        .as_ref()
        .map(|c| finite.iter().map(|&i| rgb_to_lab(c[i])).collect());
    regions.merge_convex(&geo, &pts, labs.as_deref(), min_points, params);
    // Assembly: object segments and support parts, by size descending.
    let mut clusters = regions.clusters(&finite, min_points);
    if plane.is_some() {
        clusters.extend(support_parts(&pts, &finite, &on_plane, min_points, params)?);
    }
    for c in &mut clusters {
        c.1.sort_unstable();
    }
    clusters.sort_by(|a, b| b.1.len().cmp(&a.1.len()).then(a.1[0].cmp(&b.1[0])));
    let mut support = Vec::new();
    let mut segments = Vec::with_capacity(clusters.len());
    for (label, (is_support, indices)) in clusters.into_iter().enumerate() {
        for &i in &indices {
            labels[i] = label as u32;
        }
        if is_support {
            support.push(label);
        }
        segments.push(describe(cloud, indices));
    }
    let n_seg = segments.len();
    Ok(GeometricSegmentation {
        segmentation: Segmentation {
            segments,
            labels,
            grown_segments: grown,
            colour_regions: n_seg,
        },
        support,
        plane,
        spacing_m: spacing,
        min_points,
    })
}

/// Per finite point: its normal (`None` when PCA gave none), curvature, and the
/// neighbours within the connection radius (itself excluded).
struct PointGeometry {
    nrm: Vec<Option<[f64; 3]>>,
    curv: Vec<f32>,
    nbrs: Vec<Vec<u32>>,
}

/// Step 1: normals and curvature by PCA over a radius, connectivity neighbours, and the
/// measured point spacing (m).
fn point_geometry(
    cloud: &PointCloud,
    finite: &[usize],
    pts: &[[f32; 3]],
    params: &GeometricParams,
) -> Result<(PointGeometry, f64), SegmentError> {
    let mut sub_cloud = cloud.select(finite);
    sub_cloud.normals = None;
    sub_cloud.curvature = None;
    let normals = estimate_normals(
        &sub_cloud,
        &NormalParams {
            neighbourhood: Neighbourhood::Radius(params.normal_radius_m),
            parallelism: params.parallelism,
            ..NormalParams::default()
        },
    )?;
    let nrm: Vec<Option<[f64; 3]>> = normals
        .normals
        .iter()
        .map(|n| n.iter().all(|c| c.is_finite()).then(|| widen(*n)))
        .collect();
    let tree = KdTree::build(pts);
    let query = RadiusQuery {
        max_results: Some(params.max_neighbours + 1),
        ..RadiusQuery::sorted()
    };
    let nbrs: Vec<Vec<u32>> = map_indices(pts.len(), params.parallelism, |i| {
        tree.within_radius(&pts[i], params.connect_radius_m, query)
            .into_iter()
            .filter(|nb| nb.index != i)
            .map(|nb| nb.index as u32)
            .collect()
    });
    let spacing = median_spacing(pts, &tree);
    let geo = PointGeometry {
        nrm,
        curv: normals.curvature,
        nbrs,
    };
    Ok((geo, spacing))
}

/// The support plane's inliers split into connected parts, as `(true, cloud indices)`.
fn support_parts(
    pts: &[[f32; 3]],
    finite: &[usize],
    on_plane: &[bool],
    min_points: usize,
    params: &GeometricParams,
) -> Result<Vec<(bool, Vec<usize>)>, SegmentError> {
    let support_idx: Vec<usize> = (0..pts.len()).filter(|&i| on_plane[i]).collect();
    let support_pts: Vec<[f32; 3]> = support_idx.iter().map(|&i| pts[i]).collect();
    let parts = super::euclidean::euclidean_clusters(
        &support_pts,
        &super::EuclideanParams {
            tolerance: params.connect_radius_m,
            min_size: min_points,
            max_size: usize::MAX,
            ..Default::default()
        },
    )?;
    Ok(parts
        .into_iter()
        .map(|part| (true, part.iter().map(|&k| finite[support_idx[k]]).collect()))
        .collect())
}

/// Median distance to the nearest other point over a sample (metres).
fn median_spacing(pts: &[[f32; 3]], tree: &KdTree) -> f64 {
    let step = (pts.len() / 512).max(1);
    let mut d: Vec<f64> = pts
        .iter()
        .step_by(step)
        .filter_map(|p| {
            tree.nearest_n(p, 2)
                .get(1)
                .map(|nb| (nb.squared_distance as f64).sqrt())
        })
        .filter(|d| *d > 0.0)
        .collect();
    if d.is_empty() {
        return 0.005;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}
