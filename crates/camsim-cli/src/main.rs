//! `camsim`: the command-line program. One file per subcommand under `cmd/`; no physics here,
//! only wiring between the stage crates and files.
//!
//! Exit codes: 0 success, 2 bad input (every library error: unreadable or malformed file,
//! unknown key, impossible value, too big for memory), 1 an internal bug (a panic).

mod cmd;
mod common;

use clap::{Parser, Subcommand};

const AFTER_HELP: &str = "\
The pipeline, one direction, as in ISETCam:
  scene (spectral radiance) -> optics (spectral irradiance) -> sensor (raw DN) -> isp (preview)
Each stage runs alone between files (spectral OpenEXR, DNG) or all at once with `simulate`.

Examples:
  camsim simulate --out out/default               ColorChecker, D65, 100 cd/m^2, pixel4a camera
  camsim simulate examples/slanted-edge.toml --out out/edge --frames 4
  camsim presets                                  list built-in sensors, optics and scenes
  camsim render --builtin cornell-box-mcc --out out/box
  camsim validate cornell-box --out out/report    the paper's validation, with report.html

Exit codes: 0 ok, 2 bad input (the message names the file, key or value), 1 internal error.";

#[derive(Parser)]
#[command(name = "camsim", version, about = "Simulate a digital camera end to end: spectral scene -> optics -> sensor -> raw DNG", long_about = None, after_help = AFTER_HELP)]
struct Cli {
    /// Worker threads (default: all cores). Output does not depend on this.
    #[arg(long, global = true)]
    threads: Option<usize>,
    /// Hide progress bars.
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Commands,
}

#[derive(Subcommand)]
enum Commands {
    Simulate(cmd::simulate::Args),
    Scene(cmd::scene::Args),
    Render(cmd::render::Args),
    Optics(cmd::optics::Args),
    Psf(cmd::psf::Args),
    FitShading(cmd::fit_shading::Args),
    Sensor(cmd::sensor::Args),
    Isp(cmd::isp::Args),
    Presets(cmd::presets::Args),
    #[command(subcommand)]
    Analyze(cmd::analyze::Command),
    #[command(subcommand)]
    Fit(cmd::fit::Command),
    Validate(cmd::validate::Args),
}

fn main() {
    let cli = Cli::parse();
    if let Some(n) = cli.threads {
        if n == 0 {
            eprintln!("camsim: --threads must be at least 1");
            std::process::exit(2);
        }
        // Ignore the error if a pool exists already (cannot happen in main).
        let _ = rayon::ThreadPoolBuilder::new().num_threads(n).build_global();
    }
    common::set_quiet(cli.quiet);
    // A panic is a bug in camsim: report it as such (exit 1), never as bad input.
    std::panic::set_hook(Box::new(|info| {
        eprintln!("camsim: internal error (please report): {info}");
    }));
    let result = std::panic::catch_unwind(|| match cli.command {
        Commands::Simulate(a) => cmd::simulate::run(a),
        Commands::Scene(a) => cmd::scene::run(a),
        Commands::Render(a) => cmd::render::run(a),
        Commands::Optics(a) => cmd::optics::run(a),
        Commands::Psf(a) => cmd::psf::run(a),
        Commands::FitShading(a) => cmd::fit_shading::run(a),
        Commands::Sensor(a) => cmd::sensor::run(a),
        Commands::Isp(a) => cmd::isp::run(a),
        Commands::Presets(a) => cmd::presets::run(a),
        Commands::Analyze(c) => cmd::analyze::run(c),
        Commands::Fit(c) => cmd::fit::run(c),
        Commands::Validate(a) => cmd::validate::run(a),
    });
    match result {
        Ok(Ok(())) => {}
        Ok(Err(e)) => {
            eprintln!("camsim: {}", error_message(&e));
            std::process::exit(2);
        }
        Err(_) => std::process::exit(1),
    }
}

/// The error and its causes joined by ": ", skipping a cause whose text the message already ends
/// with: the library errors print their source inside their own message (`path: cause`), so
/// anyhow's `{:#}` would print every such cause twice.
fn error_message(e: &anyhow::Error) -> String {
    let mut msg = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if msg.ends_with(&text) {
            continue;
        }
        if !msg.is_empty() {
            msg.push_str(": ");
        }
        msg.push_str(&text);
    }
    msg
}
