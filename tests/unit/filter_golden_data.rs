//! The synthetic clouds and parameters of the golden oracle fixtures, shared by
//! `tests/unit/filter_golden.rs` (checks) and `tests/oracle/filter.rs` (generator).
#![allow(dead_code)]

use softsense::cloud::PointCloud;

/// A deterministic cloud of `n` points: a noisy sphere (r = 0.1 m at z = 0.8), a noisy
/// plane patch at z = 0.9 and a few scattered outliers, coloured by position.
pub fn synthetic_cloud(seed: u64, n: usize) -> PointCloud {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut pts = Vec::with_capacity(n);
    for i in 0..n {
        let p = match i % 20 {
            0..=13 => {
                let (u, v) = (rnd() * 2.0 - 1.0, rnd() * std::f64::consts::TAU);
                let w = (1.0 - u * u).sqrt();
                let r = 0.1 + 0.001 * (rnd() - 0.5);
                [r * w * v.cos(), r * w * v.sin(), 0.8 + r * u]
            }
            14..=18 => [
                rnd() * 0.3 - 0.15,
                rnd() * 0.3 - 0.15,
                0.9 + 0.0005 * (rnd() - 0.5),
            ],
            _ => [rnd() * 0.6 - 0.3, rnd() * 0.6 - 0.3, 0.5 + rnd() * 0.6],
        };
        pts.push([p[0] as f32, p[1] as f32, p[2] as f32]);
    }
    let colors = pts
        .iter()
        .map(|p| {
            [
                (p[0] * 400.0 + 128.0) as u8,
                (p[1] * 400.0 + 128.0) as u8,
                ((p[2] - 0.5) * 400.0) as u8,
            ]
        })
        .collect();
    PointCloud {
        colors: Some(colors),
        ..PointCloud::from_positions(pts)
    }
}

/// The golden cases: (seed, points).
pub const CASES: [(u64, usize); 2] = [(1, 3000), (2, 2000)];
/// Parameters used for every case (also by the generator).
pub const PASS_Z: (f32, f32) = (0.75, 0.9);
/// Voxel leaf, metres.
pub const LEAF: f64 = 0.03;
/// Radius outlier (radius, min neighbours).
pub const ROR: (f64, usize) = (0.02, 4);
/// Statistical outlier (PCL meanK, stddev multiplier).
pub const SOR: (usize, f64) = (8, 1.0);
/// k for normals.
pub const NORMALS_K: usize = 12;
/// Normals stored for the first this many points.
pub const NORMALS_STORED: usize = 200;

/// Kept-index list as a hex bitmask (bit i of the mask = point i kept).
pub fn mask_hex(indices: &[usize], n: usize) -> String {
    let mut bytes = vec![0u8; n.div_ceil(8)];
    for &i in indices {
        bytes[i / 8] |= 1 << (i % 8);
    }
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A coordinate rounded to 1e-7 for storage (the comparisons allow 1e-5).
pub fn q(v: f32) -> f64 {
    (v as f64 * 1e7).round() / 1e7
}
