//! The paper-protocol studies' scripts (issue #37, docs/paper-protocol.md) on a convergence
//! study, whose runs keep no run record: the end-of-session carry takes a run part way and
//! drops it once the run has finished; the fold keeps each finished run (series gzipped with
//! its SHA-256, its input hash) and refuses a series changed since; a replaced machine gets the
//! finished runs back byte for byte, and a damaged record is an error, not a run put back.
//! On a copy of the clone's tools, studies and reference pages, in a folder of its own.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// `bash tools/<script> <dir>` in the copied clone `repo`, with `env`.
fn script(repo: &Path, name: &str, dir: &Path, env: &[(&str, &str)]) -> (bool, String) {
    let o = Command::new("bash")
        .arg(repo.join("tools").join(name))
        .arg(dir)
        .envs(env.iter().copied())
        .output()
        .unwrap();
    (o.status.success(), common::text(&o))
}

/// A folder the installed binary would find (the restore needs none: a stand-in that fails).
fn new_machine(root: &Path, name: &str) -> PathBuf {
    let dir = root.join(name);
    let bin = dir.join("bin-cd821d5/bin");
    std::fs::create_dir_all(&bin).unwrap();
    std::fs::write(bin.join("verify"), "#!/bin/sh\nexit 1\n").unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(bin.join("verify"), std::fs::Permissions::from_mode(0o755)).unwrap();
    dir
}

#[test]
fn a_convergence_study_is_carried_folded_and_put_back_checked() {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tmp = tempfile::tempdir().unwrap();
    let repo = tmp.path().join("clone");
    for d in ["tools", "studies"] {
        common::copy_tree(&here.join(d), &repo.join(d));
    }
    for d in ["nightly", "sweep", "paper-protocol"] {
        common::copy_tree(
            &here.join("reference").join(d),
            &repo.join("reference").join(d),
        );
    }
    let dir = new_machine(tmp.path(), "pp");
    let study = dir.join("runs/paper-protocol-convergence-mur1");
    let (done, part) = (study.join("dt1/seed1"), study.join("dt0.25/seed1"));
    std::fs::create_dir_all(&done).unwrap();
    std::fs::create_dir_all(&part).unwrap();
    std::fs::create_dir_all(dir.join("studies")).unwrap();
    std::fs::copy(
        here.join("studies/paper-protocol-convergence-mur1.toml"),
        dir.join("studies/paper-protocol-convergence-mur1.toml"),
    )
    .unwrap();
    let series = "step,mu\n0,0\n1000,0.61\n";
    std::fs::write(done.join("native.csv"), series).unwrap();
    std::fs::write(done.join("native.hash"), "5f3a").unwrap();
    // a checkpoint as the installed binary writes it (MessagePack: version, case, stage, wall
    // time, state, rows whose first field is the step, ...)
    let checkpoint = part.join("native_checkpoint.bin");
    let rows = vec![(0u64, 0.0f64), (4_242_000u64, 0.5f64)];
    let cp = rmp_serde::to_vec(&(3u32, "{}", 1u32, 1.0f64, Vec::<u8>::new(), rows)).unwrap();
    std::fs::write(&checkpoint, &cp).unwrap();

    // the session's start puts back what the clone holds; its end carries the run part way,
    // with its SHA-256 and step
    let (ok, t) = script(&repo, "paper-protocol.sh", &dir, &[("RESTORE_ONLY", "1")]);
    assert!(ok, "{t}");
    // (the finished sweep runs it put back are not this test's: the fold would fold them all)
    for sweep in ["paper-protocol-epsd", "paper-protocol-implicit"] {
        std::fs::remove_dir_all(dir.join("runs").join(sweep)).unwrap();
    }
    let carried = repo.join(
        "carried/paper-protocol/paper-protocol-convergence-mur1/dt0.25/seed1/native_checkpoint.bin",
    );
    let (ok, t) = script(&repo, "paper-protocol-carry.sh", &dir, &[]);
    assert!(ok, "{t}");
    let record = std::fs::read_to_string(carried.with_extension("bin.sha256")).unwrap();
    assert!(record.trim_end().ends_with(" 4242000"), "{record}");
    assert!(carried.with_extension("bin.gz").is_file());

    // it finishes (its checkpoint removed, its series and input hash written): the next
    // carry drops its copy, and the fold keeps both runs
    std::fs::remove_file(&checkpoint).unwrap();
    std::fs::write(part.join("native.csv"), "step,mu\n0,0\n250,0.63\n").unwrap();
    std::fs::write(part.join("native.hash"), "77c1").unwrap();
    let (ok, t) = script(&repo, "paper-protocol-carry.sh", &dir, &[]);
    assert!(ok && t.contains("no longer carried"), "{t}");
    assert!(!carried.with_extension("bin.gz").exists(), "{t}");
    let verify = [("VERIFY", common::verify_bin())];
    let (ok, t) = script(&repo, "paper-protocol-fold.sh", &dir, &verify);
    assert!(ok && t.contains("2 finished convergence run(s)"), "{t}");
    let folded = repo.join("reference/paper-protocol/convergence-mur1");
    for f in ["native.csv.gz", "native.sha256", "native.hash"] {
        assert!(folded.join("dt1/seed1").join(f).is_file(), "{f}");
    }

    // a replaced machine: both runs back, byte for byte, so the study counts them as done
    let dir2 = new_machine(tmp.path(), "pp2");
    let (ok, t) = script(&repo, "paper-protocol.sh", &dir2, &[("RESTORE_ONLY", "1")]);
    assert!(ok, "{t}");
    for (run, f) in [
        ("dt1/seed1", "native.csv"),
        ("dt1/seed1", "native.hash"),
        ("dt0.25/seed1", "native.csv"),
        ("dt0.25/seed1", "native.hash"),
    ] {
        let back = dir2.join("runs/paper-protocol-convergence-mur1").join(run);
        assert_eq!(
            std::fs::read(back.join(f)).unwrap(),
            std::fs::read(study.join(run).join(f)).unwrap(),
            "{run}/{f}"
        );
    }

    // a series changed since it was folded is not folded again over the kept one
    std::fs::write(done.join("native.csv"), "step,mu\n0,0\n1000,0.99\n").unwrap();
    let (ok, t) = script(&repo, "paper-protocol-fold.sh", &dir, &verify);
    assert!(
        !ok && t.contains("differs from the series folded before"),
        "{t}"
    );

    // a record that does not match its series: an error, and that run is not put back
    std::fs::write(folded.join("dt1/seed1/native.sha256"), "0000\n").unwrap();
    let dir3 = new_machine(tmp.path(), "pp3");
    let (ok, t) = script(&repo, "paper-protocol.sh", &dir3, &[("RESTORE_ONLY", "1")]);
    assert!(!ok && t.contains("SHA-256 differs from its record"), "{t}");
    let run = dir3.join("runs/paper-protocol-convergence-mur1/dt1/seed1");
    assert!(!run.join("native.hash").exists() && !run.join("native.csv").exists());
}
