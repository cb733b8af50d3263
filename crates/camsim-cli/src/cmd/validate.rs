//! `camsim validate`: the paper's Cornell box validation, and the same comparison for your camera.

use crate::common::{self, say};
use anyhow::Result;
use std::path::PathBuf;

macro_rules! validate_examples {
    () => {
        concat!(
            "Examples:\n",
            "  camsim validate cornell-box --out out/report          (quick: seconds; with --quality paper\n",
            "                                                        the paper's 1008 x 756 at 256 spp: minutes)\n",
            "  camsim validate cornell-box --data ../shared/data/isetcornellbox --out out/data\n",
            "  camsim simulate examples/uniform.toml --out out/uniform   (4 raw frames)\n",
            "  camsim validate compare examples/compare-frames.toml --out out/compare"
        )
    };
}

/// Reproduce the paper's validation ("Validation of image systems simulation technology using a
/// Cornell Box", Lyu et al.) end to end: 3D Cornell box -> wavefront optics -> IMX363 / Pixel 4a
/// sensor -> bilinear demosaic -> the analyses. Writes DIR/report.html (self-contained, figures
/// embedded) and DIR/results.json: MTF at two focus settings (Figure 2), the QE correction fit
/// (Figure 3), the images (Figure 4), digital values along the gray series at three chart
/// positions (Figure 5), noise in three regions against the model (Figure 6), and provenance.
///
/// `camsim validate compare CONFIG.toml` compares your measured DNGs with simulated ones region by
/// region, as the paper did with its Pixel 4a images.
#[derive(clap::Args)]
#[command(
    after_help = concat!("(`camsim validate --help` also documents the compare config.)\n\n", validate_examples!()),
    after_long_help = concat!(
        "The compare config (TOML; relative paths are relative to the config file;\n",
        "unknown keys are errors):\n",
        "  simulated = \"out/sim\"\n",
        "      required: a simulated raw DNG, or a `camsim simulate` output folder\n",
        "      (its raw.dng)\n",
        "  measured = [\"IMG_1.dng\"]\n",
        "      required: one measured DNG (a string) or a list of DNGs of one scene\n",
        "  sensor = \"pixel4a\"\n",
        "      optional: sensor preset or sensor TOML file for the noise prediction\n",
        "      (absent: no prediction)\n",
        "  exposure_s = 0.01\n",
        "      optional: exposure time for the noise prediction (dark current), s;\n",
        "      default: the simulated frame's exposure\n",
        "  [[region]]\n",
        "      one table per region (at least one), each with all three keys:\n",
        "  name = \"gray patch\"\n",
        "      shown in the report\n",
        "  measured = [1510, 2010, 40, 40]\n",
        "      row, col, rows, cols in the measured image (pixels; row, col: the\n",
        "      top-left corner)\n",
        "  simulated = [1500, 2000, 40, 40]\n",
        "      the corresponding region in the simulated image (rows, cols >= 1)\n",
        "\n",
        "For every region and CFA channel the report gives mean and standard deviation\n",
        "(DN above black) in both images and the model's predicted standard deviation;\n",
        "several measured frames are averaged. Writes report.html, results.json,\n",
        "compare_means.png and compare_std.png.\n\n",
        validate_examples!()
    )
)]
pub struct Args {
    /// cornell-box, or compare (with CONFIG).
    pub what: String,
    /// For compare: the comparison config (TOML).
    pub config: Option<PathBuf>,
    /// quick (small images, few samples) or paper (full sensor resolution, smooth curves).
    #[arg(long, default_value = "quick")]
    pub quality: String,
    /// Folder with the measured Cornell box spectra (cboxIlluminant, cboxWalls) to use in place
    /// of the built-in ones.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Opt-in wall-clock limit per Cornell box render, s: each render stops after the first pass
    /// of 8 samples per pixel that ends past it, so the report then depends on the machine
    /// (results.json records the samples taken). Default: none; every render takes all its
    /// samples and the report is the same for a seed on any machine.
    #[arg(long, value_parser = crate::common::positive_f64)]
    pub render_time_budget_s: Option<f64>,
    /// Seed of the render and the sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output folder (report.html, results.json, figures).
    #[arg(long, default_value = "out/validate")]
    pub out: PathBuf,
}

pub fn run(a: Args) -> Result<()> {
    let inputs: Vec<&std::path::Path> = a.config.iter().map(|p| p.as_path()).collect();
    let staged = common::stage_out_dir_reading(&a.out, &inputs)?;
    let out = staged.path().to_path_buf();
    match a.what.as_str() {
        "cornell-box" => {
            let quality = match a.quality.as_str() {
                "quick" => camsim::validate::Quality::Quick,
                "paper" => camsim::validate::Quality::Paper,
                q => anyhow::bail!("--quality '{q}': use quick or paper"),
            };
            let opts = camsim::validate::ValidateOptions {
                quality,
                out_dir: out.clone(),
                data_dir: a.data.clone(),
                seed: a.seed,
                command_line: std::env::args().collect::<Vec<_>>().join(" "),
            };
            let mut params = camsim::validate::QualityParams::of(quality);
            params.box_time_budget_s = a.render_time_budget_s;
            let pb = common::progress(1, "validate");
            camsim::validate::cornell_box_with(&opts, params, &|stage, done, total| {
                pb.set_message(stage.to_string());
                pb.set_length(total.max(1));
                pb.set_position(done);
            })?;
            pb.finish_and_clear();
            say(format!("report: {}", a.out.join("report.html").display()));
        }
        "compare" => {
            let cfg_path = a
                .config
                .as_ref()
                .ok_or_else(|| anyhow::anyhow!("camsim validate compare needs a CONFIG.toml"))?;
            let cfg = camsim::validate::CompareConfig::from_file(cfg_path)?;
            camsim::validate::compare(&cfg, &out)?;
            say(format!("report: {}", a.out.join("report.html").display()));
        }
        w => anyhow::bail!("unknown validation '{w}': use cornell-box or compare"),
    }
    common::commit(staged)?;
    Ok(())
}
