//! `verify convergence` and the stability figures end to end (ci preset, short).

mod common;

use common::verify;
use dem_verify::compare::Outcome;
use dem_verify::run::convergence::{ConvergenceSummary, DtPoint, StudyCode};

#[test]
fn convergence_runs_and_reports_stability_per_dt() {
    let _ = common::liggghts();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let args = [
        "convergence",
        "--mu-r",
        "1",
        "--eta-r",
        "0.5",
        "--preset",
        "ci",
        "--seeds",
        "1",
        "--strain",
        "0.2",
        "--dt-factors",
        "1,0.5",
        "--engine",
        "both",
        "--liggghts-dt-factors",
        "1",
        "--with-implicit",
        "--out",
        out.to_str().unwrap(),
    ];
    let o = verify(&args);
    let text = common::text(&o);
    // the explicit dashpot is unstable at the paper's dt here (S = 15.6): the study must say
    // "not converged" (exit 1), never accept it
    assert_eq!(o.status.code(), Some(1), "{text}");
    let read =
        || -> ConvergenceSummary { dem_verify::run::load(&out.join("summary.json")).unwrap() };
    let s = read();
    assert!(!s.converged, "{s:?}");
    let runs: Vec<(StudyCode, f64)> = s.points.iter().map(|p| (p.code, p.dt_factor)).collect();
    // native at both dt, LIGGGHTS only where asked, the stable-dashpot model at the largest dt
    for want in [
        (StudyCode::Native, 1.0),
        (StudyCode::Native, 0.5),
        (StudyCode::Liggghts, 1.0),
        (StudyCode::Implicit, 1.0),
    ] {
        assert!(runs.contains(&want), "{want:?} missing from {runs:?}");
    }
    assert_eq!(runs.len(), 4, "{runs:?}");
    assert!(!s.inconclusive, "a difference of 0.4 is decided: {s:?}");
    // LIGGGHTS stopped at factor 1: judged and reported, but the verdict is native's
    let verdict = |code| s.per_code.iter().find(|v| v.code == code).unwrap();
    assert_eq!(
        (
            verdict(StudyCode::Native).finest_factor,
            verdict(StudyCode::Liggghts).finest_factor
        ),
        (0.5, 1.0)
    );
    assert!(!verdict(StudyCode::Native).converged);
    // both codes show the same artefact at the paper's dt: they do not differ there
    // (measured 0.258 +- 0.027 native, 0.292 +- 0.030 LIGGGHTS: one seed's block CIs cannot
    // show them within 0.03 either, so "inconclusive" is the honest word), both far below
    // native at dt / 2 (0.94 +- 0.02); the stable dashpot at the paper's dt removes most of
    // the artefact (native at dt / 2 is itself not converged, S = 7.1, so equality with it is
    // not a claim one seed can test: measured since the exact plate sum, implicit 1.188,
    // dt / 2 1.053, dt 0.239)
    assert_eq!(s.codes_agree.len(), 1, "{s:?}");
    assert_eq!(s.codes_agree[0].0, 1.0);
    assert_ne!(s.codes_agree[0].1.outcome, Outcome::Disagree, "{s:?}");
    let im = s
        .implicit_matches_finest
        .as_ref()
        .expect("with --with-implicit");
    let step = verdict(StudyCode::Native).finest_step.clone().unwrap();
    assert_eq!(step.outcome, Outcome::Disagree, "{step:?}");
    assert!(step.mean > 0.4, "dt / 2 minus dt: {step:?}");
    assert!(
        im.mean.abs() < step.mean.abs() / 3.0,
        "implicit at dt against dt / 2 {im:?}, dt / 2 against dt {step:?}"
    );
    let point = |code, f: f64| {
        s.points
            .iter()
            .find(|p| p.code == code && p.dt_factor == f)
            .unwrap()
    };
    // the stability figure falls with dt (omega_r dt and lambda dt scale with dt)
    let crit = |p: &DtPoint| p.stability.entries[0].criterion;
    let (s1, s2) = (
        crit(point(StudyCode::Native, 1.0)),
        crit(point(StudyCode::Native, 0.5)),
    );
    assert!(s2 < s1 && (s2 / s1 - 0.25).abs() < 0.25, "{s1} {s2}");
    assert!(
        !point(StudyCode::Native, 1.0).stability.stable,
        "paper dt with mu_r 1, eta_r 0.5 must be flagged"
    );
    let mu = |code, f| point(code, f).steady.mu;
    assert!(
        mu(StudyCode::Native, 1.0) + 0.4 < mu(StudyCode::Native, 0.5)
            && mu(StudyCode::Liggghts, 1.0) + 0.4 < mu(StudyCode::Native, 0.5),
        "{s:?}"
    );
    // the explicit dashpot is unstable here, the implicit one is not: it must show less
    // rotational energy at the same dt from the same compacted state
    assert!(
        point(StudyCode::Implicit, 1.0).steady.erot < point(StudyCode::Native, 1.0).steady.erot,
        "{s:?}"
    );
    for f in ["mu_dt.svg", "erot_dt.svg"] {
        assert!(out.join(f).is_file());
    }
    // resumed: every run's series is current, nothing runs again, same figures
    let o2 = verify(&args);
    let text2 = common::text(&o2);
    assert_eq!(o2.status.code(), o.status.code(), "{text2}");
    assert_eq!(text2.matches("current result kept").count(), 4, "{text2}");
    // (as JSON: NaN fields compare equal there)
    let json = |p: &[DtPoint]| serde_json::to_string(p).unwrap();
    assert_eq!(json(&read().points), json(&s.points));
    // a stored series edited on disk (one digit of its last row) is not reused: that run is
    // made again, to the same bits
    let csv = out.join("dt0.5/seed1/native.csv");
    let mut bytes = std::fs::read(&csv).unwrap();
    let k = bytes.len() - 3;
    bytes[k] = if bytes[k] == b'1' { b'2' } else { b'1' };
    std::fs::write(&csv, bytes).unwrap();
    let o3 = verify(&args);
    let text3 = common::text(&o3);
    assert_eq!(o3.status.code(), o.status.code(), "{text3}");
    assert_eq!(text3.matches("current result kept").count(), 3, "{text3}");
    assert!(text3.contains("is not reused: its bytes differ"), "{text3}");
    assert_eq!(json(&read().points), json(&s.points));
}

