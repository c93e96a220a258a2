//! Decoding a PCD body (interleaved records or field-columnar blocks) into the cloud's
//! columns, field by field according to its role.

use super::{PcdError, PcdField, PcdHeader, ScalarType};
use crate::cloud::PointCloud;

/// What a declared field becomes in the cloud.
#[derive(Clone, Copy)]
pub(super) enum Role {
    Axis(usize),
    Color { alpha: bool },
    Normal(usize),
    Curvature,
    Label,
    Skip,
}

/// The role of a declared field, or why its type cannot serve it.
pub(super) fn role_of(field: &PcdField) -> Result<Role, PcdError> {
    let bad = |expected| PcdError::BadFieldType {
        field: field.name.clone(),
        ty: field.ty,
        count: field.count,
        expected,
    };
    let float = |role| {
        if field.ty.is_float() && field.count == 1 {
            Ok(role)
        } else {
            Err(bad("F4 or F8 with COUNT 1"))
        }
    };
    match field.name.as_str() {
        "x" => float(Role::Axis(0)),
        "y" => float(Role::Axis(1)),
        "z" => float(Role::Axis(2)),
        "normal_x" => float(Role::Normal(0)),
        "normal_y" => float(Role::Normal(1)),
        "normal_z" => float(Role::Normal(2)),
        "curvature" => float(Role::Curvature),
        "rgb" | "rgba" => {
            if field.ty.size() == 4 && field.count == 1 {
                Ok(Role::Color {
                    alpha: field.name == "rgba",
                })
            } else {
                Err(bad("a 4-byte packed value (U4, I4 or F4) with COUNT 1"))
            }
        }
        "label" => {
            if !field.ty.is_float() && field.ty.size() <= 4 && field.count == 1 {
                Ok(Role::Label)
            } else {
                Err(bad("an integer of at most 4 bytes with COUNT 1"))
            }
        }
        _ => Ok(Role::Skip),
    }
}

/// The decoded body: either interleaved records or field-columnar blocks.
pub(super) struct Body<'a> {
    data: &'a [u8],
    n: usize,
    columnar: bool,
    /// Per field: byte offset within the record (interleaved) or of its column (columnar).
    offsets: Vec<usize>,
    record: usize,
}

impl<'a> Body<'a> {
    pub(super) fn new(header: &PcdHeader, data: &'a [u8], n: usize, columnar: bool) -> Body<'a> {
        let mut offsets = Vec::with_capacity(header.fields.len());
        let mut at = 0;
        for f in &header.fields {
            offsets.push(at);
            at += if !columnar {
                f.byte_len()
            } else if f.is_padding() {
                0 // PCL stores no column for `_` padding in compressed bodies
            } else {
                f.byte_len() * n
            };
        }
        Body {
            data,
            n,
            columnar,
            offsets,
            record: header.record_size(),
        }
    }

    /// The bytes of field `k`'s first value, point by point. The caller has checked
    /// that `data` holds `n` records.
    fn values(&self, header: &PcdHeader, k: usize) -> impl Iterator<Item = &'a [u8]> + use<'a> {
        let f = &header.fields[k];
        let size = f.ty.size();
        let (slice, stride, off) = if self.columnar {
            let start = self.offsets[k];
            let len = f.byte_len() * self.n;
            (&self.data[start..start + len], f.byte_len(), 0)
        } else {
            (
                &self.data[..self.record * self.n],
                self.record,
                self.offsets[k],
            )
        };
        slice.chunks_exact(stride).map(move |c| &c[off..off + size])
    }
}

pub(super) fn arr4(b: &[u8]) -> [u8; 4] {
    [b[0], b[1], b[2], b[3]]
}

fn arr8(b: &[u8]) -> [u8; 8] {
    [b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]
}

/// Calls `f(i, value)` for every value of a float column.
fn for_each_f32<'a>(
    values: impl Iterator<Item = &'a [u8]>,
    ty: ScalarType,
    mut f: impl FnMut(usize, f32),
) {
    if ty == ScalarType::F64 {
        for (i, b) in values.enumerate() {
            f(i, f64::from_le_bytes(arr8(b)) as f32);
        }
    } else {
        for (i, b) in values.enumerate() {
            f(i, f32::from_le_bytes(arr4(b)));
        }
    }
}

/// An integer value of at most 4 bytes as `u32` (signed values keep their bits).
fn int_u32(b: &[u8], ty: ScalarType) -> u32 {
    match ty {
        ScalarType::I8 => b[0] as i8 as u32,
        ScalarType::U8 => u32::from(b[0]),
        ScalarType::I16 => i16::from_le_bytes([b[0], b[1]]) as u32,
        ScalarType::U16 => u32::from(u16::from_le_bytes([b[0], b[1]])),
        _ => u32::from_le_bytes(arr4(b)),
    }
}

/// The cloud held by `body`, laid out as `header` declares.
pub(super) fn decode(header: &PcdHeader, body: &Body<'_>) -> Result<PointCloud, PcdError> {
    let roles: Vec<Role> = header
        .fields
        .iter()
        .map(role_of)
        .collect::<Result<_, _>>()?;
    let find = |want: &dyn Fn(Role) -> bool| roles.iter().position(|&r| want(r));
    let n = body.n;
    let mut positions = vec![[0f32; 3]; n];
    for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
        let k = find(&|r| matches!(r, Role::Axis(a) if a == axis))
            .ok_or(PcdError::MissingField { field: name })?;
        for_each_f32(body.values(header, k), header.fields[k].ty, |i, v| {
            positions[i][axis] = v
        });
    }
    let mut cloud = PointCloud {
        positions,
        width: header.width,
        height: header.height,
        viewpoint: header.viewpoint,
        ..Default::default()
    };
    if let Some(k) = find(&|r| matches!(r, Role::Color { .. })) {
        let mut colors = Vec::with_capacity(n);
        let mut alpha = Vec::with_capacity(n);
        for b in body.values(header, k) {
            let v = u32::from_le_bytes(arr4(b));
            colors.push([(v >> 16) as u8, (v >> 8) as u8, v as u8]);
            alpha.push((v >> 24) as u8);
        }
        cloud.colors = Some(colors);
        if matches!(roles[k], Role::Color { alpha: true }) {
            cloud.alpha = Some(alpha);
        }
    }
    let normal_fields: Vec<usize> = (0..3)
        .filter_map(|axis| find(&|r| matches!(r, Role::Normal(a) if a == axis)))
        .collect();
    if normal_fields.len() == 3 {
        let mut normals = vec![[0f32; 3]; n];
        for (axis, &k) in normal_fields.iter().enumerate() {
            for_each_f32(body.values(header, k), header.fields[k].ty, |i, v| {
                normals[i][axis] = v
            });
        }
        cloud.normals = Some(normals);
    }
    if let Some(k) = find(&|r| matches!(r, Role::Curvature)) {
        let mut curvature = vec![0f32; n];
        for_each_f32(body.values(header, k), header.fields[k].ty, |i, v| {
            curvature[i] = v
        });
        cloud.curvature = Some(curvature);
    }
    if let Some(k) = find(&|r| matches!(r, Role::Label)) {
        let ty = header.fields[k].ty;
        cloud.labels = Some(body.values(header, k).map(|b| int_u32(b, ty)).collect());
    }
    Ok(cloud)
}
