//! A ROS 1 bag (`.bag`, format 2.0): its connections and messages, read whole.
//!
//! The file is `#ROSBAG V2.0\n` and then records, each a `u32` header length, a header of
//! `u32`-length-prefixed `name=value` fields (`op` names the record), a `u32` data length
//! and the data. Messages live in chunk records (op 0x05, their data uncompressed, `bz2`
//! or `lz4`), each holding connection records (op 0x07: `conn`, and in its data the
//! connection header with `topic` and `type`) and message-data records (op 0x02: `conn`
//! and `time`, two `u32` of s and ns; the data is the ROS 1 serialised message). The
//! index records after the chunks are skipped: reading every chunk in order finds every
//! message, also in a bag whose recording was cut short before its index was written.
//!
//! A message keeps its ROS 1 bytes behind [`ROS1_MARKER`], which tells the message
//! decoders (`import::ros2::cdr`) to read ROS 1's layout; types are renamed to ROS 2's
//! ([`ros2_type`]).

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use super::{ros2_type, ROS1_MARKER};
use crate::import::bag::{
    bad, declare_topic, BagError, Budget, RawMessage, Topic, MAX_RECORD_BYTES,
};

const MAGIC: &[u8] = b"#ROSBAG V2.0\n";
const OP_MESSAGE_DATA: u8 = 0x02;
const OP_CHUNK: u8 = 0x05;
const OP_CONNECTION: u8 = 0x07;

/// One record: its header fields and its data.
struct Record<'a> {
    fields: Vec<(&'a [u8], &'a [u8])>,
    data: &'a [u8],
}

impl<'a> Record<'a> {
    fn field(&self, name: &str) -> Option<&'a [u8]> {
        self.fields
            .iter()
            .find(|(n, _)| *n == name.as_bytes())
            .map(|(_, v)| *v)
    }

    fn op(&self) -> Option<u8> {
        self.field("op").and_then(|v| v.first().copied())
    }

    fn u32_field(&self, name: &str) -> Option<u32> {
        let v: [u8; 4] = self.field(name)?.try_into().ok()?;
        Some(u32::from_le_bytes(v))
    }
}

fn le_u32(buf: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(buf.get(at..at + 4)?.try_into().ok()?))
}

/// `name=value` fields, each after its `u32` length.
fn fields(mut h: &[u8]) -> Option<Vec<(&[u8], &[u8])>> {
    let mut out = vec![];
    while !h.is_empty() {
        let n = le_u32(h, 0)? as usize;
        let f = h.get(4..4 + n)?;
        let eq = f.iter().position(|&b| b == b'=')?;
        out.push((&f[..eq], &f[eq + 1..]));
        h = &h[4 + n..];
    }
    Some(out)
}

/// The records of `buf` in order with their offsets; `Err(offset)` where one is cut short
/// or malformed.
fn records(buf: &[u8]) -> Result<Vec<(usize, Record<'_>)>, usize> {
    let mut out = vec![];
    let mut at = 0;
    while at < buf.len() {
        let rec = (|| {
            let hl = le_u32(buf, at)? as usize;
            let header = buf.get(at + 4..at + 4 + hl)?;
            let dl = le_u32(buf, at + 4 + hl)? as usize;
            let data = buf.get(at + 8 + hl..at + 8 + hl + dl)?;
            Some((
                Record {
                    fields: fields(header)?,
                    data,
                },
                8 + hl + dl,
            ))
        })();
        let (r, len) = rec.ok_or(at)?;
        out.push((at, r));
        at += len;
    }
    Ok(out)
}

