//! Importing recordings kept in other formats into the exchange format. `csv_map`: any CSV
//! whose columns have other names or units, converted by a map file.

pub mod csv_map;
pub mod mat;
pub mod wpilib;

use std::path::PathBuf;

/// Why an import cannot be done: always the file, and the line, column or key at fault.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    #[error("{file}: cannot read: {source}")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    /// The map file is wrong.
    #[error("{file}: {message}")]
    Map { file: PathBuf, message: String },
    /// A cell or row of the data that cannot be converted (`line` 0: not a text line; the
    /// message says where).
    #[error("{}{}: {message}", file.display(), if *line > 0 { format!(":{line}") } else { String::new() })]
    Data {
        file: PathBuf,
        line: usize,
        message: String,
    },
}
