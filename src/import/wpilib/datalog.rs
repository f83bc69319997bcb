//! A reader of WPILib's DataLog files (`.wpilog`), as the WPILib Data Log File Format
//! Specification, version 1.0, describes them: an 8-byte header (`WPILOG`, a 16-bit
//! version, an extra header string), then records, each a bit-field of field lengths, an
//! entry id, a payload size, a timestamp in integer microseconds and the payload. Entry 0
//! carries control records (Start, Finish, Set Metadata) that name each entry, its type
//! and its metadata. All values are little-endian.
//!
//! Only what a SysId analysis needs is decoded into values (`double`, `float`, `int64`,
//! `boolean`, `string`); records of other types are kept as counts. Every breach of the
//! format is reported with the byte offset of the record at fault.

use std::collections::BTreeMap;

/// One entry (a named data channel) of the log.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// The entry's name.
    pub name: String,
    /// The entry's type string (`double`, `string`, ...).
    pub kind: String,
    /// The entry's metadata (SysId logs the unit here, e.g. `Volts`).
    pub metadata: String,
    /// Its values, in file order: (timestamp in microseconds, value).
    pub values: Vec<(i64, Value)>,
}

/// One decoded data value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A number (double, float, integer, boolean as 0/1).
    Number(f64),
    /// A string.
    Text(String),
    /// A value of a type not decoded here (arrays, raw, structs), by its payload size.
    Other(usize),
}

/// A whole log: every entry ever started, by the order they were started in.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DataLog {
    /// The header's extra string.
    pub extra_header: String,
    /// Every entry.
    pub entries: Vec<Entry>,
}

/// Why a file is not a readable data log: the byte offset and what was wrong there.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("byte {offset}: {message}")]
pub struct FormatError {
    /// Byte offset of the fault.
    pub offset: usize,
    /// What was wrong there.
    pub message: String,
}

/// A cursor over the bytes that reports where it ran out.
struct Bytes<'a> {
    data: &'a [u8],
    at: usize,
}

impl<'a> Bytes<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], FormatError> {
        let end = self.at.checked_add(n).filter(|e| *e <= self.data.len());
        let Some(end) = end else {
            return Err(FormatError {
                offset: self.at,
                message: format!(
                    "the file ends inside {what} ({n} bytes needed, {} left)",
                    self.data.len() - self.at
                ),
            });
        };
        let s = &self.data[self.at..end];
        self.at = end;
        Ok(s)
    }

    /// An unsigned little-endian integer of `n` bytes (1 to 8).
    fn uint(&mut self, n: usize, what: &str) -> Result<u64, FormatError> {
        let b = self.take(n, what)?;
        Ok(b.iter()
            .rev()
            .fold(0u64, |acc, x| (acc << 8) | u64::from(*x)))
    }

    fn string(&mut self, what: &str) -> Result<String, FormatError> {
        let at = self.at;
        let n = self.uint(4, what)? as usize;
        let b = self.take(n, what)?;
        String::from_utf8(b.to_vec()).map_err(|_| FormatError {
            offset: at,
            message: format!("{what} is not UTF-8"),
        })
    }
}

/// Parses a whole data log.
pub fn parse(data: &[u8]) -> Result<DataLog, FormatError> {
    let mut b = Bytes { data, at: 0 };
    let magic = b.take(6, "the header").map_err(|_| FormatError {
        offset: 0,
        message: "not a WPILib data log: shorter than its 6-byte `WPILOG` mark".into(),
    })?;
    if magic != b"WPILOG" {
        return Err(FormatError {
            offset: 0,
            message: "not a WPILib data log: it does not start with `WPILOG`".into(),
        });
    }
    let version = b.uint(2, "the header's version")?;
    if version >> 8 != 1 {
        return Err(FormatError {
            offset: 6,
            message: format!(
                "data log version {}.{}: this reader knows version 1.x",
                version >> 8,
                version & 0xff
            ),
        });
    }
    let extra_header = b.string("the extra header string")?;
    let mut log = DataLog {
        extra_header,
        entries: Vec::new(),
    };
    // Entry id -> index into `log.entries` while the entry is started.
    let mut live: BTreeMap<u32, usize> = BTreeMap::new();
    while b.at < data.len() {
        record(&mut b, &mut log, &mut live)?;
    }
    // Records need not be in time order (a logger's threads append as they go): each
    // entry's values are sorted by time, records of one time keeping file order.
    for e in &mut log.entries {
        e.values.sort_by_key(|(t, _)| *t);
    }
    Ok(log)
}