/// A chunk's records' bytes, decompressed.
///
/// Its size is checked before it is decompressed (rosbag's chunks are 768 KiB by default);
/// the messages kept from it are counted against the bag's budget one by one.
fn chunk_bytes(path: &Path, rec: &Record, offset: usize) -> Result<Vec<u8>, BagError> {
    let compression = rec.field("compression").unwrap_or(b"none");
    let size = rec.u32_field("size").unwrap_or(0) as usize;
    if size > MAX_RECORD_BYTES {
        return Err(bad(
            path,
            format!("the chunk at byte {offset} says {size} bytes uncompressed, more than the {MAX_RECORD_BYTES} accepted (a damaged bag?)"),
        ));
    }
    let mut out = Vec::with_capacity(size);
    let decoded = match compression {
        b"none" => {
            out.extend_from_slice(rec.data);
            Ok(())
        }
        b"bz2" => bzip2::read::BzDecoder::new(rec.data)
            .take(size as u64)
            .read_to_end(&mut out)
            .map(|_| ()),
        b"lz4" => lz4::Decoder::new(rec.data)
            .and_then(|d| d.take(size as u64).read_to_end(&mut out))
            .map(|_| ()),
        other => {
            return Err(bad(
                path,
                format!(
                    "the chunk at byte {offset} is compressed with `{}`; expected none, bz2 or lz4",
                    String::from_utf8_lossy(other)
                ),
            ))
        }
    };
    decoded.map_err(|e| {
        bad(
            path,
            format!(
                "the {} chunk at byte {offset} does not decompress: {e} (a damaged bag?)",
                String::from_utf8_lossy(compression)
            ),
        )
    })?;
    if out.len() != size {
        return Err(bad(
            path,
            format!(
                "the chunk at byte {offset} decompresses to {} bytes, its header says {size} (a damaged bag?)",
                out.len()
            ),
        ));
    }
    Ok(out)
}

/// What is wrong with a record of a bag.
#[derive(Debug, thiserror::Error)]
enum RecordFault {
    /// A record without a field it needs.
    #[error("a {record} record without `{field}`")]
    Missing {
        record: &'static str,
        field: &'static str,
    },
    /// A connection record whose header cannot be read.
    #[error("a connection record whose header is malformed")]
    MalformedHeader,
    /// A connection without a message type.
    #[error("connection `{0}` has no `type`")]
    NoType(String),
    /// A message without its time.
    #[error("a message record without an 8-byte `time`")]
    NoTime,
}

/// A bag's connections (conn -> (topic, ROS 2 type)) and its messages by connection, kept
/// until every connection is known.
#[derive(Default)]
struct Gathered {
    conns: BTreeMap<u32, (String, String)>,
    messages: Vec<(u32, RawMessage)>,
}

impl Gathered {
    /// Takes one record: a connection's topic and type, or a message.
    fn take(&mut self, rec: &Record) -> Result<(), RecordFault> {
        match rec.op() {
            Some(OP_CONNECTION) => self.connection(rec),
            Some(OP_MESSAGE_DATA) => self.message(rec),
            _ => Ok(()),
        }
    }

    fn connection(&mut self, rec: &Record) -> Result<(), RecordFault> {
        let missing = |field| RecordFault::Missing {
            record: "connection",
            field,
        };
        let conn = rec.u32_field("conn").ok_or(missing("conn"))?;
        let h = fields(rec.data).ok_or(RecordFault::MalformedHeader)?;
        let get = |n: &str| {
            h.iter()
                .find(|(k, _)| *k == n.as_bytes())
                .map(|(_, v)| String::from_utf8_lossy(v).into_owned())
        };
        let topic = rec
            .field("topic")
            .map(|v| String::from_utf8_lossy(v).into_owned())
            .or_else(|| get("topic"))
            .ok_or(missing("topic"))?;
        let ty = get("type").ok_or_else(|| RecordFault::NoType(topic.clone()))?;
        self.conns.entry(conn).or_insert((topic, ros2_type(&ty)));
        Ok(())
    }

