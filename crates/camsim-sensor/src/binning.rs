//! Pixel binning: `[binning]` of a sensor config reads k x k blocks of photodiodes as one output
//! pixel, either by summing their charge before one readout (**charge** binning: a shared floating
//! diffusion, CCD horizontal-register binning) or by reading each photodiode and summing the k^2
//! digital values on chip (**digital** binning). Both give an output grid of rows / k x cols / k
//! pixels of pitch k p holding k^2 times one photodiode's signal; they differ in their noise and
//! their well, which is the point of modelling them (ISETCam `binSensorCompute`; Nakamura, *Image
//! Sensors and Signal Processing for Digital Still Cameras*, 2006, section 5.4).
//!
//! A binned sensor is the sensor of its output pixels, with these values (k^2 photodiodes of
//! pitch p, conversion gain g, swing S, read noise s_r, DSNU d, PRNU u, dark voltage rate D, ADC
//! step q = S / 2^bits, analog gain a):
//!
//! | value             | charge binning            | digital binning (sum of k^2 reads)      |
//! |-------------------|---------------------------|-----------------------------------------|
//! | pitch             | k p                       | k p                                     |
//! | conversion gain   | g (or the readout's g')   | g                                       |
//! | swing (well)      | S: one readout, S / g e-  | k^2 S: each photodiode its own well     |
//! | ADC bits          | bits                      | bits + log2 k^2 (the step q kept)       |
//! | read noise        | s_r (one readout)         | sqrt(k^2 s_r^2 + (k^2 - 1) (a q)^2 / 12) |
//! | DSNU              | d (one readout)           | k d (k^2 independent offsets)           |
//! | PRNU              | u / k                     | u / k (the mean of k^2 gains)           |
//! | dark voltage rate | k^2 D g' / g              | k^2 D                                   |
//!
//! The variance of a sum of independent terms is the sum of their variances, which gives every
//! row. The digital sum's k^2 roundings (each uniform, variance q^2 / 12) are one rounding of the
//! sum plus k^2 - 1 more, carried as read noise (in pixel volts, so a q). So charge binning gains k
//! in read-noise-limited SNR over digital binning and loses its well to the shared readout; the
//! two agree where shot noise dominates. Approximations, stated: the photosensitive area of the
//! block is one centred square of side k p sqrt(fill factor) (the k^2 photodiodes' area, sampled
//! as one: exact for irradiance that is uniform over a block); fixed patterns and `[defects]`
//! are drawn per output pixel; a digital block clips where its sum reaches k^2 S (each photodiode
//! clips at S: the same where the block is uniform).
//!
//! The block tile: every k x k block of the CFA must hold one filter (Quad Bayer at k = 2 bins to
//! Bayer; a monochrome sensor bins at any k). A Bayer sensor's own same-colour binning combines
//! pixels two apart, whose centroids interleave: not modelled (refused, naming the block).

use crate::config::{BinningConfig, BinningMode, SensorConfig};

type Checked<T> = std::result::Result<T, (String, String)>;

fn bad<T>(key: &str, message: impl Into<String>) -> Checked<T> {
    Err((format!("binning.{key}"), message.into()))
}

/// The config of the binned sensor's output pixels (module docs), `binning` removed and `source`
/// noting the binning. Errors name the key.
pub(crate) fn apply(bin: &BinningConfig, c: &SensorConfig) -> Checked<SensorConfig> {
    let k = bin.factor;
    let digital = bin.mode == BinningMode::Digital;
    if k == 0 || k > 8 {
        return bad("factor", format!("must be 1..=8, got {k}"));
    }
    if digital && !k.is_power_of_two() {
        return bad(
                "factor",
                format!("digital binning takes 1, 2, 4 or 8 (a sum of k^2 values keeps the ADC step only for a power of two), got {k}"),
            );
    }
    if c.hdr.is_some() {
        return bad("mode", "binning an [hdr] pixel is not modelled");
    }
    if let Some(g) = bin.conversion_gain_uv_per_e {
        if digital {
            return bad(
                "conversion_gain_uv_per_e",
                "is the charge-binned readout's gain; digital binning reads each pixel at its own",
            );
        }
        if !(g.is_finite() && g > 0.0) {
            return bad(
                "conversion_gain_uv_per_e",
                format!("must be a positive number, got {g}"),
            );
        }
    }
    if c.rows < k || c.cols < k {
        return bad(
            "factor",
            format!("{k} x {k} blocks do not fit {} x {} pixels", c.rows, c.cols),
        );
    }
    let layout = c
        .cfa_layout()
        .map_err(|e| ("cfa".to_string(), e.to_string()))?;
    // The block tile (a block mixing filters is refused, named).
    let binned = layout
        .binned(k)
        .map_err(|e| ("binning.factor".to_string(), e.to_string()))?;
    let pattern: Vec<Vec<String>> = (0..binned.rows())
        .map(|r| {
            (0..binned.cols())
                .map(|c| binned.filters()[binned.filter_at(r, c)].clone())
                .collect()
        })
        .collect();
    let kk = (k * k) as f64;
    let extra_bits = if digital { kk.log2().round() as u32 } else { 0 };
    let bits = c.bits + extra_bits;
    if bits > 16 {
        return bad(
                "factor",
                format!("a digital sum of {k} x {k} {}-bit values needs {bits} bits; camsim's raws have 16 at most", c.bits),
            );
    }
    let mut b = c.clone();
    b.binning = None;
    b.rows = c.rows / k;
    b.cols = c.cols / k;
    b.pixel_pitch_um = c.pixel_pitch_um * k as f64;
    b.cfa = String::new();
    b.cfa_pattern = Some(pattern);
    b.well_capacity_e = None;
    b.prnu_percent = c.prnu_percent / k as f64;
    b.dark_voltage_mv_per_s = c.dark_voltage_mv_per_s * kk;
    if digital {
        b.voltage_swing_v = c.voltage_swing_v * kk;
        b.bits = bits;
        b.dsnu_mv = c.dsnu_mv * k as f64;
        // The k^2 - 1 extra roundings (variance q^2 / 12 each, q the ADC step referred to
        // the pixel: analog gain x swing / 2^bits), when the sensor quantizes.
        let q_mv = c.effective_analog_gain() * c.voltage_swing_v * 1e3 / (1u64 << c.bits) as f64;
        let rounding = if c.noise.quantization {
            (kk - 1.0) * q_mv * q_mv / 12.0
        } else {
            0.0
        };
        b.read_noise_mv = (kk * c.read_noise_mv * c.read_noise_mv + rounding).sqrt();
    } else if let Some(g) = bin.conversion_gain_uv_per_e {
        // The block's dark electrons read at the binned gain.
        b.conversion_gain_uv_per_e = g;
        b.dark_voltage_mv_per_s *= g / c.conversion_gain_uv_per_e;
    }
    let mode = if digital { "digital" } else { "charge" };
    let note = format!(
        "{mode}-binned {k} x {k} from {} x {} photodiodes of {} um",
        c.rows, c.cols, c.pixel_pitch_um
    );
    b.source = Some(match &c.source {
        Some(s) => format!("{s}; {note}"),
        None => note,
    });
    Ok(b)
}
