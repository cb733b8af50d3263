//! Atomic file writes and output folders.
//!
//! - Files: write to a temporary file in the destination's folder, rename it over the destination
//!   when complete, remove it on error. A reader never sees a partial file, and a failed run
//!   leaves nothing behind (the project rule "no partial output files"). Only regular files are
//!   ever replaced: a path that exists as a folder, device, FIFO or symbolic link is refused
//!   (renaming over `/dev/full` would replace the device node).
//! - Folders: [`OutputDir`] stages a whole run's outputs in a fresh sibling folder
//!   `DIR.tmp-<pid>` and swaps it in at [`OutputDir::commit`], so `DIR` always holds one complete,
//!   consistent run (the old one until the new one is complete).
//! - Signals: every temporary (file or staging folder) is registered while it exists;
//!   [`remove_temporaries_and_exit`] removes them all, for a SIGINT/SIGTERM handler.
//!
//! # Using [`OutputDir`] in a command
//!
//! ```no_run
//! use camsim_io::atomic::OutputDir;
//! # fn main() -> camsim_io::Result<()> {
//! let out = OutputDir::create("out/run")?;       // refuses a path that is not a folder camsim may replace
//! if let Some(old) = out.replaces() {              // tell the user what the commit will replace
//!     eprintln!("replacing {} ({} entries)", out.target().display(), old.len());
//! }
//! camsim_io::atomic::write_bytes_atomic(&out.join("series.csv"), b"a,b\n")?; // write into the staging folder
//! // ... every other file, the run record (run.json) last ...
//! out.commit()?;                                   // swap the staging folder in; old run removed
//! # Ok(()) }
//! ```
//!
//! Dropping an `OutputDir` without committing (an error, `?`, a panic) removes the staging folder
//! and leaves `DIR` as it was.

use crate::error::{IoError, Result};
use serde::Serialize;
use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Temporaries that exist right now (temporary files and staging folders), for the signal handler.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

fn live() -> MutexGuard<'static, Vec<PathBuf>> {
    // A panic while holding the lock cannot leave the list inconsistent (push/retain only).
    LIVE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Register a temporary before it is created. Once [`remove_temporaries_and_exit`] has started,
/// this blocks until the process exits, so no new temporary can appear behind the handler's back.
fn register(p: &Path) {
    live().push(p.to_path_buf());
}

fn unregister(p: &Path) {
    let mut l = live();
    if let Some(i) = l.iter().rposition(|q| q == p) {
        l.remove(i);
    }
}

/// The temporaries registered right now (files and staging folders).
pub fn registered_temporaries() -> Vec<PathBuf> {
    live().clone()
}

/// True once [`remove_temporaries_and_exit`] has been called (the process is about to exit; an
/// error seen by the main thread meanwhile is a consequence of the interruption).
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// Remove every registered temporary file and staging folder, then exit the process with `code`
/// (130 for an interrupt, by shell convention 128 + SIGINT). For a SIGINT/SIGTERM handler thread
/// (e.g. the `ctrlc` crate's). The list stays locked until the exit, so the main thread can
/// neither create a new temporary nor commit an [`OutputDir`] half-way meanwhile; a commit
/// already in progress finishes first.
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

/// Refuse to replace anything but a regular file: `path` must not exist, or be a regular file
/// (not a folder, device, FIFO, socket or symbolic link).
pub fn check_replaceable_file(path: &Path) -> Result<()> {
    match fs::symlink_metadata(path) {
        Err(_) => Ok(()),
        Ok(m) if m.file_type().is_file() => Ok(()),
        Ok(m) => Err(IoError::invalid(
            path,
            format!(
                "exists and is {}; camsim only replaces regular files (choose another output path)",
                describe(&m)
            ),
        )),
    }
}

