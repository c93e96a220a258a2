//! Reading an ASCII PCD body: each row's values parsed into little-endian records in
//! the header's field layout, so the binary decoder reads them.

use super::{PcdError, PcdHeader, ScalarType};

/// Parses an ASCII body into little-endian records in the header's field layout.
pub(super) fn ascii_records(
    header: &PcdHeader,
    bytes: &[u8],
    n: usize,
) -> Result<Vec<u8>, PcdError> {
    let body = &bytes[header.data_offset..];
    let tokens_per_row: usize = header.fields.iter().map(|f| f.count).sum();
    // Each value takes at least one character and one separator.
    let min_bytes = (n as u64)
        .checked_mul(2 * tokens_per_row as u64)
        .ok_or(PcdError::TooManyPoints { points: n as u64 })?;
    if n > 0 && min_bytes > body.len() as u64 + 1 {
        return Err(PcdError::Truncated {
            needed: min_bytes - 1,
            available: body.len() as u64,
        });
    }
    let header_lines = bytes[..header.data_offset]
        .iter()
        .filter(|&&b| b == b'\n')
        .count();
    let mut out = Vec::with_capacity(n * header.record_size());
    let mut rows = 0usize;
    for (k, line) in body.split(|&b| b == b'\n').enumerate() {
        let line_no = header_lines + k + 1;
        if rows == n {
            // Rows beyond POINTS mean the header's count is wrong; reading only the
            // first POINTS rows would silently drop the rest.
            if line.iter().any(|b| !b.is_ascii_whitespace()) {
                return Err(PcdError::AsciiExtraRow {
                    line: line_no,
                    expected: n as u64,
                });
            }
            continue;
        }
        let row_err = |reason: String| PcdError::AsciiRow {
            line: line_no,
            reason,
        };
        let mut tokens = line
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        let mut first = true;
        for f in &header.fields {
            for _ in 0..f.count {
                let Some(token) = tokens.next() else {
                    if first {
                        break;
                    }
                    return Err(row_err(format!(
                        "{tokens_per_row} values expected, fewer found"
                    )));
                };
                first = false;
                push_ascii_value(&mut out, token, f.ty)
                    .map_err(|text| row_err(format!("`{text}` is not a {} value", f.ty)))?;
            }
        }
        if first {
            continue; // blank line
        }
        if tokens.next().is_some() {
            return Err(row_err(format!(
                "more than the {tokens_per_row} declared values"
            )));
        }
        rows += 1;
    }
    if rows < n {
        return Err(PcdError::AsciiRows {
            expected: n as u64,
            got: rows as u64,
        });
    }
    Ok(out)
}

/// Appends one ASCII value as little-endian bytes of `ty`; on failure returns the text.
fn push_ascii_value(out: &mut Vec<u8>, token: &[u8], ty: ScalarType) -> Result<(), String> {
    let text = std::str::from_utf8(token).map_err(|_| {
        String::from_utf8_lossy(token)
            .chars()
            .take(40)
            .collect::<String>()
    })?;
    let fail = || text.chars().take(40).collect::<String>();
    use ScalarType::*;
    match ty {
        F32 => out.extend_from_slice(&text.parse::<f32>().map_err(|_| fail())?.to_le_bytes()),
        F64 => out.extend_from_slice(&text.parse::<f64>().map_err(|_| fail())?.to_le_bytes()),
        I8 | I16 | I32 | I64 => {
            let v: i64 = text.parse().map_err(|_| fail())?;
            let bytes = v.to_le_bytes();
            let size = ty.size();
            let fits = size == 8 || {
                let bits = 8 * size as u32;
                v >= -(1i64 << (bits - 1)) && v < (1i64 << (bits - 1))
            };
            if !fits {
                return Err(fail());
            }
            out.extend_from_slice(&bytes[..size]);
        }
        U8 | U16 | U32 | U64 => {
            let v: u64 = text.parse().map_err(|_| fail())?;
            let size = ty.size();
            if size < 8 && v >> (8 * size) != 0 {
                return Err(fail());
            }
            out.extend_from_slice(&v.to_le_bytes()[..size]);
        }
    }
    Ok(())
}
