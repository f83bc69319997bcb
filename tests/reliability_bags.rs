//! Hostile bag containers (the third reliability campaign, "crash, hang, memory"): MCAP
//! chunks whose records claim terabytes or decompress to gigabytes of zeros, SQLite3 files
//! whose `messages` is a view over itself. Each file is written here, byte by byte; each
//! must be refused naming the file, quickly and without taking the memory it claims.

mod common;
use common::{text, tmp};

use std::path::Path;
use std::process::{Command, Output};

fn import(bag: &Path, out: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args(["import", "ros2"])
        .arg(bag)
        .arg("--out")
        .arg(out)
        .output()
        .expect("agvsim runs")
}

/// MCAP's records, as the specification lays them out (mcap.dev/spec).
mod mcap {
    pub const MAGIC: &[u8] = b"\x89MCAP0\r\n";

    fn string(out: &mut Vec<u8>, s: &str) {
        out.extend_from_slice(&(s.len() as u32).to_le_bytes());
        out.extend_from_slice(s.as_bytes());
    }

    pub fn record(op: u8, body: &[u8]) -> Vec<u8> {
        let mut r = vec![op];
        r.extend_from_slice(&(body.len() as u64).to_le_bytes());
        r.extend_from_slice(body);
        r
    }

    /// A message record's opcode, claimed length and fixed fields (channel 1), without
    /// its data: the data follows, or does not.
    pub fn message_head(claimed_len: u64) -> Vec<u8> {
        let mut r = vec![0x05];
        r.extend_from_slice(&claimed_len.to_le_bytes());
        r.extend_from_slice(&1u16.to_le_bytes()); // channel
        r.extend_from_slice(&0u32.to_le_bytes()); // sequence
        r.extend_from_slice(&1_000_000_000u64.to_le_bytes()); // log time
        r.extend_from_slice(&1_000_000_000u64.to_le_bytes()); // publish time
        r
    }

    /// A file: header, a JointState schema and channel, one chunk holding `compressed`
    /// (`uncompressed_size` bytes of records once decompressed), data end, footer.
    pub fn file(compressed: &[u8], compression: &str, uncompressed_size: u64) -> Vec<u8> {
        let mut f = MAGIC.to_vec();
        let mut b = vec![];
        string(&mut b, "ros2");
        string(&mut b, "hostile");
        f.extend(record(0x01, &b));
        let mut b = 1u16.to_le_bytes().to_vec();
        string(&mut b, "sensor_msgs/msg/JointState");
        string(&mut b, "ros2msg");
        string(&mut b, "");
        f.extend(record(0x03, &b));
        let mut b = 1u16.to_le_bytes().to_vec();
        b.extend_from_slice(&1u16.to_le_bytes());
        string(&mut b, "/joint_states");
        string(&mut b, "cdr");
        b.extend_from_slice(&0u32.to_le_bytes()); // metadata: an empty map
        f.extend(record(0x04, &b));
        let mut b = vec![];
        b.extend_from_slice(&0u64.to_le_bytes());
        b.extend_from_slice(&u64::MAX.to_le_bytes());
        b.extend_from_slice(&uncompressed_size.to_le_bytes());
        b.extend_from_slice(&0u32.to_le_bytes()); // no CRC
        string(&mut b, compression);
        b.extend_from_slice(&(compressed.len() as u64).to_le_bytes());
        b.extend_from_slice(compressed);
        f.extend(record(0x06, &b));
        f.extend(record(0x0F, &0u32.to_le_bytes()));
        let mut b = vec![];
        b.extend_from_slice(&0u64.to_le_bytes());
        b.extend_from_slice(&0u64.to_le_bytes());
        b.extend_from_slice(&0u32.to_le_bytes());
        f.extend(record(0x02, &b));
        f.extend_from_slice(MAGIC);
        f
    }
}