/// Reads one record and files it.
fn record(
    b: &mut Bytes,
    log: &mut DataLog,
    live: &mut BTreeMap<u32, usize>,
) -> Result<(), FormatError> {
    let start = b.at;
    let bits = b.take(1, "a record header")?[0];
    if bits & 0x80 != 0 {
        return Err(FormatError {
            offset: start,
            message: format!("record header bit-field {bits:#04x} has its spare bit set"),
        });
    }
    let id_len = usize::from(bits & 0x3) + 1;
    let size_len = usize::from((bits >> 2) & 0x3) + 1;
    let time_len = usize::from((bits >> 4) & 0x7) + 1;
    let id = b.uint(id_len, "a record's entry id")? as u32;
    let size = b.uint(size_len, "a record's payload size")? as usize;
    let timestamp_us = b.uint(time_len, "a record's timestamp")? as i64;
    let payload = b.take(size, "a record's payload")?;
    if id == 0 {
        return control(payload, start, log, live);
    }
    let Some(&index) = live.get(&id) else {
        return Err(FormatError {
            offset: start,
            message: format!("a data record for entry {id}, which no Start record has opened"),
        });
    };
    let entry = &mut log.entries[index];
    let value = decode(&entry.kind, payload).map_err(|fault| FormatError {
        offset: start,
        message: format!("entry `{}` ({}): {fault}", entry.name, entry.kind),
    })?;
    entry.values.push((timestamp_us, value));
    Ok(())
}

/// A control record: Start (0), Finish (1) or Set Metadata (2).
fn control(
    payload: &[u8],
    start: usize,
    log: &mut DataLog,
    live: &mut BTreeMap<u32, usize>,
) -> Result<(), FormatError> {
    let mut p = Bytes {
        data: payload,
        at: 0,
    };
    let at = |e: FormatError| FormatError {
        offset: start,
        message: format!("control record: {}", e.message),
    };
    let kind = p.take(1, "the control type").map_err(at)?[0];
    let id = p.uint(4, "the entry id").map_err(at)? as u32;
    match kind {
        0 => {
            let name = p.string("the entry name").map_err(at)?;
            let kind = p.string("the entry type").map_err(at)?;
            let metadata = p.string("the entry metadata").map_err(at)?;
            // A name started again (a restarted logger, a Start repeated) is the same
            // channel: its values go on in the one entry, so no lookup by name finds
            // half of them.
            match log.entries.iter().position(|e| e.name == name) {
                Some(index) if log.entries[index].kind != kind => {
                    return Err(FormatError {
                        offset: start,
                        message: format!(
                            "entry `{name}` started again as `{kind}`; it was started as `{}`",
                            log.entries[index].kind
                        ),
                    })
                }
                Some(index) => {
                    live.insert(id, index);
                    if !metadata.is_empty() {
                        log.entries[index].metadata = metadata;
                    }
                }
                None => {
                    live.insert(id, log.entries.len());
                    log.entries.push(Entry {
                        name,
                        kind,
                        metadata,
                        values: Vec::new(),
                    });
                }
            }
        }
        1 => {
            live.remove(&id);
        }
        2 => {
            let metadata = p.string("the entry metadata").map_err(at)?;
            let Some(&index) = live.get(&id) else {
                return Err(FormatError {
                    offset: start,
                    message: format!("Set Metadata for entry {id}, which is not started"),
                });
            };
            log.entries[index].metadata = metadata;
        }
        other => {
            return Err(FormatError {
                offset: start,
                message: format!(
                "control record type {other}: expected 0 (Start), 1 (Finish) or 2 (Set Metadata)"
            ),
            })
        }
    }
    Ok(())
}

