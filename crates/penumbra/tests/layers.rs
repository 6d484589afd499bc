//! The library's architecture, checked: every top-level module of
//! `src/` has a layer (the table below, which docs/design.md shows), no
//! module imports one of a higher layer, and the imports between modules
//! have no cycle. Imports are read from the source as `crate::module`
//! paths (`use crate::{a, b::c}` included), outside comments and outside
//! the unit tests at the end of a file.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers, lowest first. A module may import modules of its own layer
/// or lower ones, never higher; within a layer the imports form no cycle.
const LAYERS: &[(&str, &[&str])] = &[
    ("foundation", &["error", "progress", "choice", "report", "geom"]),
    ("GPU plumbing", &["gpu"]),
    ("scenes and readers", &["scene"]),
    ("files and spherical harmonics", &["io", "sh"]),
    ("acceleration", &["accel"]),
    ("tuning", &["tune"]),
    ("ray casting and AO", &["raycast"]),
    ("methods on ray casting", &["mlrta", "field", "ssao", "prt", "bake"]),
    ("Whitted ray tracing", &["whitted"]),
    ("bounded-error ray tracing", &["bounded"]),
    ("sweeps and benches over every method", &["sweep", "bench"]),
];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|(_, mods)| mods.contains(&module))
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// The top-level modules: `src/x.rs` and `src/x/`.
fn modules() -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for entry in std::fs::read_dir(src()).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        if path.is_dir() || (path.extension().is_some_and(|e| e == "rs") && name != "lib") {
            out.insert(name);
        }
    }
    out
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// `text` without comments and without a trailing `#[cfg(test)] mod
/// tests { ... }` (unit tests may reach anywhere).
fn code(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(at) => &text[..at],
        None => text,
    };
    text.lines()
        .map(|l| match l.find("//") {
            Some(at) => &l[..at],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The top-level modules `text` names through `crate::`.
fn imports(text: &str, modules: &BTreeSet<String>) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    for (at, _) in text.match_indices("crate::") {
        let rest = &text[at + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // `use crate::{a, b::c, d::{e, f}}`: the first name of each item.
            let mut depth = 0;
            let mut item_start = true;
            for (i, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => item_start = true,
                    c if item_start && (c.is_ascii_alphabetic() || c == '_') => {
                        out.insert(ident(&group[i..]));
                        item_start = false;
                    }
                    _ => {}
                }
            }
        } else {
            out.insert(ident(rest));
        }
    }
    out.retain(|m| modules.contains(m));
    out
}

/// Module -> the modules it imports.
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let modules = modules();
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    let mut edges: BTreeMap<String, BTreeSet<String>> = modules.iter().map(|m| (m.clone(), BTreeSet::new())).collect();
    for file in files {
        let rel = file.strip_prefix(src()).unwrap();
        let top = rel.components().next().unwrap().as_os_str().to_string_lossy();
        let top = top.trim_end_matches(".rs").to_string();
        if top == "lib" {
            continue;
        }
        let text = code(&std::fs::read_to_string(&file).unwrap());
        let found = imports(&text, &modules);
        edges
            .get_mut(&top)
            .unwrap()
            .extend(found.into_iter().filter(|m| *m != top));
    }
    edges
}

/// A cycle through the graph, if there is one.
fn cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        m: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(m.to_string(), 1);
        path.push(m.to_string());
        for n in &edges[m] {
            match state.get(n.as_str()).copied().unwrap_or(0) {
                1 => {
                    let from = path.iter().position(|p| p == n).unwrap();
                    let mut c = path[from..].to_vec();
                    c.push(n.clone());
                    return Some(c);
                }
                0 => {
                    if let Some(c) = visit(n, edges, state, path) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        path.pop();
        state.insert(m.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for m in edges.keys() {
        if state.get(m.as_str()).copied().unwrap_or(0) == 0
            && let Some(c) = visit(m, edges, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

#[test]
fn every_module_imports_only_its_own_layer_or_lower_ones_without_cycles() {
    let edges = graph();
    for (module, to) in &edges {
        let names: Vec<&str> = to.iter().map(String::as_str).collect();
        println!("{module} -> {}", names.join(" "));
    }
    let unplaced: Vec<&String> = edges.keys().filter(|m| layer_of(m).is_none()).collect();
    assert!(unplaced.is_empty(), "modules without a layer in LAYERS: {unplaced:?}");
    let mut upward = Vec::new();
    for (module, to) in &edges {
        for t in to {
            if layer_of(t) > layer_of(module) {
                upward.push(format!("{module} -> {t}"));
            }
        }
    }
    assert!(
        upward.is_empty(),
        "imports from a lower layer to a higher one: {upward:?}"
    );
    assert_eq!(cycle(&edges), None, "an import cycle");
}

/// The checker finds what it should: grouped imports, a cycle, and
/// nothing in comments or unit tests.
#[test]
fn the_checker_sees_grouped_imports_cycles_and_skips_comments_and_tests() {
    let modules: BTreeSet<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
    let text = code("use crate::{a, b::{x, y}};\n// crate::c\nfn f() {}\n#[cfg(test)]\nmod tests { use crate::c; }");
    assert_eq!(
        imports(&text, &modules),
        ["a", "b"].iter().map(|s| s.to_string()).collect()
    );
    let mut edges = BTreeMap::new();
    edges.insert("a".to_string(), BTreeSet::from(["b".to_string()]));
    edges.insert("b".to_string(), BTreeSet::from(["c".to_string()]));
    edges.insert("c".to_string(), BTreeSet::from(["a".to_string()]));
    assert_eq!(cycle(&edges).map(|c| c.len()), Some(4));
    edges.get_mut("c").unwrap().clear();
    assert_eq!(cycle(&edges), None);
}

/// docs/design.md's architecture section names every layer, in order.
#[test]
fn the_design_document_lists_the_layers() {
    let design = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/design.md");
    let Ok(text) = std::fs::read_to_string(&design) else {
        println!("{} not found (a packaged crate): skipped", design.display());
        return;
    };
    let mut at = 0;
    for (name, mods) in LAYERS {
        let row = mods.iter().map(|m| format!("`{m}`")).collect::<Vec<_>>().join(", ");
        let found = text[at..].find(&row);
        assert!(
            found.is_some(),
            "docs/design.md lists layer {name:?} as {row} after the previous one"
        );
        at += found.unwrap();
    }
}
