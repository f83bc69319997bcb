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

/// Checks, before any work, that `path` can be written as a file (`folder = false`) or a
/// folder: no existing part of the way to it is a file, and a file target is not an
/// existing folder (nor a folder target an existing file). The message names the option.
pub(crate) fn check_target(option: &str, path: &Path, folder: bool) -> Result<(), String> {
    let say = |why: String| Err(format!("{option} {}: {why}", path.display()));
    if path.is_dir() && !folder {
        return say("is a folder; give a file name".into());
    }
    if path.is_file() && folder {
        return say("is a file; give a folder".into());
    }
    for a in path.ancestors().skip(1) {
        if a.as_os_str().is_empty() {
            break;
        }
        if a.exists() {
            if !a.is_dir() {
                return say(format!(
                    "{} is a file, so nothing can be written under it",
                    a.display()
                ));
            }
            break;
        }
    }
    Ok(())
}
