//! The capture's PSNR and SSIM against its noise-free image (issue 42 item 7), through
//! `simulate` with the noise-free pass, against the closed form of shot noise.
//!
//! With only shot noise and quantization on, a pixel whose noise-free value is n DN above black
//! has variance K (n) + 1/12 DN^2 (Poisson: var e = mean e, times K^2; the rounding of a signal
//! spread over many DN adds 1/12). So the raw's MSE against the noise-free DN is the mean of
//! K n + 1/12 over the pixels, and PSNR = 10 log10((white - black)^2 / MSE). The MSE of 128 x 128
//! pixels has a relative standard error of sqrt(2 / 16384) = 1.1 %; the bound on it is 5 %.

use camsim_pipeline::{simulate, SimulateConfig, SimulateOptions};
use std::path::Path;

fn config(shot: bool) -> SimulateConfig {
    let text = format!(
        r#"
seed = 4
[scene]
kind = "uniform"
mean_luminance_cd_m2 = 100.0
rows = 16
cols = 16
[optics]
preset = "diffraction-limited"
[optics.config]
shading = "none"
[sensor]
preset = "pixel4a"
rows = 128
cols = 128
[sensor.config.noise]
shot = {shot}
read = false
dsnu = false
prnu = false
dark = false
quantization = true
[capture]
exposure_ms = 5.0
"#
    );
    SimulateConfig::from_toml_str(&text, Path::new(".")).unwrap()
}

#[test]
fn raw_psnr_against_the_noise_free_image_is_shot_noises_closed_form() {
    let opts = SimulateOptions {
        noise_free: true,
        ..Default::default()
    };
    let sim = simulate(&config(true), &opts, &|_, _, _| {}).unwrap();
    let raw = &sim.frames[0];
    let nf = &sim.noise_free_dn.as_ref().unwrap()[0];
    let black = raw.black_level_dn;
    let k = sim.config.sensor().unwrap().k_dn_per_e();
    let mse_want = nf
        .iter()
        .map(|n| k * (*n as f64 - black) + 1.0 / 12.0)
        .sum::<f64>()
        / nf.len() as f64;
    let q = sim.quality.expect("the noise-free pass gives the quality");
    let peak = raw.white_level_dn - black;
    let mse_got = peak * peak / 10f64.powf(q.raw.psnr_db / 10.0);
    assert!(
        (mse_got / mse_want - 1.0).abs() < 0.05,
        "raw MSE {mse_got:.3} DN^2 from PSNR {:.2} dB, shot noise gives {mse_want:.3}",
        q.raw.psnr_db
    );
    let ssim = q.raw.ssim.expect("a 64 x 64 frame has an SSIM");
    assert!(ssim > 0.0 && ssim < 1.0, "{ssim}");
    let p = q.preview.expect("an RGGB frame renders");
    assert!(
        p.psnr_db.is_finite() && p.ssim.is_some_and(|s| s < 1.0),
        "{p:?}"
    );
    // Written to run.json's results.
    let outputs = camsim_pipeline::OutputSet::parse("raw").unwrap();
    let rec = sim.metadata(&Default::default(), &outputs);
    assert_eq!(
        rec["results"]["quality"]["raw"]["psnr_db"].as_f64(),
        Some(q.raw.psnr_db)
    );

    // Without any noise the capture is its noise-free image but for the rounding to DN: MSE
    // 1/12 at most (a flat field's noise-free values all round the same way).
    let sim = simulate(&config(false), &opts, &|_, _, _| {}).unwrap();
    let q = sim.quality.unwrap();
    let mse = peak * peak / 10f64.powf(q.raw.psnr_db / 10.0);
    assert!(mse <= 0.25 + 1e-9, "noiseless MSE {mse}");
    // And none without the noise-free pass.
    let sim = simulate(&config(true), &SimulateOptions::default(), &|_, _, _| {}).unwrap();
    assert!(sim.quality.is_none());
}
