//! A rosbag2 SQLite3 file's messages, read within limits: `topics` and `messages` must be
//! tables, no value longer than [`MAX_RECORD_BYTES`], no query past
//! [`MAX_QUERY_SECONDS`], every message counted against the bag's [`Budget`].

use std::collections::BTreeMap;
use std::path::Path;

use crate::import::bag::{
    bad, declare_topic, BagError, Budget, RawMessage, Topic, MAX_QUERY_SECONDS, MAX_RECORD_BYTES,
};

/// Reads an SQLite3 bag's topics and messages into `topics`.
pub(super) fn read(
    path: &Path,
    topics: &mut BTreeMap<String, Topic>,
    budget: &mut Budget,
) -> Result<(), BagError> {
    let sql_err = |e: rusqlite::Error| {
        bad(
            path,
            format!("{e} (not a rosbag2 SQLite3 file, or a damaged one; no message longer than {MAX_RECORD_BYTES} bytes and no query longer than {MAX_QUERY_SECONDS} s is read)"),
        )
    };
    let db = open_sqlite(path).map_err(sql_err)?;
    // rosbag2 writes tables; a view (over itself, or of huge blobs) is not a recording.
    for table in ["topics", "messages"] {
        let kind: Option<String> = db
            .query_row(
                "SELECT type FROM sqlite_master WHERE name = ?1",
                [table],
                |r| r.get(0),
            )
            .ok();
        if kind.as_deref() != Some("table") {
            return Err(bad(
                path,
                format!(
                    "`{table}` is {}; a rosbag2 SQLite3 file holds a table of that name",
                    kind.map_or("missing".to_string(), |k| format!("a {k}, not a table"))
                ),
            ));
        }
    }
    let by_id = sqlite_topics(path, &db, topics).map_err(|e| match e {
        SqliteRead::Sql(e) => sql_err(e),
        SqliteRead::Bag(e) => e,
    })?;
    let mut q = db
        .prepare("SELECT topic_id, timestamp, data FROM messages ORDER BY timestamp")
        .map_err(sql_err)?;
    let mut rows = q.query([]).map_err(sql_err)?;
    while let Some(row) = rows.next().map_err(sql_err)? {
        let id: i64 = row.get(0).map_err(sql_err)?;
        let t: i64 = row.get(1).map_err(sql_err)?;
        let data = row.get_ref(2).map_err(sql_err)?;
        let data = data.as_blob().map_err(|e| sql_err(e.into()))?;
        budget.take(path, data.len())?;
        let (name, ty) = by_id.get(&id).ok_or_else(|| {
            bad(
                path,
                format!("a message of topic id {id}, which the topics table does not list"),
            )
        })?;
        if let Some(topic) = topics.get_mut(name) {
            topic.push(
                ty,
                RawMessage {
                    log_time_ns: t,
                    data: data.to_vec(),
                },
            );
        }
    }
    Ok(())
}

/// An SQLite3 file opened read-only, no value longer than [`MAX_RECORD_BYTES`] and no
/// query running past [`MAX_QUERY_SECONDS`].
fn open_sqlite(path: &Path) -> rusqlite::Result<rusqlite::Connection> {
    let db = rusqlite::Connection::open_with_flags(
        path,
        rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY | rusqlite::OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )?;
    db.set_limit(
        rusqlite::limits::Limit::SQLITE_LIMIT_LENGTH,
        MAX_RECORD_BYTES as i32,
    )?;
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(MAX_QUERY_SECONDS);
    db.progress_handler(10_000, Some(move || std::time::Instant::now() > deadline));
    Ok(db)
}

enum SqliteRead {
    Sql(rusqlite::Error),
    Bag(BagError),
}

impl From<rusqlite::Error> for SqliteRead {
    fn from(e: rusqlite::Error) -> Self {
        SqliteRead::Sql(e)
    }
}

/// The topics table: each topic listed in `topics`, and topic id -> name.
fn sqlite_topics(
    path: &Path,
    db: &rusqlite::Connection,
    topics: &mut BTreeMap<String, Topic>,
) -> Result<BTreeMap<i64, (String, String)>, SqliteRead> {
    let mut by_id: BTreeMap<i64, (String, String)> = BTreeMap::new();
    let mut q = db.prepare("SELECT id, name, type, serialization_format FROM topics")?;
    let rows = q.query_map([], |r| {
        Ok((
            r.get::<_, i64>(0)?,
            r.get::<_, String>(1)?,
            r.get::<_, String>(2)?,
            r.get::<_, String>(3)?,
        ))
    })?;
    for row in rows {
        let (id, name, ty, format) = row?;
        if format != "cdr" {
            return Err(SqliteRead::Bag(bad(
                path,
                format!("topic `{name}`: serialization format `{format}`, expected `cdr`"),
            )));
        }
        declare_topic(topics, &name, &ty);
        by_id.insert(id, (name, ty));
    }
    Ok(by_id)
}
