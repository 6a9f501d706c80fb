//! The layering of src/: base -> solver -> spec -> deck -> run -> report -> cli, each file
//! importing its own layer and those below (the commands in src/cli/ on top: the library never
//! imports them), with the arrows still pointing up listed (issue #38, a list that may only
//! shrink); and the file-level import graph has no circle but the listed ones. Paths are read from the parsed source (`crate::a::b`,
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
    /// every module path of src/, to read a bare child path (`shear::ShearArgs` in cli/mod.rs)
    modules: BTreeSet<Vec<String>>,
    /// modules declared `#[cfg(test)] mod x;` in a file of their own: test code, read apart
    test_files: Vec<Vec<String>>,
}

/// `#[cfg(test)]`: code compiled for the unit tests only. The layers are the library's: a
/// unit test may build its input from a case description (a solver test from a preset), as
/// a test in tests/ does, without the solver depending on the description.
fn is_test(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("cfg") && a.parse_args::<syn::Ident>().is_ok_and(|i| i == "test")
    })
}

impl References {
    /// `segs` made absolute, if it starts at `crate`, `super` or `self`; else None (an
    /// external crate, a prelude name or a local item).
    fn absolute(&self, segs: &[String]) -> Option<Vec<String>> {
        let mut base = match segs.first().map(String::as_str) {
            Some("crate") => Vec::new(),
            Some("super" | "self") => self.here.clone(),
            // a bare path that names a child module of the current one (`shear::run`, not a
            // local `shear`)
            Some(first) if segs.len() >= 2 => {
                let mut child = self.here.clone();
                child.push(first.to_string());
                if !self.modules.contains(&child) {
                    return None;
                }
                self.here.clone()
            }
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
        if !is_test(&m.attrs) {
            syn::visit::visit_item_mod(self, m);
        } else if m.content.is_none() {
            self.test_files.push(self.here.clone());
        }
        self.here.pop();
    }

    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        if !is_test(&u.attrs) {
            self.use_tree(&mut Vec::new(), &u.tree);
        }
    }

    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        if !is_test(&f.attrs) {
            syn::visit::visit_item_fn(self, f);
        }
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        let segs: Vec<String> = p.segments.iter().map(|s| s.ident.to_string()).collect();
        self.record(&segs);
        syn::visit::visit_path(self, p);
    }

    /// `pub(super)`, `pub(in crate::x)`: who may see an item, not an import.
    fn visit_visibility(&mut self, _: &'ast syn::Visibility) {}

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

/// The library's references of a file (its test code left out), and the modules it declares
/// as test code in files of their own.
fn references(
    text: &str,
    me: &[String],
    modules: &BTreeSet<Vec<String>>,
) -> (Vec<Vec<String>>, Vec<Vec<String>>) {
    let file = syn::parse_file(text).unwrap_or_else(|e| panic!("{me:?} does not parse: {e}"));
    let mut r = References {
        here: me.to_vec(),
        out: Vec::new(),
        modules: modules.clone(),
        test_files: Vec::new(),
    };
    syn::visit::Visit::visit_file(&mut r, &file);
    (r.out, r.test_files)
}

#[test]
fn layers_point_one_way_and_imports_have_no_circle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let modules: BTreeMap<Vec<String>, PathBuf> = files
        .iter()
        .map(|f| (module_of(&src, f), f.clone()))
        .collect();
    assert!(modules.len() > 40, "src/ read: {} files", modules.len());
    let mut graph: BTreeMap<PathBuf, BTreeSet<PathBuf>> = BTreeMap::new();
    let names: BTreeSet<Vec<String>> = modules.keys().cloned().collect();
    let read: Vec<_> = files
        .iter()
        .map(|f| {
            let me = module_of(&src, f);
            let (refs, tests) = references(&std::fs::read_to_string(f).unwrap(), &me, &names);
            (f, me, refs, tests)
        })
        .collect();
    // test code in files of their own (`#[cfg(test)] mod tests;`) and their children
    let test_mods: Vec<Vec<String>> = read.iter().flat_map(|r| r.3.clone()).collect();
    assert!(
        test_mods.contains(&vec![
            "solver".into(),
            "shear".into(),
            "pairs".into(),
            "tests".into()
        ]),
        "test modules read: {test_mods:?}"
    );
    for (f, me, refs, _) in read {
        if test_mods.iter().any(|t| me.starts_with(t)) {
            continue;
        }
        let deps = graph.entry(f.clone()).or_default();
        for r in refs {
            if let Some(t) = resolve(&modules, &r) {
                // a module's own children and its root file are not imports
                if &t != f && !t.ends_with("lib.rs") && !t.ends_with("main.rs") {
                    deps.insert(t);
                }
            }
        }
    }
    let rel = |p: &Path| p.strip_prefix(&src).unwrap().display().to_string();
    // the graph must read the known edges (a parser that reads nothing passes nothing)
    let edge = |a: &str, b: &str| graph[&src.join(a)].contains(&src.join(b));
    assert!(
        edge("run/sweep.rs", "run/shear/mod.rs"),
        "{:?}",
        graph[&src.join("run/sweep.rs")]
    );
    assert!(edge("cli/shear.rs", "run/shear/mod.rs"));
    assert!(edge("run/shear/mod.rs", "run/mod.rs"));
    assert!(edge("cli/mod.rs", "cli/shear.rs"), "a bare child path");
    assert!(edge("cli/shear.rs", "cli/args.rs"));

    // Layers, lowest first: a file imports its own layer and those below, never one above.
    // The solver reads its own types (ShearSetup, TwoBody, PairParams from Elastic and
    // Coefficients), built from a case by spec: it never imports the description (issue #38).
    let layer = |f: &str| -> usize {
        let top = f.split('/').next().unwrap();
        match top {
            "error.rs" | "fsutil.rs" => 0,
            "solver" => 1,
            "spec" | "packing.rs" => 2,
            "deck" => 3,
            "run" | "series.rs" | "compare.rs" | "calibration.rs" | "profile.rs"
            | "liggghts.rs" | "chung_ooi.rs" | "shear.rs" | "vtk.rs" | "rotation_map.rs"
            | "ranks.rs" => 4,
            "report" => 5,
            "cli" | "lib.rs" | "main.rs" => 6,
            _ => panic!("{f}: no layer; add it to tests/architecture.rs"),
        }
    };
    const NAMES: [&str; 7] = ["base", "solver", "spec", "deck", "run", "report", "cli"];
    // Every arrow points down (issue #38 turned the last 21 round): any import of a layer
    // above is an offender.
    let mut offenders = Vec::new();
    for (f, deps) in &graph {
        let (rf, lf) = (rel(f), layer(&rel(f)));
        for d in deps {
            let ld = layer(&rel(d));
            if ld > lf {
                offenders.push(format!(
                    "{} ({}) imports {} ({})",
                    rf,
                    NAMES[lf],
                    rel(d),
                    NAMES[ld]
                ));
            }
        }
    }
    assert!(
        offenders.is_empty(),
        "a layer imports one above it:\n{}",
        offenders.join("\n")
    );

    // No circle anywhere, cli included: a study runs any command, and gets the dispatcher
    // (cli/mod.rs's `execute`) as an argument instead of importing it; the grammar it parses
    // is cli/command.rs. (Issue #38 took the last parent/child circles off: the types a parent
    // module's children share are in files of their own, solver/contact/data.rs,
    // solver/shear/records.rs, solver/shear/pairs/data.rs.)
    assert!(edge("cli/study.rs", "cli/command.rs"));
    assert!(edge("cli/mod.rs", "cli/study.rs"));
    let circles: Vec<String> = components(&graph)
        .iter()
        .map(|scc| scc.iter().map(|p| rel(p)).collect::<Vec<_>>().join(", "))
        .collect();
    assert!(
        circles.is_empty(),
        "import circles:\n{}",
        circles.join("\n")
    );
}

