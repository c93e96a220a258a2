//! The PCD writer: `ascii`, `binary` and `binary_compressed` bodies.

use super::{lzf, DataEncoding};
use crate::cloud::{CloudError, PointCloud};
use crate::io::Encoding;

/// One output column: name, TYPE letter, and each point's 4 bytes as a `u32`.
struct OutColumn {
    name: &'static str,
    letter: char,
    bits: Vec<u32>,
}

fn out_columns(cloud: &PointCloud) -> Vec<OutColumn> {
    if let Err(e @ CloudError::LengthMismatch { .. }) = cloud.validate() {
        panic!("to_pcd_bytes: inconsistent cloud: {e}");
    }
    let float = |name, it: &mut dyn Iterator<Item = f32>| OutColumn {
        name,
        letter: 'F',
        bits: it.map(f32::to_bits).collect(),
    };
    let mut cols = Vec::new();
    for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
        cols.push(float(name, &mut cloud.positions.iter().map(|p| p[axis])));
    }
    if let Some(colors) = &cloud.colors {
        let names = cloud.field_names();
        let name = if names.contains(&"rgba") {
            "rgba"
        } else {
            "rgb"
        };
        let bits = colors
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let a = cloud.alpha.as_ref().map_or(255, |a| a[i]);
                u32::from_be_bytes([a, c[0], c[1], c[2]])
            })
            .collect();
        cols.push(OutColumn {
            name,
            letter: 'U',
            bits,
        });
    }
    if let Some(normals) = &cloud.normals {
        for (axis, name) in ["normal_x", "normal_y", "normal_z"].into_iter().enumerate() {
            cols.push(float(name, &mut normals.iter().map(|p| p[axis])));
        }
    }
    if let Some(curvature) = &cloud.curvature {
        cols.push(float("curvature", &mut curvature.iter().copied()));
    }
    if let Some(labels) = &cloud.labels {
        cols.push(OutColumn {
            name: "label",
            letter: 'U',
            bits: labels.clone(),
        });
    }
    cols
}

/// Formats an `f32` with the fewest digits that read back to the same value; `nan` for
/// NaN as PCL writes it.
pub(crate) fn format_f32(out: &mut String, v: f32) {
    use std::fmt::Write;
    if v.is_nan() {
        out.push_str("nan");
    } else if v != 0.0 && v.is_finite() && !(1e-5..1e16).contains(&v.abs()) {
        let _ = write!(out, "{v:e}");
    } else {
        let _ = write!(out, "{v}");
    }
}

/// Encodes a cloud as PCD bytes. A cloud whose `width * height` does not match its
/// length is written unorganized (`WIDTH len`, `HEIGHT 1`).
///
/// Panics if an attribute column's length differs from the point count (a programmer
/// error; see [`PointCloud::validate`]).
pub fn to_pcd_bytes(cloud: &PointCloud, encoding: Encoding) -> Vec<u8> {
    use std::fmt::Write;
    let cols = out_columns(cloud);
    let n = cloud.len();
    let (width, height) = if u64::from(cloud.width) * u64::from(cloud.height) == n as u64 {
        (u64::from(cloud.width), u64::from(cloud.height))
    } else {
        (n as u64, 1)
    };
    let data = match encoding {
        Encoding::Ascii => DataEncoding::Ascii,
        Encoding::Binary => DataEncoding::Binary,
        Encoding::BinaryCompressed => DataEncoding::BinaryCompressed,
    };
    let list = |f: &dyn Fn(&OutColumn) -> String| cols.iter().map(f).collect::<Vec<_>>().join(" ");
    let mut text = String::from("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n");
    let _ = writeln!(text, "FIELDS {}", list(&|c| c.name.to_string()));
    let _ = writeln!(text, "SIZE {}", list(&|_| "4".to_string()));
    let _ = writeln!(text, "TYPE {}", list(&|c| c.letter.to_string()));
    let _ = writeln!(text, "COUNT {}", list(&|_| "1".to_string()));
    let _ = writeln!(text, "WIDTH {width}\nHEIGHT {height}");
    text.push_str("VIEWPOINT");
    let vp = &cloud.viewpoint;
    for v in vp.origin.iter().chain(&vp.orientation) {
        text.push(' ');
        format_f32(&mut text, *v);
    }
    let _ = writeln!(text, "\nPOINTS {n}\nDATA {}", data.keyword());
    match encoding {
        Encoding::Ascii => {
            text.reserve(n * cols.len() * 12);
            for i in 0..n {
                for (k, c) in cols.iter().enumerate() {
                    if k > 0 {
                        text.push(' ');
                    }
                    if c.letter == 'F' {
                        format_f32(&mut text, f32::from_bits(c.bits[i]));
                    } else {
                        let _ = write!(text, "{}", c.bits[i]);
                    }
                }
                text.push('\n');
            }
            text.into_bytes()
        }
        Encoding::Binary => {
            let mut out = text.into_bytes();
            out.reserve(n * cols.len() * 4);
            for i in 0..n {
                for c in &cols {
                    out.extend_from_slice(&c.bits[i].to_le_bytes());
                }
            }
            out
        }
        Encoding::BinaryCompressed => {
            let mut raw = Vec::with_capacity(n * cols.len() * 4);
            for c in &cols {
                raw.extend(c.bits.iter().flat_map(|b| b.to_le_bytes()));
            }
            let packed = lzf::compress(&raw);
            let mut out = text.into_bytes();
            // PCL's format stores both sizes as u32; clouds beyond 4 GiB cannot be PCD.
            out.extend_from_slice(&(packed.len() as u32).to_le_bytes());
            out.extend_from_slice(&(raw.len() as u32).to_le_bytes());
            out.extend_from_slice(&packed);
            out
        }
    }
}
