//! CSV files of measurements that camsim's analyses take as input, read with the `csv` crate:
//!
//! - [`read_emva_series`] and [`write_emva_series`]: the frame list of an EMVA 1288 series
//!   (`camsim sensor --emva-series` writes one; `camsim analyze emva` reads it);
//! - [`read_sfr_csv`]: the SFR curves of an `sfr.csv` (`camsim analyze sfr` writes one and
//!   overlays others with `--compare`);
//! - [`read_mtf_csv`]: a measured MTF curve in cycles/mm (`camsim fit mtf --measured`);
//! - [`read_lens_mtf_csv`]: a lens's tangential and sagittal MTF table at one field height, per
//!   wavelength or for the band (`blur.measured_psf` files ending in `.csv`);
//! - [`read_qe_means`]: measured ColorChecker patch means, the input of the QE correction fit
//!   (`camsim fit qe --measured`).
//!
//! Fields may be double-quoted (RFC 4180: `"a,b"` is one field, `""` inside quotes is one quote)
//! and are trimmed; blank lines are skipped. Every error names the file and, where there is one,
//! the line (`<file>, line <n>: ...`).

use crate::error::{IoError, Result};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The records of the CSV file at `path`, each with its 1-based line in the file (see
/// [`camsim_core::csv_records::records`]): fields trimmed, blank lines skipped, and `#` comment
/// lines (indented ones too) when `comments` is set.
fn records(path: &Path, comments: bool) -> Result<Vec<(usize, csv::StringRecord)>> {
    let bytes = std::fs::read(path).map_err(|e| IoError::io(path, e))?;
    camsim_core::csv_records::records(&bytes, comments)
        .map_err(|(line, e)| IoError::line(path, line, camsim_core::csv_records::error_message(&e)))
}

/// The fields of a record joined by commas (for messages quoting a line).
fn joined(r: &csv::StringRecord) -> String {
    r.iter().collect::<Vec<_>>().join(",")
}

// ---------------------------------------------------------------------------------------------

/// One level of an EMVA 1288 series as its CSV lists it.
#[derive(Debug, Clone, PartialEq)]
pub struct EmvaLevelFiles {
    /// The CSV line (1-based), for messages about this level's frames.
    pub line: usize,
    /// Exposure time, s (>= 0).
    pub exposure_s: f64,
    /// Mean photons per pixel at this level, when known (given on every line or on none).
    pub photons_per_pixel: Option<f64>,
    /// Sensor-plane photometric exposure, lux s, when known (the optional column
    /// `exposure_lux_s` after `photons_per_pixel`; on every line or on none).
    pub exposure_lux_s: Option<f64>,
    /// Bright frames (at least 2), resolved against the CSV's folder.
    pub bright: Vec<PathBuf>,
    /// Dark frames (none, or at least 2), resolved against the CSV's folder.
    pub dark: Vec<PathBuf>,
}

/// Read an EMVA 1288 series CSV: a header naming the columns (`exposure_s,photons_per_pixel,`,
/// optionally `exposure_lux_s,` (the sensor-plane exposure, lux s, for ISO 12232 speeds), then
/// frame columns whose names start with `bright` or `dark`, e.g.
/// `bright_0,bright_1,dark_0,dark_1` as `camsim sensor --emva-series` writes), one level per line.
/// Frame paths are relative to the CSV's folder; an empty photons cell (or `-`, or `nan`) means
/// the photon count is not known; empty frame cells are skipped. Lines starting with '#' and blank
/// lines are ignored. At least 3 levels, each with at least 2 bright frames and none or at least 2
/// dark frames.
pub fn read_emva_series(csv: &Path) -> Result<Vec<EmvaLevelFiles>> {
    let rows = records(csv, true)?;
    let base = csv.parent().unwrap_or(Path::new("."));
    let mut rows = rows.into_iter();
    let (hline, header) = rows
        .next()
        .ok_or_else(|| IoError::format(csv, "no header line"))?;
    let cols: Vec<String> = header.iter().map(|s| s.to_ascii_lowercase()).collect();
    if cols.len() < 3 || cols[0] != "exposure_s" || cols[1] != "photons_per_pixel" {
        return Err(IoError::line(
            csv,
            hline,
            format!(
                "the header must start with exposure_s,photons_per_pixel and name the frame columns (bright_0,bright_1,...,dark_0,dark_1,...), got '{}'",
                joined(&header)
            ),
        ));
    }
    // The optional photometric column.
    let first_frame = if cols.get(2).is_some_and(|c| c == "exposure_lux_s") {
        3
    } else {
        2
    };
    let kinds: Vec<Option<bool>> = cols
        .iter()
        .map(|c| {
            if c.starts_with("bright") {
                Some(true)
            } else if c.starts_with("dark") {
                Some(false)
            } else {
                None
            }
        })
        .collect();
    if let Some((i, c)) = cols
        .iter()
        .enumerate()
        .skip(first_frame)
        .find(|(i, _)| kinds[*i].is_none())
    {
        return Err(IoError::line(
            csv,
            hline,
            format!(
                "column {} '{c}' is neither a bright nor a dark frame column",
                i + 1
            ),
        ));
    }
    let mut levels = Vec::new();
    for (n, cells) in rows {
        let err = |m: String| IoError::line(csv, n, m);
        if cells.len() != cols.len() {
            return Err(err(format!(
                "{} values for {} columns",
                cells.len(),
                cols.len()
            )));
        }
        let exposure_s: f64 = cells[0]
            .parse()
            .map_err(|_| err(format!("exposure_s '{}' is not a number", &cells[0])))?;
        if !(exposure_s >= 0.0 && exposure_s.is_finite()) {
            return Err(err(format!("exposure_s {exposure_s} is not a time >= 0")));
        }
        let photons_per_pixel = match &cells[1] {
            "" | "-" => None,
            s => {
                let v: f64 = s
                    .parse()
                    .map_err(|_| err(format!("photons_per_pixel '{s}' is not a number")))?;
                if v.is_nan() {
                    None
                } else if v >= 0.0 && v.is_finite() {
                    Some(v)
                } else {
                    return Err(err(format!("photons_per_pixel {v} is not a number >= 0")));
                }
            }
        };
        let exposure_lux_s = match (first_frame, cells[2].trim()) {
            (2, _) | (_, "" | "-") => None,
            (_, s) => {
                let v: f64 = s
                    .parse()
                    .map_err(|_| err(format!("exposure_lux_s '{s}' is not a number")))?;
                if !(v >= 0.0 && v.is_finite()) {
                    return Err(err(format!(
                        "exposure_lux_s {v} is not an exposure >= 0 lux s"
                    )));
                }
                Some(v)
            }
        };
        let (mut bright, mut dark) = (Vec::new(), Vec::new());
        for (k, cell) in cells.iter().enumerate().skip(first_frame) {
            if cell.is_empty() {
                continue;
            }
            let p = base.join(cell);
            if kinds[k] == Some(true) {
                bright.push(p);
            } else {
                dark.push(p);
            }
        }
        if bright.len() < 2 {
            return Err(err(format!(
                "{} bright frame(s); each level needs at least 2",
                bright.len()
            )));
        }
        if dark.len() == 1 {
            return Err(err("1 dark frame; give none or at least 2".into()));
        }
        levels.push(EmvaLevelFiles {
            line: n,
            exposure_s,
            photons_per_pixel,
            exposure_lux_s,
            bright,
            dark,
        });
    }
    if levels.len() < 3 {
        return Err(IoError::format(
            csv,
            format!(
                "{} level(s); the photon transfer method needs at least 3",
                levels.len()
            ),
        ));
    }
    // The analysis does not need the photon count, but it is all or nothing.
    let known = levels
        .iter()
        .filter(|l| l.photons_per_pixel.is_some())
        .count();
    if known != 0 && known != levels.len() {
        return Err(IoError::format(
            csv,
            format!("photons_per_pixel is given on {known} of {} lines; give it on every line or on none", levels.len()),
        ));
    }
    let lux = levels.iter().filter(|l| l.exposure_lux_s.is_some()).count();
    if lux != 0 && lux != levels.len() {
        return Err(IoError::format(
            csv,
            format!(
                "exposure_lux_s is given on {lux} of {} lines; give it on every line or on none",
                levels.len()
            ),
        ));
    }
    Ok(levels)
}

/// Write an EMVA 1288 series CSV that [`read_emva_series`] reads: the header
/// `exposure_s,photons_per_pixel[,exposure_lux_s],bright_0,...,dark_0,...` (lux s when every level
/// gives it; as many frame columns as the level with
/// the most frames), one line per level, frame paths as given (relative to the CSV's folder; a
/// level with fewer frames leaves its last cells empty), an unknown photon count as an empty
/// cell. Written atomically.
pub fn write_emva_series(csv: &Path, levels: &[EmvaLevelFiles]) -> Result<()> {
    use std::fmt::Write as _;
    let nb = levels.iter().map(|l| l.bright.len()).max().unwrap_or(0);
    let nd = levels.iter().map(|l| l.dark.len()).max().unwrap_or(0);
    let lux = !levels.is_empty() && levels.iter().all(|l| l.exposure_lux_s.is_some());
    let mut text = String::from("exposure_s,photons_per_pixel");
    if lux {
        text.push_str(",exposure_lux_s");
    }
    for (kind, n) in [("bright", nb), ("dark", nd)] {
        for k in 0..n {
            let _ = write!(text, ",{kind}_{k}");
        }
    }
    text.push('\n');
    for l in levels {
        let _ = write!(text, "{},", l.exposure_s);
        if let Some(p) = l.photons_per_pixel {
            let _ = write!(text, "{p}");
        }
        if let (true, Some(h)) = (lux, l.exposure_lux_s) {
            let _ = write!(text, ",{h}");
        }
        for (frames, n) in [(&l.bright, nb), (&l.dark, nd)] {
            for k in 0..n {
                text.push(',');
                if let Some(f) = frames.get(k) {
                    text.push_str(&f.display().to_string());
                }
            }
        }
        text.push('\n');
    }
    crate::atomic::write_bytes_atomic(csv, text.as_bytes())
}

// ---------------------------------------------------------------------------------------------

/// One SFR curve of an `sfr.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct SfrCurve {
    /// The column name (`mtf_R`, `mtf_G`, `mtf_B`, `mtf_luminance`, ...).
    pub name: String,
    /// (spatial frequency in cycles per sensor pixel, SFR) where both are finite.
    pub points: Vec<(f64, f64)>,
}