/// The strongly connected components of more than one file (Tarjan): each a set of files
/// that reach each other by imports.
fn components(g: &BTreeMap<PathBuf, BTreeSet<PathBuf>>) -> Vec<Vec<PathBuf>> {
    struct T<'a> {
        g: &'a BTreeMap<PathBuf, BTreeSet<PathBuf>>,
        index: BTreeMap<&'a PathBuf, usize>,
        low: BTreeMap<&'a PathBuf, usize>,
        stack: Vec<&'a PathBuf>,
        on: BTreeSet<&'a PathBuf>,
        out: Vec<Vec<PathBuf>>,
    }
    impl<'a> T<'a> {
        fn visit(&mut self, v: &'a PathBuf) {
            let i = self.index.len();
            self.index.insert(v, i);
            self.low.insert(v, i);
            self.stack.push(v);
            self.on.insert(v);
            for w in self.g.get(v).into_iter().flatten() {
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let lw = self.low[w];
                    let lv = self.low.get_mut(v).unwrap();
                    *lv = (*lv).min(lw);
                } else if self.on.contains(w) {
                    let iw = self.index[w];
                    let lv = self.low.get_mut(v).unwrap();
                    *lv = (*lv).min(iw);
                }
            }
            if self.low[v] == self.index[v] {
                let mut c = Vec::new();
                loop {
                    let w = self.stack.pop().unwrap();
                    self.on.remove(w);
                    c.push(w.clone());
                    if w == v {
                        break;
                    }
                }
                if c.len() > 1 {
                    c.sort();
                    self.out.push(c);
                }
            }
        }
    }
    let mut t = T {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in g.keys() {
        if !t.index.contains_key(v) {
            t.visit(v);
        }
    }
    t.out
}

