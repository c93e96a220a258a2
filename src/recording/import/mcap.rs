//! A reader of MCAP files (ROS 2 bags' default storage): the magic `\x89MCAP0\r\n`, then
//! records of an opcode byte, a `u64` length and the content. Messages are found by a
//! linear scan of the data section, inside chunks (compression none or `lz4`) or at the
//! top level; the summary section after `DataEnd` is not needed.

use super::{read_body, read_head, BagMessage, ImportError};
use std::collections::HashMap;
use std::io::Read;

/// The first bytes of an MCAP file.
pub const MAGIC: &[u8] = b"\x89MCAP0\r\n";

const OP_FOOTER: u8 = 0x02;
const OP_SCHEMA: u8 = 0x03;
const OP_CHANNEL: u8 = 0x04;
const OP_MESSAGE: u8 = 0x05;
const OP_CHUNK: u8 = 0x06;
const OP_DATA_END: u8 = 0x0F;

/// A record's fields, read front to back.
struct Fields<'a> {
    buf: &'a [u8],
}

impl<'a> Fields<'a> {
    fn take(&mut self, n: u64) -> Result<&'a [u8], ImportError> {
        let n = usize::try_from(n).ok().filter(|&n| n <= self.buf.len());
        let n = n.ok_or_else(|| ImportError::Corrupt {
            reason: "MCAP record field runs past its record".into(),
        })?;
        let (head, rest) = self.buf.split_at(n);
        self.buf = rest;
        Ok(head)
    }
    fn u16(&mut self) -> Result<u16, ImportError> {
        Ok(u16::from_le_bytes(self.take(2)?.try_into().expect("2")))
    }
    fn u32(&mut self) -> Result<u32, ImportError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4")))
    }
    fn u64(&mut self) -> Result<u64, ImportError> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8")))
    }
    fn string(&mut self) -> Result<String, ImportError> {
        let n = self.u32()?;
        Ok(String::from_utf8_lossy(self.take(n.into())?).into_owned())
    }
}

/// What a channel's messages are.
struct Channel {
    topic: String,
    schema: u16,
    encoding: String,
}

/// Channels and schema names seen so far.
#[derive(Default)]
struct State {
    schemas: HashMap<u16, String>,
    channels: HashMap<u16, Channel>,
}

/// Reads one record; `Ok(None)` at a clean end of input.
fn read_record(r: &mut impl Read, at: &mut u64) -> Result<Option<(u8, Vec<u8>)>, ImportError> {
    let mut head = [0u8; 9];
    if !read_head(r, &mut head, *at)? {
        return Ok(None);
    }
    let len = u64::from_le_bytes(head[1..].try_into().expect("8 bytes"));
    let content = read_body(r, len, *at)?;
    *at += 9 + len;
    Ok(Some((head[0], content)))
}

/// Reads the MCAP data from `r` (just after [`MAGIC`]) and hands each message to
/// `on_message`, in file order. Only `cdr` messages are handed on.
pub fn read(
    r: &mut impl Read,
    on_message: &mut dyn FnMut(BagMessage<'_>) -> Result<(), ImportError>,
) -> Result<(), ImportError> {
    let mut state = State::default();
    let mut at = MAGIC.len() as u64;
    while let Some((op, content)) = read_record(r, &mut at)? {
        match op {
            OP_DATA_END | OP_FOOTER => break,
            OP_CHUNK => {
                let records = chunk_records(&content)?;
                let mut inner = records.as_slice();
                let mut inner_at = 0;
                while let Some((op, c)) = read_record(&mut inner, &mut inner_at)? {
                    handle(op, &c, &mut state, on_message)?;
                }
            }
            _ => handle(op, &content, &mut state, on_message)?,
        }
    }
    Ok(())
}

fn chunk_records(content: &[u8]) -> Result<Vec<u8>, ImportError> {
    let mut f = Fields { buf: content };
    f.u64()?; // message start time
    f.u64()?; // message end time
    let size = f.u64()?;
    f.u32()?; // crc
    let compression = f.string()?;
    let len = f.u64()?;
    let records = f.take(len)?;
    let out = match compression.as_str() {
        "" => records.to_vec(),
        "lz4" => super::lz4_frame(records, Some(size))?,
        _ => return Err(ImportError::Compression { compression }),
    };
    if out.len() as u64 != size {
        return Err(ImportError::Corrupt {
            reason: format!("chunk of {} bytes, its header says {size}", out.len()),
        });
    }
    Ok(out)
}

fn handle(
    op: u8,
    content: &[u8],
    state: &mut State,
    on_message: &mut dyn FnMut(BagMessage<'_>) -> Result<(), ImportError>,
) -> Result<(), ImportError> {
    let mut f = Fields { buf: content };
    match op {
        OP_SCHEMA => {
            let id = f.u16()?;
            let name = f.string()?;
            state.schemas.insert(id, name);
        }
        OP_CHANNEL => {
            let id = f.u16()?;
            let schema = f.u16()?;
            let topic = f.string()?;
            let encoding = f.string()?;
            let channel = Channel {
                topic,
                schema,
                encoding,
            };
            state.channels.insert(id, channel);
        }
        OP_MESSAGE => {
            let id = f.u16()?;
            f.u32()?; // sequence
            f.u64()?; // log time
            f.u64()?; // publish time
            let c = state
                .channels
                .get(&id)
                .ok_or_else(|| ImportError::Corrupt {
                    reason: format!("message on channel {id}, which no record declared"),
                })?;
            if c.encoding != "cdr" {
                return Ok(());
            }
            let msg_type = state.schemas.get(&c.schema).map_or("", String::as_str);
            on_message(BagMessage {
                topic: &c.topic,
                msg_type,
                data: f.buf,
            })?;
        }
        _ => {}
    }
    Ok(())
}
