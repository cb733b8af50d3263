//! Atomic file writes and output folders.
//!
//! - Files: write to a temporary file in the destination's folder, rename it over the destination
//!   when complete, remove it on error. A reader never sees a partial file, and a failed run
//!   leaves nothing behind (the project rule "no partial output files"). Only regular files are
//!   ever replaced: a path that exists as a folder, device, FIFO or symbolic link is refused
//!   (renaming over `/dev/full` would replace the device node). A user's `--out FILE` is claimed
//!   first with [`crate::claim::claim_file`] (ownership and lock).
//! - Folders: [`OutputDir`] stages a whole run's outputs in a fresh sibling folder
//!   `DIR.camsim-tmp-<pid>` and swaps it in at [`OutputDir::commit`], so `DIR` always holds one
//!   complete, consistent run (the old one until the new one is complete). It replaces only a
//!   folder whose every entry its marker [`OUTPUT_MARKER`] lists, and holds a lock
//!   ([`crate::lock::OutputLock`]) on `DIR` meanwhile.
//! - Signals: every temporary (file, staging folder, lock file) is registered while it exists;
//!   [`remove_temporaries_and_exit`] removes them all, for a SIGINT/SIGTERM handler. A SIGKILL
//!   leaves them, named so the next run into the same output finds and removes them
//!   ([`crate::lock::remove_stale_temporaries`]).
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
//! out.commit()?;                                   // marker written, staging folder swapped in, old run removed
//! # Ok(()) }
//! ```
//!
//! Dropping an `OutputDir` without committing (an error, `?`, a panic) removes the staging folder
//! and leaves `DIR` as it was.

use crate::error::{IoError, Result};
use crate::lock::{self, OutputLock, OLD_TAG, TMP_TAG};
pub use crate::registry::{interrupted, registered_temporaries, remove_temporaries_and_exit};
use crate::registry::{live, register, unregister};
use serde::Serialize;
use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

static COUNTER: AtomicU64 = AtomicU64::new(0);

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