/// Read the curves of an `sfr.csv` as `camsim analyze sfr` writes it: the first column
/// `freq_cyc_per_sensor_px`, then any columns; the curves are the columns whose names start with
/// `mtf_`. Every row is numbers (`nan` where a curve has no value; such points are left out).
pub fn read_sfr_csv(path: &Path) -> Result<Vec<SfrCurve>> {
    let mut rows = records(path, false)?.into_iter();
    let (_, header) = rows.next().ok_or_else(|| IoError::format(path, "empty"))?;
    if header.get(0) != Some("freq_cyc_per_sensor_px") {
        return Err(IoError::format(
            path,
            "not an sfr.csv (its first column must be freq_cyc_per_sensor_px)",
        ));
    }
    let mut cols: Vec<Vec<(f64, f64)>> = vec![Vec::new(); header.len()];
    for (line, record) in rows {
        let v: Vec<f64> = record
            .deserialize(None)
            .map_err(|_| IoError::line(path, line, "not numbers"))?;
        if v.len() != header.len() {
            return Err(IoError::line(
                path,
                line,
                format!("{} values for {} columns", v.len(), header.len()),
            ));
        }
        for (k, x) in v.iter().enumerate().skip(1) {
            if x.is_finite() && v[0].is_finite() {
                cols[k].push((v[0], *x));
            }
        }
    }
    Ok(header
        .iter()
        .zip(cols)
        .skip(1)
        .filter(|(h, _)| h.starts_with("mtf_"))
        .map(|(h, points)| SfrCurve {
            name: h.to_string(),
            points,
        })
        .collect())
}

