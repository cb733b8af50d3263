//! Sensor QE read from a file (`[qe] file = ...`): CSV and ISETCam sensor `.mat` (filterNames),
//! columns found by name, and the pixel4a correction M dropped when the QE table is replaced.

use camsim_sensor::{presets, Sensor};
use std::path::Path;

/// The pixel4a template (as `camsim presets sensor pixel4a` prints it) with its [qe] table
/// replaced by `qe_table`.
fn pixel4a_with_qe(qe_table: &str) -> String {
    let text = presets::toml("pixel4a").unwrap();
    let i = text.find("\n[qe]\n").expect("the preset has a [qe] table");
    format!("{}\n{qe_table}", &text[..i + 1])
}

fn write_sensor(dir: &Path, qe_table: &str) -> std::path::PathBuf {
    let p = dir.join("mine.toml");
    std::fs::write(&p, pixel4a_with_qe(qe_table)).unwrap();
    p
}

// A minimal MATLAB Level 5 MAT-file writer (uncompressed, little-endian), from the MathWorks
// "MAT-File Format" description: 128-byte header, then one miMATRIX element per variable holding
// array flags, dimensions, name and data sub-elements, each padded to 8 bytes.
fn element(data_type: u32, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend(data_type.to_le_bytes());
    out.extend((data.len() as u32).to_le_bytes());
    out.extend(data);
    while out.len() % 8 != 0 {
        out.push(0);
    }
    out
}

const MI_INT8: u32 = 1;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_DOUBLE: u32 = 9;
const MI_MATRIX: u32 = 14;
const MX_CELL: u32 = 1;
const MX_CHAR: u32 = 4;
const MX_DOUBLE: u32 = 6;

fn matrix(name: &str, class: u32, dims: &[usize], payload: Vec<u8>) -> Vec<u8> {
    let mut body = Vec::new();
    let mut flags = class.to_le_bytes().to_vec();
    flags.extend([0; 4]);
    body.extend(element(MI_UINT32, &flags));
    let d: Vec<u8> = dims
        .iter()
        .flat_map(|d| (*d as i32).to_le_bytes())
        .collect();
    body.extend(element(MI_INT32, &d));
    body.extend(element(MI_INT8, name.as_bytes()));
    body.extend(payload);
    let mut out = MI_MATRIX.to_le_bytes().to_vec();
    out.extend((body.len() as u32).to_le_bytes());
    out.extend(body);
    out
}

fn doubles(name: &str, rows: usize, cols: usize, column_major: &[f64]) -> Vec<u8> {
    let b: Vec<u8> = column_major.iter().flat_map(|x| x.to_le_bytes()).collect();
    matrix(name, MX_DOUBLE, &[rows, cols], element(MI_DOUBLE, &b))
}

fn chars(name: &str, s: &str) -> Vec<u8> {
    let b: Vec<u8> = s.encode_utf16().flat_map(|c| c.to_le_bytes()).collect();
    matrix(name, MX_CHAR, &[1, s.len()], element(MI_UINT16, &b))
}

fn mat_file(vars: &[Vec<u8>]) -> Vec<u8> {
    let mut out = vec![b' '; 116];
    out[..20].copy_from_slice(b"MATLAB 5.0 MAT-file ");
    out.extend([0u8; 8]);
    out.extend([0x00, 0x01, b'I', b'M']);
    for v in vars {
        out.extend(v);
    }
    out
}

#[test]
fn isetcam_sensor_mat_maps_filter_names_to_channels() {
    let dir = tempfile::tempdir().unwrap();
    // Three filters stored in the order b, g, r (ISETCam names: the first letter is the colour),
    // each a distinct constant so a wrong column shows at once.
    let wl = [400.0, 500.0, 600.0, 700.0];
    let (b, g, r) = (0.25, 0.5, 0.75);
    let mut data = Vec::new();
    for v in [b, g, r] {
        data.extend([v; 4]);
    }
    let mut cells = Vec::new();
    for n in ["bDefault", "gDefault", "rDefault"] {
        cells.extend(chars("", n));
    }
    let names = matrix("filterNames", MX_CELL, &[1, 3], cells);
    let bytes = mat_file(&[
        doubles("wavelength", 4, 1, &wl),
        doubles("data", 4, 3, &data),
        names,
        chars("comment", "test filters"),
    ]);
    std::fs::write(dir.path().join("filters.mat"), bytes).unwrap();
    let p = write_sensor(dir.path(), "[qe]\nfile = \"filters.mat\"\n");
    let s = Sensor::from_file(&p).unwrap();
    let q = &s.config().qe;
    assert_eq!(q.wavelengths_nm, wl);
    assert_eq!((q.r[0], q.g[0], q.b[0]), (r, g, b));
    assert!(q.loaded_from.as_deref().unwrap().ends_with("filters.mat"));
    assert_eq!(q.file, None);
    // No correction: the channel QE is the filter itself (ir_cut and pixel_qe absent = 1).
    assert_eq!(s.config().qe_correction, None);
    for (c, v) in [r, g, b].iter().enumerate() {
        assert_eq!(s.qe_spectrum(c).eval(550.0), *v);
    }
}

