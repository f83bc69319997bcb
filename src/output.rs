//! Writing output files whole or not at all: the bytes go to a temporary file beside the
//! target, which is then renamed over it, so a killed or failed command never leaves a
//! half-written results table, scene or recording that looks finished.

use std::path::{Path, PathBuf};

/// The temporary name a file is written under before its rename.
pub fn partial_name(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".partial");
    path.with_file_name(name)
}

/// Writes `bytes` to `path` atomically (on one file system, as the temporary file is).
pub fn write_atomically(path: &Path, bytes: impl AsRef<[u8]>) -> std::io::Result<()> {
    let tmp = partial_name(path);
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}
