//! The library's module structure: no import cycle between the top-level modules of `src/`
//! (nor between the submodules of one module), and the layers of `lib.rs` respected — a
//! stage never imports the harness, the core never imports a stage.
//!
//! The graph is read off the source: every `crate::name` path (and `crate::{a, b}` group)
//! and every `super::name` that resolves to a module, outside comments and test code
//! (`#[cfg(test)] mod …`, `tests.rs`, `*_tests.rs`, `testutil.rs`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers, in `lib.rs` order. A module may import its own layer and those before it.
const LAYERS: [(&str, &[&str]); 3] = [
    (
        "core",
        &["geometry", "raster", "scene", "io", "config", "progress"],
    ),
    (
        "stages",
        &[
            "scale",
            "normals",
            "axes",
            "photo",
            "lines",
            "hypotheses",
            "planemap",
            "classify",
            "nonplanar",
            "sky",
            "pipeline",
        ],
    ),
    (
        "harness",
        &[
            "synth",
            "workspace",
            "eval",
            "baselines",
            "bench",
            "info",
            "diag",
        ],
    ),
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// Module path of a file under `src/`: `src/photo/sweep.rs` → `[photo, sweep]`,
/// `src/photo/mod.rs` → `[photo]`, `src/lib.rs` → `[]`.
fn module_path(src: &Path, file: &Path) -> Vec<String> {
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
    parts
}

fn is_test_file(file: &Path) -> bool {
    let name = file.file_stem().unwrap().to_string_lossy();
    name == "tests" || name.ends_with("_tests") || name == "testutil"
}

/// The code of a file without its comments and its test module.
fn code_of(text: &str) -> String {
    let mut out = String::new();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let t = line.trim_start();
        if t.starts_with("#[cfg(test)]") {
            let next = lines.peek().map(|l| l.trim_start()).unwrap_or("");
            if next.starts_with("mod ") || next.starts_with("pub(crate) mod ") {
                if next.ends_with(';') {
                    lines.next();
                    continue;
                }
                break; // an inline test module runs to the end of the file
            }
        }
        if t.starts_with("//") {
            continue;
        }
        out.push_str(line.split(" //").next().unwrap_or(line));
        out.push('\n');
    }
    out
}

fn ident_at(s: &str) -> &str {
    let end = s
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(s.len());
    &s[..end]
}

/// Every module path a file's code refers to, as absolute paths (first two segments).
fn references(code: &str, here: &[String]) -> Vec<Vec<String>> {
    let mut refs = Vec::new();
    let mut push = |base: &[String], rest: &str| {
        let rest = rest.trim_start();
        if let Some(group) = rest.strip_prefix('{') {
            // `crate::{a::b, c}`: the first segment of every top-level item of the group.
            let mut depth = 0;
            let mut item = String::new();
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        let mut p = base.to_vec();
                        p.extend(
                            item.trim()
                                .split("::")
                                .take(2)
                                .map(|s| ident_at(s.trim()).to_string()),
                        );
                        refs.push(p);
                        item.clear();
                        continue;
                    }
                    _ => {}
                }
                item.push(c);
            }
            if !item.trim().is_empty() {
                let mut p = base.to_vec();
                p.extend(
                    item.trim()
                        .split("::")
                        .take(2)
                        .map(|s| ident_at(s.trim()).to_string()),
                );
                refs.push(p);
            }
        } else {
            let mut p = base.to_vec();
            for seg in rest.split("::").take(2) {
                let id = ident_at(seg);
                if id.is_empty() {
                    break;
                }
                p.push(id.to_string());
            }
            refs.push(p);
        }
    };
    for (i, _) in code.match_indices("crate::") {
        let before = code[..i].chars().last();
        if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_') {
            continue; // `$crate::` or part of a longer name
        }
        push(&[], &code[i + "crate::".len()..]);
    }
    for (i, _) in code.match_indices("super::") {
        let before = code[..i].chars().last();
        if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_' || c == ':') {
            continue; // counted with the first `super::` of a chain
        }
        let mut rest = &code[i..];
        let mut base: Vec<String> = here.to_vec();
        while let Some(r) = rest.strip_prefix("super::") {
            base.pop();
            rest = r;
        }
        push(&base, rest);
    }
    refs
}

