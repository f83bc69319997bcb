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

/// A name that comes from inside a file (a test's, a topic's) or from a file's stem as a
/// file stem of ours: anything but ASCII letters, digits, `.`, `-` and `_` replaced by
/// `_`, no leading dot (so no `..`), at most 120 characters, never empty; so that what it
/// names stays inside the output folder.
pub fn safe_file_stem(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            // Letters and digits of any script stay (names of several bags in Greek or
            // Japanese must not all become `___` and overwrite each other).
            if c.is_alphanumeric() || "._-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .take(120)
        .collect();
    match s.trim_start_matches('.') {
        "" => "unnamed".into(),
        t => t.to_string(),
    }
}

/// Checks, before any work, that `path` can be written as a file (`folder = false`) or a
/// folder: no existing part of the way to it is a file, and a file target is not an
/// existing folder (nor a folder target an existing file). The message says what is
/// wrong; the caller's error names the option and the path.
pub(crate) fn check_target(path: &Path, folder: bool) -> Result<(), String> {
    let say = |why: String| Err(why);
    if path.is_dir() && !folder {
        return say("is a folder; give a file name".into());
    }
    if path.is_file() && folder {
        return say("is a file; give a folder".into());
    }
    for a in path.ancestors().skip(1) {
        let a = if a.as_os_str().is_empty() {
            Path::new(".")
        } else {
            a
        };
        if a.exists() {
            if !a.is_dir() {
                return say(format!(
                    "{} is a file, so nothing can be written under it",
                    a.display()
                ));
            }
            // The nearest existing folder must take a file (permissions, a read-only
            // mount): found now, not after the work.
            let probe = a.join(format!(".agvsim-probe-{}", std::process::id()));
            match std::fs::File::create(&probe) {
                Ok(_) => {
                    let _ = std::fs::remove_file(&probe);
                }
                Err(e) => return say(format!("{} cannot be written: {e}", a.display())),
            }
            break;
        }
    }
    Ok(())
}

/// An output folder owned by this process while it writes there: `.agvsim.lock` holds
/// its process id, created exclusively, removed when the lock is dropped. A second
/// writer is refused, naming the first; a lock left by a process that no longer runs
/// (killed) is taken over.
#[derive(Debug)]
pub struct FolderLock {
    path: PathBuf,
    /// The folder, if taking the lock created it: removed again if left empty (a command
    /// that stopped before writing leaves nothing behind).
    created: Option<PathBuf>,
}

/// The lock file's name inside an output folder.
pub const LOCK_FILE: &str = ".agvsim.lock";

/// Whether a process of this id runs (on Unix; elsewhere every lock is taken as live).
fn process_runs(pid: u32) -> bool {
    #[cfg(unix)]
    {
        // SAFETY: kill with signal 0 only checks that the process exists.
        let r = unsafe { libc::kill(pid as libc::pid_t, 0) };
        r == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        true
    }
}

impl FolderLock {
    /// Creates `dir` if needed and takes its lock; the message says what is wrong (the
    /// caller names the option and the folder).
    pub fn acquire(dir: &Path) -> Result<FolderLock, String> {
        let created = (!dir.exists()).then(|| dir.to_path_buf());
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create the folder: {e}"))?;
        let path = dir.join(LOCK_FILE);
        let me = std::process::id();
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    use std::io::Write;
                    let _ = writeln!(f, "{me}");
                    return Ok(FolderLock { path, created });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let owner = std::fs::read_to_string(&path)
                        .ok()
                        .and_then(|t| t.trim().parse::<u32>().ok());
                    match owner {
                        Some(pid) if pid != me && process_runs(pid) => {
                            return Err(format!(
                                "another agvsim (process {pid}) is writing there; wait for it to finish or choose another folder"
                            ))
                        }
                        // A lock of a process that ended without removing it.
                        _ => {
                            let _ = std::fs::remove_file(&path);
                        }
                    }
                }
                Err(e) => return Err(format!("cannot take the folder's lock: {e}")),
            }
        }
        Err("the folder's lock changed hands while it was taken; try again".into())
    }
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
        if let Some(dir) = &self.created {
            // Only if empty: remove_dir refuses a folder with files in it.
            let _ = std::fs::remove_dir(dir);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_from_inside_files_stay_inside_the_output_folder() {
        assert_eq!(safe_file_stem("x/../../escaped"), "x_.._.._escaped");
        assert_eq!(safe_file_stem("../up"), "_up");
        assert_eq!(safe_file_stem(".."), "unnamed");
        assert_eq!(safe_file_stem(&"a".repeat(300)).len(), 120);
        assert_eq!(safe_file_stem("slow-forward"), "slow-forward");
        assert_eq!(safe_file_stem("δοκιμή 1"), "δοκιμή_1");
        assert_ne!(safe_file_stem("走行"), safe_file_stem("試験"));
    }

    #[test]
    fn a_second_writer_is_refused_and_a_dead_ones_lock_taken_over() {
        let dir = std::env::temp_dir().join(format!("agvsim_lock_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let held = FolderLock::acquire(&dir).unwrap();
        // Another live process's lock: pid 1 always runs.
        std::fs::write(dir.join(LOCK_FILE), "1\n").unwrap();
        let err = FolderLock::acquire(&dir).unwrap_err();
        assert!(err.contains("process 1"), "{err}");
        // A process id that cannot run: the lock is stale and taken over.
        std::fs::write(dir.join(LOCK_FILE), format!("{}\n", i32::MAX)).unwrap();
        let again = FolderLock::acquire(&dir).unwrap();
        drop(held);
        drop(again);
        assert!(!dir.join(LOCK_FILE).exists());
    }
}
