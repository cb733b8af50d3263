//! `camsim fit mtf` on the measured MTF of a real Pixel 4a (ISET/isetcornellbox
//! `pixel4a-measured-mtf-in-focus.csv`): the fit's figures of merit, its output files, and a bad
//! CSV refused with exit 2 and a message naming the file and line.

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_camsim");
const MEASURED: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/data/isetcornellbox/pixel4a-measured-mtf-in-focus.csv"
);

#[test]
fn fit_mtf_on_the_measured_pixel4a_curve() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fit");
    let plot = dir.path().join("plots/fit.png");
    let o = Command::new(BIN)
        .args(["fit", "mtf", "--measured", MEASURED, "--json", "--out"])
        .arg(&out)
        .arg("--plot")
        .arg(&plot)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    println!("{stderr}");
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rms = j["rms"].as_f64().unwrap();
    let (fit50, meas50) = (
        j["mtf50_fit_cyc_per_mm"].as_f64().unwrap(),
        j["mtf50_measured_cyc_per_mm"].as_f64().unwrap(),
    );
    assert!(rms <= 0.03, "RMS {rms}");
    assert!(
        (fit50 / meas50 - 1.0).abs() <= 0.05,
        "MTF50 {fit50} vs {meas50}"
    );
    // The measured MTF50 by hand: the file's points around 50 % (84.32, 52.85 %) and (90.14, 48.83 %).
    let by_hand = 84.32171995030909
        + (52.845646165670004 - 50.0) / (52.845646165670004 - 48.826117094848)
            * (90.1412868565307 - 84.32171995030909);
    assert!((meas50 - by_hand).abs() < 1e-9, "{meas50} vs {by_hand}");
    assert!(
        j["defocus_um"].as_f64().unwrap() > 0.0 && j["crosstalk_sigma_um"].as_f64().unwrap() > 0.0
    );
    // fit.json on disk is the printed one; mtf.csv holds every measured point (as a fraction).
    let on_disk: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("fit.json")).unwrap()).unwrap();
    assert_eq!(on_disk, j);
    let csv = std::fs::read_to_string(out.join("mtf.csv")).unwrap();
    let input_lines = std::fs::read_to_string(MEASURED).unwrap().lines().count();
    assert_eq!(csv.lines().count(), input_lines);
    let second: Vec<f64> = csv
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert!((second[1] - 0.9778142680803239).abs() < 1e-5, "{second:?}");
    let png = std::fs::read(&plot).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert!(!out.join("mtf_fit.png").exists(), "--plot moves the plot");
}

#[test]
fn fit_mtf_bad_csv_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad-mtf.csv");
    std::fs::write(
        &bad,
        "frequency_cy_per_mm,mtf_percent\n10,95\n20,oops\n30,70\n",
    )
    .unwrap();
    let o = Command::new(BIN)
        .args(["fit", "mtf", "--measured"])
        .arg(&bad)
        .arg("--out")
        .arg(dir.path().join("o"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(&format!("{}, line 3", bad.display())),
        "{stderr}"
    );
    assert!(
        !Path::new(&dir.path().join("o")).exists(),
        "no output folder for a failed run"
    );
    // A plot that is not a PNG is refused before any work.
    let o = Command::new(BIN)
        .args([
            "fit",
            "mtf",
            "--measured",
            MEASURED,
            "--plot",
            "fit.svg",
            "--out",
        ])
        .arg(dir.path().join("o"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--plot 'fit.svg'"));
}