/// Why a payload is not a value of its entry's type.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum PayloadFault {
    /// A fixed-size type with another size.
    #[error("a payload of {have} bytes; this type has {want}")]
    Size {
        /// The payload's bytes.
        have: usize,
        /// The type's.
        want: usize,
    },
    /// Text that is not UTF-8.
    #[error("a string that is not UTF-8")]
    NotUtf8,
}

/// A payload of an entry's type as a value.
fn decode(kind: &str, payload: &[u8]) -> Result<Value, PayloadFault> {
    let fixed = |n: usize| -> Result<[u8; 8], PayloadFault> {
        if payload.len() != n {
            return Err(PayloadFault::Size {
                have: payload.len(),
                want: n,
            });
        }
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(payload);
        Ok(b)
    };
    Ok(match kind {
        "double" => Value::Number(f64::from_le_bytes(fixed(8)?)),
        "float" => {
            let b = fixed(4)?;
            Value::Number(f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])))
        }
        "int64" => Value::Number(i64::from_le_bytes(fixed(8)?) as f64),
        "boolean" => Value::Number(f64::from(fixed(1)?[0])),
        "string" => {
            Value::Text(String::from_utf8(payload.to_vec()).map_err(|_| PayloadFault::NotUtf8)?)
        }
        _ => Value::Other(payload.len()),
    })
}

