//! A reader of rosbag v1 files (what the RealSense Viewer records): `#ROSBAG V2.0\n`, then
//! records of `u32` header length, header fields (`u32` length + `name=value`), `u32` data
//! length and data. Messages are found by a linear scan, inside chunks (compression `none`
//! or `lz4`) or at the top level; the index records at the end are not needed.
//!
//! Ours rather than the `rosbag` crate (0.6.3, the maintained ROS 1 reader): that crate
//! takes the chunk section as `data[start..index_pos]` from the bag header, so a bag whose
//! recorder was stopped before it wrote its index (the header's `index_pos` still 0, the
//! state `rosbag reindex` exists for) panics there instead of reading. A linear scan reads
//! every complete chunk of it.

use super::{read_body, read_head, BagMessage, ImportError};
use std::collections::HashMap;
use std::io::Read;

/// The first bytes of a rosbag v1 file.
pub const MAGIC: &[u8] = b"#ROSBAG V2.0\n";

const OP_MESSAGE: u8 = 0x02;
const OP_CHUNK: u8 = 0x05;
const OP_CONNECTION: u8 = 0x07;

/// A connection: the topic and its message type.
struct Connection {
    topic: String,
    msg_type: String,
}

/// One record's header fields and data.
struct Record {
    fields: Vec<(String, Vec<u8>)>,
    data: Vec<u8>,
}

impl Record {
    fn field(&self, name: &str) -> Option<&[u8]> {
        self.fields
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    fn op(&self) -> Option<u8> {
        self.field("op").and_then(|v| v.first().copied())
    }

    fn u32_field(&self, name: &str) -> Result<u32, ImportError> {
        let v = self.field(name).and_then(|v| v.get(..4));
        let v = v.ok_or_else(|| ImportError::Corrupt {
            reason: format!("record without a 4-byte `{name}` field"),
        })?;
        Ok(u32::from_le_bytes(v.try_into().expect("4 bytes")))
    }
}

/// Reads one `u32`-length-prefixed block; `Ok(None)` at a clean end of input.
fn read_block(r: &mut impl Read, at: &mut u64) -> Result<Option<Vec<u8>>, ImportError> {
    let mut len = [0u8; 4];
    if !read_head(r, &mut len, *at)? {
        return Ok(None);
    }
    let len = u32::from_le_bytes(len) as u64;
    let buf = read_body(r, len, *at)?;
    *at += 4 + len;
    Ok(Some(buf))
}

/// Splits a header block into its `name=value` fields.
fn parse_fields(mut h: &[u8]) -> Result<Vec<(String, Vec<u8>)>, ImportError> {
    let mut fields = Vec::new();
    while !h.is_empty() {
        let corrupt = || ImportError::Corrupt {
            reason: "record header field runs past its header".into(),
        };
        let len = h.get(..4).ok_or_else(corrupt)?;
        let len = u32::from_le_bytes(len.try_into().expect("4 bytes")) as usize;
        let field = h.get(4..4 + len).ok_or_else(corrupt)?;
        let eq = field.iter().position(|&b| b == b'=');
        let eq = eq.ok_or_else(|| ImportError::Corrupt {
            reason: "record header field without `=`".into(),
        })?;
        let name = String::from_utf8_lossy(&field[..eq]).into_owned();
        fields.push((name, field[eq + 1..].to_vec()));
        h = &h[4 + len..];
    }
    Ok(fields)
}

/// Reads the next record; `Ok(None)` at the end.
fn read_record(r: &mut impl Read, at: &mut u64) -> Result<Option<Record>, ImportError> {
    let start = *at;
    let Some(header) = read_block(r, at)? else {
        return Ok(None);
    };
    let data = read_block(r, at)?.ok_or(ImportError::Truncated { offset: start })?;
    Ok(Some(Record {
        fields: parse_fields(&header)?,
        data,
    }))
}

/// Reads the bag from `r` (just after [`MAGIC`]) and hands each message to `on_message`,
/// in file order.
pub fn read(
    r: &mut impl Read,
    on_message: &mut dyn FnMut(BagMessage<'_>) -> Result<(), ImportError>,
) -> Result<(), ImportError> {
    let mut connections: HashMap<u32, Connection> = HashMap::new();
    let mut at = MAGIC.len() as u64;
    while let Some(record) = read_record(r, &mut at)? {
        match record.op() {
            Some(OP_CHUNK) => {
                let chunk = decompress(&record)?;
                let mut inner = chunk.as_slice();
                let mut inner_at = 0;
                while let Some(rec) = read_record(&mut inner, &mut inner_at)? {
                    handle(rec, &mut connections, on_message)?;
                }
            }
            _ => handle(record, &mut connections, on_message)?,
        }
    }
    Ok(())
}

fn handle(
    record: Record,
    connections: &mut HashMap<u32, Connection>,
    on_message: &mut dyn FnMut(BagMessage<'_>) -> Result<(), ImportError>,
) -> Result<(), ImportError> {
    match record.op() {
        Some(OP_CONNECTION) => {
            let id = record.u32_field("conn")?;
            let topic = String::from_utf8_lossy(record.field("topic").unwrap_or_default());
            let inner = parse_fields(&record.data)?;
            let msg_type = inner.iter().find(|(n, _)| n == "type");
            let msg_type = msg_type.map(|(_, v)| String::from_utf8_lossy(v).into_owned());
            connections.insert(
                id,
                Connection {
                    topic: topic.into_owned(),
                    msg_type: msg_type.unwrap_or_default(),
                },
            );
        }
        Some(OP_MESSAGE) => {
            let id = record.u32_field("conn")?;
            let c = connections.get(&id).ok_or_else(|| ImportError::Corrupt {
                reason: format!("message on connection {id}, which no record declared"),
            })?;
            on_message(BagMessage {
                topic: &c.topic,
                msg_type: &c.msg_type,
                data: &record.data,
            })?;
        }
        _ => {}
    }
    Ok(())
}

fn decompress(chunk: &Record) -> Result<Vec<u8>, ImportError> {
    let compression = String::from_utf8_lossy(chunk.field("compression").unwrap_or(b"none"));
    let size = chunk.u32_field("size").ok().map(u64::from);
    let out = match compression.as_ref() {
        "none" => chunk.data.clone(),
        "lz4" => super::lz4_frame(&chunk.data, size)?,
        other => {
            return Err(ImportError::Compression {
                compression: other.to_string(),
            })
        }
    };
    // A chunk shorter than its header says has lost records; taking it would drop frames
    // without a word.
    match size {
        Some(n) if out.len() as u64 != n => Err(ImportError::Corrupt {
            reason: format!("chunk of {} bytes, its header says {n}", out.len()),
        }),
        _ => Ok(out),
    }
}
