//! Spectrum files: the CSV and ISETCam MAT readers on the reference data in shared/data, round
//! trips, both MAT byte orders, small data elements, and malformed input (never a panic).

use camsim_core::mat::{
    parse_mat_bytes, read_isetcam_file, read_mat_variables, MatClass, MatValue, MatVariable,
};
use camsim_core::spectrum_csv::{load_spectra, read_spectra_csv};
use proptest::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};

fn data(rel: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data")).join(rel)
}

const TWINS: [&str; 5] = [
    "BoxLampSPD",
    "cboxIlluminant",
    "cboxSurfaces",
    "cboxWalls",
    "p4aCorrected",
];

#[test]
fn reads_the_reference_csv_files() {
    let qe = read_spectra_csv(data("imx363_qe.csv")).unwrap();
    assert_eq!(qe.names, vec!["r", "g", "b", "ir_filter"]);
    assert_eq!(qe.wavelengths_nm.first(), Some(&390.0));
    assert_eq!(qe.wavelengths_nm.last(), Some(&710.0));
    assert_eq!(qe.wavelengths_nm.len(), 33); // 390-710 nm every 10 nm (README)
    assert_eq!(qe.spectrum("r").unwrap().values[0], 0.105156); // first data row of the file
    assert!(qe
        .grid()
        .unwrap()
        .same_as(&camsim_core::WavelengthGrid::new(390.0, 710.0, 10.0).unwrap()));

    let cb = read_spectra_csv(data("cornell_box_spectra.csv")).unwrap();
    assert_eq!(cb.names, vec!["white", "green", "red"]);
    assert_eq!(cb.wavelengths_nm.len(), 76); // 400-700 nm every 4 nm
    assert_eq!(cb.spectrum("white").unwrap().values[0], 0.343);

    for (name, n, cols) in [
        ("BoxLampSPD", 81, 1),
        ("cboxIlluminant", 81, 1),
        ("cboxSurfaces", 81, 3),
        ("cboxWalls", 81, 3),
        ("p4aCorrected", 33, 3),
    ] {
        let t = read_spectra_csv(data(&format!("isetcornellbox/{name}.csv"))).unwrap();
        assert_eq!((t.wavelengths_nm.len(), t.len()), (n, cols), "{name}");
        t.grid().unwrap();
    }
}

#[test]
fn every_isetcornellbox_mat_matches_its_csv_twin() {
    // The CSV twins were written with 6 significant digits (%g), so they agree with the MAT
    // file's doubles to half a unit in the 6th digit: |mat - csv| <= 5e-6 |mat|.
    for name in TWINS {
        let mat_path = data(&format!("isetcornellbox/{name}.mat"));
        let csv = read_spectra_csv(data(&format!("isetcornellbox/{name}.csv"))).unwrap();
        let f = read_isetcam_file(&mat_path).unwrap();
        let mat = &f.table;
        assert_eq!(
            mat.wavelengths_nm, csv.wavelengths_nm,
            "{name}: wavelengths"
        );
        assert_eq!(mat.len(), csv.len(), "{name}: columns");
        let mut worst = 0.0f64;
        for (cm, cc) in mat.columns.iter().zip(&csv.columns) {
            for (a, b) in cm.iter().zip(cc) {
                let rel = (a - b).abs() / a.abs().max(1e-300);
                worst = worst.max(rel);
                assert!(
                    (a - b).abs() <= 5e-6 * a.abs() + 1e-15,
                    "{name}: mat {a} vs csv {b}"
                );
            }
        }
        assert!(
            worst > 0.0 || name == "none",
            "{name}: identical to the last bit is unexpected for %g output"
        );
        // The comment is the one the CSV quotes.
        let text = std::fs::read_to_string(data(&format!("isetcornellbox/{name}.csv"))).unwrap();
        let quoted = text
            .lines()
            .find_map(|l| l.strip_prefix("# comment in file: "))
            .unwrap();
        assert_eq!(f.comment.as_deref(), Some(quoted), "{name}");
        // filterNames where the file has them (p4aCorrected: r, g, b as in the CSV header).
        if name == "p4aCorrected" {
            assert_eq!(mat.names, csv.names);
        } else {
            assert_eq!(mat.names[0], "data_1");
        }
        // load_spectra dispatches on the extension.
        assert_eq!(&load_spectra(&mat_path).unwrap(), mat);
    }
}

