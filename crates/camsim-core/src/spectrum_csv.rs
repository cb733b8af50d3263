//! Spectra as CSV: one row per wavelength, the first column the wavelength in nm, one column per
//! spectrum, a header row naming the columns, and any number of `#` comment lines, e.g.
//!
//! ```text
//! # Sony IMX363 colour-filter QE (source ...)
//! wavelength_nm,r,g,b
//! 400,0.1,0.2,0.3
//! ```
//!
//! Also [`load_spectra`], which reads CSV or ISETCam MATLAB v5 files by extension. Writing a
//! table to a file is camsim-io's (`camsim_io::spectra::write_spectra_csv`, atomically); the
//! text is [`format_spectra_csv`].

use crate::error::{CoreError, Result};
use crate::spectra_table::read_limited;
pub use crate::spectra_table::{SpectraTable, MAX_SPECTRA_FILE_BYTES};
use std::path::Path;

fn line_err(path: &Path, line: usize, message: impl Into<String>) -> CoreError {
    CoreError::Line {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// Parse one CSV number; `nan`, `inf` and the like are errors.
fn parse_number(field: &str, path: &Path, line: usize, column: usize) -> Result<f64> {
    let f = field.trim();
    match f.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err(line_err(
            path,
            line,
            format!("column {column}: {v} is not a finite number"),
        )),
        Err(_) => Err(line_err(
            path,
            line,
            format!("column {column}: '{f}' is not a number"),
        )),
    }
}

/// Parse CSV spectra from `text`; `path` names the source in errors (a file, or e.g.
/// `"<built-in imx363>"`). A header row is required unless the first row is all numbers, in which
/// case the columns are named `data_1..n`. Fields may be double-quoted (RFC 4180).
pub fn parse_spectra_csv(text: &str, path: &Path) -> Result<SpectraTable> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut names: Option<Vec<String>> = None;
    let mut ncols = 0usize;
    let mut wavelengths_nm = Vec::new();
    let mut columns: Vec<Vec<f64>> = Vec::new();
    let records = crate::csv_records::records(text.as_bytes(), true)
        .map_err(|(line, e)| line_err(path, line, crate::csv_records::error_message(&e)))?;
    for (line_no, record) in records {
        let fields: Vec<&str> = record.iter().collect();
        if names.is_none() {
            if fields.len() < 2 {
                return Err(line_err(path, line_no, "need a wavelength column and at least one spectrum column, separated by commas"));
            }
            let numeric = fields.iter().all(|f| f.parse::<f64>().is_ok());
            ncols = fields.len();
            columns = vec![Vec::new(); ncols - 1];
            if numeric {
                names = Some((1..ncols).map(|j| format!("data_{j}")).collect());
                // fall through: this row is data
            } else {
                let n: Vec<String> = fields[1..].iter().map(|s| s.to_string()).collect();
                for (j, name) in n.iter().enumerate() {
                    if name.is_empty() {
                        return Err(line_err(
                            path,
                            line_no,
                            format!("header column {} has no name", j + 2),
                        ));
                    }
                    if n[..j].contains(name) {
                        return Err(line_err(
                            path,
                            line_no,
                            format!("header names column '{name}' twice"),
                        ));
                    }
                }
                names = Some(n);
                continue;
            }
        }
        if fields.len() != ncols {
            return Err(line_err(
                path,
                line_no,
                format!(
                    "{} fields, but the header has {ncols} columns (ragged row)",
                    fields.len()
                ),
            ));
        }
        let w = parse_number(fields[0], path, line_no, 1)?;
        if w <= 0.0 {
            return Err(line_err(
                path,
                line_no,
                format!("wavelength {w} nm is not positive"),
            ));
        }
        if let Some(prev) = wavelengths_nm.last() {
            if w <= *prev {
                return Err(line_err(
                    path,
                    line_no,
                    format!("wavelength {w} nm does not increase (previous row {prev} nm)"),
                ));
            }
        }
        wavelengths_nm.push(w);
        for (j, f) in fields[1..].iter().enumerate() {
            columns[j].push(parse_number(f, path, line_no, j + 2)?);
        }
    }
    let names = names.ok_or_else(|| {
        CoreError::file(
            path,
            "no header and no data rows (only comments or blank lines)",
        )
    })?;
    if wavelengths_nm.is_empty() {
        return Err(line_err(
            path,
            text.lines().count().max(1),
            "a header but no data rows",
        ));
    }
    let table = SpectraTable {
        wavelengths_nm,
        names,
        columns,
    };
    table.validate(&path.display().to_string())?;
    Ok(table)
}

