//! The layering of src/: the library never imports a command module (src/cli/), and the
//! file-level import graph has no circle. Paths are read from the source text (`crate::a::b`,
//! `super::x`, and the items of `use` groups), each resolved to the file that defines it.

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

/// Module path of a file: src/run/mod.rs -> [run], src/run/shear.rs -> [run, shear].
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut m: Vec<String> = rel.iter().map(|c| c.to_string_lossy().into()).collect();
    if matches!(m.last().map(String::as_str), Some("mod" | "lib" | "main")) {
        m.pop();
    }
    m
}

/// The file of the longest prefix of `path` that is a module.
fn resolve(modules: &BTreeMap<Vec<String>, PathBuf>, path: &[String]) -> Option<PathBuf> {
    (1..=path.len())
        .rev()
        .find_map(|n| modules.get(&path[..n]).cloned())
}

/// Every module path the text refers to, absolute (from the crate root).
fn references(text: &str, me: &[String]) -> Vec<Vec<String>> {
    // `super::` is the parent of the file's module (for a mod.rs too: its module is the
    // directory's)
    let parent: Vec<String> = me[..me.len().saturating_sub(1)].to_vec();
    let mut refs = Vec::new();
    let code: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n");
    let bytes = code.as_bytes();
    for (root, base) in [("crate::", Vec::new()), ("super::", parent)] {
        let mut from = 0;
        while let Some(k) = code[from..].find(root) {
            let start = from + k;
            from = start + root.len();
            // not part of a longer identifier (e.g. `dem_crate::`)
            if start > 0 && (bytes[start - 1].is_ascii_alphanumeric() || bytes[start - 1] == b'_') {
                continue;
            }
            let rest = &code[from..];
            let mut segs = base.clone();
            let mut i = 0;
            let rb = rest.as_bytes();
            loop {
                let s = i;
                while i < rb.len() && (rb[i].is_ascii_alphanumeric() || rb[i] == b'_') {
                    i += 1;
                }
                if i == s {
                    break;
                }
                segs.push(rest[s..i].to_string());
                if rest[i..].starts_with("::") {
                    i += 2;
                } else {
                    break;
                }
            }
            // `use crate::a::{b, c::d}`: each item of the group
            if rest[i..].starts_with('{') {
                let end = rest[i..].find('}').map(|e| i + e).unwrap_or(rest.len());
                for item in rest[i + 1..end].split(',') {
                    let mut p = segs.clone();
                    p.extend(
                        item.split("::")
                            .map(|s| s.trim().trim_start_matches('{').trim().to_string())
                            .filter(|s| !s.is_empty() && s != "self" && s != "*"),
                    );
                    refs.push(p);
                }
            }
            refs.push(segs);
        }
    }
    refs
}

#[test]
fn library_never_imports_commands_and_has_no_import_circle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let modules: BTreeMap<Vec<String>, PathBuf> = files
        .iter()
        .map(|f| (module_of(&src, f), f.clone()))
        .collect();
    assert!(modules.len() > 40, "src/ read: {} files", modules.len());
    let mut graph: BTreeMap<PathBuf, BTreeSet<PathBuf>> = BTreeMap::new();
    for f in &files {
        let me = module_of(&src, f);
        let text = std::fs::read_to_string(f).unwrap();
        let deps = graph.entry(f.clone()).or_default();
        for r in references(&text, &me) {
            if let Some(t) = resolve(&modules, &r) {
                // a module's own children and its root file are not imports
                if &t != f && !t.ends_with("lib.rs") && !t.ends_with("main.rs") {
                    deps.insert(t);
                }
            }
        }
    }
    let cli = src.join("cli");
    let rel = |p: &Path| p.strip_prefix(&src).unwrap().display().to_string();
    // the run layer never imports the report layer (report reads run's outcomes): these
    // files still do, for their figures and pages (issue #38); the list may only shrink
    let still_drawing = ["run/nightly.rs"];
    let report = src.join("report");
    let mut upward = Vec::new();
    for (f, deps) in &graph {
        if !f.starts_with(src.join("run")) || still_drawing.contains(&rel(f).as_str()) {
            continue;
        }
        for d in deps.iter().filter(|d| d.starts_with(&report)) {
            upward.push(format!("{} imports {}", rel(f), rel(d)));
        }
    }
    assert!(
        upward.is_empty(),
        "the run layer imports the report layer:\n{}",
        upward.join("\n")
    );
    for f in still_drawing {
        assert!(
            graph[&src.join(f)].iter().any(|d| d.starts_with(&report)),
            "{f} no longer imports report: take it off the list"
        );
    }
    let mut offenders = Vec::new();
    for (f, deps) in &graph {
        if f.starts_with(&cli) || f.ends_with("main.rs") || f.ends_with("lib.rs") {
            continue;
        }
        for d in deps.iter().filter(|d| d.starts_with(&cli)) {
            offenders.push(format!("{} imports {}", rel(f), rel(d)));
        }
    }
    assert!(
        offenders.is_empty(),
        "library modules import command modules:\n{}",
        offenders.join("\n")
    );
    // the graph must read the known edges (a parser that reads nothing passes nothing)
    let edge = |a: &str, b: &str| graph[&src.join(a)].contains(&src.join(b));
    assert!(
        edge("run/sweep.rs", "run/shear.rs"),
        "{:?}",
        graph[&src.join("run/sweep.rs")]
    );
    assert!(edge("cli/shear.rs", "run/shear.rs"));
    assert!(edge("run/shear.rs", "run/mod.rs"));
    // no circle: depth-first search with colours
    fn visit(
        n: &PathBuf,
        g: &BTreeMap<PathBuf, BTreeSet<PathBuf>>,
        state: &mut BTreeMap<PathBuf, u8>,
        stack: &mut Vec<PathBuf>,
    ) -> Option<Vec<PathBuf>> {
        match state.get(n) {
            Some(2) => return None,
            Some(1) => {
                let k = stack.iter().position(|s| s == n).unwrap();
                let mut c = stack[k..].to_vec();
                c.push(n.clone());
                return Some(c);
            }
            _ => {}
        }
        state.insert(n.clone(), 1);
        stack.push(n.clone());
        for d in g.get(n).into_iter().flatten() {
            if let Some(c) = visit(d, g, state, stack) {
                return Some(c);
            }
        }
        stack.pop();
        state.insert(n.clone(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        if let Some(c) = visit(n, &graph, &mut state, &mut Vec::new()) {
            panic!(
                "import circle: {}",
                c.iter().map(|p| rel(p)).collect::<Vec<_>>().join(" -> ")
            );
        }
    }
}