fn describe(m: &fs::Metadata) -> &'static str {
    let t = m.file_type();
    if t.is_dir() {
        return "a folder";
    }
    if t.is_symlink() {
        return "a symbolic link";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// The temporary name used for `path`: `.<name>.tmp-<pid>-<n>` in the same folder, so the final
/// rename stays on one file system (and is atomic there).
pub fn temp_path_for(path: &Path) -> Result<PathBuf> {
    let name = path
        .file_name()
        .ok_or_else(|| IoError::invalid(path, "is not a file name (it ends in '..' or '/')"))?
        .to_string_lossy()
        .into_owned();
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp_name = format!(".{name}.tmp-{}-{n}", std::process::id());
    Ok(match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.join(tmp_name),
        _ => PathBuf::from(tmp_name),
    })
}

/// Call `f` with a temporary path in `path`'s folder; when `f` succeeds, rename the temporary
/// file to `path`; when it fails (or produced no file), remove the temporary file. For writers
/// that insist on opening the file themselves (the `exr` crate, image encoders).
///
/// A `path` that exists and is not a regular file is refused before anything is written (see
/// [`check_replaceable_file`]). The temporary is registered for [`remove_temporaries_and_exit`].
pub fn with_temp_path(path: &Path, f: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    check_replaceable_file(path)?;
    let tmp = temp_path_for(path)?;
    register(&tmp);
    let result = match f(&tmp) {
        Ok(()) => {
            // Checked again just before the rename: the node may have appeared meanwhile.
            let r = check_replaceable_file(path)
                .and_then(|()| fs::rename(&tmp, path).map_err(|e| IoError::io(path, e)));
            if r.is_err() {
                let _ = fs::remove_file(&tmp);
            }
            r
        }
        Err(e) => {
            let _ = fs::remove_file(&tmp);
            Err(e.with_path(path))
        }
    };
    unregister(&tmp);
    result
}

/// Write `path` atomically: `f` writes the whole content to a buffered stream over a temporary
/// file; on success the file is flushed and renamed to `path`, on error it is removed.
pub fn write_atomic(path: &Path, f: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    with_temp_path(path, |tmp| {
        let file = File::create(tmp).map_err(|e| IoError::io(path, e))?;
        let mut w = BufWriter::with_capacity(1 << 20, file);
        f(&mut w).map_err(|e| e.with_path(path))?;
        let file = w
            .into_inner()
            .map_err(|e| IoError::io(path, e.into_error()))?;
        drop(file);
        Ok(())
    })
}

/// Write `bytes` to `path` atomically.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| Ok(w.write_all(bytes)?))
}

/// Write `value` as pretty-printed JSON (with a final newline) to `path` atomically.
pub fn write_json_atomic(path: &Path, value: &impl Serialize) -> Result<()> {
    let mut text = serde_json::to_string_pretty(value)
        .map_err(|e| IoError::invalid(path, format!("cannot serialize to JSON: {e}")))?;
    text.push('\n');
    write_bytes_atomic(path, text.as_bytes())
}

/// The marker file every committed [`OutputDir`] holds: a folder with it was written by camsim and
/// may be replaced as a whole by the next run into it.
pub const OUTPUT_MARKER: &str = ".camsim-output";

/// Extensions of the files camsim writes; a folder holding only such regular files (an output
/// folder of a camsim older than [`OUTPUT_MARKER`]) may be replaced as well.
const OUTPUT_EXTENSIONS: &[&str] = &[
    "exr", "dng", "png", "json", "csv", "html", "svg", "txt", "tif", "tiff",
];

