//! Atomic file writes: write to a temporary file in the destination's folder, rename it over
//! the destination when complete, remove it on error. A reader never sees a partial file, and a
//! failed run leaves nothing behind (the project rule "no partial output files").

use crate::error::{IoError, Result};
use serde::Serialize;
use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

static COUNTER: AtomicU64 = AtomicU64::new(0);

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
pub fn with_temp_path(path: &Path, f: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_path_for(path)?;
    match f(&tmp) {
        Ok(()) => {
            if let Err(e) = fs::rename(&tmp, path) {
                let _ = fs::remove_file(&tmp);
                return Err(IoError::io(path, e));
            }
            Ok(())
        }
        Err(e) => {
            let _ = fs::remove_file(&tmp);
            Err(e.with_path(path))
        }
    }
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
}
