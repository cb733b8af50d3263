//! `camsim analyze emva`: the EMVA 1288 series analysis of camsim-pipeline, with a progress bar,
//! the summary table and the files (emva.json, ptc.png, snr.png) written atomically.

use crate::common::{self, say};
use anyhow::{Context, Result};
use camsim_analysis::emva::EmvaOptions;
use camsim_pipeline::emva::{analyze_series, MosaicFormat};

pub fn run(a: super::analyze::EmvaArgs) -> Result<()> {
    let pb = common::progress(0, "reading");
    let format = MosaicFormat {
        cfa: a.raw.cfa,
        black_dn: a.raw.black_dn,
        bits: a.raw.bits,
    };
    let series = analyze_series(
        &a.series,
        format,
        &EmvaOptions::default(),
        &|_, done, total| {
            pb.set_length(total);
            pb.set_position(done);
        },
    );
    pb.finish_and_clear();
    let series = series.with_context(|| format!("EMVA 1288 analysis of {}", a.series.display()))?;
    let staged = common::stage_out_dir_reading(&a.out, &[a.series.as_path()])?;
    let out = staged.path().to_path_buf();
    let json = series.to_json();
    camsim_io::atomic::write_json_atomic(&out.join("emva.json"), &json)?;
    series.write_plots(&out)?;
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
