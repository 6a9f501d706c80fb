//! Every page stored under reference/ is made again by this version from its stored evidence
//! (issue #36): `tools/rerender-reference.sh` on a copy of reference/ must make each page, list
//! every report.html there, and leave the evidence (summary.json, result.json) as it was.

mod common;

use std::path::{Path, PathBuf};

fn pages(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(pages(&p));
        } else if p.file_name().unwrap() == "report.html" {
            out.push(p);
        }
    }
    out.sort();
    out
}

fn copy(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let t = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy(&p, &t);
        } else {
            std::fs::copy(&p, &t).unwrap();
        }
    }
}

#[test]
fn every_stored_page_is_made_again_by_this_version() {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("reference");
    for d in ["nightly", "sweep"] {
        copy(&here.join("reference").join(d), &root.join(d));
    }
    let stored = pages(&root);
    assert!(stored.len() >= 7, "{stored:?}");
    // a page that is not made again cannot pass for one that is
    for p in &stored {
        std::fs::remove_file(p).unwrap();
    }
    let night = root.join("nightly/20261202-e1/summary.json");
    let evidence = std::fs::read(&night).unwrap();
    let o = std::process::Command::new("bash")
        .arg(here.join("tools/rerender-reference.sh"))
        .arg(&root)
        .arg(common::verify_bin())
        .output()
        .unwrap();
    let t = common::text(&o);
    assert!(o.status.success(), "{t}");
    let mut made: Vec<PathBuf> = t
        .lines()
        .filter_map(|l| l.strip_prefix("page: "))
        .map(PathBuf::from)
        .collect();
    made.sort();
    assert_eq!(made, stored, "every stored page is on the tool's list: {t}");
    for p in &made {
        let html = std::fs::read_to_string(p).unwrap();
        assert!(
            html.len() > 10_000 && html.contains("<svg"),
            "{}",
            p.display()
        );
    }
    // the night of 2026-12-02, judged by today's rules: its stress errors are the stresses'
    // (the page said 75.11 %), its verdicts the equivalence test's
    let page = std::fs::read_to_string(root.join("nightly/20261202-e1/report.html")).unwrap();
    assert!(!page.contains("75.11") && page.contains("normal stress off by 0.02 %"));
    assert!(page.contains("judged again") && page.contains("90 % CI [-0.0316, +0.0029]"));
    assert_eq!(
        std::fs::read(&night).unwrap(),
        evidence,
        "summary.json kept"
    );
}
