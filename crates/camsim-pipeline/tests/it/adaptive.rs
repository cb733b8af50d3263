//! Adaptive sampling to the sensor's noise (issue 44), measured the way EMVA 1288 measures a
//! camera: a flat grey wall captured twice (independent renders and readouts), the temporal
//! noise from half the variance of the frames' difference. With `[render.adaptive]` it equals the
//! sensor model's temporal noise (shot, read, dark, quantization; the fixed pattern cancels in
//! the difference) within 5 %, though each render stopped as soon as its own noise was a fifth of
//! the sensor's; the same capture rendered with only the first test's samples is visibly noisier,
//! so the test would see adaptive sampling stopping too soon.

use camsim_pipeline::{simulate, SimulateConfig, SimulateOptions};

/// A wall filling the view, lit by a uniform sky. Independent samples: their sample variance is
/// the render's error (Sobol's is smaller than its sample variance says).
const SCENE: &str = r#"LookAt 0 0 3  0 0 0  0 1 0
Camera "perspective" "float fov" 30
Sampler "independent"
WorldBegin
LightSource "infinite" "rgb L" [0.6 0.6 0.6]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-9 -9 0  9 -9 0  9 9 0  -9 9 0] "integer indices" [0 1 2 0 2 3]
"#;

const N: usize = 64;

fn run(
    dir: &std::path::Path,
    seed: u64,
    exposure_ms: f64,
    render: &str,
) -> camsim_pipeline::Simulation {
    let pbrt = dir.join("wall.pbrt");
    std::fs::write(&pbrt, SCENE).unwrap();
    let text = format!(
        "seed = {seed}\n[render]\npbrt = \"{}\"\n{render}\n[sensor]\npreset = \"ar0132at-rgb\"\nrows = {N}\ncols = {N}\n[capture]\nexposure_ms = {exposure_ms}\n",
        pbrt.display()
    );
    let cfg = SimulateConfig::from_toml_str(&text, std::path::Path::new("")).unwrap();
    simulate(&cfg, &SimulateOptions::default(), &|_, _, _| {}).unwrap()
}

/// EMVA 1288 temporal noise of two frames over the central window, DN, and their mean DN above
/// black.
fn temporal_noise_dn(
    a: &camsim_pipeline::Simulation,
    b: &camsim_pipeline::Simulation,
) -> (f64, f64) {
    let (fa, fb) = (&a.frames[0], &b.frames[0]);
    let m = 4;
    let (mut s, mut s2, mut sum, mut n) = (0f64, 0f64, 0f64, 0f64);
    for r in m..N - m {
        for c in m..N - m {
            let (x, y) = (fa.dn[r * N + c] as f64, fb.dn[r * N + c] as f64);
            s += x - y;
            s2 += (x - y) * (x - y);
            sum += x + y;
            n += 1.0;
        }
    }
    let var_diff = (s2 - s * s / n) / (n - 1.0);
    ((var_diff / 2.0).sqrt(), sum / (2.0 * n) - fa.black_level_dn)
}

#[test]
fn adaptive_renders_leave_the_raw_with_the_sensor_model_temporal_noise() {
    let dir = tempfile::tempdir().unwrap();
    // An exposure that puts about 300 e- in the green pixels (read noise 9 e-).
    let probe = run(dir.path(), 1, 1.0, "samples_per_pixel = 8");
    let exposure_ms = 300.0 / probe.mean_electrons_rgb[1];
    let sensor = SimulateConfig::from_toml_str(
        &format!("[sensor]\npreset = \"ar0132at-rgb\"\nrows = {N}\ncols = {N}\n[scene]\nkind = \"uniform\"\n"),
        std::path::Path::new(""),
    )
    .unwrap()
    .sensor()
    .unwrap();
    let predicted = |mean_dn: f64| {
        let p = sensor.predicted_noise_dn(mean_dn, exposure_ms * 1e-3);
        (p.shot.powi(2) + p.read.powi(2) + p.dark.powi(2) + p.quantization.powi(2)).sqrt()
    };

    let adaptive =
        "samples_per_pixel = 4096\n[render.adaptive]\nnoise_fraction = 0.2\nmin_samples = 16";
    let (a, b) = (
        run(dir.path(), 11, exposure_ms, adaptive),
        run(dir.path(), 12, exposure_ms, adaptive),
    );
    let (sigma, mean) = temporal_noise_dn(&a, &b);
    let model = predicted(mean);
    let samples = a.render_samples.clone().unwrap();
    assert!(
        (sigma / model - 1.0).abs() < 0.05,
        "adaptive: temporal noise {sigma:.2} DN against the model's {model:.2} DN at {mean:.0} DN ({} .. {} spp, mean {:.0})",
        samples.min_per_pixel,
        samples.max_per_pixel,
        samples.mean_per_pixel
    );
    assert!(samples.mean_per_pixel < 4096.0 && samples.min_per_pixel >= 16);
    assert_eq!(samples.adaptive.as_ref().unwrap().channel_unit, "electrons");
    assert_eq!(
        samples.at_most_share, 0.0,
        "no pixel needed all 4096 samples"
    );
    // Capped below what the target needs, the record says most pixels took all they could.
    let capped = run(
        dir.path(),
        11,
        exposure_ms,
        "samples_per_pixel = 32\n[render.adaptive]\nmin_samples = 16",
    );
    let share = capped.render_samples.unwrap().at_most_share;
    assert!(share > 0.5, "capped at 32 spp: {share}");

    // The first test's samples alone: the render's noise shows in the raw.
    let fixed = "samples_per_pixel = 16";
    let (c, d) = (
        run(dir.path(), 11, exposure_ms, fixed),
        run(dir.path(), 12, exposure_ms, fixed),
    );
    let (sigma16, mean16) = temporal_noise_dn(&c, &d);
    assert!(
        sigma16 > 1.1 * predicted(mean16),
        "16 spp: {sigma16:.2} DN against the model's {:.2} DN",
        predicted(mean16)
    );
}
