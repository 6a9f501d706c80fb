//! Nothing on disk is trusted unchecked (issue #36): a corrupted checkpoint is refused and
//! the run starts over to the uninterrupted run's bits; two runs never share an output folder.

mod common;

use common::{text, verify};
use std::path::Path;
use std::time::{Duration, Instant};

fn native_ci(out: &Path) -> Vec<String> {
    common::native_ci_checkpointed(out, "1")
}

fn run(args: &[String]) -> std::process::Output {
    verify(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

/// Starts the run and SIGKILLs it once its checkpoint exists.
fn killed_after_checkpoint(out: &Path) {
    let mut child = std::process::Command::new(common::verify_bin())
        .args(native_ci(out))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    common::wait_for(&out.join("seed1/native_checkpoint.bin"), 120);
    std::thread::sleep(Duration::from_millis(300));
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        !out.join("seed1/native.csv").exists(),
        "the run ended before it was killed: the test killed nothing"
    );
}

#[test]
fn a_corrupted_checkpoint_is_refused_and_the_run_starts_over() {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole");
    let o = run(&native_ci(&whole));
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // one flipped bit in the middle of the payload, then one in the header's case hash
    for (k, corrupt) in [
        (|b: &mut Vec<u8>| {
            let n = b.len();
            b[n / 2] ^= 0x10;
        }) as fn(&mut Vec<u8>),
        |b: &mut Vec<u8>| {
            let at = b.windows(13).position(|w| w == b"input_sha256\"").unwrap() + 16;
            b[at] = if b[at] == b'0' { b'1' } else { b'0' };
        },
    ]
    .into_iter()
    .enumerate()
    {
        let cut = dir.path().join(format!("cut{k}"));
        killed_after_checkpoint(&cut);
        let cp = cut.join("seed1/native_checkpoint.bin");
        let mut bytes = std::fs::read(&cp).unwrap();
        corrupt(&mut bytes);
        std::fs::write(&cp, &bytes).unwrap();
        let o = run(&native_ci(&cut));
        let t = text(&o);
        assert_eq!(o.status.code(), Some(0), "{t}");
        assert!(
            t.contains("is not resumed") && !t.contains("resumed from checkpoint at step"),
            "{t}"
        );
        assert!(
            t.contains(if k == 0 { "checksum" } else { "another case" }),
            "{t}"
        );
        assert!(cut.join("seed1/native_checkpoint.rejected").is_file());
        assert_eq!(
            std::fs::read(whole.join("seed1/native.csv")).unwrap(),
            std::fs::read(cut.join("seed1/native.csv")).unwrap(),
            "the run that started over differs from the uninterrupted one"
        );
    }
}

#[test]
fn a_second_run_into_a_busy_folder_is_refused_and_the_first_finishes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut first = std::process::Command::new(common::verify_bin())
        .args(native_ci(&out))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while !out.join("seed1/case.toml").exists() {
        assert!(t0.elapsed().as_secs() < 60, "the first run did not start");
        std::thread::sleep(Duration::from_millis(5));
    }
    let mut second = native_ci(&out);
    second.extend(["--mu-r", "0.5"].map(String::from));
    let o = run(&second);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("--out") && t.contains(&format!("pid {}", first.id())),
        "{t}"
    );
    assert!(first.wait().unwrap().success());
    // the folder holds the first run's case, and is free again
    let case = std::fs::read_to_string(out.join("seed1/case.toml")).unwrap();
    assert!(case.contains("rolling_friction = 0.0"), "{case}");
    let o = run(&native_ci(&out));
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

