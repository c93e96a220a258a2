//! MCAP files (ROS 2 bags' default storage) through the `mcap` crate, the format authors'
//! reader: records are read front to back by its sans-io `LinearReader`, with chunks
//! decompressed (none, `lz4` or `zstd`, what ROS 2's writer uses) and their CRCs checked.
//! The summary section after `DataEnd` is not needed.

use super::{BagMessage, ImportError};
use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use std::collections::HashMap;
use std::io::Read;

/// The first bytes of an MCAP file.
pub const MAGIC: &[u8] = mcap::MAGIC;

/// What a channel's messages are.
struct Channel {
    topic: String,
    schema: u16,
    encoding: String,
}

/// Reads the MCAP data from `r` (just after [`MAGIC`]) and hands each message to
/// `on_message`, in file order. Only `cdr` messages are handed on.
pub fn read(
    r: &mut impl Read,
    on_message: &mut dyn FnMut(BagMessage<'_>) -> Result<(), ImportError>,
) -> Result<(), ImportError> {
    // A record's length is held to the memory budget (a corrupt length must not allocate
    // gigabytes), never below 64 MiB: a smaller budget is for what the messages make
    // (images), which the import checks by name.
    let budget = crate::io::limits::max_bytes().max(1 << 26);
    let limit = usize::try_from(budget).unwrap_or(usize::MAX);
    // A file cut after its last message (a recording still being written) is read to its
    // end: the end magic is not required, and reading stops at `DataEnd`.
    let options = LinearReaderOptions::default()
        .with_skip_start_magic(true)
        .with_skip_end_magic(true)
        .with_record_length_limit(limit);
    let mut reader = LinearReader::new_with_options(options);
    let mut schemas: HashMap<u16, String> = HashMap::new();
    let mut channels: HashMap<u16, Channel> = HashMap::new();
    let mut at = MAGIC.len() as u64;
    loop {
        let want = match reader.next_event() {
            None => return Ok(()),
            Some(Err(e)) => return Err(refused(e, at)),
            Some(Ok(LinearReadEvent::ReadRequest(n))) => n,
            Some(Ok(LinearReadEvent::Record { data, opcode })) => {
                let record = mcap::parse_record(opcode, data).map_err(|e| refused(e, at))?;
                match record {
                    Record::DataEnd(_) | Record::Footer(_) => return Ok(()),
                    Record::Schema { header, .. } => {
                        schemas.insert(header.id, header.name);
                    }
                    Record::Channel(c) => {
                        let channel = Channel {
                            topic: c.topic,
                            schema: c.schema_id,
                            encoding: c.message_encoding,
                        };
                        channels.insert(c.id, channel);
                    }
                    Record::Message { header, data } => {
                        let id = header.channel_id;
                        let c = channels.get(&id).ok_or_else(|| ImportError::Corrupt {
                            reason: format!("message on channel {id}, which no record declared"),
                        })?;
                        if c.encoding == "cdr" {
                            let msg_type = schemas.get(&c.schema).map_or("", String::as_str);
                            on_message(BagMessage {
                                topic: &c.topic,
                                msg_type,
                                data: &data,
                            })?;
                        }
                    }
                    _ => {}
                }
                continue;
            }
        };
        let got = fill(r, reader.insert(want))?;
        at += got as u64;
        reader.notify_read(got);
    }
}

/// Reads up to `buf.len()` bytes (fewer only at the end of the input).
fn fill(r: &mut impl Read, buf: &mut [u8]) -> Result<usize, ImportError> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(ImportError::Read(e.to_string())),
        }
    }
    Ok(got)
}

/// The import error of an `mcap` crate error, `at` bytes into the file.
fn refused(e: mcap::McapError, at: u64) -> ImportError {
    match e {
        mcap::McapError::UnexpectedEof | mcap::McapError::UnexpectedEoc => {
            ImportError::Truncated { offset: at }
        }
        mcap::McapError::UnsupportedCompression(compression) => {
            ImportError::Compression { compression }
        }
        e => ImportError::Corrupt {
            reason: format!("MCAP: {e}"),
        },
    }
}
