//! Build step: the sRGB -> spectrum coefficient table (Jakob and Hanika 2019), computed here by
//! `src/rgb2spec.rs` from the CIE 1931 observer and D65 of `camsim-core` (its table file,
//! included as a module: a build script cannot use the crate itself), as pbrt-v4's build runs
//! its optimiser. The table (3 x 64^3 coefficient triples, f32 little-endian, 9.4 MB) goes to
//! `OUT_DIR/srgb_sigmoid_table.bin`, which `src/uplift.rs` includes. Deterministic: the same
//! bytes for any thread count. About 6 s of CPU at opt-level 3 (Cargo.toml compiles this
//! package, build script included, at opt-level 3 in every profile).

#[allow(dead_code)]
#[path = "src/rgb2spec.rs"]
mod rgb2spec;

#[allow(dead_code)]
#[path = "../camsim-core/src/tables/cie.rs"]
mod cie;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=src/rgb2spec.rs");
    println!("cargo:rerun-if-changed=../camsim-core/src/tables/cie.rs");
    // D65 from 360 nm (the table starts at 300 nm, 5 nm steps) to 830 nm.
    let skip = ((rgb2spec::LAMBDA_MIN_NM - cie::D65_START_NM) / 5.0).round() as usize;
    let mut d65: Vec<f64> = cie::D65[skip..].to_vec();
    d65.extend_from_slice(&rgb2spec::D65_785_830);
    assert_eq!(
        d65.len(),
        cie::CIE1931_Y_BAR.len(),
        "D65 must cover 360-830 nm"
    );
    assert_eq!(cie::CMF_START_NM, rgb2spec::LAMBDA_MIN_NM);
    let q = rgb2spec::Quadrature::new(&rgb2spec::ObserverTables {
        cmfs: [
            &cie::CIE1931_X_BAR,
            &cie::CIE1931_Y_BAR,
            &cie::CIE1931_Z_BAR,
        ],
        illuminant: &d65,
    });
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let table = rgb2spec::generate(&q, rgb2spec::RES, threads);
    let bytes: Vec<u8> = table
        .iter()
        .flat_map(|c| c.iter().flat_map(|v| v.to_le_bytes()))
        .collect();
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"))
        .join("srgb_sigmoid_table.bin");
    std::fs::write(&out, bytes).expect("write the coefficient table");
}