// ---------------------------------------------------------------------------------------------

/// One measured ColorChecker patch: a line `light,patch,r,g,b` of the QE-fit input.
#[derive(Debug, Clone, PartialEq)]
pub struct PatchMeans {
    /// The CSV line (1-based), for messages about this measurement.
    pub line: usize,
    /// The light's name as written (matched against the lights the fit is given).
    pub light: String,
    /// The ColorChecker patch, 1..=24 in the chart's order.
    pub patch: usize,
    /// Mean DN above black of the R, G and B channels over the patch (finite).
    pub rgb: [f64; 3],
}

/// A line of the QE-fit input, as the `csv` crate deserializes it (no header: fields in order).
#[derive(Deserialize)]
struct PatchRow {
    light: String,
    patch: usize,
    r: f64,
    g: f64,
    b: f64,
}

/// Read measured patch means for the QE correction fit: a header `light,patch,r,g,b` (any case),
/// then one line per light and patch (patch 1-24 in the ColorChecker's order, mean DN above black
/// of each channel over the patch), e.g. `D65,1,123.4,210.2,98.7`. Lines starting with '#' and
/// blank lines are ignored; at least 3 measurements.
pub fn read_qe_means(path: &Path) -> Result<Vec<PatchMeans>> {
    let mut rows = records(path, true)?.into_iter();
    let (hline, header) = rows.next().ok_or_else(|| {
        IoError::format(path, "no header line; the header must be light,patch,r,g,b")
    })?;
    let names: Vec<String> = header.iter().map(|t| t.to_ascii_lowercase()).collect();
    if names != ["light", "patch", "r", "g", "b"] {
        return Err(IoError::line(
            path,
            hline,
            format!(
                "the header must be light,patch,r,g,b, got '{}'",
                joined(&header)
            ),
        ));
    }
    let mut out = Vec::new();
    for (line, record) in rows {
        if record.len() != 5 {
            return Err(IoError::line(path, line, "expected light,patch,r,g,b"));
        }
        let row: PatchRow = record.deserialize(None).map_err(|e| {
            let field = match e.kind() {
                csv::ErrorKind::Deserialize { err, .. } => err.field(),
                _ => None,
            };
            IoError::line(
                path,
                line,
                if field == Some(1) {
                    "patch must be 1..24"
                } else {
                    "r, g, b must be numbers"
                },
            )
        })?;
        if !(1..=24).contains(&row.patch) {
            return Err(IoError::line(path, line, "patch must be 1..24"));
        }
        let rgb = [row.r, row.g, row.b];
        if rgb.iter().any(|v| !v.is_finite()) {
            return Err(IoError::line(path, line, "r, g, b must be finite numbers"));
        }
        out.push(PatchMeans {
            line,
            light: row.light,
            patch: row.patch,
            rgb,
        });
    }
    if out.len() < 3 {
        return Err(IoError::format(
            path,
            format!("need at least 3 measurements, found {}", out.len()),
        ));
    }
    Ok(out)
}

/// A measured MTF curve (e.g. a slanted-edge SFR of a real camera), in sensor-plane units.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredMtf {
    /// Spatial frequency in the sensor plane, cycles/mm, increasing.
    pub freq_cyc_per_mm: Vec<f64>,
    /// Modulation, fraction (1 at zero frequency); converted from percent when the file gives it.
    pub mtf: Vec<f64>,
    /// The 1-based CSV line of each point, for messages about it.
    pub lines: Vec<usize>,
}

/// A line of a measured MTF CSV, as the `csv` crate deserializes it (fields in order).
#[derive(Deserialize)]
struct MtfRow {
    freq: f64,
    mtf: f64,
}