    fn message(&mut self, rec: &Record) -> Result<(), RecordFault> {
        let conn = rec.u32_field("conn").ok_or(RecordFault::Missing {
            record: "message",
            field: "conn",
        })?;
        let time = rec
            .field("time")
            .filter(|t| t.len() == 8)
            .ok_or(RecordFault::NoTime)?;
        let sec = le_u32(time, 0).expect("8 bytes") as i64;
        let nsec = le_u32(time, 4).expect("8 bytes") as i64;
        let mut data = Vec::with_capacity(rec.data.len() + ROS1_MARKER.len());
        data.extend_from_slice(&ROS1_MARKER);
        data.extend_from_slice(rec.data);
        self.messages.push((
            conn,
            RawMessage {
                log_time_ns: sec * 1_000_000_000 + nsec,
                data,
            },
        ));
        Ok(())
    }
}

/// Reads a ROS 1 bag's topics into `topics`.
pub(in crate::import) fn read(
    path: &Path,
    buf: &[u8],
    topics: &mut BTreeMap<String, Topic>,
    budget: &mut Budget,
) -> Result<(), BagError> {
    let body = buf.strip_prefix(MAGIC).ok_or_else(|| {
        let head = String::from_utf8_lossy(&buf[..buf.len().min(13)]).trim_end().to_string();
        bad(
            path,
            format!("starts `{head}`; expected `#ROSBAG V2.0` (a ROS 1 bag of format 2.0, the only one rosbag writes since 2010)"),
        )
    })?;
    let cut = |at: usize, inside: &str| {
        bad(
            path,
            format!("a record {inside}at byte {at} is cut short or malformed (a damaged bag? `rosbag reindex` repairs one whose recording was cut short)"),
        )
    };
    let top = records(body).map_err(|at| cut(at + MAGIC.len(), ""))?;
    let mut gathered = Gathered::default();
    for (at, rec) in &top {
        let offset = at + MAGIC.len();
        if rec.op() == Some(OP_CHUNK) {
            let bytes = chunk_bytes(path, rec, offset)?;
            let inner = records(&bytes)
                .map_err(|at| cut(at, &format!("in the chunk at byte {offset}, ")))?;
            for (_, r) in &inner {
                gathered
                    .take(r)
                    .map_err(|m| bad(path, format!("in the chunk at byte {offset}: {m}")))?;
                if r.op() == Some(OP_MESSAGE_DATA) {
                    budget.take(path, r.data.len())?;
                }
            }
        } else {
            gathered
                .take(rec)
                .map_err(|m| bad(path, format!("at byte {offset}: {m}")))?;
            if rec.op() == Some(OP_MESSAGE_DATA) {
                budget.take(path, rec.data.len())?;
            }
        }
    }
    let Gathered { conns, messages } = gathered;
    for (topic, ty) in conns.values() {
        declare_topic(topics, topic, ty);
    }
    for (conn, m) in messages {
        let (topic, ty) = conns.get(&conn).ok_or_else(|| {
            bad(
                path,
                format!("a message of connection {conn}, which no connection record names"),
            )
        })?;
        topics
            .get_mut(topic)
            .expect("every connection's topic is listed")
            .push(ty, m);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_cut_short_is_found_at_its_offset() {
        // One whole record (op 0x03 with a one-byte data), then one cut inside its header.
        let mut buf = vec![];
        let field = b"op=\x03";
        buf.extend_from_slice(&(4 + field.len() as u32).to_le_bytes());
        buf.extend_from_slice(&(field.len() as u32).to_le_bytes());
        buf.extend_from_slice(field);
        buf.extend_from_slice(&1u32.to_le_bytes());
        buf.push(0);
        let whole = buf.len();
        buf.extend_from_slice(&100u32.to_le_bytes());
        buf.extend_from_slice(b"op");
        assert_eq!(records(&buf).err(), Some(whole));
        assert_eq!(
            records(&buf[..whole]).map(|r| (r[0].0, r[0].1.op())),
            Ok((0, Some(0x03)))
        );
    }
}
