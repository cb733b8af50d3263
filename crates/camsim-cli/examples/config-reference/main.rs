//! Writes the config reference page (docs/src/config.md) to stdout:
//! `cargo run -q -p camsim-cli --example config-reference > docs/src/config.md`.

mod reference;

#[allow(dead_code)]
const _: &str = reference::COMMAND;

fn main() {
    let (page, missing) = reference::page();
    if !missing.is_empty() {
        eprintln!(
            "these config keys have no doc comment (document them in the config types):\n  {}",
            missing.join("\n  ")
        );
        std::process::exit(1);
    }
    print!("{page}");
}
