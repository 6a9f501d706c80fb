//! `verify sweep` end to end: the reduced sweep (ci preset, 2 x 2 parameters, 2 seeds) locally
//! with both codes, resumption, and the same sweep through a real local SLURM (job array,
//! `run-one`, `collect`), whose results must equal the local ones bit for bit.

mod common;

use common::{text, verify};
use dem_verify::run::convergence::{ConvergenceSummary, StudyCode};
use dem_verify::run::sweep::Manifest;
use std::path::Path;
use std::process::{Command, Output};

const REDUCED: [&str; 10] = [
    "--preset", "ci", "--mu-r", "0,1", "--eta-r", "0,0.5", "--seeds", "2", "--strain", "0.5",
];

fn sweep(extra: &[&str]) -> Output {
    let mut args = vec!["sweep"];
    args.extend_from_slice(&REDUCED);
    args.extend_from_slice(extra);
    verify(&args)
}

/// (id, code) -> mu from results.csv.
fn results(dir: &Path) -> Vec<(String, String, f64, f64)> {
    let mut r = csv::Reader::from_path(dir.join("results.csv")).unwrap();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            (
                rec[1].to_string(),
                rec[6].to_string(),
                rec[7].parse().unwrap(),
                rec[8].parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn reduced_sweep_runs_both_codes_resumes_and_reports() {
    common::liggghts();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let o = sweep(&[
        "--engine",
        "both",
        "--jobs",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let m = Manifest::load(&out.join("manifest.json")).unwrap();
    assert_eq!(m.runs.len(), 8);
    let mut hashes: Vec<&str> = m.runs.iter().map(|r| r.input_hash.as_str()).collect();
    hashes.sort();
    hashes.dedup();
    assert_eq!(hashes.len(), 8);
    let res = results(&out);
    assert_eq!(res.len(), 16, "8 runs x 2 codes");
    for (id, code, mu, stress) in &res {
        assert!((0.05..0.9).contains(mu), "{id} {code}: mu {mu}");
        assert!(
            (stress / 1e7 - 1.0).abs() < 0.05,
            "{id} {code}: {stress} Pa"
        );
    }
    // per point (mean over its 2 seeds), not over the whole sweep where errors could cancel:
    // the codes agree within 0.1 (two chaotic realisations of 2 seeds each of the ci preset;
    // its seed spread is about 0.03), and each code shows the paper's claim 1 (with
    // eta_r = 0, rolling resistance raises the friction: mu(1, 0) above mu(0, 0) by > 0.05)
    let point = |code: &str, mu_r: &str, eta_r: &str| {
        let v: Vec<f64> = res
            .iter()
            .filter(|r| r.1 == code && r.0.starts_with(&format!("mur{mu_r}_etar{eta_r}_")))
            .map(|r| r.2)
            .collect();
        assert_eq!(v.len(), 2, "{code} ({mu_r}, {eta_r}): {v:?}");
        v.iter().sum::<f64>() / 2.0
    };
    for (mu_r, eta_r) in [("0", "0"), ("0", "0.5"), ("1", "0"), ("1", "0.5")] {
        let (l, n) = (point("liggghts", mu_r, eta_r), point("native", mu_r, eta_r));
        assert!(
            (l - n).abs() < 0.1,
            "({mu_r}, {eta_r}): LIGGGHTS {l} vs native {n}"
        );
    }
    for code in ["liggghts", "native"] {
        let (lo, hi) = (point(code, "0", "0"), point(code, "1", "0"));
        assert!(hi > lo + 0.05, "{code}: mu(1, 0) = {hi} vs mu(0, 0) = {lo}");
    }
    let report = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(report.contains("conclusions, checked"));
    for f in [
        "figures/mu_vs_mur_stage0.svg",
        "figures/heat_native_stage0.svg",
        "figures/heat_liggghts_stage0.svg",
        "report.json",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let rep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(
        rep["conclusions"].as_array().unwrap().len(),
        2,
        "one set per code"
    );
    // mu_r = 1 with eta_r = 0.5 at the paper's dt is flagged unstable in every result
    assert!(rep["points"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["mu_r"] == 1.0 && p["eta_r"] == 0.5)
        .all(|p| p["dashpot_stable"] == false));

    // resume: nothing to run; a lost result is run again, alone
    let o = sweep(&["--engine", "both", "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        text(&o).contains("8 runs already have a current result"),
        "{}",
        text(&o)
    );
    // ... and a result edited on disk (its first friction figure) is made again from its
    // stored seeds, never read as it stands
    std::fs::remove_file(out.join("runs/mur1_etar0_s2/result.json")).unwrap();
    let edited = out.join("runs/mur0_etar0_s1/result.json");
    let t = std::fs::read_to_string(&edited).unwrap();
    let at = t.find("\"mu\": ").expect("a friction figure") + 6;
    std::fs::write(&edited, format!("{}0.999{}", &t[..at], &t[at + 5..])).unwrap();
    let o = sweep(&["--engine", "both", "--out", out.to_str().unwrap()]);
    assert!(
        text(&o).contains("6 runs already have a current result"),
        "{}",
        text(&o)
    );
    assert!(text(&o).contains("ran 2 runs"), "{}", text(&o));
    assert!(
        text(&o).contains("result.json is not reused: its bytes differ"),
        "{}",
        text(&o)
    );
    assert_eq!(
        results(&out),
        res,
        "the rerun reproduces the lost result exactly"
    );

    // another plan into the same directory is refused
    let o = verify(&[
        "sweep",
        "--preset",
        "ci",
        "--mu-r",
        "0.25",
        "--eta-r",
        "0",
        "--seeds",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("different manifest"), "{}", text(&o));

    // a convergence study of the unstable point puts its finest-dt result beside the sweep's
    let conv = dir.path().join("conv");
    let o = verify(&[
        "convergence",
        "--preset",
        "ci",
        "--mu-r",
        "1",
        "--eta-r",
        "0.5",
        "--seeds",
        "1",
        "--strain",
        "0.2",
        "--dt-factors",
        "1,0.5",
        "--out",
        conv.to_str().unwrap(),
    ]);
    assert!(
        matches!(o.status.code(), Some(0) | Some(1) | Some(3)),
        "{}",
        text(&o)
    );
    // a stage's rotation map as `verify profile` writes it from a run's snapshots (this
    // sweep writes none: the run's own map stands in for its file)
    let seed1 = out.join("runs/mur1_etar0.5_s1/seed1");
    std::fs::copy(
        seed1.join("rotation_map.svg"),
        seed1.join("rotation_map_stage1.svg"),
    )
    .unwrap();
    let o = verify(&[
        "sweep",
        "report",
        out.to_str().unwrap(),
        "--converged",
        conv.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let json = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    // report.json is read as JSON (its format is what is checked); the study typed
    let rep = json(&out.join("report.json"));
    let study: ConvergenceSummary = dem_verify::run::load(&conv.join("summary.json")).unwrap();
    let cp = rep["converged_points"].as_array().unwrap();
    assert_eq!(cp.len(), 1, "{cp:?}");
    let finest = study
        .points
        .iter()
        .find(|p| p.code == StudyCode::Native && p.dt_factor == 0.5)
        .unwrap();
    assert_eq!(cp[0]["mu"].as_f64(), Some(finest.steady.mu));
    assert_eq!(
        (cp[0]["mu_r"].as_f64(), cp[0]["eta_r"].as_f64()),
        (Some(1.0), Some(0.5))
    );
    // the argument on one page: the bottom line, the stand-in's mu(dt) figures, the judged
    // map with its sources, the rotation maps; rendered in headless Chromium, the screenshot
    // kept in target/tmp/sweep-test/report.png
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for part in [
        "Bottom line",
        "on stable or converged numbers",
        "Time-step convergence of the stand-ins",
        "against dt at (μr 1, ηr 0.5)",
        "on stable or converged numbers: each point",
        "Rotation maps",
        "rotation_map.svg",
        "runs/mur1_etar0.5_s1/seed1/rotation_map_stage1.svg",
        "stage 1, its steady window",
        "judged from",
    ] {
        assert!(html.contains(part), "the report lacks {part:?}");
    }
    assert!(out.join("figures/heat_native_stage0_judged.svg").is_file());
    assert!(out
        .join("runs/mur1_etar0.5_s1/seed1/rotation_map.svg")
        .is_file());
    // each run's own figures, drawn as it finished (from its folder, by the command)
    for f in ["mu_strain.svg", "velocity_profile.svg"] {
        assert!(out.join("runs/mur1_etar0.5_s1").join(f).is_file(), "{f}");
    }
    let keep = Path::new(env!("CARGO_TARGET_TMPDIR")).join("sweep-test");
    let _ = std::fs::remove_dir_all(&keep);
    std::fs::create_dir_all(&keep).unwrap();
    let shot = keep.join("report.png");
    common::screenshot(
        &keep.join("profile"),
        &out.join("report.html"),
        &shot,
        "1400,9000",
    );
    // a directory that is neither a sweep nor a study is refused, naming the option
    let o = verify(&[
        "sweep",
        "report",
        out.to_str().unwrap(),
        "--converged",
        dir.path().to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--converged"), "{}", text(&o));
}

#[test]
fn reduced_sweep_through_a_local_slurm_equals_the_local_run() {
    let dir = tempfile::tempdir().unwrap();
    // local reference: native, two at a time
    let local = dir.path().join("local");
    let o = sweep(&[
        "--engine",
        "native",
        "--jobs",
        "2",
        "--out",
        local.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));

    let _slurm = common::Slurm::start(&dir.path().join("slurm"));
    let cluster = dir.path().join("cluster");
    let o = sweep(&[
        "--engine",
        "native",
        "--out",
        cluster.to_str().unwrap(),
        "--emit",
        "slurm",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let script = std::fs::read_to_string(cluster.join("sweep.sbatch")).unwrap();
    assert!(script.contains("#SBATCH --array=0-7"), "{script}");
    // collecting before the array ran names the missing runs
    let o = verify(&["sweep", "collect", cluster.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o).contains("8 of 8 runs have no current result"),
        "{}",
        text(&o)
    );
    let sb = Command::new("sbatch")
        .arg("--wait")
        .arg(cluster.join("sweep.sbatch"))
        .output()
        .unwrap();
    assert!(sb.status.success(), "sbatch: {}", text(&sb));
    let o = verify(&["sweep", "collect", cluster.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("collected 8 of 8"), "{}", text(&o));
    assert!(cluster.join("logs/run-7.log").is_file());
    assert_eq!(
        results(&cluster),
        results(&local),
        "the cluster's results equal the local ones bit for bit"
    );
    let o = verify(&["sweep", "report", cluster.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(cluster.join("report.html").is_file());
}

#[test]
fn sweep_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s");
    for (args, field) in [
        (vec!["--mu-r=0.5,-1"], "--mu-r"),
        (vec!["--eta-r", "nan"], "--eta-r"),
        (
            vec!["--engine", "fortran"],
            "[possible values: native, liggghts, both]",
        ),
        (vec!["--jobs", "0"], "--jobs"),
        (
            vec!["--emit", "slurm", "--ranks-per-run", "0"],
            "--ranks-per-run",
        ),
        (vec!["--emit", "pbs"], "[possible values: slurm]"),
        (
            vec!["--preset", "huge"],
            "[possible values: ci, fast, paper]",
        ),
        (vec!["--dt-factor", "2"], "--dt-factor"),
    ] {
        let mut a = vec!["sweep", "--seeds", "1", "--out", out.to_str().unwrap()];
        a.extend(args);
        let o = verify(&a);
        assert_eq!(o.status.code(), Some(2), "{a:?}: {}", text(&o));
        assert!(text(&o).contains(field), "{a:?}: {}", text(&o));
    }
    let o = verify(&[
        "sweep",
        "run-one",
        "--manifest",
        "/nonexistent/m.json",
        "--index",
        "0",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("/nonexistent/m.json"), "{}", text(&o));
}
