//! The temporaries that exist right now (temporary files, staging folders, lock files), so a
//! SIGINT/SIGTERM handler can remove them all before the process exits.

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, MutexGuard};

static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// The list, locked. A panic while holding the lock cannot leave it inconsistent (push/retain
/// only).
pub(crate) fn live() -> MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Register a temporary before it is created. Once [`remove_temporaries_and_exit`] has started,
/// this blocks until the process exits, so no new temporary can appear behind the handler's back.
pub(crate) fn register(p: &Path) {
    live().push(p.to_path_buf());
}

/// Forget a temporary (it was removed or renamed into place).
pub(crate) fn unregister(p: &Path) {
    let mut l = live();
    if let Some(i) = l.iter().rposition(|q| q == p) {
        l.remove(i);
    }
}

/// The temporaries registered right now (files, staging folders and lock files).
pub fn registered_temporaries() -> Vec<PathBuf> {
    live().clone()
}

/// True once [`remove_temporaries_and_exit`] has been called (the process is about to exit; an
/// error seen by the main thread meanwhile is a consequence of the interruption).
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// Remove every registered temporary file, staging folder and lock file, then exit the process
/// with `code` (130 for an interrupt, by shell convention 128 + SIGINT). For a SIGINT/SIGTERM
/// handler thread (e.g. the `ctrlc` crate's). The list stays locked until the exit, so the main
/// thread can neither create a new temporary nor commit an output folder half-way meanwhile; a
/// commit already in progress finishes first.
pub fn remove_temporaries_and_exit(code: i32) -> ! {
    INTERRUPTED.store(true, Ordering::SeqCst);
    let list = live();
    for p in list.iter().rev() {
        match fs::symlink_metadata(p) {
            Ok(m) if m.is_dir() => {
                let _ = fs::remove_dir_all(p);
            }
            Ok(_) => {
                let _ = fs::remove_file(p);
            }
            Err(_) => {}
        }
    }
    std::process::exit(code)
}