/// The positive side: where the explicit dashpot is stable, (mu_r, eta_r) = (0.5, 0), halving
/// dt leaves the steady friction where it was, so the study must say "converged" (exit 0):
/// the seed-paired difference is equivalent to 0 within the margin. Sized to decide whatever
/// the trajectories' last bits: the per-seed difference spreads by 0.039 (12 seeds, measured
/// 2026-12-06: -0.0099, 90 % CI [-0.0300, +0.0103]), so 3 seeds at 0.03 decided only by luck
/// (they did until the exact plate sum changed the bits, then said inconclusive); 12 seeds at
/// a margin of 0.05 (still half the paper's smallest effect, 0.1) fail to agree only when
/// the mean strays by 2.6 of its standard errors (about 1 %).
#[test]
fn a_stable_point_converges() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = verify(&[
        "convergence",
        "--mu-r",
        "0.5",
        "--eta-r",
        "0",
        "--preset",
        "ci",
        "--seeds",
        "12",
        "--mu-margin",
        "0.05",
        "--strain",
        "0.1",
        "--dt-factors",
        "1,0.5",
        "--engine",
        "native",
        "--out",
        out.to_str().unwrap(),
    ]);
    let text = common::text(&o);
    assert_eq!(o.status.code(), Some(0), "{text}");
    let s: ConvergenceSummary = dem_verify::run::load(&out.join("summary.json")).unwrap();
    assert!(s.converged, "{s:?}");
    // the equivalence test decided it: the paired difference of dt / 2 and dt over the 12
    // seeds (same compacted states) lies within 0.05
    let step = s.per_code[0].finest_step.clone().unwrap();
    assert_eq!((step.n, step.outcome), (12, Outcome::Agree), "{step:?}");
    assert_eq!(s.points.len(), 2, "{s:?}");
    for p in &s.points {
        assert!(p.stability.stable, "{p:?}");
        assert_eq!(p.steady.per_seed_mu.len(), 12);
        assert!((0.3..0.8).contains(&p.steady.mu), "{p:?}");
        // over 12 seeds (measured 0.090 and 0.093)
        assert!(p.steady.mu_ci95 > 0.0 && p.steady.mu_ci95 < 0.15, "{p:?}");
    }
    assert!(text.contains("verdict: agree"), "{text}");
}