#[test]
fn a_manifest_whose_run_id_leaves_its_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep");
    let o = verify(&[
        "sweep",
        "--preset",
        "ci",
        "--points",
        "0:0",
        "--seeds",
        "1",
        "--emit",
        "slurm",
        "--out",
        sweep.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let mpath = sweep.join("manifest.json");
    let good = std::fs::read_to_string(&mpath).unwrap();
    assert!(good.contains("\"mur0_etar0_s1\""), "{good}");
    let outside = dir.path().join("x");
    for bad in ["../../x", outside.to_str().unwrap(), "mur0_etar0_s2"] {
        std::fs::write(
            &mpath,
            good.replace("\"mur0_etar0_s1\"", &format!("{bad:?}")),
        )
        .unwrap();
        let o = verify(&[
            "sweep",
            "run-one",
            "--manifest",
            mpath.to_str().unwrap(),
            "--index",
            "0",
        ]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{bad}: {t}");
        assert!(t.contains("runs[0]") && t.contains("mur0_etar0_s1"), "{t}");
        assert!(!outside.exists() && !dir.path().join("x").exists());
    }
}

/// Processes whose working directory lies under `dir` (LIGGGHTS runs in the seed's folder).
fn processes_under(dir: &Path) -> Vec<String> {
    let Ok(dir) = dir.canonicalize() else {
        return Vec::new();
    };
    std::fs::read_dir("/proc")
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().parse::<u32>().is_ok())
        .filter(|e| std::fs::read_link(e.path().join("cwd")).is_ok_and(|c| c.starts_with(&dir)))
        .map(|e| {
            std::fs::read_to_string(e.path().join("cmdline"))
                .unwrap_or_default()
                .replace('\0', " ")
        })
        .collect()
}

#[test]
fn sigterm_and_sigint_end_liggghts_with_verify_and_a_rerun_resumes() {
    let _ = common::liggghts();
    // SIGTERM as SLURM and systemd send it; SIGINT sent to verify alone (a terminal's Ctrl-C
    // reaches the whole process group, LIGGGHTS included, and proves nothing)
    for (name, signal) in [("SIGTERM", libc::SIGTERM), ("SIGINT", libc::SIGINT)] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("lt");
        let args = [
            "shear",
            "--preset",
            "ci",
            "--seeds",
            "1",
            "--liggghts-only",
            "--out",
            out.to_str().unwrap(),
        ];
        let mut child = std::process::Command::new(common::verify_bin())
            .args(args)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let t0 = Instant::now();
        while processes_under(&out).is_empty() {
            assert!(t0.elapsed().as_secs() < 60, "LIGGGHTS did not start");
            std::thread::sleep(Duration::from_millis(20));
        }
        // SAFETY: a signal to the child this test spawned and still owns
        unsafe {
            libc::kill(child.id() as i32, signal);
        }
        child.wait().unwrap();
        let t1 = Instant::now();
        while !processes_under(&out).is_empty() {
            assert!(
                t1.elapsed().as_secs() < 10,
                "still running after {name}: {:?}",
                processes_under(&out)
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        let o = verify(&args);
        assert_eq!(o.status.code(), Some(0), "{name}: {}", text(&o));
        assert!(out.join("seed1/liggghts.csv").is_file());
        let temps: Vec<_> = walk(&out)
            .into_iter()
            .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with(".tmp"))
            .collect();
        assert!(temps.is_empty(), "{name}: {temps:?}");
    }
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            v.extend(walk(&p));
        } else {
            v.push(p);
        }
    }
    v
}

/// Inputs that used to be changed silently, or to exhaust the machine, are refused naming the
/// field and its valid range (exit 2, before any run starts).
#[test]
fn silently_changed_and_unbounded_inputs_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let o = out.to_str().unwrap();
    for (args, field, valid) in [
        (
            vec![
                "shear",
                "--preset",
                "ci",
                "--flat-plates",
                "--tooth-height",
                "1e-4",
                "--out",
                o,
            ],
            "--tooth-height",
            "--flat-plates",
        ),
        (
            vec![
                "convergence",
                "--preset",
                "ci",
                "--dt-factors",
                "1,1",
                "--out",
                o,
            ],
            "--dt-factors",
            "distinct",
        ),
        (
            vec![
                "shear",
                "--preset",
                "ci",
                "--native-only",
                "--threads",
                "10000",
                "--out",
                o,
            ],
            "--threads",
            "1 ..=",
        ),
        (
            vec!["bench", "--particles", "0", "--out", o],
            "--particles",
            "10 ..= 10000000",
        ),
        (
            vec!["bench", "--particles", "1000000000", "--out", o],
            "--particles",
            "10 ..= 10000000",
        ),
        (
            vec!["bench", "--threads", "1000", "--out", o],
            "--threads",
            "1 ..=",
        ),
        (
            vec!["shear", "--preset", "ci", "--eta-r", "1e300", "--out", o],
            "--eta-r",
            "0 ..= 10",
        ),
        (
            vec!["shear", "--preset", "ci", "--mu-r", "1e300", "--out", o],
            "--mu-r",
            "0 ..= 10",
        ),
        (
            vec![
                "shear",
                "--preset",
                "ci",
                "--snapshot-every",
                "18446744073709551615",
                "--out",
                o,
            ],
            "--snapshot-every",
            "the run's steps",
        ),
    ] {
        let r = verify(&args);
        let t = text(&r);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {t}");
        assert!(t.contains(field) && t.contains(valid), "{args:?}: {t}");
        assert!(!out.join("seed1").exists(), "{args:?} started a run");
    }
}

