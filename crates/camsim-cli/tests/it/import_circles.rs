//! No import circles: inside every crate, no source file uses another that uses it back (directly
//! or through others). A file "uses" another when its code (comments left out) names
//! `crate::<module>` or `super::<module>`; the crate root (lib.rs, main.rs), which declares the
//! modules, is left out, and so are a module's uses of its own submodules (a submodule may use
//! its parent: `integrator/moving.rs` extends the `Tracer` of `integrator.rs`). Every crate is
//! checked.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a source file relative to `src` ("" for the crate root).
fn module_of(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts.join("::")
}

/// Code without `//` comments (doc comments included) and string literals.
fn code_of(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut in_str = false;
        let mut prev = ' ';
        let mut kept = String::new();
        let chars: Vec<char> = line.chars().collect();
        let mut i = 0;
        while i < chars.len() {
            let c = chars[i];
            if !in_str && c == '/' && chars.get(i + 1) == Some(&'/') {
                break;
            }
            if c == '"' && prev != '\\' {
                in_str = !in_str;
            } else if !in_str {
                kept.push(c);
            }
            prev = c;
            i += 1;
        }
        out.push_str(&kept);
        out.push('\n');
    }
    out
}

/// The identifier paths after `prefix` in `code` (e.g. `a::b` of `crate::a::b::C`).
fn paths_after(code: &str, prefix: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find(prefix) {
        let before = rest[..i].chars().last();
        rest = &rest[i + prefix.len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let path: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
            .collect();
        out.push(
            path.split("::")
                .filter(|s| !s.is_empty())
                .map(str::to_string)
                .collect(),
        );
    }
    out
}

/// Strongly connected components with more than one module.
fn circles(edges: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct T<'a> {
        edges: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        let n = t.index.len();
        t.index.insert(v, n);
        t.low.insert(v, n);
        t.stack.push(v);
        t.on.insert(v);
        for w in &t.edges[v] {
            let w = w.as_str();
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low[v];
                t.low.insert(v, lv.min(lw));
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low[v];
                t.low.insert(v, lv.min(iw));
            }
        }
        if t.low[v] == t.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on.remove(w);
                comp.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                t.out.push(comp);
            }
        }
    }
    let mut t = T {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

/// The module graph of one crate's `src` (root left out).
fn module_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let modules: BTreeMap<String, String> = files
        .iter()
        .map(|f| {
            (
                module_of(src, f),
                code_of(&std::fs::read_to_string(f).unwrap()),
            )
        })
        .collect();
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, code) in &modules {
        if m.is_empty() {
            continue;
        }
        let mut targets = BTreeSet::new();
        // crate::a::b::... -> the longest module prefix.
        for p in paths_after(code, "crate::") {
            for k in (1..=p.len()).rev() {
                let cand = p[..k].join("::");
                if modules.contains_key(&cand) {
                    targets.insert(cand);
                    break;
                }
            }
        }
        // super::x -> the sibling module x.
        let parent: Vec<&str> = m.split("::").collect();
        let parent = &parent[..parent.len() - 1];
        for p in paths_after(code, "super::") {
            if let Some(first) = p.first() {
                let cand = parent
                    .iter()
                    .map(|s| s.to_string())
                    .chain(std::iter::once(first.clone()))
                    .collect::<Vec<_>>()
                    .join("::");
                if modules.contains_key(&cand) {
                    targets.insert(cand);
                }
            }
        }
        // Not the root, itself, or a module's own submodules.
        targets.retain(|t| !t.is_empty() && t != m && !t.starts_with(&format!("{m}::")));
        edges.insert(m.clone(), targets);
    }
    edges
}

#[test]
fn no_file_imports_another_that_imports_it_back() {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut found = Vec::new();
    let mut checked = 0;
    for e in std::fs::read_dir(&crates).unwrap() {
        let dir = e.unwrap().path();
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        let src = dir.join("src");
        if !src.is_dir() {
            continue;
        }
        checked += 1;
        for c in circles(&module_graph(&src)) {
            found.push(format!("{name}: {}", c.join(" <-> ")));
        }
    }
    assert!(
        checked >= 14,
        "only {checked} crates found under {crates:?}"
    );
    assert!(found.is_empty(), "import circles:\n{}", found.join("\n"));
}

#[test]
fn the_circle_finder_finds_a_circle() {
    // Guard against a finder that never finds anything: two modules naming each other, and a
    // third through super::.
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::create_dir(src.join("m")).unwrap();
    std::fs::write(src.join("lib.rs"), "mod a; mod b; mod m;").unwrap();
    std::fs::write(src.join("a.rs"), "use crate::b::X; // crate::c\n").unwrap();
    std::fs::write(src.join("b.rs"), "pub fn f() { crate::a::g() }").unwrap();
    std::fs::write(src.join("m/mod.rs"), "mod x; mod y;").unwrap();
    std::fs::write(src.join("m/x.rs"), "use super::y::Z;").unwrap();
    std::fs::write(
        src.join("m/y.rs"),
        "fn h() { super::x::k(); \"crate::a\"; }",
    )
    .unwrap();
    let c = circles(&module_graph(src));
    assert_eq!(
        c,
        vec![
            vec!["a".to_string(), "b".to_string()],
            vec!["m::x".to_string(), "m::y".to_string()]
        ]
    );
}
