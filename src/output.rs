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

/// A file's bytes, read only if it is a regular file of at most `max_bytes` (a device, a
/// pipe or a symlink to `/dev/zero` has no end; a file of gigabytes is not an input).
/// Read through a limit, so a file that grows while it is read stops at it too.
pub fn read_bounded(path: &Path, max_bytes: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let invalid = |m: String| std::io::Error::new(std::io::ErrorKind::InvalidInput, m);
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(invalid(
            "not a regular file (a device, a pipe or a folder)".into(),
        ));
    }
    let mut bytes = Vec::with_capacity(meta.len().min(max_bytes) as usize);
    std::fs::File::open(path)?
        .take(max_bytes + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(invalid(format!(
            "larger than the {max_bytes} bytes read from such a file"
        )));
    }
    Ok(bytes)
}

/// As [`read_bounded`], as UTF-8 text.
pub fn read_text_bounded(path: &Path, max_bytes: u64) -> std::io::Result<String> {
    String::from_utf8(read_bounded(path, max_bytes)?)
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}

/// Largest text input read whole (a recording, a list file), bytes.
pub const MAX_INPUT_BYTES: u64 = 2 << 30;

/// Largest small configuration file read (a rig, a topic map, a controller's YAML), bytes.
pub const MAX_CONFIG_BYTES: u64 = 16 << 20;

