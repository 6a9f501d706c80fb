//! The native solver against the stored LIGGGHTS outputs (no LIGGGHTS needed), and the
//! committed decks against the generator.

use dem_verify::compare::{compare, CONTACT_RTOL};
use dem_verify::deck::run_name;
use dem_verify::run::contact::{contact_runs, write_decks, RollingChoice};
use dem_verify::series::{contact_series, Series};
use dem_verify::solver::two_body;
use dem_verify::spec::builtin::builtin_case;
use dem_verify::spec::{CaseFile, RollingModel};
use std::path::Path;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn native_matches_stored_reference_for_every_case() {
    for case in contact_runs("all", None, RollingChoice::All).unwrap() {
        let name = run_name(&case);
        let stored = Series::read_csv(
            &root()
                .join("reference/contact")
                .join(&name)
                .join("liggghts.csv"),
        )
        .unwrap();
        let native = contact_series(&case, &two_body::run(&case.two_body()).unwrap())
            .unwrap()
            .at_steps(&stored.steps)
            .unwrap();
        for r in compare(
            &case.name,
            case.models.rolling.keyword(),
            &stored,
            &native,
            CONTACT_RTOL,
        )
        .unwrap()
        {
            assert!(r.pass, "{name}: {} rel err {:e}", r.channel, r.max_rel_err);
            // bit for bit, as claimed (the stored outputs have 17 significant digits)
            assert!(
                r.max_abs_err == 0.0,
                "{name}: {} not bit for bit: abs err {:e}",
                r.channel,
                r.max_abs_err
            );
        }
        assert!(root()
            .join("reference/contact")
            .join(&name)
            .join("provenance.json")
            .is_file());
    }
}

/// The committed decks under liggghts_inputs/ are what the generator writes now. Re-bless
/// deliberately with `verify decks` (or UPDATE_GOLDEN=1) and review the diff.
#[test]
fn committed_decks_match_the_generator() {
    let committed = root().join("liggghts_inputs");
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        write_decks(&committed).unwrap();
    }
    let fresh = tempfile::tempdir().unwrap();
    let n = write_decks(fresh.path()).unwrap();
    let mut compared = 0;
    for entry in walk(&fresh.path().join("contact")) {
        let rel = entry.strip_prefix(fresh.path()).unwrap();
        let old = std::fs::read_to_string(committed.join(rel))
            .unwrap_or_else(|_| panic!("{} is not committed; run `verify decks`", rel.display()));
        let new = std::fs::read_to_string(&entry).unwrap();
        assert_eq!(
            old,
            new,
            "{} differs from the generator; run `verify decks` and review",
            rel.display()
        );
        compared += 1;
    }
    assert!(compared >= 2 * n, "compared {compared} files for {n} decks");
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// Negative controls: the stored-reference comparison has the power to see a wrong model.
/// A 10 % wrong sliding friction (tangential_slip) and a 10 % wrong rolling stiffness
/// (rolling_elastic, epsd3's `rollingStiffness`) must each fail it, in the channel they move.
#[test]
fn a_wrong_friction_or_rolling_stiffness_fails_the_contact_comparison() {
    type Wrong = fn(&mut CaseFile);
    let controls: [(&str, RollingModel, Wrong, &str); 2] = [
        (
            "tangential_slip",
            RollingModel::Off,
            |c| c.material.friction *= 1.1,
            "ft",
        ),
        (
            "rolling_elastic",
            RollingModel::Epsd3,
            |c| c.material.rolling_stiffness *= 1.1,
            "m_roll",
        ),
    ];
    for (name, model, wrong, channel) in controls {
        let right = builtin_case(name).unwrap().with_rolling(model);
        let stored = Series::read_csv(
            &root()
                .join("reference/contact")
                .join(run_name(&right.clone().validate().unwrap()))
                .join("liggghts.csv"),
        )
        .unwrap();
        let mut file = right.clone();
        wrong(&mut file);
        let case = file.validate().unwrap();
        let native = contact_series(&case, &two_body::run(&case.two_body()).unwrap())
            .unwrap()
            .at_steps(&stored.steps)
            .unwrap();
        let results = compare(name, model.keyword(), &stored, &native, CONTACT_RTOL).unwrap();
        let r = results.iter().find(|r| r.channel == channel).unwrap();
        assert!(
            !r.pass && r.max_rel_err > 1e-3,
            "{name}/{model}: a 10 % wrong model passed in {channel} (rel err {:e})",
            r.max_rel_err
        );
    }
}
