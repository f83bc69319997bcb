//! A ROS bag's messages, raw: an MCAP file, or a rosbag2 folder (`metadata.yaml` with
//! its `.mcap` or `.db3` files), a lone `.db3` file, or a ROS 1 `.bag` file. Each topic
//! with its message type (ROS 2's name, `geometry_msgs/msg/Twist`) and its messages' log
//! times and bytes (CDR, or ROS 1's serialisation behind the `ros1` module's marker), in
//! log-time order.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Largest bag file read, bytes: the file is read whole; a longer log is better cut to
/// the test of interest first (`ros2 bag convert` or `mcap filter`).
pub const MAX_BAG_BYTES: u64 = 2 << 30;

/// Longest record read, bytes, decompressed: an MCAP record or chunk, a ROS 1 chunk, an
/// SQLite3 row's message. A recorder's chunks are about a megabyte.
pub const MAX_RECORD_BYTES: usize = 64 << 20;

/// Most message bytes read from one bag, decompressed: a few kilobytes of compressed
/// zeros can claim terabytes, so what is decompressed is counted, not the file's size.
pub const MAX_MESSAGE_BYTES: u64 = 512 << 20;

/// Largest `metadata.yaml` read, bytes (rosbag2 writes a few kilobytes).
pub const MAX_METADATA_BYTES: u64 = 16 << 20;

/// Longest an SQLite3 bag's queries may run, s (a view over itself never ends).
pub const MAX_QUERY_SECONDS: u64 = 30;

/// What keeping one message costs beside its bytes, bytes: the kept copy's vector, time
/// and allocation, and its decoded form (a `JointState` is five vectors and a header).
/// Measured: three million empty `JointState` messages peaked at 250 bytes each with no
/// decoding error on the way; a message with joint names costs more. Counting this keeps
/// a bag of millions of tiny messages (a few hundred kilobytes of bz2) inside the budget.
pub const PER_MESSAGE_BYTES: u64 = 512;

/// The message bytes a bag has left to give.
#[derive(Debug, Default)]
pub(super) struct Budget {
    /// Message bytes read so far, decompressed, each with [`PER_MESSAGE_BYTES`].
    bytes: u64,
    /// Messages read so far.
    messages: u64,
}

impl Budget {
    /// Counts a message of `n` bytes (and what keeping it costs beside its bytes); an
    /// error naming the file past [`MAX_MESSAGE_BYTES`].
    pub(super) fn take(&mut self, path: &Path, n: usize) -> Result<(), BagError> {
        self.messages += 1;
        self.bytes = self
            .bytes
            .saturating_add(n as u64)
            .saturating_add(PER_MESSAGE_BYTES);
        if self.bytes > MAX_MESSAGE_BYTES {
            return Err(bad(
                path,
                format!(
                    "its messages cost more than {} MiB to keep ({} messages so far, each its bytes decompressed and {PER_MESSAGE_BYTES} bytes of bookkeeping); cut the log to the test first (`ros2 bag convert` or `rosbag filter` with a time window, or only the topics agvsim reads)",
                    MAX_MESSAGE_BYTES >> 20,
                    self.messages
                ),
            ));
        }
        Ok(())
    }
}

/// Why a bag cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// A file cannot be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// What is wrong, in the file or folder named.
    #[error("{}: {message}", path.display())]
    Bad {
        /// The bag, or the file in it.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

pub(super) fn bad(path: &Path, message: impl Into<String>) -> BagError {
    BagError::Bad {
        path: path.to_owned(),
        message: message.into(),
    }
}

/// Which rosbag2 storage the messages came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    /// MCAP (the default since ROS 2 Iron).
    Mcap,
    /// SQLite3 (`.db3`, Humble and older).
    Sqlite3,
    /// A ROS 1 bag (`.bag`, format 2.0).
    Rosbag1,
}

impl Storage {
    /// rosbag2's name of the storage.
    pub fn name(self) -> &'static str {
        match self {
            Storage::Mcap => "mcap",
            Storage::Sqlite3 => "sqlite3",
            Storage::Rosbag1 => "ROS 1 bag",
        }
    }
}

/// One message as stored.
#[derive(Debug, Clone)]
pub struct RawMessage {
    /// When the recorder received it, ns since the epoch.
    pub log_time_ns: i64,
    /// Its CDR bytes.
    pub data: Vec<u8>,
}

/// One topic and its messages.
#[derive(Debug, Clone)]
pub struct Topic {
    /// The topic's name (`/cmd_vel`).
    pub name: String,
    /// Its message type (`geometry_msgs/msg/Twist`).
    pub msg_type: String,
    /// Its messages in log-time order.
    pub messages: Vec<RawMessage>,
    /// Other types the same name was published under, with their message counts: a
    /// recorder keeps one stream per publisher, and two publishers of one name may
    /// disagree on the type. Their messages are not kept, as they would be decoded as
    /// `msg_type`; a topic with any is refused where it is used ([`Topic::other_types`]).
    pub other_types: BTreeMap<String, usize>,
}

impl Topic {
    /// An empty topic of one type.
    pub(super) fn new(name: &str, msg_type: &str) -> Topic {
        Topic {
            name: name.to_string(),
            msg_type: msg_type.to_string(),
            messages: vec![],
            other_types: BTreeMap::new(),
        }
    }

    /// Keeps a message published as `msg_type`, or counts it under its other type.
    pub(super) fn push(&mut self, msg_type: &str, m: RawMessage) {
        if msg_type == self.msg_type {
            self.messages.push(m);
        } else {
            *self.other_types.entry(msg_type.to_string()).or_default() += 1;
        }
    }

    /// Notes that the topic is also declared as `msg_type` (a connection or channel
    /// without messages yet).
    pub(super) fn declare(&mut self, msg_type: &str) {
        if msg_type != self.msg_type {
            self.other_types.entry(msg_type.to_string()).or_default();
        }
    }

    /// Its types and message counts, `geometry_msgs/msg/Twist (80 messages) and
    /// geometry_msgs/msg/TwistStamped (20 messages)`, when it has more than one.
    pub fn mixed_types(&self) -> Option<String> {
        if self.other_types.is_empty() {
            return None;
        }
        let mut all = vec![format!(
            "{} ({} messages)",
            self.msg_type,
            self.messages.len()
        )];
        all.extend(
            self.other_types
                .iter()
                .map(|(t, n)| format!("{t} ({n} messages)")),
        );
        let last = all.pop().unwrap_or_default();
        Some(format!("{} and {last}", all.join(", ")))
    }
}

/// The topic `name` declared as `msg_type`: made if new, else noted if of another type.
pub(super) fn declare_topic<'a>(
    topics: &'a mut BTreeMap<String, Topic>,
    name: &str,
    msg_type: &str,
) -> &'a mut Topic {
    let t = topics
        .entry(name.to_string())
        .or_insert_with(|| Topic::new(name, msg_type));
    t.declare(msg_type);
    t
}

/// A bag's topics.
#[derive(Debug, Clone)]
pub struct Bag {
    /// The bag as given.
    pub path: PathBuf,
    /// Its storage.
    pub storage: Storage,
    /// Its topics, by name.
    pub topics: Vec<Topic>,
}