/// Zstandard frames built block by block (RFC 8878): raw blocks carry bytes as they
/// are, RLE blocks repeat one byte, so a few bytes stand for 128 KiB of zeros.
mod zstd_frame {
    const BLOCK: usize = 128 << 10;

    fn block_header(out: &mut Vec<u8>, last: bool, kind: u32, size: usize) {
        let h = u32::from(last) | (kind << 1) | ((size as u32) << 3);
        out.extend_from_slice(&h.to_le_bytes()[..3]);
    }

    /// One frame: for each part, its bytes as raw blocks, then its count of zero bytes as
    /// RLE blocks.
    pub fn frame(parts: &[(&[u8], u64)]) -> Vec<u8> {
        let mut f = vec![0x28, 0xB5, 0x2F, 0xFD, 0x00, 0x38]; // magic; no content size; 128 KiB window
        let mut blocks: Vec<(u32, usize, Option<&[u8]>)> = vec![];
        for (head, zeros) in parts {
            blocks.extend(head.chunks(BLOCK).map(|c| (0, c.len(), Some(c))));
            let mut left = *zeros;
            while left > 0 {
                let n = left.min(BLOCK as u64) as usize;
                blocks.push((1, n, None));
                left -= n as u64;
            }
        }
        let count = blocks.len();
        for (i, (kind, size, bytes)) in blocks.into_iter().enumerate() {
            block_header(&mut f, i + 1 == count, kind, size);
            match bytes {
                Some(b) => f.extend_from_slice(b),
                None => f.push(0),
            }
        }
        f
    }
}

#[test]
fn an_mcap_record_claiming_a_terabyte_or_two_to_the_64_is_refused_naming_the_file() {
    let dir = tmp("claims");
    for (name, claim) in [("tera", 1u64 << 40), ("max", u64::MAX)] {
        let records = mcap::message_head(claim);
        for (compression, chunk) in [
            ("zstd", zstd_frame::frame(&[(&records, 0)])),
            ("", records.clone()),
        ] {
            let bag = dir.join(format!("{name}-{}.mcap", compression.len()));
            std::fs::write(&bag, mcap::file(&chunk, compression, records.len() as u64)).unwrap();
            let o = import(&bag, &dir.join("out"));
            let t = text(&o);
            assert_eq!(o.status.code(), Some(2), "{name} {compression}: {t}");
            assert!(t.contains(&bag.display().to_string()), "{t}");
            assert!(t.contains("record"), "{t}");
            assert!(t.contains("bytes is read"), "{t}");
            assert!(!t.contains("panicked"), "{t}");
        }
    }
}

#[test]
fn a_chunk_of_compressed_zeros_is_stopped_by_the_bytes_it_decompresses_to() {
    // Nine messages of 60 MiB of zeros each (540 MiB decompressed, more than the 512 MiB
    // read from one bag), in a file of a few kilobytes.
    let dir = tmp("zeros");
    let data_len: u64 = 60 << 20;
    let head = mcap::message_head(22 + data_len);
    let frames = zstd_frame::frame(&[(&head[..], data_len); 9]);
    let uncompressed = 9 * (9 + 22 + data_len);
    let bag = dir.join("zeros.mcap");
    let file = mcap::file(&frames, "zstd", uncompressed);
    assert!(file.len() < 100_000, "{} bytes", file.len());
    std::fs::write(&bag, &file).unwrap();
    let o = import(&bag, &dir.join("out"));
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("zeros.mcap"), "{t}");
    assert!(t.contains("bytes decompressed"), "{t}");
}

fn sqlite_bag(path: &Path, messages_sql: &str) {
    let db = rusqlite::Connection::open(path).unwrap();
    db.execute_batch(&format!(
        "CREATE TABLE topics (id INTEGER PRIMARY KEY, name TEXT, type TEXT, serialization_format TEXT, offered_qos_profiles TEXT);
         INSERT INTO topics VALUES (1, '/joint_states', 'sensor_msgs/msg/JointState', 'cdr', '');
         {messages_sql}"
    ))
    .unwrap();
}

