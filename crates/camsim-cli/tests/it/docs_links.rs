//! The documentation is an mdBook (`docs/book.toml`, `docs/src/SUMMARY.md`). mdbook is not
//! part of the build, so this test checks what `mdbook build docs` would trip over: every page
//! SUMMARY.md names exists, every page under `docs/src` is in SUMMARY.md, and every relative
//! link or image in README.md and the pages points at a file that exists.

use std::path::{Path, PathBuf};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// The targets of the Markdown links `[text](target)` and images `![alt](target)` in `text`,
/// outside fenced code blocks and inline code spans.
fn link_targets(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        // Inline code spans are not links: drop them.
        let mut plain = String::new();
        for (i, part) in line.split('`').enumerate() {
            if i % 2 == 0 {
                plain.push_str(part);
            }
        }
        let mut rest = plain.as_str();
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let Some(end) = after.find(')') else { break };
            out.push(after[..end].trim().to_string());
            rest = &after[end..];
        }
    }
    out
}

/// A link that points into the repository (not a web address, an e-mail or an anchor).
fn local(target: &str) -> Option<&str> {
    if target.contains("://") || target.starts_with('#') || target.starts_with("mailto:") {
        return None;
    }
    let path = target.split('#').next().unwrap();
    (!path.is_empty()).then_some(path)
}

fn pages(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            found.extend(pages(&p));
        } else if p.extension().is_some_and(|x| x == "md") {
            found.push(p);
        }
    }
    found.sort();
    found
}

#[test]
fn summary_names_every_page_and_only_pages_that_exist() {
    let src = repo_root().join("docs/src");
    let book =
        std::fs::read_to_string(repo_root().join("docs/book.toml")).expect("docs/book.toml exists");
    assert!(book.contains("[book]"), "docs/book.toml has a [book] table");
    let summary = std::fs::read_to_string(src.join("SUMMARY.md")).unwrap();
    let listed: Vec<PathBuf> = link_targets(&summary)
        .iter()
        .filter_map(|t| local(t))
        .map(|t| src.join(t))
        .collect();
    assert!(!listed.is_empty(), "SUMMARY.md lists pages");
    for p in &listed {
        assert!(
            p.is_file(),
            "SUMMARY.md names {} which does not exist",
            p.display()
        );
    }
    for page in pages(&src) {
        if page.file_name().unwrap() == "SUMMARY.md" {
            continue;
        }
        assert!(
            listed.contains(&page),
            "{} is not in SUMMARY.md (mdbook would not build it)",
            page.display()
        );
    }
}

#[test]
fn every_relative_link_in_readme_and_docs_resolves() {
    let root = repo_root();
    let mut files = vec![root.join("README.md")];
    files.extend(pages(&root.join("docs/src")));
    let mut broken = Vec::new();
    let mut checked = 0;
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        let dir = f.parent().unwrap();
        for t in link_targets(&text) {
            let Some(path) = local(&t) else { continue };
            checked += 1;
            if !dir.join(path).exists() {
                broken.push(format!("{}: {t}", f.strip_prefix(&root).unwrap().display()));
            }
        }
    }
    assert!(
        checked > 10,
        "only {checked} links found: the link parser is broken"
    );
    assert!(
        broken.is_empty(),
        "links to nothing:\n{}",
        broken.join("\n")
    );
}

#[test]
fn the_link_parser_finds_links_and_skips_code() {
    let t = "a [x](a.md) and ![i](img/p.png#f) `[no](code.md)`\n```\n[no](fenced.md)\n```\n[w](https://e.org)";
    assert_eq!(
        link_targets(t),
        vec!["a.md", "img/p.png#f", "https://e.org"]
    );
    assert_eq!(local("img/p.png#f"), Some("img/p.png"));
    assert_eq!(local("https://e.org"), None);
}