/// A finished seed is reused only when every file it is rebuilt from checks against its
/// record: an edited profile (or series) makes the seed run again, back to the true bits.
#[test]
fn an_edited_stored_seed_is_run_again_not_reused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let o = run(&native_ci(&out));
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    for file in ["native_profile.json", "native.csv"] {
        let path = out.join("seed1").join(file);
        let good = std::fs::read(&path).unwrap();
        // one digit changed, the file still parses
        let mut bad = good.clone();
        let at = bad
            .iter()
            .rposition(|b| b.is_ascii_digit() && *b != b'9')
            .unwrap();
        bad[at] += 1;
        std::fs::write(&path, &bad).unwrap();
        let o = run(&native_ci(&out));
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        assert_eq!(
            std::fs::read(&path).unwrap(),
            good,
            "{file}: the edit was reused"
        );
    }
}

/// A study's `--dry-run` refuses what the run refuses; a boolean is no value of a valued
/// option (it was dropped, and the default ran); a TOML error is named as one.
#[test]
fn study_files_are_checked_as_the_run_checks_them() {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("s.toml");
    for (line, field, valid) in [
        ("seeds = 0", "--seeds", "1 ..= 1000"),
        (
            "first_seed = 0",
            "--first-seed",
            "1 ..= 9223372036854775807",
        ),
        ("threads = 0", "--threads", "1 ..="),
        ("seeds = false", "[options] seeds", "only for flags"),
        ("mu_r = false", "[options] mu_r", "only for flags"),
    ] {
        std::fs::write(
            &study,
            format!("version = 1\ncommand = \"shear\"\n[options]\npreset = \"ci\"\n{line}\n"),
        )
        .unwrap();
        let o = verify(&["run", study.to_str().unwrap(), "--dry-run"]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{line}: {t}");
        assert!(t.contains(field) && t.contains(valid), "{line}: {t}");
    }
    std::fs::write(&study, "version = 1\ncommand = \"shear\"\n[options\n").unwrap();
    let o = verify(&["run", study.to_str().unwrap()]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("is not valid TOML") && !t.contains("LIGGGHTS"),
        "{t}"
    );
}

/// `--json` prints its one document on stdout for a refusal at the parser too.
#[test]
fn json_prints_its_document_for_a_refusal_at_the_parser() {
    for args in [
        vec!["shear", "--bogus", "--json"],
        vec!["shear", "--json", "--preset", "nope"],
    ] {
        let o = verify(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap_or_else(|e| {
            panic!(
                "{args:?}: stdout is not one JSON document ({e}): {}",
                text(&o)
            )
        });
        assert_eq!(doc["verdict"], "error");
        assert_eq!(doc["exit_code"], 2);
        assert!(doc["error"]
            .as_str()
            .unwrap()
            .contains(if args[1] == "--bogus" {
                "--bogus"
            } else {
                "nope"
            }));
    }
}

/// `verify convergence --help` does not offer the shear flags it always refuses.
#[test]
fn convergence_help_lists_only_what_it_accepts() {
    let o = verify(&["convergence", "--help"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(t.contains("--engine") && t.contains("--dt-factors"), "{t}");
    assert!(
        !t.contains("--native-only") && !t.contains("--liggghts-only"),
        "{t}"
    );
}

/// A replay window start near u64::MAX is refused by its range, not wrapped past the check
/// into a LIGGGHTS run.
#[test]
fn a_replay_start_beyond_the_run_is_refused_by_its_range() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    for at in ["18446744073709551615", "18446744073709551600"] {
        let o = verify(&[
            "replay",
            "--preset",
            "ci",
            "--at",
            at,
            "--out",
            out.to_str().unwrap(),
        ]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{t}");
        assert!(t.contains("--at") && t.contains("1 ..="), "{t}");
        assert!(!out.join("liggghts").exists(), "LIGGGHTS ran: {t}");
    }
}

/// A run whose memory estimate exceeds what the process may use (here `ulimit -v`, as a SLURM
/// job's limit) is refused before it allocates, the estimate and the bound in the message;
/// the same run without the limit is not refused for memory.
#[test]
fn a_run_larger_than_the_memory_it_may_use_is_refused_with_its_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let o = out.to_str().unwrap();
    let bin = common::verify_bin();
    let study = dir.path().join("s.toml");
    std::fs::write(
        &study,
        format!(
            "version = 1\ncommand = \"shear\"\n[options]\npreset = \"ci\"\n\
             native_only = true\nparticles = 2000000\nout = \"{o}\"\n"
        ),
    )
    .unwrap();
    for args in [
        format!("bench --particles 2000000 --steps 1 --out {o}"),
        format!("shear --preset ci --native-only --particles 2000000 --seeds 1 --out {o}"),
        // the study's plan checks as the run does
        format!("run {} --dry-run", study.display()),
    ] {
        // 1.5 GB of address space: the binary starts (about 0.1 GB), 2e6 particles would not fit
        let r = std::process::Command::new("bash")
            .arg("-c")
            .arg(format!("ulimit -v 1500000 && exec {bin} {args}"))
            .output()
            .unwrap();
        let t = text(&r);
        assert_eq!(r.status.code(), Some(2), "{args}: {t}");
        assert!(
            t.contains("particles") && t.contains("needs about 3.27 GB") && t.contains("ulimit -v"),
            "{args}: {t}"
        );
        assert!(!out.join("seed1").exists(), "{args} started a run");
    }
    // without the limit the small ci box is not refused: it runs (its verdict at 1 % strain,
    // before the servo settles, is not the point here)
    let r = verify(&[
        "shear",
        "--preset",
        "ci",
        "--native-only",
        "--seeds",
        "1",
        "--strain",
        "0.01",
        "--out",
        o,
    ]);
    assert!(
        r.status.code() != Some(2) && out.join("seed1/native.csv").is_file(),
        "{}",
        text(&r)
    );
}

/// A convergence study's `--dry-run` checks the study's own rules as its run does, and counts
/// what the run runs: the compaction once per seed, then every (seed, dt factor, code) from
/// that state with one servo step (it counted the compaction again at every factor, scaled
/// by 1/factor).
#[test]
fn a_convergence_plan_is_the_runs_list() {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("c.toml");
    let plan = |opts: &str| {
        std::fs::write(
            &study,
            format!("version = 1\ncommand = \"convergence\"\n[options]\npreset = \"ci\"\n{opts}\n"),
        )
        .unwrap();
        verify(&["run", study.to_str().unwrap(), "--dry-run"])
    };
    let o = plan("dt_factors = [1, 1]");
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--dt-factors") && text(&o).contains("distinct"));
    let o = plan("dt_factors = [1, 0.5]\nseeds = 2\nfirst_seed = 4");
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    // 2 compactions + 2 seeds x 2 factors, native
    assert!(t.contains("plan (verify convergence): 6 run(s)"), "{t}");
    let steps = |t: &str| -> u64 {
        let s = t.split(" steps in all").next().unwrap();
        s.rsplit(' ').next().unwrap().parse().unwrap()
    };
    // halving dt doubles the shear steps only: two factors cost 3 shear runs' steps, and the
    // compaction once per seed, not once per factor
    let one = plan("dt_factors = [1, 0.5]\nseeds = 1");
    let both = steps(&text(&one));
    let o = plan("dt_factors = [1, 0.25]\nseeds = 1");
    let quarter = steps(&text(&o));
    assert!(quarter > both, "{quarter} vs {both}");
    // compaction + s + 2s = both; compaction + s + 4s = quarter -> s = (quarter - both) / 2
    let s = (quarter - both) / 2;
    let compaction = both - 3 * s;
    assert!(
        compaction > 0 && compaction < s,
        "compaction {compaction} steps once, shear {s} (+1 servo step per run)"
    );
}

/// A sweep's `--dry-run` plans the manifest the sweep would store (its checks, its runs, each
/// case as the run builds it) without writing it.
#[test]
fn a_sweep_plan_is_its_manifest_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("s.toml");
    let out = dir.path().join("sweep");
    let plan = |opts: &str| {
        std::fs::write(
            &study,
            format!(
                "version = 1\ncommand = \"sweep\"\n[options]\npreset = \"ci\"\nout = \"{}\"\n{opts}\n",
                out.display()
            ),
        )
        .unwrap();
        verify(&["run", study.to_str().unwrap(), "--dry-run"])
    };
    for (opts, field, valid) in [
        ("mu_r = [0]\neta_r = [0]\njobs = 0", "--jobs", "1 ..= 256"),
        ("mu_r = [0, 0]\neta_r = [0]", "--mu-r/--eta-r", "distinct"),
        ("mu_r = [11]\neta_r = [0]", "--mu-r", "0 ..= 10"),
    ] {
        let o = plan(opts);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{opts}: {t}");
        assert!(t.contains(field) && t.contains(valid), "{opts}: {t}");
    }
    let o = plan("mu_r = [0, 1]\neta_r = [0, 0.5]\nseeds = 2");
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(t.contains("plan (verify sweep): 8 run(s)"), "{t}");
    assert!(!out.exists(), "a dry run wrote {}", out.display());
}
