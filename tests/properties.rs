//! Property tests of the input edge: thousands of generated case files and `verify shear`
//! argument sets, valid and invalid. Every refusal must be a typed error that names the field
//! (or the option) it refuses, never a panic; every accepted input must render its LIGGGHTS
//! deck and run natively (a few steps of a shear case; a whole short contact case).

use clap::Parser;
use dem_verify::cli::{Cli, Command};
use dem_verify::deck::contact_deck;
use dem_verify::deck::shear::shear_deck;
use dem_verify::error::Error;
use dem_verify::packing::loose_packing;
use dem_verify::solver::shear::ShearSim;
use dem_verify::solver::two_body;
use dem_verify::spec::builtin::{builtin_case, builtin_names};
use dem_verify::spec::CaseFile;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::path::Path;

/// Values a mutation writes into a numeric field: the extremes that broke the validator
/// before (subnormal, huge, NaN, infinities, negative, zero) and plausible ones.
fn number() -> impl Strategy<Value = toml::Value> {
    prop_oneof![
        Just(toml::Value::Float(f64::NAN)),
        Just(toml::Value::Float(f64::INFINITY)),
        Just(toml::Value::Float(f64::NEG_INFINITY)),
        Just(toml::Value::Float(0.0)),
        Just(toml::Value::Float(-0.0)),
        Just(toml::Value::Float(1e-320)),
        Just(toml::Value::Float(1e308)),
        Just(toml::Value::Float(-1e308)),
        Just(toml::Value::Integer(0)),
        Just(toml::Value::Integer(-1)),
        Just(toml::Value::Integer(i64::MAX)),
        (-3.0f64..3.0).prop_map(toml::Value::Float),
        (-12i32..4, 1.0f64..10.0).prop_map(|(e, m)| toml::Value::Float(m * 10f64.powi(e))),
        (0i64..5000).prop_map(toml::Value::Integer),
        Just(toml::Value::String("shell touch /tmp/pwned".into())),
        Just(toml::Value::Boolean(true)),
    ]
}

/// Every leaf of a TOML value, as a path of keys and indices.
fn leaves(v: &toml::Value, path: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match v {
        toml::Value::Table(t) => {
            for (k, x) in t {
                path.push(k.clone());
                leaves(x, path, out);
                path.pop();
            }
        }
        toml::Value::Array(a) if a.iter().all(|x| x.is_table() || x.is_array()) => {
            for (i, x) in a.iter().enumerate() {
                path.push(i.to_string());
                leaves(x, path, out);
                path.pop();
            }
        }
        _ => out.push(path.clone()),
    }
}

/// The value at `path`, if an earlier edit left it there.
fn at<'a>(v: &'a mut toml::Value, path: &[String]) -> Option<&'a mut toml::Value> {
    path.iter().try_fold(v, |v, k| match v {
        toml::Value::Table(t) => t.get_mut(k),
        toml::Value::Array(a) => a.get_mut(k.parse::<usize>().ok()?),
        _ => None,
    })
}

/// The top-level keys of a case file: a refusal must name one of them.
const CASE_FIELDS: [&str; 12] = [
    "version",
    "name",
    "description",
    "dt",
    "steps",
    "output_every",
    "rolling_models",
    "reverse_at_step",
    "material",
    "models",
    "wall",
    "particles",
];

/// One case file: a built-in case with 1-3 leaves replaced (or a key removed, or an unknown
/// key added), its run kept short.
fn case_text() -> impl Strategy<Value = String> {
    let names: Vec<&'static str> = builtin_names().collect();
    (
        proptest::sample::select(names),
        proptest::collection::vec((any::<prop::sample::Index>(), number(), 0u8..10), 1..4),
    )
        .prop_map(|(name, edits)| {
            let file = builtin_case(name).unwrap();
            let mut v = toml::Value::try_from(&file).unwrap();
            // short runs: every accepted case is run
            let steps = v["steps"].as_integer().unwrap().min(600);
            v["steps"] = toml::Value::Integer(steps);
            v["output_every"] = toml::Value::Integer(1);
            if let Some(r) = v.get("reverse_at_step").and_then(|r| r.as_integer()) {
                v["reverse_at_step"] = toml::Value::Integer(r.min(steps - 1));
            }
            let mut paths = Vec::new();
            leaves(&v, &mut Vec::new(), &mut paths);
            for (idx, value, kind) in edits {
                let path = idx.get(&paths).clone();
                match kind {
                    0 => {
                        // remove the key
                        let (last, parent) = path.split_last().unwrap();
                        if let Some(toml::Value::Table(t)) = at(&mut v, parent) {
                            t.remove(last);
                        }
                    }
                    1 => {
                        let (_, parent) = path.split_last().unwrap();
                        if let Some(toml::Value::Table(t)) = at(&mut v, parent) {
                            t.insert("unknown_field".into(), value);
                        }
                    }
                    _ => {
                        if let Some(x) = at(&mut v, &path) {
                            *x = value;
                        }
                    }
                }
            }
            toml::to_string(&v).unwrap_or_default()
        })
}

/// A refusal of a case file names a field of it, or is a parse error of the file.
fn names_a_field(e: &Error) -> bool {
    match e {
        Error::Invalid { field, .. } => CASE_FIELDS.iter().any(|f| field.starts_with(f)),
        Error::Unknown { .. } | Error::CaseFile { .. } => true,
        _ => false,
    }
}

