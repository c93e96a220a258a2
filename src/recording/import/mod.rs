//! Camera recordings into a recording folder (`softsense import`): a RealSense `.bag`
//! (rosbag v1, as the RealSense Viewer records it) or a ROS 2 bag (a folder with MCAP or
//! sqlite3 files, or one `.mcap` or `.db3`) with `sensor_msgs/Image` depth and colour and
//! `sensor_msgs/CameraInfo`, written in the softsense layout by
//! [`RecordingWriter`](super::RecordingWriter).
//!
//! The rules (also in `docs/recording-format.md`):
//! - **Pairing.** Each depth frame takes the colour frame nearest in header stamp, within
//!   [`ImportParams::pair_tolerance`] (default: half the median depth frame period); a
//!   colour frame goes to at most one depth frame, the nearer. A depth frame left without
//!   colour is not written when the bag has colour (a coloured recording reads a missing
//!   colour image as an error), and is reported.
//! - **Frame numbers** are the depth frames' places in stamp order, so a skipped frame
//!   leaves a gap and frame *i* stays the *i*-th depth image of the bag.
//! - **Depth units.** `16UC1`/`mono16` keep their raw values; their unit is
//!   [`ImportParams::depth_unit`], else the RealSense `Depth Units` option, else 1 mm
//!   (REP 118). `32FC1` (metres) is rounded to [`ImportParams::float_depth_unit`].
//! - **Alignment.** When the colour camera's intrinsics or size differ from the depth
//!   camera's, or the bag's depth-to-colour extrinsic is not the identity, depth is
//!   reprojected into the colour image, nearest surface wins. The extrinsic is the
//!   RealSense streams' `<stream>/tf/<reference>` transforms; a bag without them is
//!   reprojected with the identity, and the summary warns.
//! - **Checks**: camera infos must match their images' size, fit the memory
//!   budget and have a finite `K` with positive focal lengths, or the import is refused
//!   before anything is allocated or written; an implausible transform is warned and
//!   replaced by the identity; frames without a valid depth pixel are warned.
//!
//! ```no_run
//! use softsense::recording::import::{import, ImportParams};
//! let summary = import("walk.bag".as_ref(), "walk".as_ref(), &ImportParams::default(), &mut |_, _| {})?;
//! println!("{} frames written", summary.frames_written);
//! # Ok::<(), softsense::recording::import::ImportError>(())
//! ```

mod align;
mod checks;
mod frames;
pub mod mcap;
pub mod msg;
pub mod rosbag1;
pub mod sqlite;

pub use frames::{import, pair, ImportParams, ImportSummary};

