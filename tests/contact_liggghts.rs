//! Every built-in contact case with every applicable rolling model, run by live LIGGGHTS and
//! by the native solver: every channel agrees bit for bit (max error exactly 0, as the README
//! claims; the user-facing verdict keeps its rtol 1e-9), and the live LIGGGHTS run still
//! reproduces the stored reference.

mod common;

use dem_verify::compare::{compare, CONTACT_RTOL};
use dem_verify::deck::{contact_deck, run_name};
use dem_verify::run::contact::{
    contact_runs, liggghts_contact_series, RollingChoice, REFERENCE_STRIDE,
};
use dem_verify::series::{contact_series, Series};
use dem_verify::solver::two_body;

#[test]
fn every_builtin_case_agrees_with_live_liggghts_and_the_stored_reference() {
    let lig = common::liggghts();
    let runs = contact_runs("all", None, RollingChoice::All).unwrap();
    assert!(
        runs.len() >= 20,
        "expected all cases x models, got {}",
        runs.len()
    );
    let mut worst: Vec<(String, f64)> = Vec::new();
    for case in &runs {
        let name = run_name(case);
        let dir = tempfile::tempdir().unwrap();
        let live = liggghts_contact_series(case, &contact_deck(case), &lig, dir.path()).unwrap();
        let native = contact_series(case, &two_body::run(&case.two_body()).unwrap()).unwrap();
        let results = compare(
            &case.name,
            case.models.rolling.keyword(),
            &live,
            &native,
            CONTACT_RTOL,
        )
        .unwrap();
        for r in &results {
            assert!(
                r.pass,
                "{name}: channel {} differs: rel err {:e} at step {}",
                r.channel, r.max_rel_err, r.worst_step
            );
            // the claim is bit for bit, so the test is exactly 0 (17 significant digits in
            // LIGGGHTS' output round-trip a double)
            assert!(
                r.max_abs_err == 0.0,
                "{name}: channel {} is not bit for bit: abs err {:e} at step {}",
                r.channel,
                r.max_abs_err,
                r.worst_step
            );
        }
        let w = results.iter().map(|r| r.max_rel_err).fold(0.0, f64::max);
        worst.push((name.clone(), w));

        let stored = Series::read_csv(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("reference/contact")
                .join(&name)
                .join("liggghts.csv"),
        )
        .unwrap();
        let live_at = live.at_steps(&stored.steps).unwrap();
        assert_eq!(
            stored.steps,
            live.decimate(REFERENCE_STRIDE).steps,
            "{name}: stored reference steps"
        );
        for r in compare(&case.name, "ref", &stored, &live_at, CONTACT_RTOL).unwrap() {
            assert!(
                r.pass,
                "{name}: live LIGGGHTS no longer reproduces the stored reference in {}",
                r.channel
            );
        }
    }
    for (n, w) in &worst {
        println!("{n:<32} max rel err {w:e}");
    }
}
