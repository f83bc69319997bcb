//! Importing recordings kept in other formats into the exchange format, each format an
//! [`Importer`] (its request) giving what it [`Made`]: `csv_map`, any CSV whose columns
//! have other names or units, converted by a map file, and `mat`, a MATLAB file by the same
//! map ([`MappedImport`]); `wpilib`, a SysId log; `ros2`, a ROS 2 or ROS 1 bag (ROS 1's
//! bag file and its messages' marker in `ros1`, both read from a `bag`).

mod bag;
pub mod csv_map;
mod importer;
mod mapped;
mod mat;
pub mod ros1;
pub mod ros2;
pub mod wpilib;

use std::path::PathBuf;

pub(crate) use importer::checked_recording;
pub use importer::{FileKind, Importer, Made, MadeFile, DEFAULT_OUT};
pub use mapped::MappedImport;

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

/// Why an import cannot be made: the format's own error, or a converted file that does
/// not read back as the contract's (a bug of the converter, refused rather than written).
#[derive(Debug, thiserror::Error)]
pub enum ImportFailure {
    /// A mapped CSV or MAT file, or its map.
    #[error(transparent)]
    Mapped(#[from] ImportError),
    /// A SysId log.
    #[error(transparent)]
    SysId(#[from] wpilib::SysIdError),
    /// A ROS bag.
    #[error(transparent)]
    Ros2(#[from] ros2::Ros2Error),
    /// Numbers for the robot's scene that cannot make one.
    #[error(transparent)]
    Robot(#[from] crate::scene::robot::RobotError),
    /// A converted file that does not read back as the contract's.
    #[error("{what} breaks the contract: {message}")]
    Contract {
        /// What was converted.
        what: String,
        /// The reader's complaint.
        message: String,
    },
}

impl From<ros2::robot::RobotSceneError> for ImportFailure {
    fn from(e: ros2::robot::RobotSceneError) -> Self {
        match e {
            ros2::robot::RobotSceneError::Robot(e) => ImportFailure::Robot(e),
            ros2::robot::RobotSceneError::Contract { what, message } => {
                ImportFailure::Contract { what, message }
            }
        }
    }
}