use super::RecordingError;
use msg::Wire;
use std::io::Read;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Errors of importing a bag.
#[derive(Debug, Error)]
pub enum ImportError {
    /// The file is neither a rosbag v1, an MCAP nor an SQLite file, nor a folder holding
    /// MCAP or sqlite3 files.
    #[error(
        "{path}: not a bag (a rosbag v1 file starts with `#ROSBAG V2.0`, an MCAP file with \
         `\\x89MCAP0`, a sqlite3 bag with `SQLite format 3`; a ROS 2 bag folder holds .mcap \
         or .db3 files)"
    )]
    NotABag {
        /// The path given.
        path: PathBuf,
    },
    /// A ROS 2 sqlite3 bag file that SQLite cannot read, or without a bag's tables.
    #[error("{path}: not a readable ROS 2 sqlite3 bag: {reason}")]
    Sqlite {
        /// The `.db3` file.
        path: PathBuf,
        /// What SQLite said, or which table is missing.
        reason: String,
    },
    /// The file ends inside a record.
    #[error("truncated: the file ends inside the record at byte {offset}")]
    Truncated {
        /// Where the cut record starts (within its chunk, for a record inside a chunk).
        offset: u64,
    },
    /// A record that does not parse.
    #[error("corrupt bag: {reason}")]
    Corrupt {
        /// What is wrong.
        reason: String,
    },
    /// A chunk compression this reader does not decompress.
    #[error("chunks compressed with `{compression}` are not read (rosbag: none and lz4; MCAP: none, lz4 and zstd)")]
    Compression {
        /// The compression named by the chunk.
        compression: String,
    },
    /// A message that does not decode.
    #[error("{what}: {reason}")]
    Message {
        /// The message type.
        what: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A pixel encoding this import does not convert.
    #[error("{topic}: pixel encoding `{encoding}` is not read ({expected})")]
    Encoding {
        /// The topic.
        topic: String,
        /// Its encoding.
        encoding: String,
        /// The encodings that are read.
        expected: &'static str,
    },
    /// A topic the import needs is not in the bag, or cannot be chosen alone.
    #[error("{problem}; topics in the bag: {}", list_topics(.present))]
    Topic {
        /// What is missing or ambiguous, and which option chooses.
        problem: String,
        /// `(topic, type)` of every topic present.
        present: Vec<(String, String)>,
    },
    /// Reading the file failed.
    #[error("reading the bag: {0}")]
    Read(String),
    /// A file or folder could not be opened.
    #[error("{path}: {source}")]
    Os {
        /// The path.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The output folder already holds frames.
    #[error("{path} already holds frames: import into a new or empty folder")]
    OutputHasFrames {
        /// The folder.
        path: PathBuf,
    },
    /// Writing the recording failed.
    #[error(transparent)]
    Write(#[from] RecordingError),
    /// A parameter out of range.
    #[error("{0}")]
    Params(String),
    /// An error found inside a bag, with the bag named (the readers see bytes, not paths).
    #[error("{path}: {source}")]
    InBag {
        /// The bag (file or folder) given.
        path: PathBuf,
        /// What is wrong inside it.
        source: Box<ImportError>,
    },
}

impl ImportError {
    /// This error naming the bag `path`, unless it names a file already.
    pub fn in_bag(self, path: &Path) -> Self {
        match self {
            e @ (ImportError::Truncated { .. }
            | ImportError::Corrupt { .. }
            | ImportError::Compression { .. }
            | ImportError::Message { .. }
            | ImportError::Encoding { .. }
            | ImportError::Read(_)) => {
                if e.to_string().contains(&path.display().to_string()) {
                    return e;
                }
                ImportError::InBag {
                    path: path.to_path_buf(),
                    source: Box::new(e),
                }
            }
            e => e,
        }
    }
}

fn list_topics(present: &[(String, String)]) -> String {
    if present.is_empty() {
        return "none".into();
    }
    let t: Vec<String> = present
        .iter()
        .map(|(t, ty)| format!("{t} ({ty})"))
        .collect();
    t.join(", ")
}

/// One message of a bag, as a reader hands it on.
#[derive(Clone, Copy, Debug)]
pub struct BagMessage<'a> {
    /// The topic.
    pub topic: &'a str,
    /// The message type as the bag names it (`sensor_msgs/Image`, `sensor_msgs/msg/Image`).
    pub msg_type: &'a str,
    /// The serialised message.
    pub data: &'a [u8],
}

impl BagMessage<'_> {
    /// The type without ROS 2's `/msg/` (`sensor_msgs/Image` for both).
    pub fn short_type(&self) -> String {
        self.msg_type.replacen("/msg/", "/", 1)
    }
}

/// How a bag's files store their messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Storage {
    Rosbag1,
    Mcap,
    Sqlite,
}

/// A bag on disk: its files and their format.
#[derive(Clone, Debug)]
pub struct Bag {
    files: Vec<PathBuf>,
    storage: Storage,
}

fn os(path: &Path) -> impl FnOnce(std::io::Error) -> ImportError + '_ {
    move |source| ImportError::Os {
        path: path.to_path_buf(),
        source,
    }
}

fn magic_of(path: &Path) -> Result<Vec<u8>, ImportError> {
    let mut head = Vec::new();
    let file = std::fs::File::open(path).map_err(os(path))?;
    file.take(16).read_to_end(&mut head).map_err(os(path))?;
    Ok(head)
}

impl Bag {
    /// Opens `path`: a rosbag v1 file, an MCAP file, a ROS 2 sqlite3 (`.db3`) file, or a
    /// ROS 2 bag folder (its `.mcap` files in name order, else its `.db3` files).
    pub fn open(path: &Path) -> Result<Self, ImportError> {
        if path.is_dir() {
            let (mut mcaps, mut db3s) = (Vec::new(), Vec::new());
            for e in std::fs::read_dir(path).map_err(os(path))?.flatten() {
                let p = e.path();
                match p.extension().and_then(|x| x.to_str()) {
                    Some("mcap") => mcaps.push(p),
                    Some("db3") => db3s.push(p),
                    _ => {}
                }
            }
            let (mut files, storage) = match (mcaps.is_empty(), db3s.is_empty()) {
                (false, _) => (mcaps, Storage::Mcap),
                (true, false) => (db3s, Storage::Sqlite),
                (true, true) => {
                    return Err(ImportError::NotABag {
                        path: path.to_path_buf(),
                    })
                }
            };
            files.sort();
            return Ok(Self { files, storage });
        }
        let head = magic_of(path)?;
        let storage = if head.starts_with(rosbag1::MAGIC) {
            Storage::Rosbag1
        } else if head.starts_with(mcap::MAGIC) {
            Storage::Mcap
        } else if head.starts_with(sqlite::MAGIC) {
            Storage::Sqlite
        } else {
            return Err(ImportError::NotABag {
                path: path.to_path_buf(),
            });
        };
        Ok(Self {
            files: vec![path.to_path_buf()],
            storage,
        })
    }