#[test]
fn convergence_refuses_inconsistent_options() {
    for (extra, field) in [
        (
            &["--engine", "both", "--liggghts-dt-factors", "0.3"][..],
            "--liggghts-dt-factors",
        ),
        (
            &["--rolling", "epsd2", "--with-implicit"][..],
            "--with-implicit",
        ),
        (&["--dt-factors", "1,0"][..], "--dt-factors"),
        // one dt rule: the shear option is refused, not multiplied into the study's factors
        (
            &["--dt-factor", "0.5"][..],
            "invalid value for `--dt-factor`: 0.5 (valid: 1 with verify convergence",
        ),
    ] {
        let mut args = vec!["convergence", "--preset", "ci", "--mu-r", "1"];
        args.extend_from_slice(extra);
        let o = verify(&args);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", common::text(&o));
        assert!(
            String::from_utf8_lossy(&o.stderr).contains(field),
            "{extra:?}: {}",
            common::text(&o)
        );
    }
}

/// `verify shear --preset ci --native-only` with `extra`.
fn ci_shear(extra: &[&str]) -> std::process::Output {
    let mut args = vec!["shear", "--preset", "ci", "--native-only"];
    args.extend_from_slice(extra);
    verify(&args)
}

#[test]
fn strict_stability_refuses_an_unstable_dashpot() {
    let o = ci_shear(&["--mu-r", "1", "--eta-r", "0.5", "--strict-stability"]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("unstable") && e.contains("--strict-stability"),
        "{e}"
    );
    let tmp = tempfile::tempdir().unwrap();
    let ok = ci_shear(&[
        "--mu-r",
        "0.25",
        "--strict-stability",
        "--strain",
        "0.02",
        "--seeds",
        "1",
        "--out",
        tmp.path().join("o").to_str().unwrap(),
    ]);
    // a stable case is not refused (exit 0 or 1 by the stress check of this short window)
    assert_ne!(
        ok.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
}

/// The implicit rolling dashpot removes the explicit dashpot's instability: at the paper's dt
/// with mu_r = 1, eta_r = 0.5 the explicit epsd shows orders of magnitude more rotational
/// kinetic energy than epsd_implicit (which matches epsd at a converged dt, see docs/stability.md).
#[test]
fn implicit_dashpot_tames_rotational_energy_at_the_paper_dt() {
    let dir = tempfile::tempdir().unwrap();
    let mut erot = Vec::new();
    for model in ["epsd", "epsd_implicit"] {
        let out = dir.path().join(model);
        let out_s = out.to_str().unwrap();
        let o = ci_shear(&[
            "--mu-r",
            "1",
            "--eta-r",
            "0.5",
            "--seeds",
            "1",
            "--strain",
            "0.3",
            "--rolling",
            model,
            "--out",
            out_s,
        ]);
        assert!(
            matches!(o.status.code(), Some(0) | Some(1)),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let s = dem_verify::series::Series::read_csv(&out.join("seed1/native.csv")).unwrap();
        let e = s.column("erot[J]").unwrap();
        let tail = &e[e.len() / 2..];
        erot.push(tail.iter().sum::<f64>() / tail.len() as f64);
    }
    assert!(
        erot[0] > 20.0 * erot[1],
        "explicit {:e} vs implicit {:e}",
        erot[0],
        erot[1]
    );
}

#[test]
fn native_only_models_never_reach_liggghts() {
    let o = verify(&["shear", "--rolling", "epsd_implicit", "--preset", "ci"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("exists only in the native solver"));
    // contact: tests/cli.rs `unknown_case_and_model_list_the_valid_ones`
}
