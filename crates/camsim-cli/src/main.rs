//! `camsim`: the command-line program. One file per subcommand under `cmd/`; no physics here,
//! only wiring between the stage crates and files.
//!
//! Exit codes: 0 success, 2 bad input (every library error: unreadable or malformed file,
//! unknown key, impossible value, too big for memory), 1 an internal bug (a panic), 130
//! interrupted (SIGINT, SIGTERM or SIGHUP: temporary files and staging folders are removed, and
//! every output folder keeps its previous complete run), 141 the reader of stdout went away
//! (`camsim presets | head -1`; quietly, as Unix tools end on SIGPIPE).

mod cmd;
mod common;

use clap::{Parser, Subcommand};

const AFTER_HELP: &str = "\
The pipeline, one direction, as in ISETCam:
  scene (spectral radiance) -> optics (spectral irradiance) -> sensor (raw DN) -> isp (preview)
Each stage runs alone between files (spectral OpenEXR, DNG) or all at once with `simulate`.

Examples:
  camsim simulate --out out/default               ColorChecker, D65, 100 cd/m^2, pixel4a camera
  camsim simulate examples/slanted-edge.toml --out out/edge4 --frames 4
  camsim presets                                  list built-in sensors, optics and scenes
  camsim render --builtin cornell-box-mcc --resolution 252x189 --spp 16 --out out/box   a path-traced 3D scene
  camsim validate cornell-box --out out/report    the paper's validation, with report.html
  camsim dataset --out out/dataset                24 captures as WebDataset shards + manifest
  camsim compare --out out/compare                two cameras side by side: MTF, SNR, CIEDE2000

Output folders (--out DIR) always hold one complete run: a command writes into a fresh sibling
folder DIR.camsim-tmp-<pid> and swaps it in for DIR when everything is written, with a marker
DIR/.camsim-output listing every file of the run. An existing DIR is replaced only when it is
empty or everything in it is listed in its marker (said on stderr unless --quiet); any other folder is refused
naming its first foreign file, and so is a FIFO, device or symbolic link (exit 2). A single
output file (--out X.exr, preview.png, shading.toml) replaces only a file camsim wrote (its
signature: the EXR `software` attribute, the PNG `Software` text, a first line `# camsim`)
unless --force. One run at a time writes an output: a second run into it fails at once. A failed
or interrupted run leaves the output as it was; a killed run's temporaries are removed by the
next run into the same output (it says so).

Exit codes: 0 ok, 2 bad input (the message names the file, key or value), 1 internal error,
130 interrupted (Ctrl-C or SIGTERM; temporaries are removed), 141 stdout closed early
(`camsim presets | head -1`, quietly).";

#[derive(Parser)]
#[command(name = "camsim", version, about = "Simulate a digital camera end to end: spectral scene -> optics -> sensor -> raw DNG", long_about = None, after_help = AFTER_HELP)]
struct Cli {
    /// Worker threads (default: all cores; at most 4 per core, more are capped with a warning).
    /// Output does not depend on this.
    #[arg(long, global = true)]
    threads: Option<usize>,
    /// Hide progress bars and informational notes (run summaries, renderer notes about
    /// unsupported pbrt features, chosen defaults, the note that an earlier output folder will
    /// be replaced). Warnings and errors are still printed on stderr.
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
    Unprocess(cmd::unprocess::Args),
    Presets(cmd::presets::Args),
    /// Measure raw images (camsim's or a real camera's DNG): slanted-edge SFR/MTF, ColorChecker
    /// chart values, region statistics, EMVA 1288 photon transfer.
    #[command(subcommand)]
    Analyze(cmd::analyze::Command),
    /// Fit model parameters to measurements: the sensor QE correction matrix from chart values, the
    /// lens defocus and pixel crosstalk from a measured MTF.
    #[command(subcommand)]
    Fit(cmd::fit::Command),
    Validate(cmd::validate::Args),
    Dataset(cmd::dataset::Args),
    Compare(cmd::compare::Args),
}

/// Set when a write to stdout or stderr failed because the reader went away (`camsim presets |
/// head -1`): the run then ends quietly with 141, as Unix tools killed by SIGPIPE do.
static BROKEN_PIPE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether a panic is std's "failed printing to stdout/stderr" on a closed pipe.
fn is_broken_pipe(info: &std::panic::PanicHookInfo<'_>) -> bool {
    let p = info.payload();
    let text = p
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| p.downcast_ref::<&str>().copied())
        .unwrap_or("");
    text.starts_with("failed printing to std") && text.contains("Broken pipe")
}

fn main() {
    let cli = Cli::parse();
    if let Some(n) = cli.threads {
        if n == 0 {
            eprintln!("camsim: --threads must be at least 1");
            std::process::exit(2);
        }
        // More threads than 4 per core only cost memory and start-up time (output does not
        // depend on the count): cap, and say so.
        let limit = camsim_core::mem::thread_limit();
        let n = if n > limit {
            eprintln!("camsim: warning: --threads {n} is more than 4 x the {} cores; using {limit} threads", limit / 4);
            limit
        } else {
            n
        };
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
        {
            eprintln!("camsim: cannot start {n} worker threads ({e}); give a smaller --threads");
            std::process::exit(2);
        }
    }
    common::set_quiet(cli.quiet);
    // Ctrl-C, SIGTERM, SIGHUP: remove every registered temporary file and staging folder (the
    // output folders keep their previous complete run), then exit 130.
    if let Err(e) = ctrlc::set_handler(|| camsim_io::atomic::remove_temporaries_and_exit(130)) {
        eprintln!("camsim: warning: cannot install the interrupt handler: {e}");
    }
    // A panic is a bug in camsim: report it as such (exit 1), never as bad input.
    std::panic::set_hook(Box::new(|info| {
        if is_broken_pipe(info) {
            BROKEN_PIPE.store(true, std::sync::atomic::Ordering::SeqCst);
            return;
        }
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
        Commands::Unprocess(a) => cmd::unprocess::run(a),
        Commands::Presets(a) => cmd::presets::run(a),
        Commands::Analyze(c) => cmd::analyze::run(c),
        Commands::Fit(c) => cmd::fit::run(c),
        Commands::Validate(a) => cmd::validate::run(a),
        Commands::Dataset(a) => cmd::dataset::run(a),
        Commands::Compare(a) => cmd::compare::run(a),
    });
    if camsim_io::atomic::interrupted() {
        // The interrupt handler is removing the temporaries and will exit with 130; an error the
        // main thread saw meanwhile is only a consequence of that.
        loop {
            std::thread::park();
        }
    }
    match result {
        Ok(Ok(())) => {}
        Ok(Err(e)) => {
            eprintln!("camsim: {}", error_message(&e));
            std::process::exit(2);
        }
        // The reader of our output went away: unwinding removed the temporaries; end as `yes |
        // head -1` does.
        Err(_) if BROKEN_PIPE.load(std::sync::atomic::Ordering::SeqCst) => std::process::exit(141),
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
