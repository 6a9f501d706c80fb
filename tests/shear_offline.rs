//! Shear physics checked without LIGGGHTS: the native solver against a stored LIGGGHTS run of
//! the same shear, step by step. Both start from the same compacted ci-preset state (the
//! native compaction, deterministic, recomputed here) and shear for `STEPS` steps at the
//! paper's material (e = 1), epsd, (mu_r, eta_r) = (0.5, 0). Round-off grows chaotically, so
//! the codes cannot agree forever; the stated tolerance is that they agree (every channel
//! within 1e-6 of its peak) at least half as long as the native solver agrees with itself
//! after a 1-ulp nudge, and at least 200 steps. Negative control: a 10 % wrong sliding
//! friction must lose that agreement at once.
//!
//! `UPDATE_GOLDEN=1` regenerates the stored run with LIGGGHTS (and its provenance).

mod common;

use dem_verify::compare::{lockstep, Horizon, LOCKSTEP_RTOL};
use dem_verify::fsutil::{sha256_hex, write_atomic};
use dem_verify::packing::{chaos_probe, loose_packing, Packing};
use dem_verify::run::progress::Progress;
use dem_verify::run::shear::{lockstep_case, shear_lockstep, LOCKSTEP_CHANNELS};
use dem_verify::series::Series;
use dem_verify::shear::{run_native, shear_series, Checkpointing};
use dem_verify::solver::shear::compact;
use dem_verify::spec::shear::{CaseRequest, Overrides, Preset, Protocol, ShearCase};
use dem_verify::spec::RollingModel;
use std::path::{Path, PathBuf};

const STEPS: u64 = 3000;

fn reference_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("reference/shear/ci_lockstep_epsd_mur0.5_etar0")
}

fn native(case: &ShearCase, start: &Packing) -> Series {
    let dir = tempfile::tempdir().unwrap();
    let run = run_native(
        case,
        start,
        dir.path(),
        &Progress::hidden(),
        Checkpointing::Off,
    )
    .unwrap();
    shear_series(case, &run.rows)
}

fn horizon(a: &Series, b: &Series) -> Horizon {
    lockstep(a, b, &LOCKSTEP_CHANNELS, LOCKSTEP_RTOL)
}

#[test]
fn native_shear_follows_the_stored_liggghts_run() {
    let (case, _) = ShearCase::build(&CaseRequest {
        preset: Preset::Ci,
        rolling: RollingModel::Epsd,
        mu_r: 0.5,
        eta_r: 0.0,
        seed: 1,
        protocol: Protocol::default(),
        overrides: Overrides::default(),
        allow_inertial: false,
    })
    .unwrap();
    assert_eq!(case.material.restitution, 1.0);
    let compacted = compact(&case.setup(), &loose_packing(&case), case.compression_steps).unwrap();
    let lc = lockstep_case(&case, STEPS);
    let csv = reference_dir().join("liggghts.csv");
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        let lig = common::liggghts();
        let tmp = tempfile::tempdir().unwrap();
        shear_lockstep(&case, &compacted, &lig, tmp.path(), STEPS).unwrap();
        let bytes = std::fs::read(tmp.path().join("liggghts.csv")).unwrap();
        write_atomic(&csv, &bytes).unwrap();
        let prov = serde_json::json!({
            "liggghts_version": lig.version(),
            "what": "LIGGGHTS shear of the ci preset (epsd, mu_r 0.5, eta_r 0, e 1, seed 1) for \
                     3000 steps from the native compacted state (tests/shear_offline.rs)",
            "rows": Series::read_csv(&csv).unwrap().rows.len(),
            "sha256": sha256_hex(&bytes),
        });
        write_atomic(
            &reference_dir().join("provenance.json"),
            serde_json::to_string_pretty(&prov).unwrap().as_bytes(),
        )
        .unwrap();
    }
    let bytes = std::fs::read(&csv).unwrap();
    let prov: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(reference_dir().join("provenance.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        prov["sha256"],
        sha256_hex(&bytes),
        "the stored run was changed"
    );
    let stored = Series::read_csv(&csv).unwrap();
    assert_eq!(prov["rows"], stored.rows.len());
    assert_eq!(
        stored.steps.last(),
        Some(&lc.total_steps()),
        "a whole run is stored"
    );

    let ours = native(&lc, &compacted);
    let codes = horizon(&stored, &ours);
    let mut nudged = compacted.clone();
    let mid = chaos_probe(nudged.position.len());
    nudged.position[mid][0] = f64::from_bits(nudged.position[mid][0].to_bits() + 1);
    let chaos = horizon(&ours, &native(&lc, &nudged));
    let mut wrong = lc.clone();
    wrong.material.friction *= 1.1;
    let control = horizon(&stored, &native(&wrong, &compacted));
    eprintln!(
        "agreement with the stored LIGGGHTS run: {} steps; native vs 1-ulp native: {} steps; \
         10 % wrong friction: {} steps",
        codes.last_agree_step, chaos.last_agree_step, control.last_agree_step
    );
    assert!(
        codes.last_agree_step >= 200 && 2 * codes.last_agree_step >= chaos.last_agree_step,
        "codes agree for {} steps, the chaos baseline is {} ({:?})",
        codes.last_agree_step,
        chaos.last_agree_step,
        codes
    );
    assert!(
        control.last_agree_step * 5 < codes.last_agree_step,
        "a 10 % wrong friction agrees for {} steps: the check has no power",
        control.last_agree_step
    );
}

/// The calibration's rolling-stiffness error is a pure one: epsd3 with the factor 2.25 is epsd
/// bit for bit over the lockstep run (so `--rolling epsd3 --rolling-stiffness 2.475` against
/// epsd differs in k_r by exactly 10 % and in nothing else), and 2.475 leaves lockstep.
#[test]
fn epsd3_at_the_epsd_factor_is_epsd_bit_for_bit() {
    let build = |rolling, k: Option<f64>| {
        ShearCase::build(&CaseRequest {
            preset: Preset::Ci,
            rolling,
            mu_r: 0.5,
            eta_r: 0.5,
            seed: 1,
            protocol: Protocol::default(),
            overrides: Overrides {
                rolling_stiffness: k,
                ..Overrides::default()
            },
            allow_inertial: false,
        })
        .unwrap()
        .0
    };
    let epsd = build(RollingModel::Epsd, None);
    let compacted = compact(&epsd.setup(), &loose_packing(&epsd), epsd.compression_steps).unwrap();
    let run = |c: &ShearCase| native(&lockstep_case(c, STEPS), &compacted);
    let base = run(&epsd);
    let same = run(&build(RollingModel::Epsd3, Some(2.25)));
    assert_eq!(base.rows.len(), same.rows.len());
    assert!(base.rows == same.rows, "epsd3 at 2.25 differs from epsd");
    let stiffer = run(&build(RollingModel::Epsd3, Some(2.475)));
    assert!(
        horizon(&base, &stiffer).last_agree_step < STEPS,
        "k_r x 1.1 changes nothing"
    );
    let e = CaseRequest {
        preset: Preset::Ci,
        rolling: RollingModel::Epsd,
        mu_r: 0.5,
        eta_r: 0.5,
        seed: 1,
        protocol: Protocol::default(),
        overrides: Overrides {
            rolling_stiffness: Some(2.475),
            ..Overrides::default()
        },
        allow_inertial: false,
    };
    let err = ShearCase::build(&e).unwrap_err().to_string();
    assert!(
        err.contains("--rolling-stiffness") && err.contains("epsd3"),
        "{err}"
    );
}
