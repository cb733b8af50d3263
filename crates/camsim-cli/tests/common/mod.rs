//! Helpers shared by the CLI tests that walk the program's own help: the help text of a
//! subcommand, its subcommand list, and running a command with a time limit.
#![allow(dead_code)] // each test binary uses its own subset

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

pub const BIN: &str = env!("CARGO_BIN_EXE_camsim");

/// The help text of `camsim PATH --help`, unwrapped (a wide terminal: clap reads COLUMNS).
pub fn help<S: AsRef<str>>(path: &[S]) -> String {
    let args: Vec<&str> = path.iter().map(|s| s.as_ref()).collect();
    let o = Command::new(BIN)
        .args(&args)
        .arg("--help")
        .env("COLUMNS", "400")
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "camsim {} --help failed",
        args.join(" ")
    );
    String::from_utf8(o.stdout).unwrap()
}

/// The subcommand names of a help text's `Commands:` section (without `help`).
pub fn subcommands(help_text: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut inside = false;
    for line in help_text.lines() {
        if line.trim_end() == "Commands:" {
            inside = true;
            continue;
        }
        if inside {
            if line.trim().is_empty() || !line.starts_with("  ") {
                break;
            }
            if line.starts_with("   ") {
                continue; // a wrapped description
            }
            let name = line.split_whitespace().next().unwrap_or("");
            if !name.is_empty() && name != "help" {
                names.push(name.to_string());
            }
        }
    }
    names
}

/// Every subcommand path (`[]`, `["analyze"]`, `["analyze", "sfr"]` ...), depth first, with its
/// help text.
pub fn command_tree() -> Vec<(Vec<String>, String)> {
    let mut out = Vec::new();
    let mut stack: Vec<Vec<String>> = vec![vec![]];
    while let Some(path) = stack.pop() {
        let text = help(&path);
        for sub in subcommands(&text).into_iter().rev() {
            let mut p = path.clone();
            p.push(sub);
            stack.push(p);
        }
        out.push((path, text));
    }
    out
}

/// What a limited run gave: exit code (`None`: killed at the limit or by a signal), stderr, and
/// the wall time.
pub struct Outcome {
    pub code: Option<i32>,
    pub stderr: String,
    pub seconds: f64,
}

/// Run `cmd` (stdin and stdout closed, stderr captured) and kill it after `limit`.
pub fn run_limited(mut cmd: Command, limit: Duration) -> Outcome {
    let start = Instant::now();
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut pipe = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut pipe, &mut s);
        s
    });
    let code = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code();
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Outcome {
        code,
        stderr: reader.join().unwrap(),
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Run `camsim ARGS --quiet` and require success (the message shows the command and its stderr).
pub fn run_ok(args: &[&str]) {
    let o = Command::new(BIN)
        .args(args)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "`camsim {}` failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
}