/// The print macros a file's library code (its test code left out) invokes.
struct Prints {
    found: Vec<String>,
}

impl<'ast> syn::visit::Visit<'ast> for Prints {
    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        if !is_test(&m.attrs) {
            syn::visit::visit_item_mod(self, m);
        }
    }

    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        if !is_test(&f.attrs) && !f.attrs.iter().any(|a| a.path().is_ident("test")) {
            syn::visit::visit_item_fn(self, f);
        }
    }

    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        let name = m.path.segments.last().map(|s| s.ident.to_string());
        if let Some(n) = name.filter(|n| PRINTS.contains(&n.as_str())) {
            self.found.push(format!("{n}!"));
        }
        // inside a macro's tokens (a `macro_rules!` body, another macro's arguments)
        self.tokens(m.tokens.clone());
        syn::visit::visit_macro(self, m);
    }
}

const PRINTS: [&str; 5] = ["println", "eprintln", "print", "eprint", "dbg"];

impl Prints {
    fn tokens(&mut self, ts: proc_macro2::TokenStream) {
        let tt: Vec<proc_macro2::TokenTree> = ts.into_iter().collect();
        for (k, t) in tt.iter().enumerate() {
            match t {
                proc_macro2::TokenTree::Group(g) => self.tokens(g.stream()),
                proc_macro2::TokenTree::Ident(id)
                    if PRINTS.contains(&id.to_string().as_str())
                        && matches!(tt.get(k + 1), Some(proc_macro2::TokenTree::Punct(p)) if p.as_char() == '!') =>
                {
                    self.found.push(format!("{id}! (in a macro)"));
                }
                _ => {}
            }
        }
    }
}

/// Only the command layer writes to the terminal (issue #38): the library says what it has
/// to say through `run::tell` (lines, warnings, notes, progress), and `verify` shows it
/// (cli/console.rs). One exception: a serving MPI rank (no sink) that cannot start says why
/// on stderr before it ends.
#[test]
fn only_the_command_layer_prints() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let allowed: [(&str, usize); 1] = [("shear.rs", 1)];
    let mut offenders = Vec::new();
    let mut seen_allowed = 0;
    let mut cli_prints = 0;
    for f in &files {
        let rel = f.strip_prefix(&src).unwrap().display().to_string();
        let file = syn::parse_file(&std::fs::read_to_string(f).unwrap()).unwrap();
        let mut p = Prints { found: Vec::new() };
        syn::visit::Visit::visit_file(&mut p, &file);
        if rel.starts_with("cli/") || rel == "main.rs" {
            cli_prints += p.found.len();
            continue;
        }
        // test code in files of their own
        if rel.ends_with("/tests.rs") {
            continue;
        }
        match allowed.iter().find(|(a, _)| *a == rel) {
            Some((_, n)) if p.found.len() == *n => seen_allowed += 1,
            _ if p.found.is_empty() => {}
            _ => offenders.push(format!("{rel}: {}", p.found.join(", "))),
        }
    }
    // the visitor must see prints where they are (a reader that finds none passes nothing)
    assert!(
        cli_prints >= 5,
        "prints read in cli/ and main.rs: {cli_prints}"
    );
    assert!(
        offenders.is_empty(),
        "the library prints (say it through run::tell instead):\n{}",
        offenders.join("\n")
    );
    assert_eq!(
        seen_allowed,
        allowed.len(),
        "an allowed print is gone: take it off the list"
    );
}
