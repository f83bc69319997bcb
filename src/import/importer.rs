//! The one shape every importer has: a request that reads its source and gives the
//! recordings it converted and what the source says of the machine (a rig, a scene), each
//! already checked to read back as the contract's, with what the import says of them. The
//! command (`agvsim import FORMAT`) only takes the output folder's lock, writes every file
//! or none and prints.

use std::path::{Path, PathBuf};

use super::ImportFailure;

/// What a file an import makes is, as its report line names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileKind {
    /// A contract recording (`.csv`).
    Recording,
    /// A rig (`.rig.toml`): the machine as the identification models see it.
    Rig,
    /// A scene (`.scene.toml`): the machine for the simulator.
    Scene,
}

impl FileKind {
    /// The word the report prints before the file's path.
    pub fn word(self) -> &'static str {
        match self {
            FileKind::Recording => "recording",
            FileKind::Rig => "rig",
            FileKind::Scene => "scene",
        }
    }
}

/// One file an import makes.
#[derive(Debug, Clone)]
pub struct MadeFile {
    /// What it is.
    pub kind: FileKind,
    /// Where it is written (in the output folder).
    pub path: PathBuf,
    /// Its text, checked to read back as the contract's.
    pub text: String,
}

/// What an import makes: its files and what it says before and after their list.
#[derive(Debug, Clone, Default)]
pub struct Made {
    /// What is said before the files' list: the source, how each column was made, notes.
    pub said_before: String,
    /// The files in the order they are listed: recordings, then the rig, then the scene.
    pub files: Vec<MadeFile>,
    /// What is said after the files' list (SysId's gains; why no scene was written).
    pub said_after: String,
}

impl Made {
    /// The first file of a kind.
    pub fn first(&self, kind: FileKind) -> Option<&MadeFile> {
        self.files.iter().find(|f| f.kind == kind)
    }

    /// The report: `said_before`, a `KIND  PATH` line per file, `said_after`.
    pub fn report(&self) -> String {
        let mut s = self.said_before.clone();
        for f in &self.files {
            s.push_str(&format!("{:<10} {}\n", f.kind.word(), f.path.display()));
        }
        s.push_str(&self.said_after);
        s
    }
}

/// An importer: a format's request (the file, the options) that converts its source.
pub trait Importer {
    /// The output folder asked for (`None`: [`DEFAULT_OUT`]).
    fn out(&self) -> Option<&Path>;

    /// Reads the source and converts it, naming each file it makes in `dir`; nothing is
    /// written.
    fn import(&self, dir: &Path) -> Result<Made, ImportFailure>;

    /// The folder the files go to.
    fn out_dir(&self) -> PathBuf {
        self.out()
            .map_or_else(|| PathBuf::from(DEFAULT_OUT), Path::to_path_buf)
    }
}

/// The output folder when none is asked for.
pub const DEFAULT_OUT: &str = "runs/import";

/// A converted recording, checked to read back as the contract's at `path`.
pub(crate) fn checked_recording(text: String, path: PathBuf) -> Result<MadeFile, ImportFailure> {
    crate::record::Recording::parse(&text, &path).map_err(|e| ImportFailure::Contract {
        what: "the converted recording".into(),
        message: e.to_string(),
    })?;
    Ok(MadeFile {
        kind: FileKind::Recording,
        path,
        text,
    })
}
