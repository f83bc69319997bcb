//! `agvsim import csv` and `import mat`: a file converted by a map ([`super::csv_map`],
//! [`super::mat`]) into one recording, `DIR/FILE_STEM.csv`.

use std::path::{Path, PathBuf};

use super::importer::{Importer, Made};
use super::{checked_recording, csv_map, mat, ImportError, ImportFailure};

/// What `agvsim import csv` or `import mat` was asked.
#[derive(Debug, Clone)]
pub struct MappedImport {
    /// The CSV or MAT file.
    pub file: PathBuf,
    /// The map file.
    pub map: PathBuf,
    /// Output folder (default [`super::DEFAULT_OUT`]).
    pub out: Option<PathBuf>,
    /// A MAT file (else a CSV).
    pub mat: bool,
}

impl Importer for MappedImport {
    fn out(&self) -> Option<&Path> {
        self.out.as_deref()
    }

    /// Loads the map, reads the file, converts it and checks the result reads as a
    /// contract recording named `DIR/FILE_STEM.csv`.
    fn import(&self, dir: &Path) -> Result<Made, ImportFailure> {
        let map = csv_map::load_map(&self.map)?;
        let bytes = crate::output::read_bounded(&self.file, crate::output::MAX_INPUT_BYTES)
            .map_err(|source| ImportError::Read {
                file: self.file.clone(),
                source,
            })?;
        let text = if self.mat {
            mat::convert(&bytes, &self.file, &map, &self.map)?
        } else {
            let text = String::from_utf8(bytes).map_err(|_| ImportError::Data {
                file: self.file.clone(),
                line: 0,
                message: "not UTF-8 text".into(),
            })?;
            csv_map::convert(&text, &self.file, &map, &self.map)?
        };
        let path = dir.join(format!(
            "{}.csv",
            crate::output::file_stem_or(&self.file, "imported")
        ));
        Ok(Made {
            files: vec![checked_recording(text, path)?],
            ..Made::default()
        })
    }
}
