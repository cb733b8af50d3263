//! The whole pipeline from Rust: run the built-in default at two exposures in memory, print what
//! each gives, and write the files of one of them.
//!
//! cargo run --release -p camsim --example simulate -- [OUT_DIR]

fn main() -> camsim::Result<()> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "out/lib-example".into());
    let mut config = camsim::SimulateConfig::builtin_default();
    let mut last = None;
    for exposure_ms in [5.0, 20.0] {
        config.capture.exposure_ms = Some(exposure_ms);
        let sim = camsim::simulate(
            &config,
            &camsim::SimulateOptions {
                noise_free: true,
                ..Default::default()
            },
            &|_, _, _| {},
        )?;
        let nf = sim.noise_free_frame(0).unwrap_or_default();
        let mean_nf = nf.iter().map(|v| *v as f64).sum::<f64>() / nf.len().max(1) as f64;
        println!(
            "{exposure_ms:5.1} ms: mean DN r/g/b {:.1} / {:.1} / {:.1}, noise-free mean {mean_nf:.1} DN, irradiance {} x {} x {} bands",
            sim.mean_dn_rgb[0],
            sim.mean_dn_rgb[1],
            sim.mean_dn_rgb[2],
            sim.irradiance.rows,
            sim.irradiance.cols,
            sim.irradiance.bands()
        );
        last = Some(sim);
    }
    if let Some(sim) = last {
        let outputs = camsim::OutputSet::parse("raw,preview,noise-free")?;
        sim.write(
            out.as_ref(),
            &outputs,
            camsim::ExrOptions::default(),
            &camsim::RunInfo::default(),
        )?;
        println!("wrote {out}");
    }
    Ok(())
}
