//! An MCAP file's messages, read record by record within limits: no record or chunk
//! longer than [`MAX_RECORD_BYTES`] (checked before it is decompressed), and every message
//! kept counted against the bag's [`Budget`].

use std::collections::BTreeMap;
use std::path::Path;

use super::cdr;
use crate::import::bag::{
    bad, declare_topic, BagError, Budget, RawMessage, Topic, MAX_RECORD_BYTES,
};

/// Reads an MCAP file's channels and messages into `topics`.
pub(super) fn read(
    path: &Path,
    topics: &mut BTreeMap<String, Topic>,
    budget: &mut Budget,
) -> Result<(), BagError> {
    let buf = std::fs::read(path).map_err(|source| BagError::Io {
        path: path.to_owned(),
        source,
    })?;
    // Channels without messages are listed in the summary, when the file has one.
    if let Ok(Some(summary)) = read_mcap_summary(&buf) {
        let mut channels: Vec<_> = summary.channels.values().collect();
        channels.sort_by_key(|c| c.id);
        for c in channels {
            let ty = c.schema.as_ref().map_or(String::new(), |s| s.name.clone());
            mcap_topic(topics, &c.topic, &c.message_encoding, ty);
        }
    }
    // The records are read one by one, each chunk's lengths (compressed and decompressed)
    // checked before it is decompressed: a record claiming a terabyte is refused, not
    // allocated.
    let mut reader = mcap::sans_io::LinearReader::new_with_options(
        mcap::sans_io::LinearReaderOptions::default()
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(MAX_RECORD_BYTES),
    );
    let mut stream = McapStream::default();
    let mut rest: &[u8] = &buf;
    while let Some(event) = reader.next_event() {
        let record = match event {
            Ok(mcap::sans_io::LinearReadEvent::ReadRequest(need)) => {
                let n = need.min(rest.len());
                reader.insert(n).copy_from_slice(&rest[..n]);
                reader.notify_read(n);
                rest = &rest[n..];
                continue;
            }
            Ok(mcap::sans_io::LinearReadEvent::Record { opcode, data }) => {
                mcap::parse_record(opcode, data)
            }
            Err(e) => Err(e),
        };
        stream.count += 1;
        let record = record.map_err(|e| {
            bad(
                path,
                format!(
                    "record {}: {e} (a truncated or damaged MCAP file? `mcap doctor` says more; no record or chunk longer than {MAX_RECORD_BYTES} bytes is read)",
                    stream.count
                ),
            )
        })?;
        stream.take(path, record, topics, budget)?;
    }
    Ok(())
}

/// What an MCAP file's records have declared so far.
#[derive(Default)]
struct McapStream {
    /// Schema id -> its type name.
    schemas: BTreeMap<u16, String>,
    /// Channel id -> (topic, message encoding, ROS 2 type).
    channels: BTreeMap<u16, (String, String, String)>,
    /// Records read.
    count: usize,
}

impl McapStream {
    fn take(
        &mut self,
        path: &Path,
        record: mcap::records::Record,
        topics: &mut BTreeMap<String, Topic>,
        budget: &mut Budget,
    ) -> Result<(), BagError> {
        use mcap::records::Record;
        match record {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, header.name);
            }
            Record::Channel(c) => {
                let ty = self.schemas.get(&c.schema_id).cloned().unwrap_or_default();
                let ty = mcap_topic(topics, &c.topic, &c.message_encoding, ty);
                self.channels
                    .insert(c.id, (c.topic, c.message_encoding, ty));
            }
            Record::Message { header, data } => {
                let count = self.count;
                let (topic, encoding, ty) = self.channels.get(&header.channel_id).ok_or_else(|| {
                    bad(
                        path,
                        format!(
                            "record {count}: a message on channel {}, which no channel record before it declares",
                            header.channel_id
                        ),
                    )
                })?;
                // A ROS 1 data set converted to MCAP keeps ROS 1's serialisation.
                let ros1 = match encoding.as_str() {
                    "cdr" => false,
                    "ros1" => true,
                    other => {
                        return Err(bad(
                            path,
                            format!(
                                "topic `{topic}`: message encoding `{other}`, expected `cdr` (ROS 2) or `ros1`"
                            ),
                        ))
                    }
                };
                budget.take(path, data.len())?;
                let data = if ros1 {
                    [&cdr::ROS1_MARKER[..], &data].concat()
                } else {
                    data.into_owned()
                };
                if let Some(t) = topics.get_mut(topic) {
                    t.push(
                        ty,
                        RawMessage {
                            log_time_ns: header.log_time as i64,
                            data,
                        },
                    );
                }
            }
            _ => {}
        }
        Ok(())
    }
}

/// Lists a channel's topic, ROS 1 type names as ROS 2's.
fn mcap_topic(
    topics: &mut BTreeMap<String, Topic>,
    topic: &str,
    encoding: &str,
    ty: String,
) -> String {
    let ty = if encoding == "ros1" {
        crate::import::ros1::ros2_type(&ty)
    } else {
        ty
    };
    declare_topic(topics, topic, &ty);
    ty
}

/// An MCAP file's summary section, its records' lengths limited.
fn read_mcap_summary(buf: &[u8]) -> mcap::McapResult<Option<mcap::Summary>> {
    use std::io::{Read, Seek};
    let mut cursor = std::io::Cursor::new(buf);
    let mut reader = mcap::sans_io::SummaryReader::new_with_options(
        mcap::sans_io::SummaryReaderOptions::default()
            .with_file_size(buf.len() as u64)
            .with_record_length_limit(MAX_RECORD_BYTES),
    );
    while let Some(event) = reader.next_event() {
        match event? {
            mcap::sans_io::SummaryReadEvent::ReadRequest(n) => {
                let read = cursor.read(reader.insert(n))?;
                reader.notify_read(read);
            }
            mcap::sans_io::SummaryReadEvent::SeekRequest(to) => {
                let pos = cursor.seek(to)?;
                reader.notify_seeked(pos);
            }
        }
    }
    Ok(reader.finish())
}
