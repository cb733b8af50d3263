//! Electron images of a general colour filter array (RGBW, Quad Bayer, any N x M `cfa_pattern`):
//! the same area integration as the Bayer path of [`Sensor::electron_rate_image`], with one
//! channel factor per column phase of the CFA tile instead of two.

use crate::compute::Axis;
use crate::error::Result;
use crate::sensor::Sensor;
use camsim_core::{mem, CfaLayout, SpectralImage};
use rayon::prelude::*;

impl Sensor {
    /// Steps 1-2 of [`Sensor::compute`] for a non-Bayer CFA: electrons per second at every pixel
    /// for its own filter, row-major. Rows in blocks (rayon), bands outermost within a block: the
    /// y-weighted irradiance of each band is accumulated into one input-resolution row per column
    /// phase of the tile (weighted by that phase's filter factor), then integrated along x once
    /// per pixel. Fixed block structure: the result does not depend on the thread count.
    pub(crate) fn electron_rate_image_layout(
        &self,
        irr: &SpectralImage,
        layout: &CfaLayout,
    ) -> Result<Vec<f32>> {
        let (rows, cols) = (self.rows(), self.cols());
        mem::check_alloc((rows * cols * 4) as u64, "the sensor electron image")?;
        let pd_width_m = self.pixel_pitch_m * self.fill_factor.sqrt();
        let ax = Axis::new(
            cols,
            self.pixel_pitch_m,
            pd_width_m,
            irr.cols,
            irr.sample_spacing_m,
        );
        let ay = Axis::new(
            rows,
            self.pixel_pitch_m,
            pd_width_m,
            irr.rows,
            irr.sample_spacing_m,
        );
        let fac: Vec<Vec<f32>> = self
            .band_factors_filters(&irr.grid)
            .iter()
            .map(|f| f.iter().map(|v| *v as f32).collect())
            .collect();
        let in_cols = irr.cols;
        let phases = layout.cols();
        let mut rate = vec![0.0f32; rows * cols];
        let Some((jmin, jmax)) = ax.input_span() else {
            return Ok(rate);
        };
        let range = jmax - jmin;
        const BLOCK_ROWS: usize = 8;
        rate.par_chunks_mut(cols * BLOCK_ROWS)
            .enumerate()
            .for_each_init(Vec::<f32>::new, |tmp, (blk, out)| {
                let nrows = out.len() / cols;
                tmp.clear();
                tmp.resize(nrows * phases * range, 0.0);
                for (b, f) in fac.iter().enumerate() {
                    let plane = irr.band(b);
                    for k in 0..nrows {
                        let r = blk * BLOCK_ROWS + k;
                        let (i0, wy) = ay.entries(r);
                        let acc = &mut tmp[k * phases * range..(k + 1) * phases * range];
                        for (kk, w) in wy.iter().enumerate() {
                            if *w == 0.0 {
                                continue;
                            }
                            let row = &plane[(i0 + kk) * in_cols + jmin..][..range];
                            for (phase, dst) in acc.chunks_mut(range).enumerate() {
                                let a = w * f[layout.filter_at(r, phase)];
                                if a == 0.0 {
                                    continue;
                                }
                                for (x, e) in dst.iter_mut().zip(row) {
                                    *x += a * e;
                                }
                            }
                        }
                    }
                }
                for (k, orow) in out.chunks_mut(cols).enumerate() {
                    let acc = &tmp[k * phases * range..(k + 1) * phases * range];
                    for (c, o) in orow.iter_mut().enumerate() {
                        let (st, wx) = ax.entries(c);
                        let src = &acc[(c % phases) * range..(c % phases + 1) * range];
                        *o = wx
                            .iter()
                            .zip(&src[st.saturating_sub(jmin)..])
                            .map(|(a, b)| a * b)
                            .sum();
                    }
                }
            });
        Ok(rate)
    }

    /// Noise-free mean electrons (photo + dark) per filter of `layout` for an electron-rate
    /// image: per-row sums (rayon) then a sequential total, so independent of the thread count.
    pub(crate) fn layout_mean_electrons(
        &self,
        layout: &CfaLayout,
        rate: &[f32],
        rows: usize,
        cols: usize,
        exposure_s: f64,
        global_reset: Option<&crate::compute::GlobalReset>,
    ) -> Vec<f64> {
        let nf = layout.filters().len();
        let row_sums: Vec<Vec<f64>> = rate
            .par_chunks(cols)
            .enumerate()
            .map(|(r, row)| {
                let mut s = vec![0.0f64; nf];
                let light_s = crate::compute::row_weight_s(global_reset, r, exposure_s);
                for (c, v) in row.iter().enumerate() {
                    s[layout.filter_at(r, c)] += *v as f64 * light_s;
                }
                s
            })
            .collect();
        let mut sums = vec![0.0f64; nf];
        for s in &row_sums {
            for (a, b) in sums.iter_mut().zip(s) {
                *a += b;
            }
        }
        let dark_e =
            self.dark_electrons(crate::compute::mean_dark_s(global_reset, rows, exposure_s));
        let per_pixel_s = if global_reset.is_some() {
            1.0
        } else {
            exposure_s
        };
        let counts = layout.pixel_counts(rows, cols);
        sums.iter()
            .zip(&counts)
            .map(|(s, &n)| {
                if n > 0 {
                    s / n as f64 * per_pixel_s + dark_e
                } else {
                    0.0
                }
            })
            .collect()
    }
}