/// A run's output folder, staged: files are written into a fresh sibling folder `DIR.tmp-<pid>`
/// ([`OutputDir::path`], [`OutputDir::join`]) and [`OutputDir::commit`] swaps it in for `DIR`.
/// `DIR` therefore always holds one complete run: the previous one until the commit, the new one
/// after it. Dropped without a commit (an error, a panic), the staging folder is removed and `DIR`
/// is untouched. The staging folder is registered for [`remove_temporaries_and_exit`], so a
/// SIGINT/SIGTERM handler removes it too.
///
/// Replacing: `DIR` may be absent, an empty folder, a folder an earlier camsim run wrote (it holds
/// [`OUTPUT_MARKER`], or only regular files with the extensions camsim writes). Anything else (a
/// regular file, a device, a FIFO, a symbolic link, a folder with other content such as a source
/// tree) is refused by [`OutputDir::create`] before any work is done.
#[derive(Debug)]
pub struct OutputDir {
    target: PathBuf,
    staging: PathBuf,
    replaces: Option<Vec<String>>,
    committed: bool,
}

impl OutputDir {
    /// Check `target`, create its parent folders and a fresh, empty staging folder beside it.
    pub fn create(target: impl AsRef<Path>) -> Result<OutputDir> {
        let target = target.as_ref().to_path_buf();
        let name = match target.file_name() {
            Some(n) => n.to_string_lossy().into_owned(),
            None => {
                return Err(IoError::invalid(
                    &target,
                    "names no folder (it ends in '..' or is a root): give an output folder such as out/run",
                ))
            }
        };
        let replaces = Self::check_target(&target)?;
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        fs::create_dir_all(&parent).map_err(|e| IoError::io(&parent, e))?;
        let staging = parent.join(format!("{name}.tmp-{}", std::process::id()));
        register(&staging);
        let dir = OutputDir {
            target,
            staging,
            replaces,
            committed: false,
        };
        // A leftover of an earlier process with the same id (a crash) is ours to remove.
        if fs::symlink_metadata(&dir.staging).is_ok() {
            let _ = fs::remove_dir_all(&dir.staging);
        }
        fs::create_dir(&dir.staging).map_err(|e| IoError::io(&dir.staging, e))?;
        fs::write(
            dir.staging.join(OUTPUT_MARKER),
            "This folder was written by camsim; the next run into it replaces it as a whole.\n",
        )
        .map_err(|e| IoError::io(&dir.staging, e))?;
        Ok(dir)
    }

