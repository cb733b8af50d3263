//! Spectra CSV files written by camsim-io: exact round trips of the reference data through
//! camsim-core's reader, comment lines, and concurrent writers of one file (each write complete,
//! no temporary left, ordinary permissions).

use camsim_core::mat::read_isetcam_file;
use camsim_core::spectrum_csv::{read_spectra_csv, SpectraTable};
use camsim_io::spectra::{write_spectra_csv, write_spectra_csv_with_comments};
use std::path::{Path, PathBuf};

fn data(rel: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data")).join(rel)
}

#[test]
fn csv_round_trips_exactly() {
    let dir = tempfile::tempdir().unwrap();
    for rel in [
        "imx363_qe.csv",
        "cornell_box_spectra.csv",
        "isetcornellbox/cboxWalls.csv",
    ] {
        let t = read_spectra_csv(data(rel)).unwrap();
        let out = dir.path().join("out.csv");
        write_spectra_csv(&out, &t).unwrap();
        assert_eq!(read_spectra_csv(&out).unwrap(), t, "{rel}");
    }
    // Full-precision doubles from the MAT file survive CSV exactly (shortest round-trip output).
    let t = read_isetcam_file(data("isetcornellbox/cboxSurfaces.mat"))
        .unwrap()
        .table;
    let out = dir.path().join("surf.csv");
    write_spectra_csv_with_comments(&out, &t, &["from cboxSurfaces.mat", "relative"]).unwrap();
    assert_eq!(read_spectra_csv(&out).unwrap(), t);
    assert!(std::fs::read_to_string(&out)
        .unwrap()
        .starts_with("# from cboxSurfaces.mat\n# relative\nwavelength_nm,"));
    // No temporary file is left behind.
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left.len(), 2, "{left:?}");
}

#[test]
fn concurrent_writers_of_one_file_never_share_a_temporary() {
    // Threads of one process writing the same file: each write is complete and atomic (the old
    // temporary name `.<name>.tmp-<pid>` was shared by all threads of the process).
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("same.csv");
    let tables: Vec<SpectraTable> = (0..8)
        .map(|k| {
            let w: Vec<f64> = (0..200).map(|i| 380.0 + i as f64).collect();
            let c: Vec<f64> = (0..200).map(|i| (k * 1000 + i) as f64).collect();
            SpectraTable::new(w, vec![format!("t{k}")], vec![c], "t").unwrap()
        })
        .collect();
    std::thread::scope(|s| {
        for t in &tables {
            let out = &out;
            s.spawn(move || {
                for _ in 0..20 {
                    write_spectra_csv(out, t).unwrap();
                }
            });
        }
    });
    let back = read_spectra_csv(&out).unwrap();
    assert!(tables.contains(&back));
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "temporary files left"
    );
    #[cfg(unix)]
    {
        // An ordinary output file (File::create's 0o666 less the umask), not a private temporary.
        use std::os::unix::fs::PermissionsExt;
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        let plain = dir.path().join("plain.txt");
        std::fs::File::create(&plain).unwrap();
        assert_eq!(mode(&out), mode(&plain), "{:o}", mode(&out));
    }
}

#[test]
fn writing_an_invalid_table_fails_without_creating_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bad.csv");
    let t = SpectraTable {
        wavelengths_nm: vec![400.0, 410.0],
        names: vec!["a".into()],
        columns: vec![vec![1.0, f64::NAN]],
    };
    let e = write_spectra_csv(&out, &t).unwrap_err().to_string();
    assert!(e.contains("bad.csv") && e.contains("finite"), "{e}");
    assert!(!out.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}
