//! The `verify` binary end to end: exit codes, outputs, and clear errors for bad input.

mod common;

use common::verify;
use std::path::Path;
use std::process::Output;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn write_case(dir: &Path, edit: impl Fn(String) -> String) -> String {
    let text = edit(include_str!("../cases/rolling_plastic.toml").to_string());
    let p = dir.join("case.toml");
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

/// An executable script standing in for LIGGGHTS, in `dir`.
fn fake_liggghts(dir: &Path, script: &str) -> std::path::PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let fake = dir.join("liggghts");
    std::fs::write(&fake, script).unwrap();
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
    fake
}

/// `verify contact --case rolling_plastic --rolling epsd` with `fake` as LIGGGHTS.
fn contact_with_fake(fake: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "contact",
        "--case",
        "rolling_plastic",
        "--rolling",
        "epsd",
        "--liggghts",
        fake.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    verify(&args)
}

#[test]
fn contact_rolling_plastic_agrees_and_writes_outputs() {
    common::liggghts();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = verify(&[
        "contact",
        "--case",
        "rolling_plastic",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        stderr(&o)
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["pass"], true);
    let results = summary["results"].as_array().unwrap();
    assert!(!results.is_empty());
    for key in [
        "case",
        "model",
        "channel",
        "max_abs_err",
        "max_rel_err",
        "rtol",
        "pass",
    ] {
        assert!(
            results[0].get(key).is_some(),
            "summary.json result lacks {key}"
        );
    }
    for model in ["cdt", "epsd", "epsd2", "epsd3"] {
        let d = out.join(format!("rolling_plastic__{model}"));
        for f in [
            "liggghts.csv",
            "native.csv",
            "deck/in.deck",
            "deck/data.txt",
            "liggghts/log.liggghts",
        ] {
            assert!(d.join(f).is_file(), "missing {}", d.join(f).display());
        }
        // the dumps of a successful run are not kept
        assert!(!d.join("liggghts/atoms.dump").exists());
    }
}

/// A build without the `mpi` feature started as one of several MPI ranks would run the
/// whole command once per rank: it refuses, naming the feature (issue #39).
#[cfg(not(feature = "mpi"))]
#[test]
fn a_build_without_mpi_refuses_to_run_as_several_ranks() {
    let dir = tempfile::tempdir().unwrap();
    let o = std::process::Command::new(common::verify_bin())
        .args(["shear", "--preset", "ci", "--native-only", "--out"])
        .arg(dir.path().join("out"))
        .env("OMPI_COMM_WORLD_SIZE", "2")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("one of 2 MPI ranks") && e.contains("--features mpi"),
        "{e}"
    );
    assert!(!dir.path().join("out").exists(), "it ran anyway");
}