/// Read a spectra CSV file (see the module docs). Errors name the file and line.
pub fn read_spectra_csv(path: impl AsRef<Path>) -> Result<SpectraTable> {
    let path = path.as_ref();
    let bytes = read_limited(path)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        // Report the line of the first bad byte.
        let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = good.iter().filter(|b| **b == b'\n').count() + 1;
        line_err(path, line, "not UTF-8 text")
    })?;
    parse_spectra_csv(&text, path)
}

/// Format a table as CSV text: optional `# ` comment lines, the header `wavelength_nm,<names>`, then
/// one row per wavelength. Numbers are written in Rust's shortest round-trip form, so reading the
/// text back gives the same f64 values.
pub fn format_spectra_csv(table: &SpectraTable, comments: &[&str]) -> Result<String> {
    table.validate("spectra table to write")?;
    let mut s = String::new();
    for c in comments {
        for l in c.lines() {
            s.push_str("# ");
            s.push_str(l);
            s.push('\n');
        }
    }
    s.push_str("wavelength_nm");
    for n in &table.names {
        s.push(',');
        s.push_str(n.trim());
    }
    s.push('\n');
    for (i, w) in table.wavelengths_nm.iter().enumerate() {
        s.push_str(&format!("{w}"));
        for c in &table.columns {
            s.push_str(&format!(",{}", c[i]));
        }
        s.push('\n');
    }
    Ok(s)
}