/// Writes `bytes` to `path` atomically (on one file system, as the temporary file is).
pub fn write_atomically(path: &Path, bytes: impl AsRef<[u8]>) -> std::io::Result<()> {
    let tmp = partial_name(path);
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

/// A file's name without its extension, or `fallback` (a path with no name).
pub fn file_stem_or(path: &std::path::Path, fallback: &str) -> String {
    path.file_stem()
        .map_or_else(|| fallback.into(), |s| s.to_string_lossy().into_owned())
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

/// Why an output path cannot be written (the caller names the option and the path).
#[derive(Debug, thiserror::Error)]
pub enum TargetError {
    /// A file was asked for where a folder is.
    #[error("is a folder; give a file name")]
    IsFolder,
    /// A folder was asked for where a file is.
    #[error("is a file; give a folder")]
    IsFile,
    /// Part of the way to it is a file.
    #[error("{} is a file, so nothing can be written under it", .0.display())]
    UnderFile(PathBuf),
    /// The nearest existing folder takes no file.
    #[error("{} cannot be written: {source}", folder.display())]
    Unwritable {
        /// The folder.
        folder: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

/// Why an output folder's lock could not be taken.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// The folder could not be made.
    #[error("cannot create the folder: {0}")]
    Create(std::io::Error),
    /// The lock file could not be opened, locked or written.
    #[error("cannot take the output's lock: {0}")]
    Lock(std::io::Error),
    /// Another process holds it (as its lock file names it).
    #[error("another agvsim ({}) is writing there; wait for it to finish, or write elsewhere", if .0.is_empty() { "starting" } else { .0.as_str() })]
    Held(String),
    /// The lock file was replaced each time it was taken.
    #[error("the output's lock changed hands while it was taken; try again")]
    Moving,
}

/// Checks, before any work, that `path` can be written as a file (`folder = false`) or a
/// folder: no existing part of the way to it is a file, and a file target is not an
/// existing folder (nor a folder target an existing file). The message says what is
/// wrong; the caller's error names the option and the path.
pub(crate) fn check_target(path: &Path, folder: bool) -> Result<(), TargetError> {
    if path.is_dir() && !folder {
        return Err(TargetError::IsFolder);
    }
    if path.is_file() && folder {
        return Err(TargetError::IsFile);
    }
    for a in path.ancestors().skip(1) {
        let a = if a.as_os_str().is_empty() {
            Path::new(".")
        } else {
            a
        };
        if a.exists() {
            if !a.is_dir() {
                return Err(TargetError::UnderFile(a.to_owned()));
            }
            // The nearest existing folder must take a file (permissions, a read-only
            // mount): found now, not after the work.
            let probe = a.join(format!(".agvsim-probe-{}", std::process::id()));
            match std::fs::File::create(&probe) {
                Ok(_) => {
                    let _ = std::fs::remove_file(&probe);
                }
                Err(source) => {
                    return Err(TargetError::Unwritable {
                        folder: a.to_owned(),
                        source,
                    })
                }
            }
            break;
        }
    }
    Ok(())
}

/// An output folder owned by this process while it writes there: `.agvsim.lock`, locked
/// with `flock` (a lock the kernel holds and releases when the process ends, however it
/// ends, whatever PID namespace it runs in; on NFS the kernel takes it on the server),
/// holding the owner's process id and host for the message a second writer gets. The
/// file is removed when the lock is dropped.
#[derive(Debug)]
pub struct FolderLock {
    path: PathBuf,
    /// The open, locked file: closing it releases the lock.
    _file: std::fs::File,
    /// The folder, if taking the lock created it: removed again if left empty (a command
    /// that stopped before writing leaves nothing behind).
    created: Option<PathBuf>,
}

/// The lock file's name inside an output folder.
pub const LOCK_FILE: &str = ".agvsim.lock";

/// This machine's name, for the lock's owner ("unknown host" where it cannot be read).
fn host_name() -> String {
    #[cfg(unix)]
    {
        let mut buf = [0u8; 256];
        // SAFETY: the buffer is writable for its length; gethostname NUL-terminates
        // within it when the name fits.
        let r = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) };
        if r == 0 {
            let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
            return String::from_utf8_lossy(&buf[..end]).into_owned();
        }
    }
    "unknown host".into()
}

/// Takes an exclusive lock on `f` without waiting: `Ok(false)` when another holds it.
fn try_lock(f: &std::fs::File) -> std::io::Result<bool> {
    #[cfg(unix)]
    {
        use std::os::unix::io::AsRawFd;
        // SAFETY: flock on an open descriptor of ours.
        let r = unsafe { libc::flock(f.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) };
        if r == 0 {
            return Ok(true);
        }
        let e = std::io::Error::last_os_error();
        if e.raw_os_error() == Some(libc::EWOULDBLOCK) {
            return Ok(false);
        }
        Err(e)
    }
    #[cfg(not(unix))]
    {
        let _ = f;
        Ok(true)
    }
}

/// Whether `f` is still the file at `path` (a lock taken on a file its owner removed
/// meanwhile locks nothing anyone else opens).
fn still_at(f: &std::fs::File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (f.metadata(), std::fs::metadata(path)) {
            (Ok(a), Ok(b)) => a.ino() == b.ino() && a.dev() == b.dev(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = (f, path);
        true
    }
}

/// Takes the lock file at `path` (created if missing) without waiting, writing this
/// process's id and host into it.
fn lock_file_at(path: &Path) -> Result<std::fs::File, LockError> {
    use std::io::{Read, Seek, Write};
    let cannot = LockError::Lock;
    for _ in 0..10 {
        let mut f = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .map_err(cannot)?;
        if !try_lock(&f).map_err(cannot)? {
            let mut owner = String::new();
            let _ = f.read_to_string(&mut owner);
            return Err(LockError::Held(owner.trim().to_string()));
        }
        if !still_at(&f, path) {
            continue; // its owner removed it as we locked it: take the new one
        }
        f.set_len(0).map_err(cannot)?;
        f.rewind().map_err(cannot)?;
        writeln!(f, "process {} on {}", std::process::id(), host_name()).map_err(cannot)?;
        return Ok(f);
    }
    Err(LockError::Moving)
}

impl FolderLock {
    /// Creates `dir` if needed and takes its lock; the message says what is wrong (the
    /// caller names the option and the folder).
    pub fn acquire(dir: &Path) -> Result<FolderLock, LockError> {
        FolderLock::lock_in(dir, LOCK_FILE)
    }

    /// Takes the lock of one output file (`--json FILE`): a lock file beside it,
    /// `.NAME.agvsim.lock`, so two commands writing the same file (with the same or other
    /// flags) do not leave one's result under the other's name. A folder made for it is
    /// removed again if left empty.
    pub fn acquire_file(file: &Path) -> Result<FolderLock, LockError> {
        let name = file
            .file_name()
            .map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
        let dir = match file.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        FolderLock::lock_in(&dir, &format!(".{name}.agvsim.lock"))
    }

    /// Creates `dir` if needed and takes the lock file `lock_name` in it; a folder made
    /// here is removed again if the lock cannot be taken (or, on drop, if left empty).
    fn lock_in(dir: &Path, lock_name: &str) -> Result<FolderLock, LockError> {
        let created = (!dir.exists()).then(|| dir.to_path_buf());
        std::fs::create_dir_all(dir).map_err(LockError::Create)?;
        let path = dir.join(lock_name);
        match lock_file_at(&path) {
            Ok(file) => Ok(FolderLock {
                path,
                _file: file,
                created,
            }),
            Err(e) => {
                if let Some(d) = &created {
                    let _ = std::fs::remove_dir(d);
                }
                Err(e)
            }
        }
    }
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        // Removed while still locked; the lock goes with the file's descriptor.
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
    fn an_output_files_lock_refuses_a_second_writer_and_goes_with_its_holder() {
        let dir = std::env::temp_dir().join(format!("agvsim_file_lock_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let file = dir.join("sub/result.json");
        let held = FolderLock::acquire_file(&file).unwrap();
        let lock = dir.join("sub/.result.json.agvsim.lock");
        assert!(lock.exists());
        let err = FolderLock::acquire_file(&file).unwrap_err().to_string();
        assert!(err.contains("another agvsim (process"), "{err}");
        // Another file in the same folder is another lock.
        let other = FolderLock::acquire_file(&dir.join("sub/result.toml")).unwrap();
        drop(other);
        drop(held);
        // The lock file and the folder made for it, left empty, are gone.
        assert!(!lock.exists());
        assert!(!dir.join("sub").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_second_writer_is_refused_and_a_dead_ones_lock_taken_over() {
        let dir = std::env::temp_dir().join(format!("agvsim_lock_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let held = FolderLock::acquire(&dir).unwrap();
        // The kernel's lock refuses a second taker, even in this process (a lock is
        // the open file's), naming the holder.
        let err = FolderLock::acquire(&dir).unwrap_err().to_string();
        assert!(
            err.contains(&format!("process {} on ", std::process::id())),
            "{err}"
        );
        drop(held);
        // The folder the first lock created, left empty, is gone with it.
        assert!(!dir.exists());
        // A lock file left by a killed writer holds no lock: it is taken over, whatever
        // process id it names (another container's, a reused one).
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(LOCK_FILE), "process 1 on elsewhere\n").unwrap();
        let again = FolderLock::acquire(&dir).unwrap();
        drop(again);
        assert!(!dir.join(LOCK_FILE).exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