/// The temporary name used for `path`: `.<name>.camsim-tmp-<pid>-<n>` in the same folder, so the
/// final rename stays on one file system (and is atomic there), and a later run can tell a
/// killed run's leftover by its process id ([`crate::lock::remove_stale_temporaries`]).
pub fn temp_path_for(path: &Path) -> Result<PathBuf> {
    let name = path
        .file_name()
        .ok_or_else(|| IoError::invalid(path, "is not a file name (it ends in '..' or '/')"))?
        .to_string_lossy()
        .into_owned();
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp_name = format!(".{name}{TMP_TAG}{}-{n}", std::process::id());
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

/// The marker every committed [`OutputDir`] holds, written last: a JSON object whose `files` list
/// every file and folder the run wrote (relative paths, `/` separators, folders with a trailing
/// `/`). A later run replaces the folder only when everything in it is listed there.
pub const OUTPUT_MARKER: &str = ".camsim-output";

/// What [`OUTPUT_MARKER`] holds.
#[derive(Debug, Serialize, serde::Deserialize)]
struct Marker {
    written_by: String,
    note: String,
    files: Vec<String>,
}

/// Every entry under `dir` (not following symbolic links), relative, sorted, folders with a
/// trailing `/`.
fn walk(dir: &Path) -> Result<Vec<String>> {
    let mut out = Vec::new();
    let mut stack = vec![(dir.to_path_buf(), String::new())];
    while let Some((abs, rel)) = stack.pop() {
        for e in fs::read_dir(&abs).map_err(|e| IoError::io(&abs, e))? {
            let e = e.map_err(|e| IoError::io(&abs, e))?;
            let name = format!("{rel}{}", e.file_name().to_string_lossy());
            if e.file_type().map(|t| t.is_dir()).unwrap_or(false) {
                out.push(format!("{name}/"));
                stack.push((e.path(), format!("{name}/")));
            } else {
                out.push(name);
            }
        }
    }
    out.sort();
    Ok(out)
}

/// A run's output folder, staged: files are written into a fresh sibling folder
/// `DIR.camsim-tmp-<pid>` ([`OutputDir::path`], [`OutputDir::join`]) and [`OutputDir::commit`]
/// swaps it in for `DIR`. `DIR` therefore always holds one complete run: the previous one until
/// the commit, the new one after it. Dropped without a commit (an error, a panic), the staging
/// folder is removed and `DIR` is untouched. The staging folder is registered for
/// [`remove_temporaries_and_exit`], so a SIGINT/SIGTERM handler removes it too.
///
/// Ownership: `DIR` may be absent, an empty folder, or a folder an earlier camsim run wrote whose
/// every entry is listed in its [`OUTPUT_MARKER`]. Anything else (a regular file, a device, a
/// FIFO, a symbolic link, a folder without the marker, a marked folder holding a file the marker
/// does not list) is refused by [`OutputDir::create`], naming the first such entry, before any
/// work is done, and checked again at the commit.
///
/// Concurrency: an [`OutputLock`] on `DIR` is held from [`OutputDir::create`] until the
/// `OutputDir` is dropped, so a second run into the same `DIR` fails at once. With the lock held,
/// the temporaries of killed runs into `DIR` are removed ([`OutputDir::removed_stale`]).
#[derive(Debug)]
pub struct OutputDir {
    target: PathBuf,
    staging: PathBuf,
    replaces: Option<Vec<String>>,
    removed_stale: Vec<PathBuf>,
    committed: bool,
    _lock: OutputLock,
}

impl OutputDir {
    /// Check `target`, create its parent folders, lock it, remove stale temporaries of killed
    /// runs into it, and create a fresh, empty staging folder beside it.
    pub fn create(target: impl AsRef<Path>) -> Result<OutputDir> {
        let target = target.as_ref().to_path_buf();
        let name = lock::file_name(&target)?;
        let parent = lock::parent_dir(&target);
        fs::create_dir_all(&parent).map_err(|e| lock::cannot_write_beside(&target, e))?;
        let lock = OutputLock::acquire(&target)?;
        let replaces = Self::check_target(&target)?;
        let removed_stale = lock::remove_stale_temporaries(&target);
        let staging = parent.join(format!("{name}{TMP_TAG}{}", std::process::id()));
        register(&staging);
        let dir = OutputDir {
            target,
            staging,
            replaces,
            removed_stale,
            committed: false,
            _lock: lock,
        };
        fs::create_dir(&dir.staging).map_err(|e| lock::cannot_write_beside(&dir.target, e))?;
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
                    "exists and is {}, not an output folder; choose another output folder",
                    describe(&meta)
                ),
            ));
        }
        let entries = walk(target)?;
        if entries.is_empty() {
            return Ok(None);
        }
        let marker_path = target.join(OUTPUT_MARKER);
        let listed: Vec<String> = match fs::read(&marker_path) {
            Err(_) => {
                return Err(IoError::invalid(
                    target,
                    format!(
                        "is a folder camsim did not write (it holds {} and no {OUTPUT_MARKER} marker); camsim replaces its output folder as a whole, so choose a new or empty folder",
                        entries[0].trim_end_matches('/')
                    ),
                ))
            }
            Ok(bytes) => match serde_json::from_slice::<Marker>(&bytes) {
                Ok(m) => m.files,
                Err(_) => {
                    return Err(IoError::invalid(
                        target,
                        format!(
                            "its {OUTPUT_MARKER} does not list the files camsim wrote (an older camsim, or edited); delete the folder yourself or choose another output folder"
                        ),
                    ))
                }
            },
        };
        let foreign = entries
            .iter()
            .find(|e| e.as_str() != OUTPUT_MARKER && !listed.contains(e));
        if let Some(f) = foreign {
            return Err(IoError::invalid(
                target,
                format!(
                    "holds {f}, which camsim did not write (its {OUTPUT_MARKER} does not list it); a run replaces the folder as a whole, so move {f} out of it or choose another output folder"
                ),
            ));
        }
        Ok(Some(
            entries.into_iter().filter(|e| e != OUTPUT_MARKER).collect(),
        ))
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

    /// The temporaries of killed runs into this folder that [`OutputDir::create`] removed.
    pub fn removed_stale(&self) -> &[PathBuf] {
        &self.removed_stale
    }

    /// Write the marker (last), then swap the staging folder in for the target: the old folder
    /// (if any) is renamed to `DIR.camsim-old-<pid>`, the staging folder to `DIR`, and the old one
    /// removed. If the second rename fails the old folder is put back. A signal handler calling
    /// [`remove_temporaries_and_exit`] waits until the swap is done.
    pub fn commit(mut self) -> Result<()> {
        let files: Vec<String> = walk(&self.staging)?
            .into_iter()
            .filter(|e| e != OUTPUT_MARKER)
            .collect();
        let marker = Marker {
            written_by: crate::software::SOFTWARE.to_string(),
            note: "camsim wrote this folder: the next camsim run into it replaces it, provided it holds nothing but the files listed here".into(),
            files,
        };
        write_json_atomic(&self.staging.join(OUTPUT_MARKER), &marker)?;
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
            "{}{OLD_TAG}{}",
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

/// A scratch folder (`NAME.camsim-tmp-<pid>` beside output `NAME`) for intermediate files:
/// registered for [`remove_temporaries_and_exit`] and removed when dropped; after a SIGKILL,
/// found and removed by [`crate::lock::remove_stale_temporaries`] of `NAME`.
#[derive(Debug)]
pub struct ScratchDir {
    path: PathBuf,
}

impl ScratchDir {
    /// Create the scratch folder of output path `target` (an earlier one of this process is
    /// emptied).
    pub fn create(target: &Path) -> Result<ScratchDir> {
        let name = lock::file_name(target)?;
        let path = lock::parent_dir(target).join(format!("{name}{TMP_TAG}{}", std::process::id()));
        register(&path);
        let dir = ScratchDir { path };
        if fs::symlink_metadata(&dir.path).is_ok() {
            let _ = fs::remove_dir_all(&dir.path);
        }
        fs::create_dir_all(&dir.path).map_err(|e| lock::cannot_write_beside(target, e))?;
        Ok(dir)
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.path);
        unregister(&self.path);
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
        assert_eq!(fs::read(&f).unwrap(), b"keep");
        // A folder with foreign content (a source tree, a README).
        let src = root.path().join("src");
        fs::create_dir(&src).unwrap();
        fs::write(src.join("main.rs"), b"fn main() {}").unwrap();
        let e = OutputDir::create(&src).unwrap_err().to_string();
        assert!(e.contains("main.rs") && e.contains("did not write"), "{e}");
        assert_eq!(fs::read(&f).unwrap(), b"keep");
        assert!(src.join("main.rs").is_file());
        assert!(OutputDir::create(root.path().join("..")).is_err());
    }

    /// Issue 25 item 1: a folder of the user's own DNG (an extension camsim also writes) was
    /// taken for an earlier run and deleted. Ownership is now the marker's file list alone.
    #[test]
    fn an_unmarked_folder_of_camsim_like_files_is_refused_and_kept() {
        let root = tempfile::tempdir().unwrap();
        for ext in ["dng", "png", "tif", "exr", "csv", "json", "txt"] {
            let d = root.path().join(format!("photos-{ext}"));
            fs::create_dir(&d).unwrap();
            fs::write(d.join(format!("IMG_0001.{ext}")), b"precious").unwrap();
            let e = OutputDir::create(&d).unwrap_err().to_string();
            assert!(
                e.contains(&format!("IMG_0001.{ext}")) && e.contains("did not write"),
                "{e}"
            );
            assert_eq!(
                fs::read(d.join(format!("IMG_0001.{ext}"))).unwrap(),
                b"precious"
            );
        }
        assert_eq!(
            entries(root.path()).len(),
            7,
            "no staging folder or lock left"
        );
    }

    #[test]
    fn the_marker_lists_the_run_and_a_foreign_file_in_a_marked_folder_is_refused() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("run");
        let d = OutputDir::create(&target).unwrap();
        write_run(&d, "11");
        fs::create_dir(d.join("plots")).unwrap();
        write_bytes_atomic(&d.join("plots/mtf.png"), b"png").unwrap();
        d.commit().unwrap();
        let m: serde_json::Value =
            serde_json::from_slice(&fs::read(target.join(OUTPUT_MARKER)).unwrap()).unwrap();
        assert_eq!(
            m["files"],
            serde_json::json!(["plots/", "plots/mtf.png", "raw.dng", "run.json"])
        );
        // A file the user put into the output folder: refused, named, kept.
        fs::write(target.join("plots/notes.txt"), b"mine").unwrap();
        let e = OutputDir::create(&target).unwrap_err().to_string();
        assert!(e.contains("plots/notes.txt"), "{e}");
        assert_eq!(fs::read(target.join("plots/notes.txt")).unwrap(), b"mine");
        // Without it, the folder is replaced.
        fs::remove_file(target.join("plots/notes.txt")).unwrap();
        let d = OutputDir::create(&target).unwrap();
        write_run(&d, "13");
        // ... unless a foreign file appears while the run computes: the commit refuses.
        fs::write(target.join("late.txt"), b"mine").unwrap();
        assert!(d.commit().unwrap_err().to_string().contains("late.txt"));
        assert_eq!(fs::read(target.join("raw.dng")).unwrap(), b"11");
        assert_eq!(fs::read(target.join("late.txt")).unwrap(), b"mine");
        // A marker that lists nothing (an older camsim's) protects nothing either.
        let old = root.path().join("old");
        fs::create_dir(&old).unwrap();
        fs::write(
            old.join(OUTPUT_MARKER),
            b"This folder was written by camsim\n",
        )
        .unwrap();
        fs::write(old.join("raw.png"), b"x").unwrap();
        let e = OutputDir::create(&old).unwrap_err().to_string();
        assert!(e.contains("does not list"), "{e}");
    }

    /// Issue 25 item 4: two runs into one folder both succeeded.
    #[test]
    fn a_second_run_into_a_folder_being_written_fails_at_once() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("run");
        let first = OutputDir::create(&target).unwrap();
        let e = OutputDir::create(&target).unwrap_err().to_string();
        assert!(e.contains("being written by another camsim run"), "{e}");
        write_run(&first, "11");
        first.commit().unwrap();
        let second = OutputDir::create(&target).unwrap();
        drop(second);
        assert_eq!(entries(root.path()), vec!["run".to_string()]);
    }

    /// Issue 25 item 3: a killed run's staging folder stayed forever.
    #[test]
    fn a_killed_runs_staging_folder_and_files_are_removed_by_the_next_run() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("run");
        let mut c = std::process::Command::new("true").spawn().unwrap();
        let dead = c.id();
        c.wait().unwrap();
        let stale = root.path().join(format!("run.camsim-tmp-{dead}"));
        fs::create_dir(&stale).unwrap();
        fs::write(stale.join("raw.dng"), vec![0u8; 1000]).unwrap();
        let d = OutputDir::create(&target).unwrap();
        assert_eq!(d.removed_stale(), std::slice::from_ref(&stale));
        assert!(!stale.exists());
        drop(d);
        assert!(entries(root.path()).is_empty());
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
