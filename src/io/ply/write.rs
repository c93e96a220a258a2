//! The PLY writer, with Open3D's property names.

use super::PlyFormat;
use crate::cloud::PointCloud;
use crate::io::Encoding;

/// Encodes a cloud as PLY bytes: ASCII for [`Encoding::Ascii`], otherwise
/// `binary_little_endian` (PLY has no compressed encoding).
pub fn to_ply_bytes(cloud: &PointCloud, encoding: Encoding) -> Vec<u8> {
    let format = match encoding {
        Encoding::Ascii => PlyFormat::Ascii,
        Encoding::Binary | Encoding::BinaryCompressed => PlyFormat::BinaryLittleEndian,
    };
    to_ply_bytes_with(cloud, format)
}

/// One written vertex value.
#[derive(Clone, Copy)]
enum Value {
    F(f32),
    U8(u8),
    U32(u32),
}

/// Encodes a cloud as PLY bytes in the given format.
///
/// Panics if an attribute column's length differs from the point count.
pub fn to_ply_bytes_with(cloud: &PointCloud, format: PlyFormat) -> Vec<u8> {
    use std::fmt::Write;
    if let Err(e @ crate::cloud::CloudError::LengthMismatch { .. }) = cloud.validate() {
        panic!("to_ply_bytes: inconsistent cloud: {e}");
    }
    let n = cloud.len();
    let mut props: Vec<(&str, &str)> = vec![("float", "x"), ("float", "y"), ("float", "z")];
    if cloud.normals.is_some() {
        props.extend([("float", "nx"), ("float", "ny"), ("float", "nz")]);
    }
    if cloud.colors.is_some() {
        props.extend([("uchar", "red"), ("uchar", "green"), ("uchar", "blue")]);
    }
    if cloud.alpha.is_some() {
        props.push(("uchar", "alpha"));
    }
    if cloud.curvature.is_some() {
        props.push(("float", "curvature"));
    }
    if cloud.labels.is_some() {
        props.push(("uint", "label"));
    }
    let format_name = match format {
        PlyFormat::Ascii => "ascii",
        PlyFormat::BinaryLittleEndian => "binary_little_endian",
        PlyFormat::BinaryBigEndian => "binary_big_endian",
    };
    let mut text = format!(
        "ply\nformat {format_name} 1.0\ncomment Created by softsense\nelement vertex {n}\n"
    );
    for (ty, name) in &props {
        let _ = writeln!(text, "property {ty} {name}");
    }
    text.push_str("end_header\n");
    let mut values = Vec::with_capacity(props.len());
    let mut out = Vec::new();
    for i in 0..n {
        values.clear();
        values.extend(cloud.positions[i].map(Value::F));
        if let Some(nm) = &cloud.normals {
            values.extend(nm[i].map(Value::F));
        }
        if let Some(c) = &cloud.colors {
            values.extend(c[i].map(Value::U8));
        }
        if let Some(a) = &cloud.alpha {
            values.push(Value::U8(a[i]));
        }
        if let Some(c) = &cloud.curvature {
            values.push(Value::F(c[i]));
        }
        if let Some(l) = &cloud.labels {
            values.push(Value::U32(l[i]));
        }
        for (k, v) in values.iter().enumerate() {
            match format {
                PlyFormat::Ascii => {
                    if k > 0 {
                        text.push(' ');
                    }
                    match *v {
                        Value::F(f) => crate::io::pcd::format_f32(&mut text, f),
                        Value::U8(b) => {
                            let _ = write!(text, "{b}");
                        }
                        Value::U32(b) => {
                            let _ = write!(text, "{b}");
                        }
                    }
                }
                PlyFormat::BinaryLittleEndian => match *v {
                    Value::F(f) => out.extend_from_slice(&f.to_le_bytes()),
                    Value::U8(b) => out.push(b),
                    Value::U32(b) => out.extend_from_slice(&b.to_le_bytes()),
                },
                PlyFormat::BinaryBigEndian => match *v {
                    Value::F(f) => out.extend_from_slice(&f.to_be_bytes()),
                    Value::U8(b) => out.push(b),
                    Value::U32(b) => out.extend_from_slice(&b.to_be_bytes()),
                },
            }
        }
        if format == PlyFormat::Ascii {
            text.push('\n');
        }
    }
    let mut bytes = text.into_bytes();
    bytes.extend_from_slice(&out);
    bytes
}
