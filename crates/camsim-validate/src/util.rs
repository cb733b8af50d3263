//! Shared helpers: the Cornell box spectra (built-in or measured), figure files, statistics and
//! the report's assembly.

use crate::report::Html;
use crate::{Provenance, Result, ValidateError, ValidateOptions, ValidationResults};
use camsim_core::spectrum::Extrapolation;
use camsim_core::spectrum_csv::{load_spectra, SpectraTable};
use camsim_core::{Spectrum, WavelengthGrid};
use camsim_scene3d::builtin::{BuiltinOptions, WallSpectra};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// A PNG figure: written to the output folder and embedded in the report.
#[derive(Debug, Clone, Serialize)]
pub struct FigurePng {
    /// File name inside the output folder.
    pub file: String,
    /// Caption.
    pub caption: String,
    /// The PNG bytes (not serialized).
    #[serde(skip)]
    pub png: Vec<u8>,
}

/// Write a PNG into the output folder and keep its bytes for the report.
pub fn save_png(out_dir: &Path, file: &str, caption: &str, png: Vec<u8>) -> Result<FigurePng> {
    camsim_io::atomic::write_bytes_atomic(&out_dir.join(file), &png)?;
    Ok(FigurePng {
        file: file.to_string(),
        caption: caption.to_string(),
        png,
    })
}

/// The Cornell box's light and wall spectra: the built-in ones (Cornell data page) or the
/// measured isetcornellbox files.
#[derive(Debug, Clone, Default)]
pub struct BoxSpectra {
    /// Relative light spectrum (None: built-in).
    pub light: Option<Spectrum>,
    /// Wall reflectances (None entries: built-in).
    pub walls: WallSpectra,
    /// Where each came from, for the provenance.
    pub describe: Vec<String>,
}

fn find_file(dir: &Path, stems: &[&str]) -> Option<PathBuf> {
    for stem in stems {
        for ext in ["csv", "mat"] {
            let p = dir.join(format!("{stem}.{ext}"));
            if p.is_file() {
                return Some(p);
            }
        }
    }
    None
}

/// A column by name (case-insensitive), or by position when the file has no such names
/// (ISETCam .mat files may carry generic names).
fn column(t: &SpectraTable, name: &str, index: usize, path: &Path) -> Result<Spectrum> {
    let s = match t.index_of(name) {
        Some(i) => t.spectrum_at(i),
        None if index < t.len() => t.spectrum_at(index),
        None => {
            return Err(ValidateError::file(
                path,
                format!("no column '{name}' (columns: {})", t.names.join(", ")),
            ))
        }
    };
    Ok(s.map_err(|e| ValidateError::file(path, e.to_string()))?
        .with_extrapolation(Extrapolation::Hold))
}

impl BoxSpectra {
    /// Built-in spectra (`data_dir` None) or the measured ones from `data_dir`: the lamp
    /// `cboxIlluminant` and the walls `cboxSurfaces` (else `cboxWalls`), columns red, green,
    /// white. Reflectances above 1 (the files' estimates beyond 700 nm) are clipped to 1 so the
    /// box cannot gain energy.
    pub fn load(data_dir: Option<&Path>, _grid: &WavelengthGrid) -> Result<BoxSpectra> {
        let Some(dir) = data_dir else {
            return Ok(BoxSpectra {
                light: None,
                walls: WallSpectra::default(),
                describe: vec![
                    "light: Cornell Program of Computer Graphics, Cornell box data page (built in)"
                        .into(),
                    "walls: Cornell Program of Computer Graphics, Cornell box data page (built in)"
                        .into(),
                ],
            });
        };
        if !dir.is_dir() {
            return Err(ValidateError::file(dir, "the --data folder does not exist"));
        }
        let lp = find_file(dir, &["cboxIlluminant"]).ok_or_else(|| {
            ValidateError::file(
                dir,
                "no cboxIlluminant.csv or cboxIlluminant.mat in this folder",
            )
        })?;
        let lt = load_spectra(&lp)?;
        let light = column(&lt, "spd", 0, &lp)?;
        light.require_non_negative(&lp.display().to_string())?;
        let wp = find_file(dir, &["cboxSurfaces", "cboxWalls"]).ok_or_else(|| {
            ValidateError::file(
                dir,
                "no cboxSurfaces or cboxWalls (.csv or .mat) in this folder",
            )
        })?;
        let wt = load_spectra(&wp)?;
        let clip = |s: Spectrum| -> Spectrum {
            let v = s.values.iter().map(|x| x.clamp(0.0, 1.0)).collect();
            Spectrum { values: v, ..s }
        };
        let red = clip(column(&wt, "red", 0, &wp)?);
        let green = clip(column(&wt, "green", 1, &wp)?);
        let white = clip(column(&wt, "white", 2, &wp)?);
        Ok(BoxSpectra {
            light: Some(light),
            walls: WallSpectra {
                white: Some(white),
                red: Some(red),
                green: Some(green),
            },
            describe: vec![
                format!(
                    "light: {} (ISET/isetcornellbox, PR670 measurement)",
                    lp.display()
                ),
                format!(
                    "walls: {} (ISET/isetcornellbox; red, green, white; clipped to [0, 1])",
                    wp.display()
                ),
            ],
        })
    }

