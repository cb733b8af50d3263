//! Run the Cornell box validation without the CLI:
//! `cargo run --release -p camsim-validate --example cornell_box -- quick|paper OUT_DIR [DATA_DIR]`.
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let quality = match a.get(1).map(String::as_str) {
        Some("paper") => camsim_validate::Quality::Paper,
        _ => camsim_validate::Quality::Quick,
    };
    let opts = camsim_validate::ValidateOptions {
        quality,
        out_dir: a
            .get(2)
            .cloned()
            .unwrap_or_else(|| "out/validate".into())
            .into(),
        data_dir: a.get(3).map(Into::into),
        seed: 1,
        command_line: a.join(" "),
    };
    let t0 = std::time::Instant::now();
    let last = std::sync::Mutex::new(String::new());
    let r = camsim_validate::cornell_box(&opts, &|stage, _, _| {
        let mut l = last.lock().unwrap();
        if *l != stage {
            eprintln!("[{:7.1} s] {stage}", t0.elapsed().as_secs_f64());
            *l = stage.to_string();
        }
    });
    match r {
        Ok(r) => {
            for c in &r.checks {
                println!(
                    "[{}] {}: {}",
                    if c.passed { "ok" } else { "FAIL" },
                    c.name,
                    c.detail
                );
            }
            println!("total {:.1} s", r.provenance.total_seconds);
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    }
}