#[test]
fn generated_case_files_are_refused_by_field_or_run() {
    let mut runner = TestRunner::new(Config {
        cases: 8000,
        failure_persistence: None,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20261202),
        ..Config::default()
    });
    let (mut accepted, mut refused) = (0u32, 0u32);
    let counts = std::cell::RefCell::new((0u32, 0u32));
    runner
        .run(&case_text(), |text| {
            let parsed = CaseFile::from_toml(&text, Path::new("generated.toml"));
            let result = parsed.and_then(|f| {
                let models = f.applicable_rolling();
                let mut cases = Vec::new();
                for m in models {
                    cases.push(f.with_rolling(m).validate()?);
                }
                Ok(cases)
            });
            match result {
                Err(e) => {
                    prop_assert!(names_a_field(&e), "refusal names no field: {e}\n{text}");
                    counts.borrow_mut().1 += 1;
                }
                Ok(cases) => {
                    for case in cases {
                        let deck = contact_deck(&case);
                        prop_assert!(deck.get("in.deck").is_some_and(|d| !d.contains("shell")));
                        match two_body::run(&case.two_body()) {
                            Ok(frames) => prop_assert!(!frames.is_empty()),
                            // a run may stop, with the step and the reason, never panic
                            Err(Error::Solver { .. }) => {}
                            Err(e) => prop_assert!(false, "accepted case failed: {e}\n{text}"),
                        }
                    }
                    counts.borrow_mut().0 += 1;
                }
            }
            Ok(())
        })
        .unwrap();
    let c = counts.borrow();
    accepted += c.0;
    refused += c.1;
    eprintln!("case files: {accepted} accepted and run, {refused} refused by field");
    // both sides are exercised: not a test of only refusals or only acceptances
    assert!(
        accepted > 100 && refused > 2000,
        "{accepted} accepted, {refused} refused"
    );
}

/// Values for `verify shear` options: valid, edge and garbage.
fn option_value() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-1".to_string()),
        Just("0".to_string()),
        Just("1e-300".to_string()),
        Just("1e300".to_string()),
        Just("bogus".to_string()),
        Just("".to_string()),
        (0.0f64..1.5).prop_map(|x| format!("{x}")),
        (-6i32..1, 1.0f64..10.0).prop_map(|(e, m)| format!("{:e}", m * 10f64.powi(e))),
        (1u32..400).prop_map(|n| n.to_string()),
    ]
}

const SHEAR_OPTIONS: [&str; 14] = [
    "--mu-r",
    "--eta-r",
    "--rolling",
    "--seeds",
    "--first-seed",
    "--speeds",
    "--strain",
    "--dt-factor",
    "--tooth-height",
    "--tooth-wavelength",
    "--particles",
    "--restitution",
    "--mu-margin",
    "--stress-rtol",
];

#[test]
fn generated_shear_arguments_are_refused_by_option_or_start() {
    let mut runner = TestRunner::new(Config {
        cases: 2000,
        failure_persistence: None,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20261202),
        ..Config::default()
    });
    let counts = std::cell::RefCell::new((0u32, 0u32, 0u32));
    let strategy = proptest::collection::vec(
        (
            proptest::sample::select(SHEAR_OPTIONS.to_vec()),
            option_value(),
        ),
        1..4,
    );
    runner
        .run(&strategy, |opts| {
            let mut args = vec!["verify", "shear", "--preset", "ci", "--native-only"];
            for (o, v) in &opts {
                args.push(o);
                args.push(v);
            }
            let a = match Cli::try_parse_from(&args) {
                Err(e) => {
                    // clap's refusal (exit 2) names the option
                    let msg = e.to_string();
                    prop_assert!(
                        opts.iter().any(|(o, _)| msg.contains(o)) || msg.contains("--"),
                        "{args:?}: {msg}"
                    );
                    counts.borrow_mut().0 += 1;
                    return Ok(());
                }
                Ok(Cli {
                    command: Command::Shear(a),
                    ..
                }) => a,
                Ok(_) => unreachable!("a shear command line"),
            };
            let req = a.request(a.engine(), "prop");
            match req.seed_case(req.case.seed) {
                Err(e) => {
                    let named = match &e {
                        Error::Invalid { field, .. } => !field.is_empty(),
                        Error::Unknown { .. } => true,
                        _ => false,
                    };
                    prop_assert!(named, "{args:?}: refusal names no field: {e}");
                    counts.borrow_mut().1 += 1;
                }
                Ok((case, _warnings)) => {
                    let packing = loose_packing(&case);
                    prop_assert!(shear_deck(&case, &packing).get("in.deck").is_some());
                    let mut sim = ShearSim::new(&case.setup(), &packing);
                    let ran = sim
                        .setup(0.0)
                        .and_then(|_| (0..3).try_for_each(|_| sim.step()));
                    match ran {
                        Ok(()) | Err(Error::Solver { .. }) => {}
                        Err(e) => prop_assert!(false, "{args:?}: accepted, then {e}"),
                    }
                    counts.borrow_mut().2 += 1;
                }
            }
            Ok(())
        })
        .unwrap();
    let (clap_refused, refused, accepted) = *counts.borrow();
    eprintln!(
        "shear arguments: {clap_refused} refused by the parser, {refused} by the validator, \
         {accepted} accepted and started"
    );
    assert!(
        clap_refused > 100 && refused > 200 && accepted > 100,
        "{clap_refused} / {refused} / {accepted}"
    );
}