fn find_cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    // Depth-first search with colours; returns one cycle.
    fn visit(
        n: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for m in edges.get(n).into_iter().flatten() {
            match state.get(m.as_str()).copied().unwrap_or(0) {
                1 => {
                    let start = stack.iter().position(|s| s == m).unwrap();
                    let mut cycle = stack[start..].to_vec();
                    cycle.push(m.clone());
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(m, edges, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in edges.keys() {
        if state.get(n.as_str()).copied().unwrap_or(0) == 0 {
            let mut stack = Vec::new();
            if let Some(c) = visit(n, edges, &mut state, &mut stack) {
                return Some(c);
            }
        }
    }
    None
}

struct Graph {
    /// Top-level module → the top-level modules it imports, with one file that does.
    top: BTreeMap<String, BTreeMap<String, PathBuf>>,
    /// Per top-level module: submodule → sibling submodules it imports.
    sub: BTreeMap<String, BTreeMap<String, BTreeSet<String>>>,
}

fn graph(src: &Path) -> Graph {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let is_module = |path: &[String]| {
        let mut p = src.to_path_buf();
        for s in path {
            p.push(s);
        }
        p.with_extension("rs").is_file() || p.join("mod.rs").is_file()
    };
    let mut g = Graph {
        top: BTreeMap::new(),
        sub: BTreeMap::new(),
    };
    for file in &files {
        let here = module_path(src, file);
        if here.is_empty() || is_test_file(file) {
            continue; // lib.rs / main.rs, and test code
        }
        let code = code_of(&std::fs::read_to_string(file).unwrap());
        g.top.entry(here[0].clone()).or_default();
        for r in references(&code, &here) {
            let Some(first) = r.first() else { continue };
            if !is_module(&r[..1]) {
                continue;
            }
            if *first != here[0] {
                g.top
                    .entry(here[0].clone())
                    .or_default()
                    .entry(first.clone())
                    .or_insert_with(|| file.clone());
            } else if here.len() >= 2 && r.len() >= 2 && r[1] != here[1] && is_module(&r[..2]) {
                g.sub
                    .entry(here[0].clone())
                    .or_default()
                    .entry(here[1].clone())
                    .or_default()
                    .insert(r[1].clone());
            }
        }
    }
    g
}

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn no_import_cycle_between_top_level_modules() {
    let g = graph(&src_dir());
    let edges: BTreeMap<String, BTreeSet<String>> = g
        .top
        .iter()
        .map(|(k, v)| (k.clone(), v.keys().cloned().collect()))
        .collect();
    assert!(
        edges.len() >= 20,
        "the scan found too few modules: {edges:?}"
    );
    if let Some(cycle) = find_cycle(&edges) {
        let via: Vec<String> = cycle
            .windows(2)
            .map(|w| format!("{} → {} ({})", w[0], w[1], g.top[&w[0]][&w[1]].display()))
            .collect();
        panic!(
            "import cycle between top-level modules:\n  {}",
            via.join("\n  ")
        );
    }
}

#[test]
fn no_import_cycle_between_submodules() {
    let g = graph(&src_dir());
    for (module, edges) in &g.sub {
        if let Some(cycle) = find_cycle(edges) {
            panic!("import cycle inside {module}: {}", cycle.join(" → "));
        }
    }
}

#[test]
fn layers_only_import_themselves_and_the_layers_before() {
    let g = graph(&src_dir());
    let layer_of = |m: &str| LAYERS.iter().position(|(_, ms)| ms.contains(&m));
    let mut bad = Vec::new();
    for (from, tos) in &g.top {
        let Some(lf) = layer_of(from) else {
            bad.push(format!(
                "{from} is in no layer: add it to lib.rs's groups and LAYERS"
            ));
            continue;
        };
        for (to, file) in tos {
            match layer_of(to) {
                Some(lt) if lt > lf => bad.push(format!(
                    "{from} ({}) imports {to} ({}) in {}",
                    LAYERS[lf].0,
                    LAYERS[lt].0,
                    file.display()
                )),
                _ => {}
            }
        }
    }
    assert!(bad.is_empty(), "layering broken:\n  {}", bad.join("\n  "));
}

#[test]
fn the_scan_sees_groups_supers_and_skips_comments_and_tests() {
    let here = vec!["photo".to_string(), "sweep".to_string()];
    let code = code_of(
        "use crate::{geometry::Plane, scene::{Scene, View}};\n\
         // crate::bench is only mentioned\n\
         use super::volume::CostVolume;\n\
         let x = crate::raster::ImageF32::new(); // crate::synth\n\
         #[cfg(test)]\nmod tests {\n use crate::synth;\n}\n",
    );
    let refs = references(&code, &here);
    let firsts: BTreeSet<String> = refs.iter().filter_map(|r| r.first().cloned()).collect();
    assert_eq!(
        firsts,
        ["geometry", "photo", "raster", "scene"]
            .into_iter()
            .map(String::from)
            .collect()
    );
    assert!(
        refs.contains(&vec![
            "photo".to_string(),
            "volume".to_string(),
            "CostVolume".to_string()
        ]) || refs.contains(&vec!["photo".to_string(), "volume".to_string()])
    );
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    edges.entry("a".into()).or_default().insert("b".into());
    edges.entry("b".into()).or_default().insert("c".into());
    assert!(find_cycle(&edges).is_none());
    edges.entry("c".into()).or_default().insert("a".into());
    assert_eq!(find_cycle(&edges).unwrap(), ["a", "b", "c", "a"]);
}
