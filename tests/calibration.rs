//! The steady-friction verdict as a measured instrument (docs/verdicts.md): its outcome rates
//! recomputed from the stored per-seed paired sets (reference/calibration/<preset>.json) must
//! be the table in docs/verdicts.md and the rates `verify shear` cites, and must keep the
//! promises the verdict makes: equal codes rarely DISAGREE, a large error never agrees.

use dem_verify::calibration::{cited, markdown, table, Stored, CITED, SEED_COUNTS};
use dem_verify::compare::MU_MARGIN;
use dem_verify::spec::shear::Preset;
use std::path::Path;

fn stored(preset: &str) -> Stored {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("reference/calibration")
        .join(format!("{preset}.json"));
    Stored::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn the_docs_table_and_the_cited_rates_are_what_the_stored_sets_give() {
    let docs =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/verdicts.md"))
            .unwrap();
    let mut compared = 0;
    for (name, preset) in [("ci", Preset::Ci), ("fast", Preset::Fast)] {
        let s = stored(name);
        assert_eq!(s.preset, preset);
        assert!(
            s.sets.iter().any(|set| set.equal) && s.sets.iter().any(|set| !set.equal),
            "{name}: needs equal-code sets and known-error sets"
        );
        let rows = table(&s, MU_MARGIN);
        let md = markdown(&rows);
        // a header, its rule and one line per row (an empty table is contained in any text:
        // a cargo-mutants survivor)
        assert_eq!(md.lines().count(), 2 + rows.len(), "{md}");
        assert!(
            docs.contains(&md),
            "docs/verdicts.md lacks the {name} table recomputed from the stored sets:\n{md}"
        );
        for n in SEED_COUNTS {
            let got = cited(&rows, preset, n).unwrap();
            let c = CITED
                .iter()
                .find(|c| c.preset == preset && c.seeds == n)
                .unwrap_or_else(|| panic!("CITED lacks {name} at {n} seeds"));
            for (what, got, want) in [
                ("false alarm", got.false_alarm, c.false_alarm),
                ("agree", got.agree, c.agree),
                ("power against mu_p x1.1", got.power_mup, c.power_mup),
                (
                    "power against the synthetic shift",
                    got.power_shift,
                    c.power_shift,
                ),
            ] {
                assert!(
                    (got - want).abs() < 1e-12 || (got.is_nan() && want.is_nan()),
                    "{name}, {n} seeds: CITED {what} {want} but the stored sets give {got}"
                );
            }
            compared += 1;
        }
    }
    assert_eq!(compared, 2 * SEED_COUNTS.len());
}

#[test]
fn equal_codes_rarely_disagree_and_a_difference_of_the_papers_size_never_agrees() {
    let mut synthetic = 0;
    for name in ["ci", "fast"] {
        let rows = table(&stored(name), MU_MARGIN);
        assert!(!rows.is_empty());
        for r in &rows {
            let sum = r.rates.agree + r.rates.disagree + r.rates.inconclusive;
            assert!((sum - 1.0).abs() < 1e-9, "{r:?}");
            if r.equal {
                // the promise of "DISAGREE must mean a difference": at most 5 % false alarms
                assert!(
                    r.rates.disagree <= 0.05,
                    "{name} {} at {} seeds: false alarm {:.1} %",
                    r.label,
                    r.seeds,
                    100.0 * r.rates.disagree
                );
                // equal codes: the paired mean is consistent with 0 (within 3 standard errors)
                let se = r.pool_sd / (r.pool as f64).sqrt();
                assert!(
                    r.pool_mean.abs() <= 3.0 * se,
                    "{name} {}: equal codes differ by {:+.4} (se {:.4})",
                    r.label,
                    r.pool_mean,
                    se
                );
            } else if r.label.ends_with("(synthetic)") {
                // a difference of the paper's smallest effect is never called "agree"
                assert!(
                    r.rates.agree <= 0.005,
                    "{name} {}: a difference of 0.1 agrees in {:.2} % of draws",
                    r.label,
                    100.0 * r.rates.agree
                );
                synthetic += 1;
            }
        }
    }
    assert!(
        synthetic > 0,
        "no synthetic-shift rows: nothing tested the power"
    );
}
