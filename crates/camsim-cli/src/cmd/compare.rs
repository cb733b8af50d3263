//! `camsim compare`: two cameras side by side (MTF, acutance, SNR, noise power spectrum,
//! CIEDE2000 per ColorChecker patch) with report.html, results.json and plots.

use crate::common::{self, say};
use anyhow::Result;
use camsim::validate::{CameraCompareOptions, CameraSpec};
use std::path::PathBuf;

/// Compare two cameras on the standard targets. Each camera (a sensor preset or TOML file, with an
/// optional pixel pitch, behind a lens) is simulated on a slanted edge (e-SFR of the demosaicked
/// luminance: MTF curves, MTF50 and the CPIQ acutance at a viewing condition), ISETCam's zone plate
/// (the demosaicked luminance's modulation against radial frequency in all orientations, plotted
/// beside the edge MTF, in cycles/mm), a uniform grey field
/// at the same exposure time for both (SNR per CFA channel, normalised noise power spectrum) and the
/// ColorChecker under D65 (bilinear demosaic, white balance, a colour matrix fitted on the patches,
/// CIEDE2000 per patch). Writes DIR/report.html, DIR/results.json and DIR/compare_*.png.
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim compare --out out/compare                                          pixel4a vs imx363 (corrected vs published QE)\n  camsim compare --a pixel4a --b pixel4a --pitch-b-um 2.8 --out out/compare-pitch   4x the pixel area\n  camsim compare --a pixel4a --b pixel4a-raw10 --size 64 --out out/compare-raw10"
)]
pub struct Args {
    /// First camera's sensor: a preset (`camsim presets sensor`) or a sensor TOML file.
    #[arg(long, default_value = "pixel4a")]
    pub a: String,
    /// Second camera's sensor: a preset or a sensor TOML file.
    #[arg(long, default_value = "imx363")]
    pub b: String,
    /// First camera's lens: a preset (`camsim presets optics`) or a lens TOML file.
    #[arg(long, default_value = "pixel4a")]
    pub lens_a: String,
    /// Second camera's lens.
    #[arg(long, default_value = "pixel4a")]
    pub lens_b: String,
    /// Pixel pitch of the first sensor, um (default: the sensor's own).
    #[arg(long, value_parser = common::positive_f64)]
    pub pitch_a_um: Option<f64>,
    /// Pixel pitch of the second sensor, um (default: the sensor's own).
    #[arg(long, value_parser = common::positive_f64)]
    pub pitch_b_um: Option<f64>,
    /// Side of the square sensor windows of the edge and the uniform field, pixels, 64 to 1024
    /// (the chart window is SIZE x 4/3 SIZE).
    #[arg(long, default_value_t = 128)]
    pub size: usize,
    /// Acutance viewing distance, m (the full sensor height shown --display-height-m high).
    #[arg(long, default_value_t = 0.4, value_parser = common::positive_f64)]
    pub viewing_distance_m: f64,
    /// Height of the shown picture for the acutance, m (0.1: a 4 x 6 inch print's short side).
    #[arg(long, default_value_t = 0.1, value_parser = common::positive_f64)]
    pub display_height_m: f64,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output folder.
    #[arg(long, default_value = "out/compare")]
    pub out: PathBuf,
}

pub fn run(a: Args) -> Result<()> {
    if !(64..=1024).contains(&a.size) {
        anyhow::bail!("--size {}: must be 64 to 1024 pixels", a.size);
    }
    let inputs: Vec<&std::path::Path> = [&a.a, &a.b, &a.lens_a, &a.lens_b]
        .iter()
        .map(|s| std::path::Path::new(s.as_str()))
        .collect();
    let staged = common::stage_out_dir_reading(&a.out, &inputs)?;
    let mut opts = CameraCompareOptions::new(
        CameraSpec {
            sensor: a.a.clone(),
            pixel_pitch_um: a.pitch_a_um,
            lens: a.lens_a.clone(),
        },
        CameraSpec {
            sensor: a.b.clone(),
            pixel_pitch_um: a.pitch_b_um,
            lens: a.lens_b.clone(),
        },
    );
    opts.size_px = a.size;
    opts.seed = a.seed;
    opts.viewing_distance_m = a.viewing_distance_m;
    opts.display_height_m = a.display_height_m;
    opts.out_dir = Some(staged.path().to_path_buf());
    opts.command_line = std::env::args().collect::<Vec<_>>().join(" ");
    let pb = common::progress(4, "compare");
    let r = camsim::validate::compare_cameras(&opts, &|stage, done, total| {
        pb.set_message(stage.to_string());
        pb.set_length(total.max(1));
        pb.set_position(done);
    })?;
    pb.finish_and_clear();
    common::commit(staged)?;
    for m in [&r.a, &r.b] {
        say(format!(
            "{}: MTF50 {} cy/px (zone plate {}), acutance {:.3}, SNR G {:.1} dB, CIEDE2000 mean {:.2}",
            m.label,
            m.mtf.mtf50_cy_per_px.map(|v| format!("{v:.3}")).unwrap_or_else(|| "-".into()),
            m.zone_plate.mtf50_cy_per_px.map(|v| format!("{v:.3}")).unwrap_or_else(|| "-".into()),
            m.mtf.acutance,
            m.noise.snr[1].snr_db,
            m.color.mean_delta_e2000
        ));
    }
    say(format!("report: {}", a.out.join("report.html").display()));
    Ok(())
}