/// Read spectra from a file, choosing the format by extension: `.csv` (or `.txt`) as CSV,
/// `.mat` as an ISETCam MATLAB v5 spectral file ([`crate::mat::read_isetcam_spectra`]).
pub fn load_spectra(path: impl AsRef<Path>) -> Result<SpectraTable> {
    let path = path.as_ref();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "csv" | "txt" => read_spectra_csv(path),
        "mat" => crate::mat::read_isetcam_spectra(path),
        _ => Err(CoreError::file(
            path,
            format!("unknown spectra file type '{ext}': use .csv (wavelength_nm, columns) or .mat (ISETCam MATLAB v5)"),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn p() -> PathBuf {
        PathBuf::from("t.csv")
    }

    #[test]
    fn parses_comments_header_and_rows() {
        let t = parse_spectra_csv(
            "# c\n\nwavelength_nm, a ,b\r\n400,1,2\n# mid\n410,3,4\n",
            &p(),
        )
        .unwrap();
        assert_eq!(t.names, vec!["a", "b"]);
        assert_eq!(t.wavelengths_nm, vec![400.0, 410.0]);
        assert_eq!(t.columns, vec![vec![1.0, 3.0], vec![2.0, 4.0]]);
        assert_eq!(t.spectrum("B").unwrap().values, vec![2.0, 4.0]);
        let e = t.spectrum("c").unwrap_err().to_string();
        assert!(e.contains("a, b"), "{e}");
    }

    #[test]
    fn quoted_fields_comments_and_line_numbers() {
        // Quoted header names and numbers (as spreadsheets write them), an indented comment, a
        // comment line holding a quote and a comma, CRLF line ends.
        let text = "# exported, \"QE\"\r\n\"wavelength_nm\",\"r (QE)\",\"g\"\"x\"\"\"\r\n  # indented\r\n\"400\",0.1,\" 0.2 \"\r\n410,0.3,0.4\r\n";
        let t = parse_spectra_csv(text, &p()).unwrap();
        assert_eq!(t.names, vec!["r (QE)", "g\"x\""]);
        assert_eq!(t.wavelengths_nm, vec![400.0, 410.0]);
        assert_eq!(t.columns, vec![vec![0.1, 0.3], vec![0.2, 0.4]]);
        // Lines are counted in the file, comments and blank lines included.
        let e = parse_spectra_csv("# a\n\n\"w\",\"a\"\n# b\n400,1\n410,\"x,y\"\n", &p())
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("t.csv, line 6:") && e.contains("'x,y' is not a number"),
            "{e}"
        );
        // A quoted field may hold a comma, but a spectrum's name may not (the writer could not
        // write it back): a clear error, never a wrong table.
        let e = parse_spectra_csv("w,\"a,b\"\n400,1\n", &p())
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.csv") && e.contains("'a,b'"), "{e}");
        // An unterminated quote swallows the rest of the file: a ragged row, not a panic.
        let e = parse_spectra_csv("w,a\n400,\"1\n410,2\n", &p())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.csv, line 2:"), "{e}");
    }

    #[test]
    fn headerless_files_get_generated_names() {
        let t = parse_spectra_csv("400,1\n410,2\n", &p()).unwrap();
        assert_eq!(t.names, vec!["data_1"]);
        assert_eq!(t.wavelengths_nm, vec![400.0, 410.0]);
        assert_eq!(t.columns, vec![vec![1.0, 2.0]]);
    }

    #[test]
    fn parse_returns_exactly_the_numbers_written() {
        // Written as text by hand (not by our formatter): every value must come back bit for bit,
        // as Rust's float parser guarantees the nearest double to each decimal.
        let text = "wavelength_nm,q,t\n380.5,0.1,1e-300\n400,123456.789,-0.0\n412.25,0.30000000000000004,2.5E3\n";
        let t = parse_spectra_csv(text, &p()).unwrap();
        assert_eq!(t.wavelengths_nm, vec![380.5, 400.0, 412.25]);
        assert_eq!(t.columns[0], vec![0.1, 123456.789, 0.30000000000000004]);
        assert_eq!(t.columns[1][0].to_bits(), 1e-300f64.to_bits());
        assert_eq!(t.columns[1][2], 2500.0);
        // And our own writer round-trips every bit, awkward values included.
        let w: Vec<f64> = (0..7).map(|i| 400.0 + i as f64 * 10.0 / 3.0).collect();
        let c: Vec<f64> = (0..7).map(|i| (i as f64 * 0.7).sin() / 3.0).collect();
        let table = SpectraTable::new(w.clone(), vec!["s".into()], vec![c.clone()], "t").unwrap();
        let back =
            parse_spectra_csv(&format_spectra_csv(&table, &["a comment"]).unwrap(), &p()).unwrap();
        assert_eq!(back.wavelengths_nm, w);
        assert_eq!(back.columns[0], c);
    }

    #[test]
    fn errors_name_file_and_line() {
        let cases = [
            ("w,a\n400,1\n400,2\n", 3, "increase"),
            ("w,a\n400,1\n410,nan\n", 3, "finite"),
            ("w,a\n400,1\n410,1,2\n", 3, "ragged"),
            ("w,a\n400,1\n410,x\n", 3, "'x'"),
            ("w,a\n400,1\n\n\n410,x\n", 5, "'x'"),
            ("w,a,a\n400,1,1\n", 1, "twice"),
            ("w,a\n-1,1\n", 2, "positive"),
            ("w\n400\n", 1, "at least one"),
            ("# only\nw,a\n", 2, "no data"),
        ];
        for (text, line, what) in cases {
            let e = parse_spectra_csv(text, &p()).unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("t.csv, line {line}:")),
                "{text:?}: {e}"
            );
            assert!(e.contains(what), "{text:?}: {e}");
        }
        assert!(parse_spectra_csv("# x\n", &p())
            .unwrap_err()
            .to_string()
            .contains("t.csv"));
    }

    #[test]
    fn validate_rejects_bad_tables() {
        let ok = SpectraTable::new(
            vec![400.0, 410.0],
            vec!["a".into()],
            vec![vec![1.0, 2.0]],
            "t",
        );
        assert!(ok.is_ok());
        assert!(
            SpectraTable::new(vec![400.0, 410.0], vec!["a".into()], vec![vec![1.0]], "t").is_err()
        );
        assert!(SpectraTable::new(
            vec![400.0, 410.0],
            vec!["a,b".into()],
            vec![vec![1.0, 2.0]],
            "t"
        )
        .is_err());
        assert!(SpectraTable::new(
            vec![410.0, 400.0],
            vec!["a".into()],
            vec![vec![1.0, 2.0]],
            "t"
        )
        .is_err());
        assert!(SpectraTable::new(vec![400.0], vec![], vec![], "t").is_err());
    }

    #[test]
    fn load_spectra_rejects_unknown_extensions() {
        let e = load_spectra("x.xlsx").unwrap_err().to_string();
        assert!(e.contains("x.xlsx") && e.contains(".csv"), "{e}");
    }
}
