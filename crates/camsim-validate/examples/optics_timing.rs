//! Timing of the optics pieces of section 1 (development aid).
fn main() {
    let mut c = camsim_optics::OpticsConfig::preset("pixel4a").unwrap();
    c.padding = camsim_optics::config::Padding::None;
    let o = camsim_optics::Optics::from_config(&c).unwrap();
    let wf = o.wavefront_for(None, 0.5).unwrap();
    let t = std::time::Instant::now();
    for wl in [400.0, 550.0, 700.0] {
        let m = wf.mtf(wl).unwrap();
        println!("mtf {wl}: {} samples, {:.3} s", m.freq_cyc_per_mm.len(), t.elapsed().as_secs_f64());
    }
    let g = camsim_core::WavelengthGrid::default();
    let mut img = camsim_core::SpectralImage::zeros(352, 352, g, 0.7e-6 * 0.5 / 4.418e-3, camsim_core::Quantity::Radiance).unwrap();
    img.geometry.distance_m = 0.5;
    img.data.iter_mut().enumerate().for_each(|(i, v)| *v = (i % 352 > 176) as u8 as f32);
    let t = std::time::Instant::now();
    let irr = o.compute(&img).unwrap();
    println!("compute 352^2 x 31: {:.3} s ({} x {})", t.elapsed().as_secs_f64(), irr.rows, irr.cols);
}
