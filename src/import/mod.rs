//! Importing recordings kept in other formats into the exchange format. `csv_map`: any CSV
//! whose columns have other names or units, converted by a map file.

pub mod csv_map;
pub mod mat;
pub mod ros2;
pub mod wpilib;

use std::path::PathBuf;

/// Why an import cannot be done: always the file, and the line, column or key at fault.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The file could not be read.
    #[error("{file}: cannot read: {source}")]
    Read {
        /// The file.
        file: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The map file is wrong.
    #[error("{file}: {message}")]
    Map {
        /// The map file.
        file: PathBuf,
        /// What is wrong, with the key.
        message: String,
    },
    /// A cell or row of the data that cannot be converted (`line` 0: not a text line; the
    /// message says where).
    #[error("{}{}: {message}", file.display(), if *line > 0 { format!(":{line}") } else { String::new() })]
    Data {
        /// The data file.
        file: PathBuf,
        /// The line (0: not a text line).
        line: usize,
        /// What cannot be converted.
        message: String,
    },
}