    /// Builtin options with these spectra.
    pub fn apply(&self, o: &mut BuiltinOptions) {
        o.light_spectrum = self.light.clone();
        o.wall_spectra = self.walls.clone();
    }
}

/// Round for tables.
pub fn f(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "-".into()
    }
}

/// Optional number for tables.
pub fn fo(x: Option<f64>, digits: usize) -> String {
    x.map(|v| f(v, digits)).unwrap_or_else(|| "-".into())
}

/// Placeholder replaced by the timing table once the report is rendered.
pub const TIMINGS_PLACEHOLDER: &str = "<!--camsim-timings-->";

/// The timing table.
pub fn timings_html(p: &Provenance) -> String {
    let mut h = Html::new("");
    let mut rows: Vec<Vec<String>> = p
        .timings
        .iter()
        .map(|t| vec![t.stage.clone(), f(t.seconds, 2)])
        .collect();
    rows.push(vec!["total".into(), f(p.total_seconds, 2)]);
    h.table(&["stage", "seconds"], &rows);
    let s = h.finish();
    // Only the table (between <body> ... </body>, after the empty title).
    let start = s.find("<table>").unwrap_or(0);
    let end = s.find("</table>").map(|e| e + 8).unwrap_or(s.len());
    s[start..end].to_string()
}

/// Assemble the HTML report (timings are filled in afterwards).
pub fn write_report(
    opts: &ValidateOptions,
    r: &mut ValidationResults,
    _stages: &crate::Stages,
) -> Result<String> {
    let mut h = Html::new("camsim validation: the Cornell box (Lyu et al.)");
    h.p(&format!(
        "This report reproduces figures 2-6 of Lyu et al., \"Validation of image systems simulation technology using a \
         Cornell Box\", with camsim {} ({} quality). The \"measured\" data of the paper are replaced by camsim's own \
         simulation with the corrected Pixel 4a sensor and its noise: every check below compares the simulation \
         with an independent model (optics MTF, noise model, the paper's matrix M).",
        r.provenance.camsim_version,
        match opts.quality {
            crate::Quality::Quick => "quick",
            crate::Quality::Paper => "paper",
        }
    ));
    h.h3("Checks");
    for c in &r.checks {
        h.check(c.passed, &format!("{}: {}", c.name, c.detail));
    }
    r.optics.report(&mut h);
    r.qe.report(&mut h);
    r.scene.report(&mut h);
    h.h2("6. Provenance", "provenance");
    let p = &r.provenance;
    h.table(
        &["parameter", "value"],
        &[
            vec!["camsim version".into(), p.camsim_version.clone()],
            vec!["command".into(), p.command_line.clone()],
            vec!["seed".into(), p.seed.to_string()],
            vec!["threads".into(), p.threads.to_string()],
            vec!["spectra".into(), p.spectra.join("; ")],
            vec![
                "quality parameters".into(),
                serde_json::to_string(&p.params).unwrap_or_default(),
            ],
        ],
    );
    h.raw(TIMINGS_PLACEHOLDER);
    for (name, text) in [
        ("pixel4a sensor (corrected QE)", &p.sensor_pixel4a_toml),
        ("imx363 sensor (published QE)", &p.sensor_imx363_toml),
        ("pixel4a optics", &p.optics_pixel4a_toml),
    ] {
        h.raw(&format!(
            "<details><summary>{}</summary><pre>{}</pre></details>",
            crate::report::esc(name),
            crate::report::esc(text)
        ));
    }
    Ok(h.finish())
}