/// `--bricks` (the split of a run over MPI ranks) in one process: anything but 1x1x1 is an
/// error naming the field, the rank count and how to start ranks; a malformed split is
/// refused by the parser; nothing is written.
#[test]
fn bricks_must_multiply_to_the_rank_count() {
    for (bricks, says) in [
        ("2x1x1", "rank count, 1 (one process"),
        ("2x1", "expected NXxNYxNZ"),
        ("0x1x1", "expected NXxNYxNZ"),
        ("1x1x1;shell", "expected NXxNYxNZ"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o");
        let o = std::process::Command::new(common::verify_bin())
            .args([
                "--bricks",
                bricks,
                "shear",
                "--preset",
                "ci",
                "--native-only",
            ])
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{bricks}");
        let e = stderr(&o);
        assert!(e.contains("--bricks") && e.contains(says), "{bricks}: {e}");
        assert!(!out.exists(), "{bricks}: wrote {out:?}");
    }
}

/// `verify bench --ranks 2` and `verify sweep --emit slurm --ranks-per-run 2` in a build
/// without the `mpi` feature: an error naming the field and the feature, before any work.
#[cfg(not(feature = "mpi"))]
#[test]
fn runs_over_ranks_need_the_mpi_feature() {
    for (args, field, written) in [
        (
            vec!["bench", "--native-only", "--ranks", "1,2"],
            "`--ranks`",
            "bench.json",
        ),
        (
            vec![
                "sweep",
                "--preset",
                "ci",
                "--emit",
                "slurm",
                "--ranks-per-run",
                "2",
            ],
            "`--ranks-per-run`",
            "sweep.sbatch",
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o");
        let o = std::process::Command::new(common::verify_bin())
            .args(&args)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let e = stderr(&o);
        assert!(e.contains(field) && e.contains("--features mpi"), "{e}");
        assert!(!out.join(written).exists(), "{args:?}");
    }
}

#[test]
fn reference_mode_needs_no_liggghts() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = common::reference_contact(&out, &["--liggghts", "/nonexistent/liggghts"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // one verdict line ends every comparing command
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(stdout.lines().last(), Some("verdict: agree"), "{stdout}");
}

/// `--json`: stdout is one JSON document (verdict, exit code, the summary the command wrote);
/// the human lines go to stderr. An error is a document too.
#[test]
fn json_puts_one_document_on_stdout() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = common::reference_contact(&out, &["--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(doc["verdict"], "agree");
    assert_eq!(doc["exit_code"], 0);
    assert_eq!(doc["summary"]["pass"], true, "{doc}");
    assert!(!doc["summary"]["results"].as_array().unwrap().is_empty());
    assert_eq!(
        doc["summary_file"].as_str().map(Path::new),
        Some(out.join("summary.json").as_path())
    );
    assert!(stderr(&o).contains("verdict: agree"));
    let o = verify(&["shear", "--mu-r", "nan", "--json"]);
    assert_eq!(o.status.code(), Some(2));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(doc["verdict"], "error");
    assert!(doc["error"].as_str().unwrap().contains("--mu-r"), "{doc}");
}

/// Study files: a run writes its resolved study beside its summary; `verify run` on it
/// repeats the run (finished parts reused), prints a plan first, overrides fields with flags
/// after `--`, stops after the plan with --dry-run, and refuses unknown fields by name. Every
/// study shipped in studies/ parses and plans.
#[test]
fn studies_round_trip_plan_and_refuse_unknown_fields() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // a ci-sized study, end to end from its file (the servo check widened to 5 %: this test
    // is about the file, and one seed's mean stress strays by 1-2 % with the trajectory)
    let first = dir.path().join("ci.toml");
    std::fs::write(
        &first,
        format!(
            "version = 1\ncommand = \"shear\"\n[options]\npreset = \"ci\"\nseeds = 1\n\
             strain = 0.05\nstress_rtol = {}\nnative_only = true\nout = \"{}\"\n",
            common::MECHANICS_STRESS_RTOL,
            out.display()
        ),
    )
    .unwrap();
    let o = verify(&["run", first.to_str().unwrap()]);
    let t = String::from_utf8_lossy(&o.stdout).to_string();
    assert_eq!(o.status.code(), Some(0), "{t}{}", stderr(&o));
    assert!(
        t.contains("plan (verify shear): 1 run(s), 16141 steps"),
        "{t}"
    );
    let study = out.join("study.toml");
    let text = std::fs::read_to_string(&study).unwrap();
    for line in [
        "command = \"shear\"",
        "preset = \"ci\"",
        "strain = 0.05",
        "native_only = true",
        "mu_margin = 0.03",
    ] {
        assert!(text.contains(line), "{line}: {text}");
    }
    // the resolved copy repeats it: in place (the finished seed reused), and into another
    // directory with identical results
    let o = verify(&["run", study.to_str().unwrap()]);
    let t = String::from_utf8_lossy(&o.stdout).to_string();
    assert_eq!(o.status.code(), Some(0), "{t}{}", stderr(&o));
    assert!(t.contains("native result found, reused"), "{t}");
    let again = dir.path().join("again");
    let o = verify(&[
        "run",
        study.to_str().unwrap(),
        "--",
        "--out",
        again.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let csv = |d: &Path| std::fs::read(d.join("seed1/native.csv")).unwrap();
    assert_eq!(csv(&out), csv(&again), "the repeated run differs");
    // a field overridden, the plan only: nothing runs
    let other = dir.path().join("other");
    let o = verify(&[
        "run",
        study.to_str().unwrap(),
        "--dry-run",
        "--",
        "--seeds",
        "2",
        "--out",
        other.to_str().unwrap(),
    ]);
    let t = String::from_utf8_lossy(&o.stdout).to_string();
    assert_eq!(o.status.code(), Some(0), "{t}{}", stderr(&o));
    assert!(
        t.contains("plan (verify shear): 2 run(s), 32282 steps"),
        "{t}"
    );
    assert!(!other.exists(), "--dry-run ran something");
    for (body, expect) in [
        (
            "version = 1\ncommand = \"shear\"\n[options]\nmu_rr = 0.5\n",
            "[options] mu_rr",
        ),
        (
            "version = 1\ncommand = \"shear\"\n[options]\nmu_r = \"abc\"\n",
            "--mu-r",
        ),
        ("version = 2\ncommand = \"shear\"\n", "version"),
        ("version = 1\ncommand = \"shell\"\n", "command"),
    ] {
        let bad = dir.path().join("bad.toml");
        std::fs::write(&bad, body).unwrap();
        let o = verify(&["run", bad.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "{body}");
        assert!(stderr(&o).contains(expect), "{body}: {}", stderr(&o));
    }
    let studies = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies");
    let mut n = 0;
    for e in std::fs::read_dir(&studies).unwrap() {
        let p = e.unwrap().path();
        let o = verify(&["run", p.to_str().unwrap(), "--dry-run"]);
        assert_eq!(o.status.code(), Some(0), "{}: {}", p.display(), stderr(&o));
        let t = String::from_utf8_lossy(&o.stdout).to_string();
        assert!(
            t.contains("plan (verify") && t.contains("core-hours"),
            "{}: {t}",
            p.display()
        );
        n += 1;
    }
    assert!(n >= 6, "studies/ holds {n} studies");
}

/// Copies the stored reference of `rolling_elastic__epsd` into `refdir`, its CSV lines edited
/// by `edit`; with `reseal` the provenance gets the edited file's row count and checksum (as
/// if it had been stored so), else it keeps the original's.
fn edited_reference(refdir: &Path, edit: impl Fn(&mut Vec<String>), reseal: bool) {
    use sha2::Digest;
    let name = "rolling_elastic__epsd";
    let src = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("reference/contact")
        .join(name);
    let dst = refdir.join("contact").join(name);
    std::fs::create_dir_all(&dst).unwrap();
    let csv = std::fs::read_to_string(src.join("liggghts.csv")).unwrap();
    let mut lines: Vec<String> = csv.lines().map(String::from).collect();
    edit(&mut lines);
    let text = lines.join("\n") + "\n";
    std::fs::write(dst.join("liggghts.csv"), &text).unwrap();
    let mut prov: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(src.join("provenance.json")).unwrap())
            .unwrap();
    if reseal {
        let sum: String = sha2::Sha256::digest(text.as_bytes())
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        prov["sha256"] = sum.into();
        prov["rows"] = (lines.len() - 1).into();
    }
    std::fs::write(dst.join("provenance.json"), prov.to_string()).unwrap();
}

/// Replaces the normal force (third column) of the stored reference's row 20 by `f` of it.
fn edit_normal_force(lines: &mut [String], f: impl Fn(&str) -> String) {
    let mut cells: Vec<String> = lines[20].split(',').map(String::from).collect();
    cells[2] = f(&cells[2]);
    lines[20] = cells.join(",");
}

fn verify_against(refdir: &Path, out: &Path) -> Output {
    verify(&[
        "contact",
        "--case",
        "rolling_elastic",
        "--rolling",
        "epsd",
        "--reference",
        "--reference-dir",
        refdir.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ])
}

#[test]
fn perturbed_reference_is_a_disagreement_with_exit_1() {
    // A perturbed stored reference (stored so: consistent provenance) must make the
    // comparison fail with exit 1.
    let dir = tempfile::tempdir().unwrap();
    let refdir = dir.path().join("ref");
    edited_reference(
        &refdir,
        |lines| {
            // Scale the normal force of one row by (1 + 1e-6).
            edit_normal_force(lines, |v| {
                format!("{:e}", v.parse::<f64>().unwrap() * (1.0 + 1e-6))
            })
        },
        true,
    );
    let o = verify_against(&refdir, &dir.path().join("out"));
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(String::from_utf8_lossy(&o.stdout).contains("DISAGREE"));
}

/// A NaN or an infinity in a stored reference (stored so: consistent provenance) is a
/// disagreement, as a NaN in live output is; it used to hang in the error plot's axis code.
#[test]
fn non_finite_reference_values_disagree_and_never_hang() {
    for bad in ["NaN", "inf", "-inf"] {
        let dir = tempfile::tempdir().unwrap();
        let refdir = dir.path().join("ref");
        edited_reference(
            &refdir,
            |lines| edit_normal_force(lines, |_| bad.to_string()),
            true,
        );
        let (tx, rx) = std::sync::mpsc::channel();
        let out = dir.path().join("out");
        let r = refdir.clone();
        std::thread::spawn(move || {
            let _ = tx.send(verify_against(&r, &out));
        });
        let o = rx
            .recv_timeout(std::time::Duration::from_secs(120))
            .unwrap_or_else(|_| panic!("{bad} in the reference: no answer within 120 s"));
        assert_eq!(o.status.code(), Some(1), "{bad}: {}", stderr(&o));
    }
}

#[test]
fn changed_reference_fails_its_checksum_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let refdir = dir.path().join("ref");
    edited_reference(
        &refdir,
        |lines| lines[30] = lines[30].replace('e', "E"),
        false,
    );
    let o = verify_against(&refdir, &dir.path().join("out"));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("checksum"), "{}", stderr(&o));
}

#[test]
fn incomplete_reference_is_an_error_never_an_agreement() {
    // header only, one row, half the rows, one row deleted: each stored with a consistent
    // provenance, so only the step check can catch them
    type Cut = fn(&mut Vec<String>);
    let cuts: [(&str, Cut); 4] = [
        ("header only", |l| l.truncate(1)),
        ("one row", |l| l.truncate(2)),
        ("half the rows", |l| {
            let n = l.len() / 2;
            l.truncate(n)
        }),
        ("a deleted row", |l| {
            l.remove(17);
        }),
    ];
    for (what, cut) in cuts {
        let dir = tempfile::tempdir().unwrap();
        let refdir = dir.path().join("ref");
        edited_reference(&refdir, cut, true);
        let o = verify_against(&refdir, &dir.path().join("out"));
        assert_eq!(o.status.code(), Some(2), "{what}: {}", stderr(&o));
        assert!(stderr(&o).contains("incomplete"), "{what}: {}", stderr(&o));
        // the failure is recorded, with the other cases' results, in summary.json
        let summary: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join("out/summary.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(summary["pass"], false, "{what}");
        assert_eq!(summary["errors"].as_array().unwrap().len(), 1, "{what}");
    }
}

#[test]
fn user_case_never_replaces_a_built_in_reference() {
    let dir = tempfile::tempdir().unwrap();
    let spec = write_case(dir.path(), |t| t);
    let o = verify(&[
        "contact",
        "--spec",
        &spec,
        "--update-reference",
        "--reference-dir",
        dir.path().join("ref").to_str().unwrap(),
        "--liggghts",
        "/nonexistent/liggghts",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("built-in case") && stderr(&o).contains("`name"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("ref").exists());
}

#[test]
fn list_names_every_case() {
    let o = verify(&["contact", "--list"]);
    assert_eq!(o.status.code(), Some(0));
    let s = String::from_utf8_lossy(&o.stdout);
    for c in dem_verify::spec::builtin::builtin_names() {
        assert!(s.contains(c), "--list lacks {c}");
    }
}

#[test]
fn unknown_case_and_model_list_the_valid_ones() {
    let o = verify(&["contact", "--case", "rolling_plastik", "--reference"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("unknown case `rolling_plastik`")
            && stderr(&o).contains("rolling_plastic")
    );
    let o = verify(&[
        "contact",
        "--case",
        "rolling_plastic",
        "--rolling",
        "epsd4",
        "--reference",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("epsd4") && stderr(&o).contains("epsd3"),
        "{}",
        stderr(&o)
    );
    // LIGGGHTS' models only: the native-only one is neither offered nor accepted silently
    assert!(!stderr(&o).contains("epsd_implicit"), "{}", stderr(&o));
    let o = verify(&[
        "contact",
        "--case",
        "rolling_plastic",
        "--rolling",
        "epsd_implicit",
        "--reference",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("exists only in the native solver"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn bad_case_files_name_the_field_and_range() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &str, &str); 11] = [
        // finite values whose derived deck numbers were not (the period of the spin, the
        // power-of-two box)
        (
            "omega = [60.0, 80.0, 0.0]",
            "omega = [1e-320, 0.0, 0.0]",
            "particles[1].motion.omega",
        ),
        (
            "position = [0.0, 0.0, 0.0]",
            "position = [1e308, 0.0, 0.0]",
            "particles[0].position",
        ),
        ("radius = 1.0e-3", "radius = 1.0e300", "particles[0].radius"),
        (
            "youngs_modulus = 7.0e10",
            "youngs_modulus = nan",
            "material.youngs_modulus",
        ),
        ("radius = 0.6e-3", "radius = -0.6e-3", "particles[1].radius"),
        ("dt = 1.0e-8", "dt = 1.0e-5", "Rayleigh"),
        ("restitution = 0.9", "restitution = 0.01", "0.05 < e <= 1"),
        (
            "name = \"rolling_plastic\"",
            "name = \"x\\nshell touch /tmp/pwned\"",
            "identifier",
        ),
        (
            "position = [0.0, 0.0, 1.599e-3]",
            "position = [0.0, 0.0, 0.9e-3]",
            "initial overlap",
        ),
        // a vector longer than three was cut to its first three (issue #36)
        (
            "position = [0.0, 0.0, 1.599e-3]",
            "position = [0.0, 0.0, 1.599e-3, 5.0, 6.0]",
            "three numbers",
        ),
        (
            "position = [0.0, 0.0, 0.0]",
            "position = [0.0, 0.0]",
            "three numbers",
        ),
    ];
    for (from, to, expect) in cases {
        let spec = write_case(dir.path(), |t| {
            assert!(t.contains(from), "template lacks {from}");
            t.replacen(from, to, 1)
        });
        let o = verify(&["contact", "--spec", &spec, "--reference"]);
        assert_eq!(o.status.code(), Some(2), "{to}");
        assert!(stderr(&o).contains(expect), "{to}: {}", stderr(&o));
    }
    assert!(!Path::new("/tmp/pwned").exists());
}

#[test]
fn dt_above_twenty_percent_of_rayleigh_warns() {
    let dir = tempfile::tempdir().unwrap();
    // Rayleigh time of the 0.6 mm sphere is about 0.62 us; 0.2 us is about 32 %.
    let spec = write_case(dir.path(), |t| {
        t.replacen("dt = 1.0e-8", "dt = 2.0e-7", 1)
            .replacen("steps = 4000", "steps = 50", 1)
    });
    let lig = common::liggghts();
    let o = verify(&[
        "contact",
        "--spec",
        &spec,
        "--rolling",
        "epsd",
        "--liggghts",
        lig.binary.to_str().unwrap(),
        "--out",
        dir.path().join("out").to_str().unwrap(),
    ]);
    assert!(
        stderr(&o).contains("Rayleigh") && stderr(&o).contains("above 20 %"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
}

#[test]
fn missing_liggghts_says_how_to_install() {
    let o = verify(&[
        "contact",
        "--case",
        "rolling_plastic",
        "--liggghts",
        "/nonexistent/liggghts",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("apt-get install -y liggghts")
            && e.contains("--reference")
            && e.contains("--native-only"),
        "{e}"
    );
}

#[test]
fn failing_liggghts_run_shows_the_log_tail() {
    let dir = tempfile::tempdir().unwrap();
    let fake = fake_liggghts(
        dir.path(),
        "#!/bin/sh\necho 'LIGGGHTS (fake)' > log.liggghts\necho 'ERROR: Lost atoms: original 2 current 1' >> log.liggghts\nexit 1\n",
    );
    let o = contact_with_fake(&fake, &dir.path().join("out"), &[]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("LIGGGHTS run failed") && e.contains("ERROR: Lost atoms"),
        "{e}"
    );
    // the log the error names is kept, with the failed run's files
    let log = e
        .split_whitespace()
        .find(|w| w.ends_with("log.liggghts"))
        .expect("the error names the log");
    assert!(Path::new(log).is_file(), "{log} was not kept: {e}");
}

#[test]
fn timeout_kills_what_a_wrapper_started() {
    // a wrapper script whose "LIGGGHTS" (a sleep) is its child, not itself: the timeout
    // must end both
    let dir = tempfile::tempdir().unwrap();
    let marker = format!("{}", 86_400 + std::process::id() % 10_000);
    let fake = fake_liggghts(
        dir.path(),
        &format!(
            "#!/bin/sh\necho 'LIGGGHTS (wrapper)' > log.liggghts\nsleep {marker}\necho done\n"
        ),
    );
    let o = contact_with_fake(&fake, &dir.path().join("out"), &["--timeout", "1"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("timed out"), "{}", stderr(&o));
    let ps = std::process::Command::new("ps")
        .args(["-eo", "args"])
        .output()
        .unwrap();
    let left: Vec<String> = String::from_utf8_lossy(&ps.stdout)
        .lines()
        .filter(|l| l.contains(&format!("sleep {marker}")))
        .map(String::from)
        .collect();
    assert!(left.is_empty(), "still running after the timeout: {left:?}");
}

#[test]
fn list_into_a_closed_pipe_ends_quietly() {
    // the reader is gone before verify writes (as `verify contact --list | head -1` once the
    // head has its line): the write gets EPIPE every time
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let o = std::process::Command::new(common::verify_bin())
        .args(["contact", "--list"])
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap();
    use std::os::unix::process::ExitStatusExt;
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    assert_eq!(o.status.signal(), Some(13), "{:?}", o.status);
}

#[test]
fn an_installed_binary_works_from_any_directory() {
    // a copy of the binary elsewhere (as `cargo install --path .` puts it), run from another
    // directory: it finds the stored references without --reference-dir
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("bin/verify");
    std::fs::create_dir_all(bin.parent().unwrap()).unwrap();
    std::fs::copy(common::verify_bin(), &bin).unwrap();
    let run = |env: Option<&str>| {
        let mut c = std::process::Command::new(&bin);
        c.args([
            "contact",
            "--case",
            "rolling_unload",
            "--reference",
            "--out",
            "out",
        ])
        .current_dir(dir.path())
        .env_remove("DEM_VERIFY_REFERENCE");
        if let Some(v) = env {
            c.env("DEM_VERIFY_REFERENCE", v);
        }
        // a child another test thread forks while the copy's write descriptor is open holds
        // it until its own exec, and exec of the copy then fails with ETXTBSY for that
        // moment (seen once in CI): try again
        for _ in 0..100 {
            match c.output() {
                Err(e) if e.kind() == std::io::ErrorKind::ExecutableFileBusy => {
                    std::thread::sleep(std::time::Duration::from_millis(20))
                }
                other => return other.unwrap(),
            }
        }
        panic!("{} stayed busy for 2 s", bin.display())
    };
    let o = run(None);
    assert_eq!(o.status.code(), Some(0), "{}", common::text(&o));
    let o = run(Some("/nonexistent/reference"));
    assert_eq!(o.status.code(), Some(2), "{}", common::text(&o));
    assert!(
        stderr(&o).contains("/nonexistent/reference"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn completions_and_man_page_are_printed() {
    let o = verify(&["completions", "bash"]);
    assert_eq!(o.status.code(), Some(0));
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(s.contains("_verify()") && s.contains("--mu-r"), "{s}");
    let o = verify(&["man"]);
    assert_eq!(o.status.code(), Some(0));
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(s.contains(".TH verify 1") && s.contains("contact"), "{s}");
}

/// DEM_VERIFY_MAX_KERNEL makes `verify` act as a CPU without the faster kernel paths: a bad
/// value is refused naming the variable, a cap hides the paths above it (a path asked for
/// beyond the cap is refused naming the option), and the capped bench runs the allowed one.
#[test]
fn max_kernel_variable_caps_the_paths_and_refuses_bad_values() {
    let run = |cap: &str, args: &[&str]| {
        std::process::Command::new(common::verify_bin())
            .args(args)
            .env("DEM_VERIFY_MAX_KERNEL", cap)
            .output()
            .expect("run verify")
    };
    let o = run("avx3", &["bench", "--native-only", "--steps", "1"]);
    assert_eq!(o.status.code(), Some(2), "{}", common::text(&o));
    assert!(
        stderr(&o).contains("DEM_VERIFY_MAX_KERNEL") && stderr(&o).contains("scalar, avx2, avx512"),
        "{}",
        common::text(&o)
    );
    let o = run(
        "scalar",
        &[
            "bench",
            "--native-only",
            "--steps",
            "1",
            "--kernels",
            "avx2",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", common::text(&o));
    assert!(stderr(&o).contains("--kernels"), "{}", common::text(&o));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let o = run(
        "scalar",
        &[
            "bench",
            "--preset",
            "ci",
            "--native-only",
            "--steps",
            "20",
            "--compression-steps",
            "200",
            "--threads",
            "1",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", common::text(&o));
    let text = common::text(&o);
    assert!(text.contains("scalar kernel"), "{text}");
    assert!(
        !text.contains("avx2 kernel") && !text.contains("avx512 kernel"),
        "{text}"
    );
}

/// The bench's scaling model is fitted to the kernel path its ratios and its model check use
/// (the fastest at 1 thread), not to the first path benched: its one-process time per step is
/// that path's 1-rank, 1-thread run's phases per step, exactly (before, the scalar path's was
/// checked against the fastest path's 2-rank run: measured / predicted 0.65-0.74 from that
/// alone). Every path this machine has is benched, scalar first, on 2,500 particles, where a
/// SIMD path is the fastest (so the first path benched is not the one reported).
#[test]
fn bench_fits_its_scaling_model_to_the_kernel_it_reports() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let o = verify(&[
        "bench",
        "--native-only",
        "--steps",
        "300",
        "--compression-steps",
        "200",
        "--threads",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", common::text(&o));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("bench.json")).unwrap()).unwrap();
    let kernel = &r["kernel"];
    let per_step = |row: &serde_json::Value| {
        let p = &row["phases"];
        let sum: f64 = ["pairs", "sum_walls", "integrate", "neighbor", "plates"]
            .iter()
            .map(|k| p[k].as_f64().unwrap())
            .sum();
        sum / p["steps"].as_f64().unwrap()
    };
    let rows: Vec<_> = r["rows"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|x| x["code"] == "native" && x["workers"] == 1 && x["ranks"] == 1)
        .collect();
    assert!(!rows.is_empty(), "{r}");
    let fitted = r["scaling"]["one_rank_s"].as_f64().unwrap();
    for row in &rows {
        let rel = (fitted / per_step(row) - 1.0).abs();
        if row["kernel"] == *kernel {
            assert!(
                rel < 1e-9,
                "fitted {fitted} against {kernel}'s {}",
                per_step(row)
            );
        } else {
            // another path's run is another time per step
            assert!(
                rel > 1e-6,
                "fitted to {} instead of {kernel}",
                row["kernel"]
            );
        }
    }
}

/// `verify bench --rounds 2` runs both codes twice, in rounds, and reports the median of the
/// rounds' ratios (of two, their mean) besides each round's; 0 rounds is refused naming the
/// option and its range.
#[test]
fn bench_rounds_report_the_median_of_the_rounds_ratios() {
    let o = verify(&["bench", "--native-only", "--rounds", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", common::text(&o));
    assert!(
        stderr(&o).contains("--rounds") && stderr(&o).contains("1 to 50"),
        "{}",
        common::text(&o)
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let o = verify(&[
        "bench",
        "--preset",
        "ci",
        "--steps",
        "20",
        "--compression-steps",
        "200",
        "--threads",
        "1,2",
        "--procs",
        "1",
        "--kernels",
        "scalar",
        "--rounds",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", common::text(&o));
    let text = common::text(&o);
    assert!(
        text.contains("round 2 of 2") && text.contains("median of 2 rounds"),
        "{text}"
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("bench.json")).unwrap()).unwrap();
    let runs: Vec<(String, u64, u64)> = r["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| {
            (
                x["code"].as_str().unwrap().to_string(),
                x["workers"].as_u64().unwrap(),
                x["round"].as_u64().unwrap(),
            )
        })
        .collect();
    let want: Vec<(String, u64, u64)> = (0..2)
        .flat_map(|k| {
            [("native", 1), ("native", 2), ("liggghts", 1)].map(|(c, w)| (c.to_string(), w, k))
        })
        .collect();
    assert_eq!(runs, want);
    // each run's neighbour rebuilds in its timed steps (LIGGGHTS: parsed from its log)
    for x in r["rows"].as_array().unwrap() {
        assert!(x["rebuilds"].as_u64().is_some(), "{x}");
    }
    assert!(text.contains("neighbour rebuild"), "{text}");
    for (median, rounds) in [
        ("native_vs_liggghts_1", "rounds_native_vs_liggghts_1"),
        ("native_2_vs_1", "rounds_native_2_vs_1"),
    ] {
        let each: Vec<f64> = r[rounds]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(each.len(), 2, "{rounds}");
        assert!(each.iter().all(|x| x.is_finite() && *x > 0.0), "{each:?}");
        let m = r[median].as_f64().unwrap();
        assert!(
            (m - 0.5 * (each[0] + each[1])).abs() <= 1e-12 * m,
            "{median} {m} {each:?}"
        );
    }
}
