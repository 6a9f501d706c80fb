//! The layering of src/: the library never imports a command module (src/cli/), and the
//! file-level import graph has no circle. Paths are read from the parsed source (`crate::a::b`,
//! `super::x` relative to the inline module it stands in, the items of `use` trees, and paths
//! inside macro arguments), each resolved to the file that defines it.

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

/// Every module path a file refers to, absolute (from the crate root): `use` trees and paths
/// that start with `crate`, `super` or `self`, read with `syn` so that `super` inside an inline
/// module (`mod tests`, `mod avx2`) means that module's parent, not the file's.
struct References {
    /// module path at the current point: the file's module, then the inline modules around it
    here: Vec<String>,
    out: Vec<Vec<String>>,
}

impl References {
    /// `segs` made absolute, if it starts at `crate`, `super` or `self`; else None (an
    /// external crate, a prelude name or a local item).
    fn absolute(&self, segs: &[String]) -> Option<Vec<String>> {
        let mut base = match segs.first().map(String::as_str) {
            Some("crate") => Vec::new(),
            Some("super" | "self") => self.here.clone(),
            _ => return None,
        };
        let mut rest = if segs[0] == "crate" { &segs[1..] } else { segs };
        while let Some(s) = rest.first() {
            match s.as_str() {
                "super" => {
                    base.pop()?;
                }
                "self" => {}
                _ => break,
            }
            rest = &rest[1..];
        }
        base.extend(rest.iter().cloned());
        Some(base)
    }

    fn use_tree(&mut self, prefix: &mut Vec<String>, tree: &syn::UseTree) {
        match tree {
            syn::UseTree::Path(p) => {
                prefix.push(p.ident.to_string());
                self.use_tree(prefix, &p.tree);
                prefix.pop();
            }
            syn::UseTree::Name(n) => {
                prefix.push(n.ident.to_string());
                self.record(prefix);
                prefix.pop();
            }
            syn::UseTree::Rename(r) => {
                prefix.push(r.ident.to_string());
                self.record(prefix);
                prefix.pop();
            }
            syn::UseTree::Glob(_) => self.record(prefix),
            syn::UseTree::Group(g) => {
                for t in &g.items {
                    self.use_tree(prefix, t);
                }
            }
        }
    }

    fn record(&mut self, segs: &[String]) {
        if let Some(a) = self.absolute(segs) {
            self.out.push(a);
        }
    }
}

impl<'ast> syn::visit::Visit<'ast> for References {
    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        self.here.push(m.ident.to_string());
        syn::visit::visit_item_mod(self, m);
        self.here.pop();
    }

    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        self.use_tree(&mut Vec::new(), &u.tree);
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        let segs: Vec<String> = p.segments.iter().map(|s| s.ident.to_string()).collect();
        self.record(&segs);
        syn::visit::visit_path(self, p);
    }

    /// A macro's arguments are tokens, not syntax: `crate::a::b` / `super::x` runs in them.
    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        self.tokens(m.tokens.clone());
        syn::visit::visit_macro(self, m);
    }
}

impl References {
    fn tokens(&mut self, ts: proc_macro2::TokenStream) {
        let tt: Vec<proc_macro2::TokenTree> = ts.into_iter().collect();
        let mut i = 0;
        while i < tt.len() {
            match &tt[i] {
                proc_macro2::TokenTree::Group(g) => self.tokens(g.stream()),
                proc_macro2::TokenTree::Ident(id) if id == "crate" || id == "super" => {
                    // ident (`::` ident)*, where `::` is two ':' puncts
                    let mut segs = vec![id.to_string()];
                    let mut j = i + 1;
                    while let (
                        Some(proc_macro2::TokenTree::Punct(a)),
                        Some(proc_macro2::TokenTree::Punct(b)),
                        Some(proc_macro2::TokenTree::Ident(n)),
                    ) = (tt.get(j), tt.get(j + 1), tt.get(j + 2))
                    {
                        if a.as_char() != ':' || b.as_char() != ':' {
                            break;
                        }
                        segs.push(n.to_string());
                        j += 3;
                    }
                    self.record(&segs);
                    i = j;
                    continue;
                }
                _ => {}
            }
            i += 1;
        }
    }
}

fn references(text: &str, me: &[String]) -> Vec<Vec<String>> {
    let file = syn::parse_file(text).unwrap_or_else(|e| panic!("{me:?} does not parse: {e}"));
    let mut r = References {
        here: me.to_vec(),
        out: Vec::new(),
    };
    syn::visit::Visit::visit_file(&mut r, &file);
    r.out
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
