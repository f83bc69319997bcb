//! The exchange format (`shared/spec/recording-format.md`): recordings written by runs
//! and read from elsewhere.

mod reader;
mod writer;

pub use reader::{Recording, RecordingError, KNOWN_UNITS};
pub use writer::{vehicle_columns, RecordingWriter};
