//! A reader of ROS 2 sqlite3 bags (`.db3`, rosbag2's storage before MCAP): a table
//! `topics` (`id`, `name`, `type`, `serialization_format`) and a table `messages`
//! (`topic_id`, `timestamp`, `data`). The database is opened read-only; SQLite itself
//! (the `rusqlite` crate, bundled) reads the file format.

use super::{BagMessage, ImportError};
use rusqlite::{Connection, OpenFlags};
use std::collections::HashMap;
use std::path::Path;

/// The first bytes of an SQLite database file.
pub const MAGIC: &[u8] = b"SQLite format 3\0";

/// An error of the `.db3` file at `path`.
fn error(path: &Path, reason: impl std::fmt::Display) -> ImportError {
    ImportError::Sqlite {
        path: path.to_path_buf(),
        reason: reason.to_string(),
    }
}

/// What a topic's messages are.
struct Topic {
    name: String,
    msg_type: String,
    cdr: bool,
}

/// Refuses a database without the tables of a ROS 2 bag, naming the missing one.
fn check_tables(db: &Connection, path: &Path) -> Result<(), ImportError> {
    for table in ["topics", "messages"] {
        let n: i64 = db
            .query_row(
                "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = ?1",
                [table],
                |r| r.get(0),
            )
            .map_err(|e| error(path, e))?;
        if n == 0 {
            return Err(error(
                path,
                format!(
                    "no `{table}` table (a ROS 2 sqlite3 bag has the tables `topics` and \
                     `messages`)"
                ),
            ));
        }
    }
    Ok(())
}

fn topics(db: &Connection, path: &Path) -> Result<HashMap<i64, Topic>, ImportError> {
    let mut q = db
        .prepare("SELECT id, name, type, serialization_format FROM topics")
        .map_err(|e| error(path, e))?;
    let rows = q
        .query_map([], |r| {
            let format: String = r.get(3)?;
            Ok((
                r.get::<_, i64>(0)?,
                Topic {
                    name: r.get(1)?,
                    msg_type: r.get(2)?,
                    cdr: format == "cdr",
                },
            ))
        })
        .map_err(|e| error(path, e))?;
    rows.collect::<Result<_, _>>().map_err(|e| error(path, e))
}

/// Reads the `.db3` file at `path` and hands each `cdr` message to `on_message`, in
/// insertion (row) order.
pub fn read(
    path: &Path,
    on_message: &mut dyn FnMut(BagMessage<'_>) -> Result<(), ImportError>,
) -> Result<(), ImportError> {
    let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX;
    let db = Connection::open_with_flags(path, flags).map_err(|e| error(path, e))?;
    check_tables(&db, path)?;
    let topics = topics(&db, path)?;
    // Row order, not `ORDER BY timestamp`: sorting would copy every image blob through
    // SQLite's sorter; the import orders frames by their header stamps anyway.
    let mut q = db
        .prepare("SELECT topic_id, data FROM messages ORDER BY rowid")
        .map_err(|e| error(path, e))?;
    let mut rows = q.query([]).map_err(|e| error(path, e))?;
    while let Some(row) = rows.next().map_err(|e| error(path, e))? {
        let id: i64 = row.get(0).map_err(|e| error(path, e))?;
        let topic = topics.get(&id).ok_or_else(|| {
            error(
                path,
                format!("a message of topic id {id}, which `topics` lacks"),
            )
        })?;
        if !topic.cdr {
            continue;
        }
        let data = row
            .get_ref(1)
            .and_then(|v| v.as_blob().map_err(Into::into))
            .map_err(|e| error(path, format!("message data: {e}")))?;
        on_message(BagMessage {
            topic: &topic.name,
            msg_type: &topic.msg_type,
            data,
        })?;
    }
    Ok(())
}