#[test]
fn mat_variables_have_their_matlab_classes() {
    let vars = read_mat_variables(data("isetcornellbox/p4aCorrected.mat")).unwrap();
    let names: Vec<&str> = vars.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names, vec!["wavelength", "data", "filterNames", "comment"]);
    match &vars[0].value {
        MatValue::Numeric {
            class, dims, real, ..
        } => {
            // A double array that MATLAB stored compactly as miUINT16 data (its integer values fit).
            assert_eq!(*class, MatClass::Double);
            assert_eq!(dims, &vec![33, 1]);
            assert_eq!(real[0], 390.0);
        }
        v => panic!("wavelength: {v:?}"),
    }
    assert_eq!(vars[1].value.dims(), &[33, 3]);
    assert_eq!(vars[2].value.as_strings().unwrap(), vec!["r", "g", "b"]);
    assert_eq!(
        vars[3].value.as_string().unwrap(),
        "sensor QE calibration for p4a"
    );
}

#[test]
fn csv_errors_name_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("ragged.csv");
    std::fs::write(&p, "# c\nwavelength_nm,a,b\n400,1,2\n410,1\n").unwrap();
    let e = read_spectra_csv(&p).unwrap_err().to_string();
    assert!(e.contains("ragged.csv, line 4"), "{e}");
    let e = read_spectra_csv(dir.path().join("missing.csv"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing.csv"), "{e}");
    let p = dir.path().join("bin.csv");
    std::fs::write(&p, b"w,a\n400,1\n\xff\xfe\n").unwrap();
    let e = read_spectra_csv(&p).unwrap_err().to_string();
    assert!(e.contains("bin.csv, line 3") && e.contains("UTF-8"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// A minimal Level 5 MAT writer for tests, written from the MathWorks format description: it can
// write either byte order, compressed or not, and uses small data elements for <= 4 bytes as
// MATLAB does. Used to check the reader on big-endian and uncompressed layouts.

struct Enc {
    big: bool,
}

impl Enc {
    fn u32(&self, v: u32) -> [u8; 4] {
        if self.big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        }
    }
    fn element(&self, data_type: u32, data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        if data.len() <= 4 && !data.is_empty() {
            out.extend(self.u32(((data.len() as u32) << 16) | data_type));
            let mut d = data.to_vec();
            d.resize(4, 0);
            out.extend(d);
        } else {
            out.extend(self.u32(data_type));
            out.extend(self.u32(data.len() as u32));
            out.extend(data);
            while out.len() % 8 != 0 {
                out.push(0);
            }
        }
        out
    }
    fn matrix(&self, name: &str, v: &MatValue) -> Vec<u8> {
        let (class, dims): (u32, &[usize]) = match v {
            MatValue::Numeric { class, dims, .. } => {
                (if *class == MatClass::UInt16 { 11 } else { 6 }, dims)
            }
            MatValue::Char { dims, .. } => (4, dims),
            MatValue::Cell { dims, .. } => (1, dims),
            _ => panic!("test encoder: unsupported"),
        };
        let mut body = Vec::new();
        let mut flags = self.u32(class).to_vec();
        flags.extend([0; 4]);
        body.extend(self.element(6, &flags));
        let d: Vec<u8> = dims.iter().flat_map(|d| self.u32(*d as u32)).collect();
        body.extend(self.element(5, &d));
        body.extend(self.element(1, name.as_bytes()));
        match v {
            MatValue::Numeric { class, real, .. } => {
                if *class == MatClass::UInt16 {
                    let b: Vec<u8> = real
                        .iter()
                        .flat_map(|x| {
                            if self.big {
                                (*x as u16).to_be_bytes()
                            } else {
                                (*x as u16).to_le_bytes()
                            }
                        })
                        .collect();
                    body.extend(self.element(4, &b));
                } else {
                    let b: Vec<u8> = real
                        .iter()
                        .flat_map(|x| {
                            if self.big {
                                x.to_be_bytes()
                            } else {
                                x.to_le_bytes()
                            }
                        })
                        .collect();
                    body.extend(self.element(9, &b));
                }
            }
            MatValue::Char { chars, .. } => {
                let b: Vec<u8> = chars
                    .iter()
                    .flat_map(|c| {
                        if self.big {
                            (*c as u16).to_be_bytes()
                        } else {
                            (*c as u16).to_le_bytes()
                        }
                    })
                    .collect();
                body.extend(self.element(4, &b));
            }
            MatValue::Cell { cells, .. } => {
                for c in cells {
                    body.extend(self.matrix("", c));
                }
            }
            _ => unreachable!(),
        }
        let mut out = Vec::new();
        out.extend(self.u32(14));
        out.extend(self.u32(body.len() as u32));
        out.extend(body);
        out
    }
    fn file(&self, vars: &[MatVariable], compress: bool) -> Vec<u8> {
        let mut out = vec![b' '; 116];
        out[..20].copy_from_slice(b"MATLAB 5.0 MAT-file ");
        out.extend([0u8; 8]);
        if self.big {
            out.extend([0x01, 0x00, b'M', b'I']);
        } else {
            out.extend([0x00, 0x01, b'I', b'M']);
        }
        for v in vars {
            let m = self.matrix(&v.name, &v.value);
            if compress {
                let mut z =
                    flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
                z.write_all(&m).unwrap();
                let z = z.finish().unwrap();
                out.extend(self.u32(15));
                out.extend(self.u32(z.len() as u32));
                out.extend(z);
            } else {
                out.extend(m);
            }
        }
        out
    }
}

#[test]
fn both_byte_orders_compressed_or_not_give_the_same_variables() {
    for name in TWINS {
        let path = data(&format!("isetcornellbox/{name}.mat"));
        let vars = read_mat_variables(&path).unwrap();
        // dFormat etc. are char arrays; all are encodable.
        for big in [false, true] {
            for compress in [false, true] {
                let bytes = Enc { big }.file(&vars, compress);
                let back = parse_mat_bytes(&bytes, Path::new("enc.mat")).unwrap();
                assert_eq!(back, vars, "{name} big={big} compressed={compress}");
            }
        }
    }
}

#[test]
fn small_data_elements_are_read() {
    // A 1x1 uint16 (2 bytes) and a 1x2 char (4 bytes) both fit the small-element format; the
    // name "w" too.
    let vars = vec![
        MatVariable {
            name: "w".into(),
            global: false,
            value: MatValue::Numeric {
                class: MatClass::UInt16,
                dims: vec![1, 1],
                real: vec![555.0],
                imag: None,
                logical: false,
            },
        },
        MatVariable {
            name: "c".into(),
            global: false,
            value: MatValue::Char {
                dims: vec![1, 2],
                chars: vec!['o', 'k'],
            },
        },
    ];
    for big in [false, true] {
        let bytes = Enc { big }.file(&vars, false);
        // Check the encoder did use the small format for the uint16 value: tag with 2 << 16.
        let tag = Enc { big }.u32((2 << 16) | 4);
        assert!(bytes.windows(4).any(|w| w == tag));
        assert_eq!(parse_mat_bytes(&bytes, Path::new("s.mat")).unwrap(), vars);
    }
}

#[test]
fn isetcam_data_stored_transposed_is_accepted_and_bad_shapes_are_named() {
    let w = MatVariable {
        name: "wavelength".into(),
        global: false,
        value: MatValue::Numeric {
            class: MatClass::Double,
            dims: vec![1, 3],
            real: vec![400.0, 500.0, 600.0],
            imag: None,
            logical: false,
        },
    };
    // data as 2 spectra x 3 wavelengths, column-major.
    let d = MatVariable {
        name: "data".into(),
        global: false,
        value: MatValue::Numeric {
            class: MatClass::Double,
            dims: vec![2, 3],
            real: vec![1.0, 10.0, 2.0, 20.0, 3.0, 30.0],
            imag: None,
            logical: false,
        },
    };
    let p = Path::new("t.mat");
    let f = camsim_core::mat::isetcam_spectra_from_variables(&[w.clone(), d], p).unwrap();
    assert_eq!(
        f.table.columns,
        vec![vec![1.0, 2.0, 3.0], vec![10.0, 20.0, 30.0]]
    );
    let bad = MatVariable {
        name: "data".into(),
        global: false,
        value: MatValue::Numeric {
            class: MatClass::Double,
            dims: vec![2, 2],
            real: vec![1.0; 4],
            imag: None,
            logical: false,
        },
    };
    let e = camsim_core::mat::isetcam_spectra_from_variables(&[w.clone(), bad], p)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("t.mat") && e.contains("2 x 2") && e.contains("3 wavelengths"),
        "{e}"
    );
    let e = camsim_core::mat::isetcam_spectra_from_variables(&[w], p)
        .unwrap_err()
        .to_string();
    assert!(e.contains("'data'"), "{e}");
}

#[test]
fn every_truncation_of_a_real_file_is_an_error_not_a_panic() {
    for name in TWINS {
        let bytes = std::fs::read(data(&format!("isetcornellbox/{name}.mat"))).unwrap();
        let vars = parse_mat_bytes(&bytes, Path::new("x.mat")).unwrap();
        let plain = Enc { big: true }.file(&vars, false);
        for src in [&bytes, &plain] {
            for len in 0..src.len() {
                let r = parse_mat_bytes(&src[..len], Path::new("cut.mat"));
                if let Err(e) = r {
                    assert!(e.to_string().starts_with("cut.mat: "), "{e}");
                } else {
                    // Cutting exactly between variables leaves a shorter valid file.
                    assert!(
                        r.unwrap().len() < vars.len(),
                        "{name}: cut at {len} still parsed fully"
                    );
                }
            }
        }
    }
}

fn corpus() -> &'static [Vec<u8>] {
    static CORPUS: std::sync::OnceLock<Vec<Vec<u8>>> = std::sync::OnceLock::new();
    CORPUS.get_or_init(build_corpus)
}

fn build_corpus() -> Vec<Vec<u8>> {
    let mut c = Vec::new();
    for name in TWINS {
        let bytes = std::fs::read(data(&format!("isetcornellbox/{name}.mat"))).unwrap();
        let vars = parse_mat_bytes(&bytes, Path::new("x.mat")).unwrap();
        c.push(Enc { big: false }.file(&vars, false));
        c.push(Enc { big: true }.file(&vars, false));
        c.push(bytes);
    }
    c
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600), header in any::<bool>()) {
        let mut b = bytes;
        if header && b.len() >= 128 {
            b[124..128].copy_from_slice(&[0, 1, b'I', b'M']);
        }
        let _ = parse_mat_bytes(&b, Path::new("r.mat"));
    }

    #[test]
    fn corrupted_real_files_never_panic(which in 0usize..15, edits in proptest::collection::vec((any::<u16>(), any::<u8>()), 1..8), cut in any::<u16>()) {
        let corpus = corpus();
        let mut b = corpus[which].clone();
        for (pos, val) in edits {
            let i = 128 + (pos as usize) % (b.len() - 128);
            b[i] = val;
        }
        let len = b.len() - (cut as usize % 16);
        let r = parse_mat_bytes(&b[..len], Path::new("c.mat"));
        if let Err(e) = r {
            prop_assert!(e.to_string().starts_with("c.mat: "));
        }
    }
}