    /// The existing entries of `target` (None: absent or empty), or an error if camsim may not
    /// replace it.
    fn check_target(target: &Path) -> Result<Option<Vec<String>>> {
        let meta = match fs::symlink_metadata(target) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(IoError::io(target, e)),
            Ok(m) => m,
        };
        if !meta.is_dir() {
            return Err(IoError::invalid(
                target,
                format!(
                    "exists and is {}, not an output folder; choose another --out",
                    describe(&meta)
                ),
            ));
        }
        let mut names = Vec::new();
        let mut foreign = Vec::new();
        let mut marked = false;
        for e in fs::read_dir(target).map_err(|e| IoError::io(target, e))? {
            let e = e.map_err(|e| IoError::io(target, e))?;
            let n = e.file_name().to_string_lossy().into_owned();
            if n == OUTPUT_MARKER {
                marked = true;
                continue;
            }
            let is_file = e.file_type().map(|t| t.is_file()).unwrap_or(false);
            let ext = Path::new(&n)
                .extension()
                .map(|x| x.to_string_lossy().to_ascii_lowercase());
            if !(is_file && ext.is_some_and(|x| OUTPUT_EXTENSIONS.contains(&x.as_str()))) {
                foreign.push(n.clone());
            }
            names.push(if is_file { n } else { format!("{n}/") });
        }
        names.sort();
        foreign.sort();
        if !marked && !foreign.is_empty() {
            return Err(IoError::invalid(
                target,
                format!(
                    "is a folder camsim did not write (it holds {}); a run replaces its output folder as a whole, so choose a new or empty folder",
                    foreign.join(", ")
                ),
            ));
        }
        Ok(if names.is_empty() { None } else { Some(names) })
    }

    /// The staging folder: write every output here.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// `name` inside the staging folder.
    pub fn join(&self, name: impl AsRef<Path>) -> PathBuf {
        self.staging.join(name)
    }

    /// The folder the outputs will have after [`OutputDir::commit`].
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// The entries of the existing output folder that the commit will replace (sorted, folders
    /// with a trailing `/`); `None` when the folder is absent or empty.
    pub fn replaces(&self) -> Option<&[String]> {
        self.replaces.as_deref()
    }

    /// Swap the staging folder in for the target: the old folder (if any) is renamed to
    /// `DIR.old-<pid>`, the staging folder to `DIR`, and the old one removed. If the second rename
    /// fails the old folder is put back. A signal handler calling
    /// [`remove_temporaries_and_exit`] waits until the swap is done.
    pub fn commit(mut self) -> Result<()> {
        let guard = live();
        let r = self.swap();
        drop(guard);
        if r.is_ok() {
            self.committed = true;
            unregister(&self.staging);
        }
        r
    }

    fn swap(&self) -> Result<()> {
        // Checked again: the target may have changed while the run was computing.
        Self::check_target(&self.target)?;
        if fs::symlink_metadata(&self.target).is_err() {
            return fs::rename(&self.staging, &self.target)
                .map_err(|e| IoError::io(&self.target, e));
        }
        let mut old = self.staging.clone();
        old.set_file_name(format!(
            "{}.old-{}",
            self.target
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            std::process::id()
        ));
        if fs::symlink_metadata(&old).is_ok() {
            let _ = fs::remove_dir_all(&old);
        }
        fs::rename(&self.target, &old).map_err(|e| IoError::io(&self.target, e))?;
        if let Err(e) = fs::rename(&self.staging, &self.target) {
            let _ = fs::rename(&old, &self.target);
            return Err(IoError::io(&self.target, e));
        }
        fs::remove_dir_all(&old).map_err(|e| IoError::io(&old, e))
    }
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_dir_all(&self.staging);
            unregister(&self.staging);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn failing_writer_leaves_no_file_behind() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        let r = write_atomic(&path, |w| {
            w.write_all(&[1u8; 5000])?;
            Err(IoError::invalid("x", "simulated failure half way"))
        });
        assert!(r.is_err());
        assert!(
            entries(dir.path()).is_empty(),
            "left behind: {:?}",
            entries(dir.path())
        );
    }

    #[test]
    fn failing_writer_keeps_the_previous_file_intact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        write_bytes_atomic(&path, b"old").unwrap();
        let _ = write_atomic(&path, |w| {
            w.write_all(b"new but incomplete")?;
            Err(IoError::invalid(&path, "fail"))
        });
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert_eq!(entries(dir.path()), vec!["out.txt".to_string()]);
    }

    #[test]
    fn success_writes_content_and_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.json");
        write_json_atomic(&path, &serde_json::json!({"seed": 7, "exposure_s": 0.01})).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&fs::read(&path).unwrap()).unwrap();
        assert_eq!(v["seed"], 7);
        assert_eq!(entries(dir.path()), vec!["run.json".to_string()]);
    }

    #[test]
    fn with_temp_path_removes_file_on_error_and_names_the_target() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("img.exr");
        let err = with_temp_path(&path, |tmp| {
            fs::write(tmp, b"partial")?;
            Err(IoError::Stream(std::io::Error::other("disk full")))
        })
        .unwrap_err();
        assert!(err.to_string().contains("img.exr"), "{err}");
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn missing_folder_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no/such/dir/out.bin");
        let err = write_bytes_atomic(&path, b"x").unwrap_err();
        assert!(err.to_string().contains("out.bin"), "{err}");
    }

    fn write_run(dir: &OutputDir, seed: &str) {
        write_bytes_atomic(&dir.join("raw.dng"), seed.as_bytes()).unwrap();
        write_json_atomic(&dir.join("run.json"), &serde_json::json!({ "seed": seed })).unwrap();
    }

    #[test]
    fn output_dir_commit_replaces_the_old_run_as_a_whole() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("run");
        let d = OutputDir::create(&target).unwrap();
        assert_eq!(d.replaces(), None);
        write_run(&d, "11");
        write_bytes_atomic(&d.join("raw_0001.dng"), b"frame 2 of seed 11").unwrap();
        assert!(!target.exists(), "nothing appears before the commit");
        d.commit().unwrap();
        assert_eq!(
            entries(&target),
            vec![
                OUTPUT_MARKER.to_string(),
                "raw.dng".into(),
                "raw_0001.dng".into(),
                "run.json".into()
            ]
        );
        // A new run with one frame: the old second frame must not survive beside it.
        let d = OutputDir::create(&target).unwrap();
        assert_eq!(
            d.replaces().unwrap(),
            ["raw.dng", "raw_0001.dng", "run.json"]
        );
        write_run(&d, "13");
        d.commit().unwrap();
        assert_eq!(
            entries(&target),
            vec![
                OUTPUT_MARKER.to_string(),
                "raw.dng".into(),
                "run.json".into()
            ]
        );
        assert_eq!(fs::read(target.join("raw.dng")).unwrap(), b"13");
        assert_eq!(
            entries(root.path()),
            vec!["run".to_string()],
            "no staging or old folder left"
        );
    }

    #[test]
    fn output_dir_dropped_without_commit_leaves_the_old_run_intact() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("run");
        let d = OutputDir::create(&target).unwrap();
        write_run(&d, "11");
        d.commit().unwrap();
        {
            let d = OutputDir::create(&target).unwrap();
            assert!(registered_temporaries().contains(&d.path().to_path_buf()));
            write_bytes_atomic(&d.join("raw.dng"), b"13").unwrap(); // fails before run.json
        }
        assert_eq!(fs::read(target.join("raw.dng")).unwrap(), b"11");
        assert_eq!(entries(root.path()), vec!["run".to_string()]);
    }

    #[test]
    fn output_dir_refuses_what_it_may_not_replace() {
        let root = tempfile::tempdir().unwrap();
        // A regular file.
        let f = root.path().join("file.txt");
        fs::write(&f, b"keep").unwrap();
        assert!(OutputDir::create(&f)
            .unwrap_err()
            .to_string()
            .contains("not an output folder"));
        // A folder with foreign content (a source tree, a README).
        let src = root.path().join("src");
        fs::create_dir(&src).unwrap();
        fs::write(src.join("main.rs"), b"fn main() {}").unwrap();
        let e = OutputDir::create(&src).unwrap_err().to_string();
        assert!(e.contains("main.rs") && e.contains("did not write"), "{e}");
        assert_eq!(fs::read(&f).unwrap(), b"keep");
        assert!(src.join("main.rs").is_file());
        // An old output folder (only files camsim writes) is accepted and listed.
        let old = root.path().join("old");
        fs::create_dir(&old).unwrap();
        fs::write(old.join("raw.png"), b"x").unwrap();
        assert_eq!(
            OutputDir::create(&old).unwrap().replaces().unwrap(),
            ["raw.png"]
        );
        assert!(OutputDir::create(root.path().join("..")).is_err());
    }

    #[cfg(unix)]
    #[test]
    fn non_regular_files_are_never_replaced() {
        let root = tempfile::tempdir().unwrap();
        let link = root.path().join("link.bin");
        std::os::unix::fs::symlink("/dev/null", &link).unwrap();
        let e = write_bytes_atomic(&link, b"x").unwrap_err().to_string();
        assert!(e.contains("symbolic link"), "{e}");
        assert!(fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        let sub = root.path().join("sub");
        fs::create_dir(&sub).unwrap();
        assert!(write_bytes_atomic(&sub, b"x")
            .unwrap_err()
            .to_string()
            .contains("a folder"));
        assert!(sub.is_dir());
        assert_eq!(
            entries(root.path()),
            vec!["link.bin".to_string(), "sub".into()]
        );
    }
}
