//! `camsim unprocess`: an 8-bit sRGB photo -> a training raw DNG with a calibrated sensor's
//! noise (the inverse ISP of Brooks et al. 2019, through the application layer's
//! [`camsim::Isp::unprocess_photo`]).

use crate::common::say;
use anyhow::Result;
use camsim::core::WavelengthGrid;
use camsim::isp::WhiteBalanceMethod;
use camsim::Isp;
use std::path::PathBuf;

fn parse_white_balance(s: &str) -> std::result::Result<WhiteBalanceMethod, String> {
    match s.parse::<WhiteBalanceMethod>().map_err(|e| e.to_string())? {
        w @ (WhiteBalanceMethod::Illuminant | WhiteBalanceMethod::None) => Ok(w),
        _ => Err(format!(
            "'{s}': unprocessing takes illuminant or none (gray-world and white-patch fit their gains to a raw frame, which a photo does not carry)"
        )),
    }
}

fn parse_tone(s: &str) -> std::result::Result<camsim::isp::tone::ToneMap, String> {
    use camsim::isp::tone::ToneMap;
    match s {
        "clip" => Ok(ToneMap::Clip),
        "filmic" => Ok(ToneMap::Filmic),
        _ => Err(format!(
            "'{s}' is not one of clip, filmic (reinhard's white level is fitted per image and cannot be undone)"
        )),
    }
}

/// Turn an sRGB photo (PNG or JPEG, 8 bit) into a training raw: the inverse of the ISP that
/// would have made it as a preview (Brooks et al., "Unprocessing images for learned raw
/// denoising", CVPR 2019): sRGB decoding (IEC 61966-2-1), the inverse tone curve, the inverse of
/// the colour matrix fitted from --sensor's QE under --illuminant (white balance included), the
/// exposure scale, the mosaic of the sensor's CFA (r, g, b filters), then the sensor's temporal
/// noise: Poisson shot noise of the electrons (DN / conversion gain), its read noise, black
/// level, white level and ADC rounding, seeded by --seed (same seed, same bytes, any thread
/// count). Fixed patterns (DSNU, PRNU, defects) are not added. The raw has the photo's size and
/// goes through `camsim isp` with the same settings back to the photo within noise.
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim simulate --out out/photo\n  camsim unprocess --in out/photo/preview.png --sensor pixel4a --seed 1 --out out/photo-unprocessed.dng\n  camsim isp --in out/photo-unprocessed.dng --sensor pixel4a --out out/photo-back.png\n\nFor a preview camsim rendered, give the exposure scale `camsim isp --json` reports (\"exposure_scale\") as --exposure-scale to get the raw's own DN back; without it the photo's white lands at the sensor's saturation. The scale used is printed: `camsim isp --exposure-scale` with it renders the raw back to the photo."
)]
pub struct Args {
    /// The sRGB photo: PNG or JPEG, 8 bit (grey and RGBA images are converted, alpha dropped).
    #[arg(long = "in")]
    pub input: PathBuf,
    /// The sensor whose raw to make (its CFA, QE, conversion gain, read noise, levels and bit
    /// depth): preset or TOML file. Its CFA must have r, g, b filters only (Bayer, Quad Bayer).
    #[arg(long, default_value = "pixel4a")]
    pub sensor: String,
    /// Scene illuminant the preview's white balance and colour matrix assumed: built-in name or
    /// spectrum file.
    #[arg(long, default_value = "D65")]
    pub illuminant: String,
    /// The preview's white balance: illuminant (from --illuminant and the sensor QE) or none.
    #[arg(long, default_value = "illuminant", value_parser = parse_white_balance, value_name = "illuminant|none")]
    pub white_balance: WhiteBalanceMethod,
    /// The preview's tone curve: clip or filmic (ACES fit, Narkowicz 2016).
    #[arg(long, default_value = "clip", value_parser = parse_tone, value_name = "clip|filmic")]
    pub tone_map: camsim::isp::tone::ToneMap,
    /// The preview's exposure scale (linear sRGB = scale x matrix x camera DN above black; `camsim
    /// isp --json` reports it); default: the photo's white at the sensor's saturation.
    #[arg(long, value_parser = crate::common::positive_f64)]
    pub exposure_scale: Option<f64>,
    /// Exposure time written into the raw's metadata, ms.
    #[arg(long, default_value_t = 10.0, value_parser = crate::common::positive_f64)]
    pub exposure_ms: f64,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output raw: a 16-bit CFA DNG (the format `camsim simulate` writes).
    #[arg(long, default_value = "out/unprocessed.dng")]
    pub out: PathBuf,
    /// Overwrite --out even when camsim did not write it (a file camsim wrote, recognised by its
    /// signature, is replaced without this; anything else is refused).
    #[arg(long)]
    pub force: bool,
}

pub fn run(a: Args) -> Result<()> {
    let _claim = crate::common::claim_out_file(&a.out, a.force)?;
    let (rows, cols, data) = camsim::io::raster::read_png8_rgb(&a.input)?;
    let photo = camsim::Rgb8Image { rows, cols, data };
    let sensor = camsim::pipeline::load_sensor(&a.sensor)?;
    let illuminant = camsim::scene::load_illuminant(&a.illuminant, "--illuminant")?;
    let mut isp = Isp::new(illuminant, WavelengthGrid::default());
    isp.white_balance = a.white_balance;
    isp.tone_map = a.tone_map;
    isp.exposure_scale = a.exposure_scale;
    let (raw, inverse) = isp
        .unprocess_photo(&photo, &sensor, a.exposure_ms * 1e-3, a.seed)
        .map_err(|e| anyhow::anyhow!("--sensor {}: {e}", a.sensor))?;
    let description = format!(
        "camsim unprocess --in {} --sensor {} --illuminant {} --white-balance {} --tone-map {} --seed {}",
        a.input.display(),
        a.sensor,
        a.illuminant,
        a.white_balance.name(),
        a.tone_map.name(),
        a.seed
    );
    let meta = isp.dng_metadata(&sensor, Some(description))?;
    camsim::io::dng::write_dng(&a.out, &raw, &meta)?;
    say(format!(
        "wrote {} ({} x {}, CFA {}); exposure scale {:.6e} (`camsim isp --exposure-scale` with it renders the photo back)",
        a.out.display(),
        raw.cols,
        raw.rows,
        raw.cfa_layout().name(),
        inverse.exposure_scale
    ));
    Ok(())
}