/// Read a measured MTF: a header naming two columns, the frequency in cycles/mm
/// (`frequency_cy_per_mm`, `freq_cyc_per_mm`, `cycles_per_mm`, ...: a name containing `freq` or
/// `cy`) and the modulation (`mtf_percent` or any name with `percent`/`%`: percent; `mtf`,
/// `sfr`, `modulation`: fraction), then one point per line with increasing frequency >= 0, e.g.
/// `9.17,97.78` (the isetcornellbox `pixel4a-measured-mtf-in-focus.csv`). Lines starting with '#'
/// and blank lines are ignored; at least 3 points; a modulation must lie in [-0.05, 1.5] as a
/// fraction.
pub fn read_mtf_csv(path: &Path) -> Result<MeasuredMtf> {
    let mut rows = records(path, true)?.into_iter();
    let (hline, header) = rows.next().ok_or_else(|| {
        IoError::format(
            path,
            "no header line; the header must name the frequency (cycles/mm) and MTF columns, e.g. frequency_cy_per_mm,mtf_percent",
        )
    })?;
    let names: Vec<String> = header.iter().map(|t| t.to_ascii_lowercase()).collect();
    let freq_ok = names
        .first()
        .is_some_and(|n| n.contains("freq") || n.contains("cy"));
    let mtf_ok = names
        .get(1)
        .is_some_and(|n| ["mtf", "sfr", "modulation"].iter().any(|k| n.contains(k)));
    if names.len() != 2 || !freq_ok || !mtf_ok {
        return Err(IoError::line(
            path,
            hline,
            format!(
                "the header must be two columns, frequency in cycles/mm then MTF (e.g. frequency_cy_per_mm,mtf_percent), got '{}'",
                joined(&header)
            ),
        ));
    }
    if names[0].contains("px") || names[0].contains("pixel") {
        return Err(IoError::line(
            path,
            hline,
            format!(
                "column '{}' is per pixel; give the frequency in cycles/mm",
                &names[0]
            ),
        ));
    }
    let scale = if names[1].contains("percent") || names[1].contains('%') {
        0.01
    } else {
        1.0
    };
    let mut out = MeasuredMtf {
        freq_cyc_per_mm: Vec::new(),
        mtf: Vec::new(),
        lines: Vec::new(),
    };
    for (line, record) in rows {
        if record.len() != 2 {
            return Err(IoError::line(
                path,
                line,
                format!("{} values; expected frequency,mtf", record.len()),
            ));
        }
        let row: MtfRow = record.deserialize(None).map_err(|_| {
            IoError::line(
                path,
                line,
                format!("'{}' is not two numbers", joined(&record)),
            )
        })?;
        if !(row.freq.is_finite() && row.freq >= 0.0) {
            return Err(IoError::line(
                path,
                line,
                format!("frequency {} is not a number >= 0", row.freq),
            ));
        }
        if out.freq_cyc_per_mm.last().is_some_and(|f| row.freq <= *f) {
            return Err(IoError::line(
                path,
                line,
                format!("frequency {} does not increase", row.freq),
            ));
        }
        let m = row.mtf * scale;
        if !(m.is_finite() && (-0.05..=1.5).contains(&m)) {
            return Err(IoError::line(
                path,
                line,
                format!(
                    "MTF {} is not a modulation (fraction in [-0.05, 1.5])",
                    row.mtf
                ),
            ));
        }
        out.freq_cyc_per_mm.push(row.freq);
        out.mtf.push(m);
        out.lines.push(line);
    }
    if out.mtf.len() < 3 {
        return Err(IoError::format(
            path,
            format!("need at least 3 points, found {}", out.mtf.len()),
        ));
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------

/// A lens's tangential and sagittal MTF at one wavelength (or for its whole band), as a lens MTF
/// table ([`read_lens_mtf_csv`]) gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct LensMtfCurves {
    /// Spatial frequency in the sensor plane, cycles/mm, increasing.
    pub freq_cyc_per_mm: Vec<f64>,
    /// Tangential (meridional) modulation, fraction in [0, 1]: the MTF for frequencies along the
    /// radius (lines perpendicular to it).
    pub tangential: Vec<f64>,
    /// Sagittal modulation, fraction in [0, 1]: frequencies along the tangent.
    pub sagittal: Vec<f64>,
    /// Tangential phase transfer (PTF), radians, per point, when the table has it (all zero
    /// otherwise). Goodman's convention, OTF(f) = int LSF(x) e^(-i 2 pi f x) dx = MTF e^(i PTF):
    /// a line spread function displaced by +x0 (outward along the radius) has PTF = -2 pi f x0.
    pub tangential_phase_rad: Vec<f64>,
    /// Sagittal phase transfer, radians (zero for a lens symmetric about the meridional plane).
    pub sagittal_phase_rad: Vec<f64>,
}

/// A lens MTF table at one field height: its curves per wavelength, nm, increasing (`None`: the
/// file has no wavelength column, one curve pair for the whole band).
#[derive(Debug, Clone, PartialEq)]
pub struct LensMtf {
    /// The curves, by wavelength.
    pub curves: Vec<(Option<f64>, LensMtfCurves)>,
}

/// Read a lens MTF table, the tangential and sagittal MTF a lens bench (or a lens datasheet)
/// gives at one field height: a header naming the columns, in any order, the frequency in
/// cycles/mm (a name containing `freq` or `cy`, not `px`/`pixel`), the tangential MTF (`tan` or
/// `merid`), the sagittal MTF (`sag`), and optionally the wavelength in nm (`wavelength` or
/// `lambda`); a modulation column with `percent` or `%` in its name is in percent, otherwise a
/// fraction. Then one point per line, e.g. `frequency_cy_per_mm,tangential_percent,
/// sagittal_percent` and `50,62.1,70.4`. Points of one wavelength have increasing frequencies
/// (>= 0), at least 2 of them; modulations lie in [-0.05, 1.05] as fractions (clipped to [0, 1]).
/// Optional phase transfer columns (what a lens bench such as an MTF/PTF tester also reports):
/// `tangential_phase_deg` and `sagittal_phase_deg` (a name with `phase` or `ptf`, and `tan` /
/// `merid` or `sag`; degrees with `deg` in the name, else radians; see
/// [`LensMtfCurves::tangential_phase_rad`] for the sign). Lines starting with '#' and blank lines
/// are ignored.
pub fn read_lens_mtf_csv(path: &Path) -> Result<LensMtf> {
    let mut rows = records(path, true)?.into_iter();
    let (hline, header) = rows.next().ok_or_else(|| {
        IoError::format(
            path,
            "no header line; name the columns, e.g. frequency_cy_per_mm,tangential_percent,sagittal_percent",
        )
    })?;
    let names: Vec<String> = header.iter().map(|t| t.to_ascii_lowercase()).collect();
    let is_phase = |i: usize| names[i].contains("phase") || names[i].contains("ptf");
    let find_of = |keys: &[&str], phase: bool, what: &str| -> Result<Option<usize>> {
        let hits: Vec<usize> = (0..names.len())
            .filter(|&i| is_phase(i) == phase && keys.iter().any(|k| names[i].contains(k)))
            .collect();
        match hits.as_slice() {
            [] => Ok(None),
            [i] => Ok(Some(*i)),
            _ => Err(IoError::line(
                path,
                hline,
                format!("more than one {what} column in '{}'", joined(&header)),
            )),
        }
    };
    let missing = |keys: &[&str], what: &str| {
        IoError::line(
            path,
            hline,
            format!(
                "no {what} column (a name containing {}) in '{}'",
                keys.join(" or "),
                joined(&header)
            ),
        )
    };
    let wl_col = find_of(&["wavelength", "lambda"], false, "wavelength")?;
    let tan_col = find_of(&["tan", "merid"], false, "tangential MTF")?
        .ok_or_else(|| missing(&["tan", "merid"], "tangential MTF"))?;
    let sag_col = find_of(&["sag"], false, "sagittal MTF")?
        .ok_or_else(|| missing(&["sag"], "sagittal MTF"))?;
    let tan_phase_col = find_of(&["tan", "merid"], true, "tangential phase")?;
    let sag_phase_col = find_of(&["sag"], true, "sagittal phase")?;
    let phase_cols = [tan_phase_col, sag_phase_col];
    let freq_col = (0..names.len())
        .find(|&i| {
            Some(i) != wl_col
                && i != tan_col
                && i != sag_col
                && !phase_cols.contains(&Some(i))
                && (names[i].contains("freq") || names[i].contains("cy"))
        })
        .ok_or_else(|| {
            IoError::line(
                path,
                hline,
                format!(
                    "no frequency column (cycles/mm, a name containing freq or cy) in '{}'",
                    joined(&header)
                ),
            )
        })?;
    if names[freq_col].contains("px") || names[freq_col].contains("pixel") {
        return Err(IoError::line(
            path,
            hline,
            format!(
                "column '{}' is per pixel; give the frequency in cycles/mm",
                &names[freq_col]
            ),
        ));
    }
    let scale = |i: usize| {
        if names[i].contains("percent") || names[i].contains('%') {
            0.01
        } else {
            1.0
        }
    };
    let (tan_scale, sag_scale) = (scale(tan_col), scale(sag_col));
    // Curves by wavelength, in the file's order of first appearance.
    let mut curves: Vec<(Option<f64>, LensMtfCurves)> = Vec::new();
    for (line, record) in rows {
        if record.len() != names.len() {
            return Err(IoError::line(
                path,
                line,
                format!(
                    "{} values; the header names {} columns",
                    record.len(),
                    names.len()
                ),
            ));
        }
        let number = |i: usize| -> Result<f64> {
            record[i].parse::<f64>().map_err(|_| {
                IoError::line(
                    path,
                    line,
                    format!("'{}' ({}) is not a number", &record[i], &names[i]),
                )
            })
        };
        let freq = number(freq_col)?;
        if !(freq.is_finite() && freq >= 0.0) {
            return Err(IoError::line(
                path,
                line,
                format!("frequency {freq} is not a number >= 0"),
            ));
        }
        let wl = match wl_col {
            Some(i) => {
                let w = number(i)?;
                if !(w.is_finite() && w > 0.0) {
                    return Err(IoError::line(
                        path,
                        line,
                        format!("wavelength {w} nm is not a positive number"),
                    ));
                }
                Some(w)
            }
            None => None,
        };
        let modulation = |i: usize, s: f64| -> Result<f64> {
            let m = number(i)? * s;
            if !(m.is_finite() && (-0.05..=1.05).contains(&m)) {
                return Err(IoError::line(
                    path,
                    line,
                    format!(
                        "{} {} is not a modulation (fraction in [-0.05, 1.05])",
                        &names[i], &record[i]
                    ),
                ));
            }
            Ok(m.clamp(0.0, 1.0))
        };
        let (t, s) = (
            modulation(tan_col, tan_scale)?,
            modulation(sag_col, sag_scale)?,
        );
        let phase = |col: Option<usize>| -> Result<f64> {
            let Some(i) = col else { return Ok(0.0) };
            let v = number(i)?;
            if !v.is_finite() {
                return Err(IoError::line(
                    path,
                    line,
                    format!("{} {} is not a finite phase", &names[i], &record[i]),
                ));
            }
            Ok(if names[i].contains("deg") {
                v.to_radians()
            } else {
                v
            })
        };
        let (tp, sp) = (phase(tan_phase_col)?, phase(sag_phase_col)?);
        let idx = match curves.iter().position(|(w, _)| *w == wl) {
            Some(i) => i,
            None => {
                curves.push((
                    wl,
                    LensMtfCurves {
                        freq_cyc_per_mm: Vec::new(),
                        tangential: Vec::new(),
                        sagittal: Vec::new(),
                        tangential_phase_rad: Vec::new(),
                        sagittal_phase_rad: Vec::new(),
                    },
                ));
                curves.len() - 1
            }
        };
        let c = &mut curves[idx].1;
        if c.freq_cyc_per_mm.last().is_some_and(|&f| freq <= f) {
            return Err(IoError::line(
                path,
                line,
                format!("frequency {freq} does not increase"),
            ));
        }
        c.freq_cyc_per_mm.push(freq);
        c.tangential.push(t);
        c.sagittal.push(s);
        c.tangential_phase_rad.push(tp);
        c.sagittal_phase_rad.push(sp);
    }
    if curves.is_empty() {
        return Err(IoError::format(path, "no points"));
    }
    for (wl, c) in &curves {
        if c.freq_cyc_per_mm.len() < 2 {
            let at = wl.map(|w| format!(" at {w} nm")).unwrap_or_default();
            return Err(IoError::format(
                path,
                format!(
                    "need at least 2 points per curve, found {}{at}",
                    c.freq_cyc_per_mm.len()
                ),
            ));
        }
    }
    curves.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap_or(std::cmp::Ordering::Equal));
    Ok(LensMtf { curves })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn err(r: Result<impl std::fmt::Debug>) -> String {
        r.unwrap_err().to_string()
    }

    #[test]
    fn an_emva_series_written_reads_back_as_written() {
        let dir = tempfile::tempdir().unwrap();
        let level = |line: usize, t: f64, p: Option<f64>, n: usize| EmvaLevelFiles {
            line,
            exposure_s: t,
            photons_per_pixel: p,
            exposure_lux_s: None,
            bright: (0..n)
                .map(|k| dir.path().join(format!("b{line}_{k}.dng")))
                .collect(),
            dark: (0..2)
                .map(|k| dir.path().join(format!("d{line}_{k}.dng")))
                .collect(),
        };
        let csv = dir.path().join("series.csv");
        let levels = vec![
            level(2, 0.0, Some(0.0), 2),
            level(3, 1e-3, Some(123.456), 2),
            level(4, 2.5e-3, Some(246.912), 3),
        ];
        write_emva_series(&csv, &levels).unwrap();
        assert_eq!(read_emva_series(&csv).unwrap(), levels);
        let text = std::fs::read_to_string(&csv).unwrap();
        assert!(text.starts_with(
            "exposure_s,photons_per_pixel,bright_0,bright_1,bright_2,dark_0,dark_1\n"
        ));
        // An unknown photon count is an empty cell, read back as unknown.
        let unknown: Vec<_> = levels
            .iter()
            .map(|l| EmvaLevelFiles {
                photons_per_pixel: None,
                ..l.clone()
            })
            .collect();
        write_emva_series(&csv, &unknown).unwrap();
        assert_eq!(read_emva_series(&csv).unwrap(), unknown);
        // The photometric exposure (ISO 12232): its own column, read back; given on some lines
        // only, it is refused naming the column.
        let lux: Vec<_> = levels
            .iter()
            .map(|l| EmvaLevelFiles {
                exposure_lux_s: Some(0.5 * l.exposure_s),
                ..l.clone()
            })
            .collect();
        write_emva_series(&csv, &lux).unwrap();
        assert!(std::fs::read_to_string(&csv)
            .unwrap()
            .starts_with("exposure_s,photons_per_pixel,exposure_lux_s,bright_0"));
        assert_eq!(read_emva_series(&csv).unwrap(), lux);
        let text = std::fs::read_to_string(&csv).unwrap();
        let partial: String = text
            .lines()
            .enumerate()
            .map(|(i, l)| {
                if i == 2 {
                    let mut c: Vec<&str> = l.split(',').collect();
                    c[2] = "";
                    c.join(",") + "\n"
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        std::fs::write(&csv, partial).unwrap();
        let e = err(read_emva_series(&csv));
        assert!(e.contains("exposure_lux_s is given on 2 of 3 lines"), "{e}");
    }

    #[test]
    fn emva_series_with_quotes_comments_and_relative_paths() {
        let dir = tempfile::tempdir().unwrap();
        let text =
            "# series\n\"exposure_s\",\"photons_per_pixel\",bright_0,bright_1,dark_0,dark_1\n\n\
                    0.001, 10 ,\"a 0.dng\",\"b,1.dng\",,\n  # indented comment\n\
                    0.002,-,c.dng,d.dng,e.dng,f.dng\n0.003,nan,g.dng,h.dng,,\n";
        let p = file(&dir, "series.csv", text);
        let e = err(read_emva_series(&p));
        assert!(
            e.starts_with(&format!(
                "{}: photons_per_pixel is given on 1 of 3 lines",
                p.display()
            )),
            "{e}"
        );
        let p = file(&dir, "series.csv", &text.replace(" 10 ", ""));
        let l = read_emva_series(&p).unwrap();
        assert_eq!(l.iter().map(|l| l.line).collect::<Vec<_>>(), [4, 6, 7]);
        assert_eq!(
            l[0].bright,
            [dir.path().join("a 0.dng"), dir.path().join("b,1.dng")]
        );
        assert!(l[0].dark.is_empty() && l[1].dark.len() == 2);
        assert_eq!((l[1].exposure_s, l[1].photons_per_pixel), (0.002, None));
    }

    #[test]
    fn emva_series_errors_name_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let h = "exposure_s,photons_per_pixel,bright_0,bright_1,dark_0,dark_1\n";
        let ok = "0.001,,a,b,,\n0.002,,a,b,,\n";
        let cases = [
            ("", "no header line".to_string()),
            ("# only a comment\n", "no header line".into()),
            (
                "a,b\n1,2\n",
                "line 1: the header must start with exposure_s,photons_per_pixel".into(),
            ),
            (
                "exposure_s,photons_per_pixel,flat_0\n",
                "line 1: column 3 'flat_0' is neither".into(),
            ),
            (
                &format!("{h}{ok}0.003,,a\n"),
                "line 4: 3 values for 6 columns".into(),
            ),
            (
                &format!("{h}{ok}x,,a,b,,\n"),
                "line 4: exposure_s 'x' is not a number".into(),
            ),
            (
                &format!("{h}{ok}-1,,a,b,,\n"),
                "line 4: exposure_s -1 is not a time >= 0".into(),
            ),
            (
                &format!("{h}{ok}1,-5,a,b,,\n"),
                "line 4: photons_per_pixel -5 is not a number >= 0".into(),
            ),
            (
                &format!("{h}{ok}1,,a,,,\n"),
                "line 4: 1 bright frame(s)".into(),
            ),
            (
                &format!("{h}{ok}1,,a,b,c,\n"),
                "line 4: 1 dark frame".into(),
            ),
            (
                &format!("{h}{ok}1,,\"a,b,,\n"),
                "line 4: 3 values for 6 columns".into(),
            ),
            (&format!("{h}{ok}"), "2 level(s)".into()),
        ];
        for (text, want) in cases {
            let p = file(&dir, "s.csv", text);
            let e = err(read_emva_series(&p));
            let want = if want.starts_with("line") {
                format!("{}, {want}", p.display())
            } else {
                format!("{}: {want}", p.display())
            };
            assert!(e.starts_with(&want), "{text:?}: {e}");
        }
        assert!(err(read_emva_series(&dir.path().join("missing.csv"))).contains("missing.csv"));
        let p = dir.path().join("bin.csv");
        std::fs::write(
            &p,
            [h.as_bytes(), ok.as_bytes(), b"1,,a\xff,b,,\n"].concat(),
        )
        .unwrap();
        let e = err(read_emva_series(&p));
        assert!(
            e.starts_with(&format!("{}, line 4: not UTF-8 text", p.display())),
            "{e}"
        );
    }

    #[test]
    fn sfr_csv_curves_with_quoted_header() {
        let dir = tempfile::tempdir().unwrap();
        let p = file(
            &dir,
            "sfr.csv",
            "\"freq_cyc_per_sensor_px\",freq_cyc_per_mm,\"mtf_R\",mtf_luminance\n0.00,0,1,1\n\n0.01,7.1,\"0.99\",NaN\n",
        );
        let c = read_sfr_csv(&p).unwrap();
        assert_eq!(c.len(), 2);
        assert_eq!(
            c[0],
            SfrCurve {
                name: "mtf_R".into(),
                points: vec![(0.0, 1.0), (0.01, 0.99)]
            }
        );
        assert_eq!(
            c[1],
            SfrCurve {
                name: "mtf_luminance".into(),
                points: vec![(0.0, 1.0)]
            }
        );
        for (text, want) in [
            ("", ": empty"),
            ("a,b\n1,2\n", ": not an sfr.csv"),
            (
                "freq_cyc_per_sensor_px,mtf_R\n0,1\n\n0.1,x\n",
                ", line 4: not numbers",
            ),
            (
                "freq_cyc_per_sensor_px,mtf_R\n0,1,2\n",
                ", line 2: 3 values for 2 columns",
            ),
        ] {
            let p = file(&dir, "bad.csv", text);
            let e = err(read_sfr_csv(&p));
            assert!(
                e.starts_with(&format!("{}{want}", p.display())),
                "{text:?}: {e}"
            );
        }
    }

    #[test]
    fn qe_means_with_quotes_and_comments() {
        let dir = tempfile::tempdir().unwrap();
        let p = file(
            &dir,
            "m.csv",
            "# chart means\nLight,Patch,R,G,B\n\"D65, 6504 K\",1,1.5,2,3\n  # skipped\n\"A\",\"24\",4,5,6e1\nF2,3,7,8,9\n",
        );
        let m = read_qe_means(&p).unwrap();
        assert_eq!(
            m[0],
            PatchMeans {
                line: 3,
                light: "D65, 6504 K".into(),
                patch: 1,
                rgb: [1.5, 2.0, 3.0]
            }
        );
        assert_eq!(
            (m[1].line, m[1].light.as_str(), m[1].patch, m[1].rgb),
            (5, "A", 24, [4.0, 5.0, 60.0])
        );
        assert_eq!(m[2].line, 6);
        let h = "light,patch,r,g,b\n";
        for (text, want) in [
            ("", ": no header line".to_string()),
            (
                "D65,1,1,2,3\n",
                ", line 1: the header must be light,patch,r,g,b, got 'D65,1,1,2,3'".into(),
            ),
            (
                &format!("{h}D65,1,1,2\n"),
                ", line 2: expected light,patch,r,g,b".into(),
            ),
            (
                &format!("{h}D65,25,1,2,3\n"),
                ", line 2: patch must be 1..24".into(),
            ),
            (
                &format!("{h}D65,x,1,2,3\n"),
                ", line 2: patch must be 1..24".into(),
            ),
            (
                &format!("{h}D65,1,1,y,3\n"),
                ", line 2: r, g, b must be numbers".into(),
            ),
            (
                &format!("{h}D65,1,1,nan,3\n"),
                ", line 2: r, g, b must be finite numbers".into(),
            ),
            (
                &format!("{h}D65,1,1,2,3\n"),
                ": need at least 3 measurements, found 1".into(),
            ),
        ] {
            let p = file(&dir, "bad.csv", text);
            let e = err(read_qe_means(&p));
            assert!(
                e.starts_with(&format!("{}{want}", p.display())),
                "{text:?}: {e}"
            );
        }
    }

    #[test]
    fn measured_mtf_percent_and_fraction_with_errors_naming_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = file(
            &dir,
            "m.csv",
            "# slanted edge\nfrequency_cy_per_mm,mtf_percent\n9.5,97.5\n\n20,\"90\"\n40,50\n",
        );
        let m = read_mtf_csv(&p).unwrap();
        assert_eq!(m.freq_cyc_per_mm, [9.5, 20.0, 40.0]);
        assert_eq!(m.mtf, [0.975, 0.9, 0.5]);
        assert_eq!(m.lines, [3, 5, 6]);
        let p = file(&dir, "m.csv", "freq_cyc_per_mm,mtf\n0,1\n10,0.9\n20,0.5\n");
        assert_eq!(read_mtf_csv(&p).unwrap().mtf, [1.0, 0.9, 0.5]);
        let h = "frequency_cy_per_mm,mtf_percent\n";
        for (text, want) in [
            ("", ": no header line".to_string()),
            ("a,b\n", ", line 1: the header must be two columns".into()),
            (
                "freq_cyc_per_px,mtf\n",
                ", line 1: column 'freq_cyc_per_px' is per pixel".into(),
            ),
            (
                &format!("{h}1,99\n2,x\n"),
                ", line 3: '2,x' is not two numbers".into(),
            ),
            (&format!("{h}1,99\n2\n"), ", line 3: 1 values".into()),
            (
                &format!("{h}1,99\n1,98\n"),
                ", line 3: frequency 1 does not increase".into(),
            ),
            (
                &format!("{h}1,99\n-2,98\n"),
                ", line 3: frequency -2 is not".into(),
            ),
            (
                &format!("{h}1,99\n2,nan\n"),
                ", line 3: MTF NaN is not a modulation".into(),
            ),
            (
                &format!("{h}1,99\n2,9000\n"),
                ", line 3: MTF 9000 is not a modulation".into(),
            ),
            (
                &format!("{h}1,99\n2,98\n"),
                ": need at least 3 points, found 2".into(),
            ),
        ] {
            let p = file(&dir, "bad.csv", text);
            let e = err(read_mtf_csv(&p));
            assert!(
                e.starts_with(&format!("{}{want}", p.display())),
                "{text:?}: {e}"
            );
        }
    }

    #[test]
    fn lens_mtf_tables_by_wavelength_with_errors_naming_the_line() {
        let dir = tempfile::tempdir().unwrap();
        // Columns in any order, percent per column, wavelengths interleaved.
        let p = file(
            &dir,
            "l.csv",
            "# bench\nsagittal,wavelength_nm,Frequency (cy/mm),Tangential %\n1,650,0,100\n0.9,550,0,100\n0.8,650,50,70\n0.85,550,50,80\n",
        );
        let m = read_lens_mtf_csv(&p).unwrap();
        assert_eq!(m.curves.len(), 2);
        assert_eq!(m.curves[0].0, Some(550.0));
        assert_eq!(m.curves[0].1.freq_cyc_per_mm, [0.0, 50.0]);
        assert_eq!(m.curves[0].1.tangential, [1.0, 0.8]);
        assert_eq!(m.curves[0].1.sagittal, [0.9, 0.85]);
        assert_eq!(m.curves[1].0, Some(650.0));
        assert_eq!(m.curves[1].1.sagittal, [1.0, 0.8]);
        // No wavelength column: one pair for the band; a slight overshoot is clipped.
        let p = file(
            &dir,
            "l.csv",
            "freq_cyc_per_mm,tan,sag\n0,1.02,1\n100,0.5,0.4\n",
        );
        let m = read_lens_mtf_csv(&p).unwrap();
        assert_eq!(m.curves.len(), 1);
        assert_eq!(m.curves[0].0, None);
        assert_eq!(m.curves[0].1.tangential, [1.0, 0.5]);
        let h = "freq_cyc_per_mm,tangential,sagittal\n";
        for (text, want) in [
            ("", ": no header line".to_string()),
            (
                "freq,tangential\n",
                ", line 1: no sagittal MTF column".into(),
            ),
            (
                "freq_cyc_per_px,tan,sag\n",
                ", line 1: column 'freq_cyc_per_px' is per pixel".into(),
            ),
            ("f,tan,sag\n", ", line 1: no frequency column".into()),
            (
                &format!("{h}0,1,1\n10,x,1\n"),
                ", line 3: 'x' (tangential) is not a number".into(),
            ),
            (&format!("{h}0,1,1\n10,1\n"), ", line 3: 2 values".into()),
            (
                &format!("{h}0,1,1\n0,1,1\n"),
                ", line 3: frequency 0 does not increase".into(),
            ),
            (
                &format!("{h}0,1,1\n10,1,1.5\n"),
                ", line 3: sagittal 1.5 is not a modulation".into(),
            ),
            (
                &format!("{h}0,1,1\n"),
                ": need at least 2 points per curve, found 1".into(),
            ),
        ] {
            let p = file(&dir, "bad.csv", text);
            let e = err(read_lens_mtf_csv(&p));
            assert!(
                e.starts_with(&format!("{}{want}", p.display())),
                "{text:?}: {e}"
            );
        }
    }
}
