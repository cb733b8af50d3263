//! `camsim analyze emva`: the EMVA 1288 series analysis of `camsim::pipeline::measure::emva`,
//! with a progress bar, the summary table and the files (emva.json, ptc.png, snr.png).

use crate::cmd::args::RawInput;
use crate::common::{self, say};
use anyhow::{Context, Result};
use camsim::analysis::emva::EmvaOptions;
use camsim::pipeline::measure::emva::analyze_series;
use std::path::PathBuf;

/// EMVA 1288 (release 4.0) photon-transfer characterization of a series of flat-field and dark
/// frame pairs at increasing exposure, per colour channel: system gain K (DN/e-), temporal dark
/// noise, DSNU, PRNU, saturation capacity, dark current, QE (when the photon count is known), SNR
/// curve and dynamic range. Writes, in --out: emva.json (every figure, per channel and per level),
/// ptc.png (photon transfer) and snr.png.
///
/// The series is a CSV with one level per line: a header `exposure_s,photons_per_pixel,`, an
/// optional `exposure_lux_s,` (the photometric exposure H = E t at the sensor, for ISO 12232's
/// speeds), then the frame columns, `bright_0,...,bright_<N-1>,dark_0,...,dark_<N-1>` for N frames
/// per level (any column whose name starts with `bright` or `dark` is a frame), e.g. with
/// --frames-per-level 2: `exposure_s,photons_per_pixel,exposure_lux_s,bright_0,bright_1,dark_0,dark_1`.
/// This is what
/// `camsim sensor --emva-series` writes (series.csv); for a real camera, write it yourself. Frame
/// cells are DNG (or PNG/TIFF mosaic, with --cfa) file names relative to the CSV; an empty
/// photons_per_pixel cell means the photon count is unknown (no QE then).
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim sensor --emva-series --sensor imx363 --rows 64 --cols 64 --levels 12 --out out/emva\n  camsim analyze emva out/emva/series.csv --out out/emva-report"
)]
pub struct EmvaArgs {
    /// The series CSV (header `exposure_s,photons_per_pixel,bright_0,...,dark_0,...`).
    pub series: PathBuf,
    #[command(flatten)]
    pub raw: RawInput,
    /// Also print emva.json on stdout.
    #[arg(long)]
    pub json: bool,
    /// Output folder for emva.json, ptc.png and snr.png (created if missing).
    #[arg(long, default_value = "out/emva-report")]
    pub out: PathBuf,
}

pub fn run(a: EmvaArgs) -> Result<()> {
    let pb = common::progress(0, "reading");
    let series = analyze_series(
        &a.series,
        a.raw.format(),
        &EmvaOptions::default(),
        &|_, done, total| {
            pb.set_length(total);
            pb.set_position(done);
        },
    );
    pb.finish_and_clear();
    let series = series.with_context(|| format!("EMVA 1288 analysis of {}", a.series.display()))?;
    let staged = common::stage_out_dir_reading(&a.out, &[a.series.as_path()])?;
    let json = series.write_files(staged.path())?;
    if a.json {
        // A closed pipe (`| head`) is not an error of the analysis.
        use std::io::Write as _;
        let _ = writeln!(
            std::io::stdout().lock(),
            "{}",
            serde_json::to_string_pretty(&json)?
        );
    }
    say(series.summary());
    for ch in series.unsaturated_channels() {
        say(format!(
            "warning: channel {}: the temporal variance still grows at the brightest level, so the series does not reach saturation; its saturation, dynamic range and PRNU level are not meaningful (extend the exposures or use light this channel sees)",
            ch.letter()
        ));
    }
    say(format!(
        "{} levels -> {}",
        series.levels.len(),
        a.out.join("emva.json").display()
    ));
    common::commit(staged)?;
    Ok(())
}
