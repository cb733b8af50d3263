//! Claiming a single output file (`--out X.exr`, `--out preview.png`, `--out shading.toml`)
//! before a command computes it: camsim replaces an existing file only when camsim wrote it (or
//! the user said `--force`), and one run at a time writes it.
//!
//! A file is camsim's when it carries camsim's signature ([`crate::software`]): an OpenEXR file
//! whose `software` header attribute starts with `camsim`, a PNG whose `Software` text chunk
//! starts with `camsim`, or a text file whose first line starts with `# camsim`. A file moved or
//! copied keeps its signature; a file another program rewrote loses it.

use crate::atomic::check_replaceable_file;
use crate::error::{IoError, Result};
use crate::lock::{self, OutputLock};
use std::fs;
use std::io::Read;
use std::path::{Path, PathBuf};

/// A claim on a single output file: the file's lock, held until dropped. Write the file (with
/// the atomic writers) while holding it.
#[derive(Debug)]
pub struct FileClaim {
    removed_stale: Vec<PathBuf>,
    _lock: OutputLock,
}

impl FileClaim {
    /// Temporaries of killed runs writing this file, removed by the claim.
    pub fn removed_stale(&self) -> &[PathBuf] {
        &self.removed_stale
    }
}

/// Claim `path` as a single output file: create its folder, refuse a path that is not a regular
/// file, lock it (a second run fails naming the first), refuse an existing file camsim did not
/// write unless `force`, and remove stale temporaries of killed runs writing it.
pub fn claim_file(path: &Path, force: bool) -> Result<FileClaim> {
    lock::file_name(path)?;
    let dir = lock::parent_dir(path);
    fs::create_dir_all(&dir).map_err(|e| lock::cannot_write_beside(path, e))?;
    check_replaceable_file(path)?;
    let lock = OutputLock::acquire(path)?;
    if !force && path.exists() && !written_by_camsim(path) {
        return Err(IoError::invalid(
            path,
            "exists and camsim did not write it (it has no camsim signature); choose another output file, or add --force to overwrite it",
        ));
    }
    Ok(FileClaim {
        removed_stale: lock::remove_stale_temporaries(path),
        _lock: lock,
    })
}

/// Whether the file at `path` carries camsim's signature (see the module documentation).
pub fn written_by_camsim(path: &Path) -> bool {
    let mut head = [0u8; 16];
    let n = match fs::File::open(path).and_then(|mut f| f.read(&mut head)) {
        Ok(n) => n,
        Err(_) => return false,
    };
    let head = &head[..n];
    if head.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        crate::exr::written_by_camsim(path)
    } else if head.starts_with(b"\x89PNG\r\n\x1a\n") {
        crate::raster::png_written_by_camsim(path)
    } else {
        first_line_signed(path)
    }
}

fn first_line_signed(path: &Path) -> bool {
    let mut buf = vec![0u8; crate::software::TEXT_SIGNATURE.len()];
    fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut buf))
        .is_ok()
        && buf == crate::software::TEXT_SIGNATURE.as_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 25 item 1: `camsim scene --out notes.txt` overwrote a text file with EXR data.
    #[test]
    fn a_users_file_is_refused_unless_forced_camsims_own_are_replaced() {
        let root = tempfile::tempdir().unwrap();
        let notes = root.path().join("notes.txt");
        fs::write(&notes, b"my notes").unwrap();
        let e = claim_file(&notes, false).unwrap_err().to_string();
        assert!(e.contains("notes.txt") && e.contains("--force"), "{e}");
        assert_eq!(fs::read(&notes).unwrap(), b"my notes");
        assert!(claim_file(&notes, true).is_ok());
        // Files with camsim's signature, one per format camsim writes as a single output.
        let exr = root.path().join("r.exr");
        crate::exr::write_gray_exr(&exr, 2, 2, "Y", &[1.0; 4]).unwrap();
        let png = root.path().join("p.png");
        crate::raster::write_png8_rgb(&png, 1, 1, &[1, 2, 3]).unwrap();
        let toml = root.path().join("s.toml");
        fs::write(&toml, "# camsim lens shading fit\norder = 4\n").unwrap();
        for p in [&exr, &png, &toml] {
            assert!(written_by_camsim(p), "{}", p.display());
            assert!(claim_file(p, false).is_ok(), "{}", p.display());
        }
        // The same formats from elsewhere are not camsim's.
        let other_png = root.path().join("photo.png");
        image::RgbImage::new(1, 1).save(&other_png).unwrap();
        assert!(!written_by_camsim(&other_png));
        assert!(claim_file(&other_png, false).is_err());
        // An absent file is claimed; a second claim while the first is held fails.
        let new = root.path().join("new.exr");
        let first = claim_file(&new, false).unwrap();
        assert!(claim_file(&new, false)
            .unwrap_err()
            .to_string()
            .contains("another camsim run"));
        drop(first);
    }
}