    /// How the bag's messages are serialised.
    pub fn wire(&self) -> Wire {
        match self.storage {
            Storage::Rosbag1 => Wire::Ros1,
            Storage::Mcap | Storage::Sqlite => Wire::Cdr,
        }
    }

    /// Hands every message of the bag to `on_message`, in file order.
    pub fn for_each(
        &self,
        on_message: &mut dyn FnMut(BagMessage<'_>) -> Result<(), ImportError>,
    ) -> Result<(), ImportError> {
        for path in &self.files {
            if self.storage == Storage::Sqlite {
                sqlite::read(path, on_message)?;
                continue;
            }
            let file = std::fs::File::open(path).map_err(os(path))?;
            let mut r = std::io::BufReader::with_capacity(1 << 20, file);
            let magic = match self.storage {
                Storage::Rosbag1 => rosbag1::MAGIC,
                _ => mcap::MAGIC,
            };
            let mut head = vec![0u8; magic.len()];
            r.read_exact(&mut head).map_err(os(path))?;
            let read = match self.storage {
                Storage::Rosbag1 => rosbag1::read(&mut r, on_message),
                _ => mcap::read(&mut r, on_message),
            };
            read.map_err(|e| match e {
                ImportError::Read(m) => ImportError::Read(format!("{}: {m}", path.display())),
                e => e,
            })?;
        }
        Ok(())
    }
}

/// Fills `head` from `r`: `Ok(false)` at a clean end of input (no byte left), an error
/// when the input ends inside `head`; `at` (the record's offset) names the cut record.
fn read_head(r: &mut impl Read, head: &mut [u8], at: u64) -> Result<bool, ImportError> {
    let mut got = 0;
    while got < head.len() {
        match r.read(&mut head[got..]) {
            Ok(0) if got == 0 => return Ok(false),
            Ok(0) => return Err(ImportError::Truncated { offset: at }),
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(ImportError::Read(e.to_string())),
        }
    }
    Ok(true)
}

/// Reads `len` bytes of the record at `at`, refusing a short read.
fn read_body(r: &mut impl Read, len: u64, at: u64) -> Result<Vec<u8>, ImportError> {
    let mut buf = Vec::new();
    let n = r
        .take(len)
        .read_to_end(&mut buf)
        .map_err(|e| ImportError::Read(e.to_string()))?;
    match (n as u64) < len {
        true => Err(ImportError::Truncated { offset: at }),
        false => Ok(buf),
    }
}

/// Decompresses an LZ4 frame (rosbag's and MCAP's `lz4` chunks) that its chunk header
/// says holds `declared` bytes. A few kilobytes of LZ4 can declare or expand to gigabytes,
/// so the declared size is held to the memory budget before decoding, and decoding stops
/// past it (or past the budget, when the header declares none).
fn lz4_frame(data: &[u8], declared: Option<u64>) -> Result<Vec<u8>, ImportError> {
    let limit = crate::io::limits::max_bytes();
    if let Some(n) = declared {
        crate::io::limits::check("bytes uncompressed", n, 1)
            .map_err(|e| ImportError::Read(format!("an lz4 chunk {e}")))?;
    }
    let bound = declared.unwrap_or(limit);
    let mut out = Vec::new();
    lz4_flex::frame::FrameDecoder::new(data)
        .take(bound.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| ImportError::Corrupt {
            reason: format!("lz4 chunk: {e}"),
        })?;
    if out.len() as u64 > bound {
        return Err(ImportError::Corrupt {
            reason: format!("an lz4 chunk decompresses to more than the {bound} bytes it may hold"),
        });
    }
    Ok(out)
}
