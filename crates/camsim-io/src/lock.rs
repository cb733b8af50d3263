//! Advisory locks on output paths, and the temporaries a killed run left beside them.
//!
//! - [`OutputLock`]: one camsim run at a time writes an output path (a folder, a single file, a
//!   dataset shard). The lock is `flock(2)` (std's `File::try_lock`) on a hidden lock file
//!   `.NAME.camsim-lock` beside the output, which holds the holder's process id; a second run
//!   fails at once naming that process. The kernel releases the lock when its holder dies, even
//!   by SIGKILL, so a stale lock file never blocks a later run.
//! - Temporaries are named after their output and the process that made them:
//!   `NAME.camsim-tmp-PID` (a staging folder), `NAME.camsim-old-PID` (the previous folder during
//!   the swap), `.NAME.camsim-tmp-PID-N` (a file being written). [`remove_stale_temporaries`]
//!   finds those of a path whose process no longer runs and removes them; called with the lock
//!   held, so no live camsim run can own them.

use crate::error::{IoError, Result};
use std::fs::{self, File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// The tag in a temporary's name before its process id.
pub const TMP_TAG: &str = ".camsim-tmp-";
/// The tag of the previous folder while an output folder is swapped.
pub const OLD_TAG: &str = ".camsim-old-";
/// The suffix of a lock file (`.NAME.camsim-lock`).
pub const LOCK_SUFFIX: &str = ".camsim-lock";

/// The file name of `target` (its last component), or an error naming it.
pub fn file_name(target: &Path) -> Result<String> {
    match target.file_name() {
        Some(n) => Ok(n.to_string_lossy().into_owned()),
        None => Err(IoError::invalid(
            target,
            "names no file or folder (it ends in '..' or is a root): give a path such as out/run",
        )),
    }
}

/// The folder `target` is in (`.` for a bare name).
pub fn parent_dir(target: &Path) -> PathBuf {
    match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Whether process `pid` runs on this machine (`kill(pid, 0)`: it exists, or exists under another
/// user). Where that cannot be asked, every process is taken as running (nothing is removed).
pub fn process_running(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Ok(p) = libc::pid_t::try_from(pid) else {
            return false;
        };
        if p <= 0 {
            return false;
        }
        // SAFETY: signal 0 only checks that the process exists and may be signalled.
        let r = unsafe { libc::kill(p, 0) };
        r == 0 || std::io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        true
    }
}

/// An exclusive advisory lock on an output path, held until dropped (the lock file is removed
/// then). See the module documentation.
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
    file: Option<File>,
}

impl OutputLock {
    /// Lock output path `target` (which need not exist; its parent folder must). Fails at once,
    /// naming the holder's process id, when another run holds the lock.
    pub fn acquire(target: &Path) -> Result<OutputLock> {
        match Self::lock(target, false)? {
            Ok(l) => Ok(l),
            Err(holder) => Err(IoError::invalid(
                target,
                format!("is being written by {holder}; wait for it to finish or choose another output path"),
            )),
        }
    }

    /// [`OutputLock::acquire`], but `None` when another run holds the lock (other errors, such
    /// as a folder that cannot be written, are errors).
    pub fn try_acquire(target: &Path) -> Result<Option<OutputLock>> {
        Ok(Self::lock(target, false)?.ok())
    }

    /// [`OutputLock::acquire`], waiting for another holder to release the lock instead of
    /// failing: for short steps that runs sharing a folder take in turn (a dataset's `spec.json`).
    pub fn acquire_waiting(target: &Path) -> Result<OutputLock> {
        Self::lock(target, true)?
            .map_err(|holder| IoError::invalid(target, format!("is locked by {holder}")))
    }

    /// The lock, or (inner error) a description of the run that holds it.
    fn lock(target: &Path, wait: bool) -> Result<std::result::Result<OutputLock, String>> {
        let name = file_name(target)?;
        let path = parent_dir(target).join(format!(".{name}{LOCK_SUFFIX}"));
        // A holder removes the lock file when it releases the lock; a run that opened the old
        // file just before then locks an unlinked file. So: lock, then check that the path still
        // names the locked file, else try again.
        for _ in 0..16 {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(|e| cannot_write_beside(target, e))?;
            let locked = if wait {
                file.lock().map_err(fs::TryLockError::Error)
            } else {
                file.try_lock()
            };
            match locked {
                Ok(()) => {}
                Err(fs::TryLockError::WouldBlock) => {
                    let mut holder = String::new();
                    let _ = file.read_to_string(&mut holder);
                    return Ok(Err(match holder.trim().parse::<u32>() {
                        Ok(pid) => format!("another camsim run (process {pid})"),
                        Err(_) => "another camsim run".to_string(),
                    }));
                }
                Err(fs::TryLockError::Error(e)) if e.kind() == std::io::ErrorKind::Unsupported => {
                    // A file system without locks: go on unlocked (the lock file is removed).
                    return Ok(Ok(OutputLock {
                        path,
                        file: Some(file),
                    }));
                }
                Err(fs::TryLockError::Error(e)) => return Err(cannot_write_beside(target, e)),
            }
            if !same_file(&file, &path) {
                continue;
            }
            let _ = file.set_len(0);
            let _ = file.write_all(std::process::id().to_string().as_bytes());
            crate::registry::register(&path);
            return Ok(Ok(OutputLock {
                path,
                file: Some(file),
            }));
        }
        Err(IoError::invalid(
            target,
            "its lock file keeps changing (many camsim runs at once?); try again",
        ))
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Removed while still locked, so no other run can hold this file meanwhile.
        let _ = fs::remove_file(&self.path);
        crate::registry::unregister(&self.path);
        drop(self.file.take());
    }
}

#[cfg(unix)]
fn same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(_file: &File, path: &Path) -> bool {
    path.exists()
}

/// The error when nothing can be created beside `target` (a read-only or missing folder): it
/// names the user's path, not the lock or temporary file.
pub fn cannot_write_beside(target: &Path, e: std::io::Error) -> IoError {
    IoError::invalid(
        target,
        format!(
            "cannot write in its folder {} ({e}); choose an output path in a folder you can write to",
            parent_dir(target).display()
        ),
    )
}

/// The process id in a temporary's name of output `name`: `NAME.camsim-tmp-PID`,
/// `NAME.camsim-old-PID` or `.NAME.camsim-tmp-PID-N`; None for any other name.
pub fn temporary_pid(entry: &str, name: &str) -> Option<u32> {
    let rest = entry
        .strip_prefix(name)
        .or_else(|| entry.strip_prefix('.').and_then(|e| e.strip_prefix(name)))?;
    let rest = rest
        .strip_prefix(TMP_TAG)
        .or_else(|| rest.strip_prefix(OLD_TAG))?;
    let (pid, counter) = match rest.split_once('-') {
        Some((p, n)) => (p, Some(n)),
        None => (rest, None),
    };
    let all_digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !all_digits(pid) || counter.is_some_and(|n| !all_digits(n)) {
        return None;
    }
    pid.parse().ok()
}

/// Remove the temporaries that runs which no longer exist left for output path `target` (see
/// the module documentation): those of a process that does not run, and those of this process's
/// own id that it does not hold (left by an earlier process with the same id). Call with the
/// path's [`OutputLock`] held. Returns what was removed.
pub fn remove_stale_temporaries(target: &Path) -> Vec<PathBuf> {
    let (Ok(name), dir) = (file_name(target), parent_dir(target)) else {
        return Vec::new();
    };
    let Ok(entries) = fs::read_dir(&dir) else {
        return Vec::new();
    };
    let me = std::process::id();
    let live = crate::registry::registered_temporaries();
    let mut removed = Vec::new();
    for e in entries.flatten() {
        let entry = e.file_name().to_string_lossy().into_owned();
        let Some(pid) = temporary_pid(&entry, &name) else {
            continue;
        };
        let path = dir.join(&entry);
        let stale = if pid == me {
            !live.contains(&path)
        } else {
            !process_running(pid)
        };
        if !stale {
            continue;
        }
        let gone = match fs::symlink_metadata(&path) {
            Ok(m) if m.is_dir() => fs::remove_dir_all(&path).is_ok(),
            Ok(_) => fs::remove_file(&path).is_ok(),
            Err(_) => false,
        };
        if gone {
            removed.push(path);
        }
    }
    removed.sort();
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporary_names_are_recognised_with_their_process() {
        assert_eq!(temporary_pid("run.camsim-tmp-123", "run"), Some(123));
        assert_eq!(temporary_pid("run.camsim-old-9", "run"), Some(9));
        assert_eq!(temporary_pid(".r.exr.camsim-tmp-77-3", "r.exr"), Some(77));
        assert_eq!(temporary_pid("run.camsim-tmp-", "run"), None);
        assert_eq!(temporary_pid("run.camsim-tmp-12x", "run"), None);
        assert_eq!(temporary_pid("run2.camsim-tmp-12", "run"), None);
        assert_eq!(temporary_pid("run", "run"), None);
        assert_eq!(temporary_pid("notes.txt", "run"), None);
    }

    /// A process id that does not run: a child that has exited and been waited for.
    fn dead_pid() -> u32 {
        let mut c = std::process::Command::new("true").spawn().unwrap();
        let pid = c.id();
        c.wait().unwrap();
        assert!(!process_running(pid));
        pid
    }

    #[test]
    fn stale_temporaries_of_dead_processes_are_removed_live_ones_kept() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("run");
        let dead = dead_pid();
        let live = std::process::Command::new("sleep")
            .arg("30")
            .spawn()
            .unwrap();
        let stale_dir = root.path().join(format!("run.camsim-tmp-{dead}"));
        let stale_file = root.path().join(format!(".run.camsim-tmp-{dead}-0"));
        let busy = root.path().join(format!("run.camsim-tmp-{}", live.id()));
        let other = root.path().join(format!("other.camsim-tmp-{dead}"));
        fs::create_dir(&stale_dir).unwrap();
        fs::write(stale_dir.join("raw.dng"), b"x").unwrap();
        fs::write(&stale_file, b"x").unwrap();
        fs::create_dir(&busy).unwrap();
        fs::create_dir(&other).unwrap();
        let removed = remove_stale_temporaries(&target);
        let mut live = live;
        let _ = live.kill();
        let _ = live.wait();
        assert_eq!(removed, vec![stale_file.clone(), stale_dir.clone()]);
        assert!(!stale_dir.exists() && !stale_file.exists());
        assert!(busy.exists(), "a running process's staging folder is kept");
        assert!(other.exists(), "another output's temporary is kept");
    }

    #[test]
    fn a_second_lock_on_one_path_fails_naming_the_holder() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("run");
        let first = OutputLock::acquire(&target).unwrap();
        let e = OutputLock::acquire(&target).unwrap_err().to_string();
        assert!(
            e.contains("another camsim run") && e.contains(&std::process::id().to_string()),
            "{e}"
        );
        drop(first);
        let again = OutputLock::acquire(&target).unwrap();
        drop(again);
        assert_eq!(
            fs::read_dir(root.path()).unwrap().count(),
            0,
            "lock file removed"
        );
    }
}
