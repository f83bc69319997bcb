//! The exchange format (`shared/spec/recording-format.md`): recordings written by runs.

mod writer;

pub use writer::{vehicle_columns, RecordingWriter};
