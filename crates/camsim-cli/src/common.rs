//! Small helpers shared by the subcommands: progress bars, output folders, reading inputs by
//! extension.

use anyhow::Result;
use camsim::io::atomic::OutputDir;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

static QUIET: AtomicBool = AtomicBool::new(false);

pub fn set_quiet(q: bool) {
    QUIET.store(q, Ordering::Relaxed);
}

/// A progress bar on stderr for `total` steps (hidden with --quiet or when stderr is no terminal).
pub fn progress(total: u64, what: &str) -> ProgressBar {
    if QUIET.load(Ordering::Relaxed) {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(total);
    pb.set_style(
        ProgressStyle::with_template(
            "{msg:>12} [{elapsed_precise}] {wide_bar} {pos}/{len} (eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb.set_message(what.to_string());
    pb
}

/// A spinner for steps without a known length.
pub fn spinner(what: &str) -> ProgressBar {
    if QUIET.load(Ordering::Relaxed) {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new_spinner();
    pb.set_message(what.to_string());
    pb.enable_steady_tick(std::time::Duration::from_millis(120));
    pb
}

/// Print a line unless --quiet.
pub fn say(msg: impl AsRef<str>) {
    if !QUIET.load(Ordering::Relaxed) {
        eprintln!("{}", msg.as_ref());
    }
}

/// Stage an output folder: outputs go into a fresh sibling `DIR.camsim-tmp-<pid>` that
/// [`camsim::io::atomic::OutputDir::commit`] swaps in for DIR when the run is complete (see that
/// type). Refuses a DIR that is not a folder camsim may replace (exit 2). When DIR holds an
/// earlier run, says on stderr (unless --quiet) what the commit will replace.
///
/// Use in a command: `let out = common::stage_out_dir(&a.out)?;` write every file to
/// `out.join(name)`, then `common::commit(out)?` last.
pub fn stage_out_dir(dir: &Path) -> Result<OutputDir> {
    let out = OutputDir::create(dir)?;
    report_removed(out.removed_stale());
    if let Some(old) = out.replaces() {
        const SHOWN: usize = 8;
        let mut list = old
            .iter()
            .take(SHOWN)
            .cloned()
            .collect::<Vec<_>>()
            .join(", ");
        if old.len() > SHOWN {
            list.push_str(&format!(" and {} more", old.len() - SHOWN));
        }
        say(format!(
            "camsim: {} holds an earlier run ({list}); it will be replaced as a whole when this run completes",
            dir.display()
        ));
    }
    Ok(out)
}

/// [`stage_out_dir`] for a command that reads `inputs`: refuses an output folder that holds one
/// of them (committing would replace the folder as a whole, inputs included).
pub fn stage_out_dir_reading(dir: &Path, inputs: &[&Path]) -> Result<OutputDir> {
    if let Ok(target) = dir.canonicalize() {
        for input in inputs {
            if let Ok(i) = input.canonicalize() {
                if i.starts_with(&target) {
                    anyhow::bail!(
                        "--out {} holds the input {}: the output folder is replaced as a whole when the run completes; choose another --out",
                        dir.display(),
                        input.display()
                    );
                }
            }
        }
    }
    stage_out_dir(dir)
}

/// Say (even with --quiet) which temporaries of killed runs were removed.
pub fn report_removed(paths: &[PathBuf]) {
    for p in paths {
        eprintln!(
            "camsim: removed {}, left by a camsim run that no longer runs",
            p.display()
        );
    }
}

/// Claim a single output file before computing it (see `camsim::io::claim`): refuses a file
/// camsim did not write unless `force`, and a second run writing the same file. Hold the claim
/// until the file is written.
pub fn claim_out_file(path: &Path, force: bool) -> Result<camsim::io::claim::FileClaim> {
    let claim = camsim::io::claim::claim_file(path, force)?;
    report_removed(claim.removed_stale());
    Ok(claim)
}

/// Commit a staged output folder (swap it in for its target).
pub fn commit(out: OutputDir) -> Result<()> {
    Ok(out.commit()?)
}

/// clap value parser: a finite number > 0 (NaN, infinities and zero refused).
pub fn positive_f64(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("'{s}' is not a finite number > 0")),
    }
}

/// clap value parser: a finite number >= 0.
pub fn non_negative_f64(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v >= 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("'{s}' is not a finite number >= 0")),
    }
}

/// clap value parser: a finite number (NaN and infinities refused).
pub fn finite_f64(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("'{s}' is not a finite number")),
    }
}

/// Read a spectral EXR (`camsim::pipeline::inputs::read_spectral_exr`), printing its warning on
/// stderr when round-off-sized negative samples were clamped to 0.
pub fn read_spectral_exr(path: &Path) -> Result<camsim::core::SpectralImage> {
    let (img, warning) = camsim::pipeline::inputs::read_spectral_exr(path)?;
    if let Some(w) = warning {
        eprintln!("camsim: warning: {w}");
    }
    Ok(img)
}
