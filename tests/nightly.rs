//! `verify nightly --quick` end to end against live LIGGGHTS, and its report checked in a real
//! browser (Debian's chromium, headless): it loads without script or console errors, every plot
//! is present with a size and content, and a screenshot is kept in
//! target/tmp/nightly-test/report.png.

mod common;

use common::{browse, text, verify};
use dem_verify::run::nightly::NightlySummary;
use std::path::Path;

fn body_attr(dom: &str, name: &str) -> Option<usize> {
    let key = format!("{name}=\"");
    let start = dom.find(&key)? + key.len();
    dom[start..].split('"').next()?.parse().ok()
}

#[test]
fn quick_night_never_disagrees_and_its_report_renders_in_chromium() {
    common::liggghts();
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("nightly-test");
    let _ = std::fs::remove_dir_all(&root);
    let out = root.join("night");
    let history = root.join("history.jsonl");
    let o = verify(&[
        "nightly",
        "--quick",
        "--out",
        out.to_str().unwrap(),
        "--history",
        history.to_str().unwrap(),
    ]);
    // one seed per shear point: a row whose two block CIs straddle the margin cannot decide,
    // and the night then says inconclusive (exit 3); a disagreement or an error never passes
    let code = o.status.code();
    assert!(code == Some(0) || code == Some(3), "{}", text(&o));

    // the night's outcome, read back typed (schema checked)
    let s: NightlySummary = dem_verify::run::load(&out.join("summary.json")).unwrap();
    assert!(s.pass && s.quick);
    assert_eq!(
        code == Some(3),
        s.shear.iter().any(|r| r.inconclusive),
        "exit 3 exactly when a row is inconclusive"
    );
    assert_eq!(
        s.contact.len(),
        23,
        "every built-in case x applicable model"
    );
    for c in &s.contact {
        // the verdict's rule is rtol 1e-9; the claim (README, docs/nightly.md) is bit for bit
        assert!(c.max_rel_err == 0.0, "not bit for bit: {c:?}");
    }
    assert_eq!(s.shear.len(), 5);
    for r in &s.shear {
        for (code, st) in [("liggghts", &r.liggghts), ("native", &r.native)] {
            let stats = st.as_ref().unwrap();
            // the plates' grip of the last stage, from the code's own particles
            let p = stats.profile.as_ref().unwrap();
            assert!(
                p.layers[0].u > p.layers.last().unwrap().u,
                "{} {code}: {p:?}",
                r.name
            );
            let st = &stats.steady;
            assert!(
                (0.1..0.9).contains(&st.mu),
                "{} {code}: mu {}",
                r.name,
                st.mu
            );
            assert!(
                (st.normal_stress / 1e7 - 1.0).abs() < 0.03,
                "{}",
                st.normal_stress
            );
            assert!(st.erot > 0.0);
        }
        assert!(r.lockstep_steps.unwrap() > 10, "{r:?}");
        // every shear point is also replayed contact by contact, and agrees
        let rp = r.replay.as_ref().unwrap();
        assert!(rp.pass, "{r:?}");
        assert_eq!(rp.windows, 4, "{r:?}");
        assert!(rp.worst_step1 <= 1e-12, "{r:?}");
        assert_eq!(rp.min_horizon, 12, "{r:?}");
    }
    // the paper's point with the unstable explicit dashpot is flagged
    let unstable: Vec<&str> = s
        .shear
        .iter()
        .filter(|r| r.dashpot_stable == Some(false))
        .map(|r| r.name.as_str())
        .collect();
    assert!(
        unstable.contains(&"ci/epsd mu_r=1 eta_r=0.5"),
        "{unstable:?}"
    );
    assert_eq!(
        std::fs::read_to_string(&history).unwrap().lines().count(),
        28,
        "one history line per case"
    );

    // the report in a real browser
    let report = out.join("report.html");
    let html = std::fs::read_to_string(&report).unwrap();
    assert!(
        !html.contains("src=\"http") && !html.contains("href=\"http"),
        "self-contained: no network resources"
    );
    let expected = body_attr(&html, "data-plots-expected").unwrap();
    // 1 bar chart + 2 trend plots + 6 per shear case + 2 per contact run
    assert_eq!(expected, 1 + 2 + 5 * 6 + 23 * 2);
    let dom = browse(&root.join("profile-dom"), &report, &["--dump-dom"]);
    assert!(dom.status.success(), "{}", text(&dom));
    let dom_text = String::from_utf8_lossy(&dom.stdout);
    assert_eq!(
        body_attr(&dom_text, "data-script-errors"),
        Some(0),
        "script errors"
    );
    assert_eq!(body_attr(&dom_text, "data-plots-found"), Some(expected));
    assert_eq!(
        body_attr(&dom_text, "data-plots-ok"),
        Some(expected),
        "every plot rendered with a size and content"
    );
    let stderr = String::from_utf8_lossy(&dom.stderr);
    let console: Vec<&str> = stderr.lines().filter(|l| l.contains("CONSOLE")).collect();
    assert!(console.is_empty(), "console messages: {console:?}");
    let shot = root.join("report.png");
    common::screenshot(&root.join("profile-shot"), &report, &shot, "1400,2400");
    println!("screenshot of the report: {}", shot.display());
}

#[test]
fn nightly_refuses_a_corrupt_history_before_running() {
    let dir = tempfile::tempdir().unwrap();
    let history = dir.path().join("history.jsonl");
    std::fs::write(&history, "{\"night\": 1\n").unwrap();
    let o = verify(&[
        "nightly",
        "--quick",
        "--out",
        dir.path().join("night").to_str().unwrap(),
        "--history",
        history.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("line 1"), "{}", text(&o));
    assert_eq!(
        std::fs::read_to_string(&history).unwrap(),
        "{\"night\": 1\n",
        "history untouched"
    );
    assert!(!dir.path().join("night").exists(), "nothing run");
}

#[test]
fn nightly_without_liggghts_says_how_to_install_it() {
    let dir = tempfile::tempdir().unwrap();
    let o = verify(&[
        "nightly",
        "--quick",
        "--out",
        dir.path().join("night").to_str().unwrap(),
        "--liggghts",
        "/nonexistent/liggghts",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("apt-get install -y liggghts"),
        "{}",
        text(&o)
    );
}