#[test]
fn an_sqlite_bag_whose_messages_are_a_view_is_refused_at_once() {
    let dir = tmp("sqlite-view");
    for (name, sql) in [
        (
            "recursive",
            "CREATE VIEW messages AS WITH RECURSIVE r(id, topic_id, timestamp, data) AS
               (SELECT 1, 1, 0, x'00' UNION ALL SELECT id + 1, 1, timestamp + 1, data FROM r)
             SELECT * FROM r;",
        ),
        (
            "blobs",
            "CREATE VIEW messages AS SELECT 1 AS id, 1 AS topic_id, 0 AS timestamp, zeroblob(1000000000) AS data;",
        ),
    ] {
        let bag = dir.join(format!("{name}.db3"));
        sqlite_bag(&bag, sql);
        let o = import(&bag, &dir.join("out"));
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {t}");
        assert!(t.contains(&format!("{name}.db3")), "{t}");
        assert!(t.contains("`messages` is a view, not a table"), "{t}");
    }
}

#[test]
fn an_sqlite_message_longer_than_a_record_is_refused() {
    // A real table holding one 70 MB blob (zeros, so the file stays small on most file
    // systems once SQLite writes it): longer than any recorder's message.
    let dir = tmp("sqlite-long");
    let bag = dir.join("long.db3");
    sqlite_bag(
        &bag,
        "CREATE TABLE messages (id INTEGER PRIMARY KEY, topic_id INTEGER, timestamp INTEGER, data BLOB);
         INSERT INTO messages VALUES (1, 1, 0, zeroblob(70000000));",
    );
    let o = import(&bag, &dir.join("out"));
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("long.db3"), "{t}");
    assert!(t.contains("too big"), "{t}");
    let _ = std::fs::remove_file(&bag);
}

#[test]
fn a_device_given_as_a_bag_scene_rig_or_recording_is_refused_not_read_forever() {
    let dir = tmp("devices");
    let link = |name: &str| {
        let p = dir.join(name);
        std::os::unix::fs::symlink("/dev/zero", &p).unwrap();
        p
    };
    let bag = link("zero.mcap");
    let o = import(&bag, &dir.join("out"));
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("zero.mcap: not a regular file"), "{t}");
    let scene = link("zero.toml");
    let rig = link("zero.rig.toml");
    let rec = link("zero.csv");
    for args in [
        vec![
            "run",
            scene.to_str().unwrap(),
            "--out",
            dir.join("o1").to_str().unwrap(),
        ],
        vec![
            "diagnose",
            "--rig",
            rig.to_str().unwrap(),
            "--recording",
            rec.to_str().unwrap(),
        ],
        vec![
            "replay",
            "--scene",
            "scenes/lab_offset_120mm.toml",
            "--recording",
            rec.to_str().unwrap(),
            "--out",
            dir.join("o2").to_str().unwrap(),
        ],
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_agvsim"))
            .args(&args)
            .output()
            .unwrap();
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {t}");
        assert!(t.contains("not a regular file"), "{args:?}: {t}");
    }
}

/// A ROS 1 bag of its magic line alone (13 bytes) holds no records: the error says so,
/// not "no velocity command topic" over an empty list of the bag's topics.
#[test]
fn a_bag_of_its_magic_line_alone_is_said_to_hold_no_records() {
    let dir = tmp("reliability-bags-magic-only");
    std::fs::create_dir_all(&dir).unwrap();
    let bag = dir.join("magic_only.bag");
    std::fs::write(&bag, b"#ROSBAG V2.0\n").unwrap();
    let o = import(&bag, &dir.join("out"));
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("magic_only.bag"), "{t}");
    assert!(t.contains("it holds no records"), "{t}");
    assert!(
        !t.contains("the bag has \n") && !t.trim_end().ends_with("the bag has"),
        "{t}"
    );
}