#[test]
fn csv_columns_are_found_by_name_and_the_pixel4a_correction_is_dropped() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("qe.csv"),
        "# ir first, colours in another order\nwavelength_nm,IR_filter,Green,r,b\n400,0.5,0.2,0.1,0.6\n700,0.25,0.3,0.9,0.05\n",
    )
    .unwrap();
    let p = write_sensor(dir.path(), "[qe]\nfile = \"qe.csv\"\n");
    let s = Sensor::from_file(&p).unwrap();
    let q = &s.config().qe;
    assert_eq!(q.r, vec![0.1, 0.9]);
    assert_eq!(q.g, vec![0.2, 0.3]);
    assert_eq!(q.b, vec![0.6, 0.05]);
    assert_eq!(q.ir_cut, Some(vec![0.5, 0.25]));
    assert_eq!(
        s.config().qe_correction,
        None,
        "the paper's M must not be applied to other QE"
    );
    // Channel QE = filter x IR cut, exactly (no M): r at 400 nm = 0.1 x 0.5.
    assert_eq!(s.qe_spectrum(0).eval(400.0), 0.1 * 0.5);
    // The preset itself still has M (it lives in its [qe] table) ...
    let p4a = Sensor::preset("pixel4a").unwrap();
    assert_eq!(
        p4a.config().qe_correction,
        Some([[0.532, 0.0, 0.0], [0.06, 0.70, 0.0], [0.0, 0.36, 0.84]])
    );
    // ... and a custom sensor keeps a correction only when it sets one explicitly.
    let text = pixel4a_with_qe("[qe]\nfile = \"qe.csv\"\ncorrection = [[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]\n");
    std::fs::write(&p, text).unwrap();
    let s = Sensor::from_file(&p).unwrap();
    assert_eq!(s.qe_spectrum(0).eval(400.0), 2.0 * 0.1 * 0.5);
    // The resolved config is self-contained: it round-trips through TOML without the file.
    let again = Sensor::from_toml_str(&s.to_toml(), "round trip").unwrap();
    assert_eq!(again.config(), s.config());
}

#[test]
fn bad_qe_files_are_errors_naming_the_file_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("wavelength_nm,r,b\n400,1,1\n700,1,1\n", "no 'g' column"),
        (
            "wavelength_nm,r,g,b,w\n400,1,1,1,1\n700,1,1,1,1\n",
            "column 'w'",
        ),
    ];
    for (csv, needle) in cases {
        std::fs::write(dir.path().join("qe.csv"), csv).unwrap();
        let p = write_sensor(dir.path(), "[qe]\nfile = \"qe.csv\"\n");
        let e = Sensor::from_file(&p).unwrap_err().to_string();
        assert!(e.contains("qe.csv") && e.contains(needle), "{e}");
    }
    // Both a file and inline curves.
    let p = write_sensor(
        dir.path(),
        "[qe]\nfile = \"qe.csv\"\nwavelengths_nm = [400.0]\nr = [1.0]\ng = [1.0]\nb = [1.0]\n",
    );
    let e = Sensor::from_file(&p).unwrap_err().to_string();
    assert!(e.contains("not both"), "{e}");
    // A missing file names itself.
    let p = write_sensor(dir.path(), "[qe]\nfile = \"nope.csv\"\n");
    let e = Sensor::from_file(&p).unwrap_err().to_string();
    assert!(e.contains("nope.csv"), "{e}");
    // M given twice.
    let text = pixel4a_with_qe("[qe]\nfile = \"qe.csv\"\ncorrection = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]\n")
        .replace("fixed_pattern_seed = 363", "fixed_pattern_seed = 363\nqe_correction = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]");
    std::fs::write(
        dir.path().join("qe.csv"),
        "wavelength_nm,r,g,b\n400,1,1,1\n700,1,1,1\n",
    )
    .unwrap();
    std::fs::write(&p, text).unwrap();
    let e = Sensor::from_file(&p).unwrap_err().to_string();
    assert!(e.contains("qe_correction") && e.contains("both"), "{e}");
}

#[test]
fn a_window_larger_than_the_sensor_is_refused() {
    let s = Sensor::preset("pixel4a").unwrap();
    let e = s.window(5000, 6000).unwrap_err().to_string();
    assert!(e.contains("3024 x 4032") && e.contains("rows"), "{e}");
    let e = s.window(100, 4033).unwrap_err().to_string();
    assert!(e.contains("cols") && e.contains("1..=4032"), "{e}");
    let w = s.window(3024, 4032).unwrap();
    assert_eq!((w.rows(), w.cols()), (3024, 4032));
    assert!(s.window(0, 10).is_err());
}