/// Writes a data log (used by tests to build logs from the specification, and by
/// anyone who wants a `.wpilog` of a recording). `records`: (entry index, timestamp in
/// microseconds, payload bytes) in file order; every entry is started at time 0.
pub fn write(
    extra_header: &str,
    entries: &[(&str, &str, &str)],
    records: &[(usize, i64, Vec<u8>)],
) -> Vec<u8> {
    let mut out = b"WPILOG".to_vec();
    out.extend_from_slice(&0x0100u16.to_le_bytes());
    out.extend_from_slice(&(extra_header.len() as u32).to_le_bytes());
    out.extend_from_slice(extra_header.as_bytes());
    let put = |out: &mut Vec<u8>, id: u32, t: i64, payload: &[u8]| {
        // Four-byte id and size, eight-byte timestamp: the bit-field 0b0111_1111.
        out.push(0x7f);
        out.extend_from_slice(&id.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        out.extend_from_slice(&t.to_le_bytes());
        out.extend_from_slice(payload);
    };
    for (i, (name, kind, metadata)) in entries.iter().enumerate() {
        let mut p = vec![0u8];
        p.extend_from_slice(&(i as u32 + 1).to_le_bytes());
        for s in [name, kind, metadata] {
            p.extend_from_slice(&(s.len() as u32).to_le_bytes());
            p.extend_from_slice(s.as_bytes());
        }
        put(&mut out, 0, 0, &p);
    }
    for (i, t, payload) in records {
        put(&mut out, *i as u32 + 1, *t, payload);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The specification's own examples: an empty version 1.0 header, the Start record of
    /// an `int64` entry `test` with id 1 (32 bytes) and the record of its value 3 at 1 s.
    #[test]
    fn the_specifications_example_bytes_read_as_it_says() {
        let mut f = vec![0x57, 0x50, 0x49, 0x4c, 0x4f, 0x47, 0x00, 0x01, 0, 0, 0, 0];
        f.extend_from_slice(&[
            0x20, 0x00, 0x1a, 0x40, 0x42, 0x0f, 0x00, 1, 0, 0, 0, 4, 0, 0, 0,
        ]);
        f.extend_from_slice(b"test");
        f.extend_from_slice(&[5, 0, 0, 0]);
        f.extend_from_slice(b"int64");
        f.extend_from_slice(&[0, 0, 0, 0]);
        f.extend_from_slice(&[0x20, 0x01, 0x08, 0x40, 0x42, 0x0f, 3, 0, 0, 0, 0, 0, 0, 0]);
        let log = parse(&f).unwrap();
        assert_eq!(log.entries.len(), 1);
        assert_eq!(log.entries[0].name, "test");
        assert_eq!(log.entries[0].values, vec![(1_000_000, Value::Number(3.0))]);
        // Cut inside the last record: refused at that record's offset.
        let cut = &f[..f.len() - 3];
        let e = parse(cut).unwrap_err();
        assert!(e.message.contains("ends inside a record's payload"), "{e}");
    }

    #[test]
    fn written_logs_read_back() {
        let bytes = write(
            "agvsim",
            &[
                ("voltage-left-drive", "double", "Volts"),
                ("state", "string", ""),
            ],
            &[
                (0, 20_000, 1.5f64.to_le_bytes().to_vec()),
                (1, 20_001, b"none".to_vec()),
            ],
        );
        let log = parse(&bytes).unwrap();
        assert_eq!(log.extra_header, "agvsim");
        assert_eq!(log.entries[0].metadata, "Volts");
        assert_eq!(log.entries[0].values, vec![(20_000, Value::Number(1.5))]);
        assert_eq!(
            log.entries[1].values,
            vec![(20_001, Value::Text("none".into()))]
        );
    }

    /// A Start record with its own id for `name`.
    fn start(id: u32, name: &str, kind: &str) -> Vec<u8> {
        let mut p = vec![0u8];
        p.extend_from_slice(&id.to_le_bytes());
        for s in [name, kind, ""] {
            p.extend_from_slice(&(s.len() as u32).to_le_bytes());
            p.extend_from_slice(s.as_bytes());
        }
        p
    }

    /// One record, as the specification lays it out (four-byte id and size, eight-byte
    /// timestamp).
    fn put(out: &mut Vec<u8>, id: u32, t: i64, payload: &[u8]) {
        out.push(0x7f);
        out.extend_from_slice(&id.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        out.extend_from_slice(&t.to_le_bytes());
        out.extend_from_slice(payload);
    }

    /// An entry finished and started again under a new id, a Start repeated, and records
    /// out of time order: one entry, every value, in time order. A name started again as
    /// another type is refused naming both.
    #[test]
    fn restarted_entries_and_unsorted_records_read_as_one_channel_in_time_order() {
        let mut f = write("", &[], &[]);
        let v = |x: f64| x.to_le_bytes().to_vec();
        put(&mut f, 0, 0, &start(1, "speed", "double"));
        put(&mut f, 1, 30, &v(3.0));
        put(&mut f, 1, 10, &v(1.0));
        put(&mut f, 0, 40, &{
            let mut p = vec![1u8];
            p.extend_from_slice(&1u32.to_le_bytes());
            p
        });
        put(&mut f, 0, 50, &start(7, "speed", "double"));
        put(&mut f, 0, 50, &start(7, "speed", "double"));
        put(&mut f, 7, 60, &v(6.0));
        put(&mut f, 7, 20, &v(2.0));
        let log = parse(&f).unwrap();
        assert_eq!(log.entries.len(), 1);
        let times: Vec<i64> = log.entries[0].values.iter().map(|(t, _)| *t).collect();
        assert_eq!(times, [10, 20, 30, 60]);
        put(&mut f, 0, 70, &start(9, "speed", "int64"));
        let e = parse(&f).unwrap_err();
        assert!(
            e.message
                .contains("started again as `int64`; it was started as `double`"),
            "{e}"
        );
    }
}
