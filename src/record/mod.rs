//! The exchange format (`shared/spec/recording-format.md`): recordings written by runs
//! and read from elsewhere.

pub mod channels;
mod join;
mod reader;
mod writer;

pub use reader::{median_interval_s, Recording, RecordingError, KNOWN_UNITS, MAX_CELL_MAGNITUDE};
pub use writer::{header, vehicle_columns, Column, RecordingWriter};

/// Row ranges from the rows where segments start (the first is row 0) and the row count.
pub fn segment_ranges(starts: &[usize], rows: usize) -> Vec<std::ops::Range<usize>> {
    let mut ends: Vec<usize> = starts.iter().skip(1).copied().collect();
    ends.push(rows);
    starts
        .iter()
        .zip(ends)
        .filter(|(s, e)| **s < *e)
        .map(|(s, e)| *s..e)
        .collect()
}
