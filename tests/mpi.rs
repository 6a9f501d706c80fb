//! One simulation over MPI ranks (issue #39): `mpirun -np N verify shear --native-only`
//! writes one process's outputs byte for byte (rows, velocity profiles, ParaView snapshots,
//! the rotation map) for 2 and 3 ranks (split across the gap, and along the periodic x), and
//! a run killed on 2 ranks along x resumes on 3 across the gap from its checkpoint to the
//! uninterrupted run's bytes. Built with the `mpi` feature (CI runs
//! `cargo test --release --features mpi --test mpi`, with OpenMPI's `mpirun`).
#![cfg(feature = "mpi")]

mod common;

use common::{text, verify, verify_bin};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

/// `mpirun` with `np` ranks of `verify args` (more ranks than cores allowed: correctness,
/// not speed; as root too, as CI machines run).
fn mpirun(np: usize) -> Command {
    let mut c = Command::new("mpirun");
    c.args(["--oversubscribe", "--allow-run-as-root", "-np"])
        .arg(np.to_string())
        .arg(verify_bin());
    c
}

/// The ci shear of one seed to strain 0.1, native only, mu_r 0.5, eta_r 0.5, on 1 thread
/// per rank, a checkpoint at every output step, into `out`.
fn case(out: &Path) -> Vec<String> {
    let mut a = common::native_ci_checkpointed(out, "1");
    let more = [
        "--mu-r",
        "0.5",
        "--eta-r",
        "0.5",
        "--strain",
        "0.1",
        "--snapshot-every",
        "2000",
    ];
    a.extend(more.map(String::from));
    a
}

fn ran(o: &Output, what: &str) {
    assert!(o.status.success(), "{what}: {}", text(o));
}

/// Every output file of seed 1 that a run's bits decide (not native_run.json: wall time).
fn outputs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let seed = dir.join("seed1");
    let mut files: Vec<(String, Vec<u8>)> = [
        "native.csv",
        "native_profile.csv",
        "native_profile.json",
        "rotation_map.svg",
    ]
    .iter()
    .map(|f| {
        let p = seed.join(f);
        let bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        (f.to_string(), bytes)
    })
    .collect();
    let mut vtk: Vec<_> = std::fs::read_dir(seed.join("vtk"))
        .expect("snapshots")
        .map(|e| e.unwrap().path())
        .collect();
    vtk.sort();
    assert!(vtk.len() >= 3, "snapshots: {vtk:?}");
    for p in vtk {
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        files.push((name, std::fs::read(&p).unwrap()));
    }
    assert!(files.iter().all(|(_, b)| !b.is_empty()));
    files
}

fn same_outputs(a: &Path, b: &Path, what: &str) {
    let (x, y) = (outputs(a), outputs(b));
    assert_eq!(x.len(), y.len(), "{what}: file count");
    for ((n, p), (m, q)) in x.iter().zip(&y) {
        assert_eq!(n, m);
        assert!(p == q, "{what}: {n} differs from one process's");
    }
}

#[test]
fn two_and_three_ranks_write_one_process_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("one");
    let args = case(&one);
    ran(
        &verify(&args.iter().map(String::as_str).collect::<Vec<_>>()),
        "one process",
    );
    // the default split (the least boundary: across the gap here) and 2 along the periodic x
    // (ghosts and pairs across the periodic side between ranks)
    for (np, bricks, split) in [
        (2, None, "1 x 2 x 1"),
        (2, Some("2x1x1"), "2 x 1 x 1"),
        (3, None, "1 x 3 x 1"),
    ] {
        let out = dir
            .path()
            .join(format!("np{np}-{}", bricks.unwrap_or("default")));
        let mut c = mpirun(np);
        if let Some(b) = bricks {
            c.args(["--bricks", b]);
        }
        let o = c.args(case(&out)).output().unwrap();
        ran(&o, &format!("{np} ranks"));
        let t = text(&o);
        assert!(
            t.contains(&format!("decomposed over {np} MPI ranks: {split} bricks")),
            "{np} ranks: not decomposed as {split}: {t}"
        );
        same_outputs(&one, &out, &format!("{np} ranks, {split}"));
        eprintln!("{np} ranks ({split}): every output byte for byte one process's");
    }
    // a split that is not the rank count's: an error naming the field, before any step
    let out = dir.path().join("bad");
    let o = mpirun(2)
        .args(["--bricks", "3x1x1"])
        .args(case(&out))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let t = text(&o);
    assert!(
        t.contains("`--bricks`: 3x1x1") && t.contains("rank count, 2"),
        "{t}"
    );
    assert!(!out.join("seed1/native.csv").exists());
}

#[test]
fn a_run_killed_on_two_ranks_resumes_on_three_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("one");
    let cut = dir.path().join("cut");
    ran(
        &verify(&case(&one).iter().map(String::as_str).collect::<Vec<_>>()),
        "one process",
    );
    // 2 ranks along x, stopped (SIGTERM to mpirun, which ends its ranks) once a checkpoint
    // exists; resumed on 3 across the gap
    let mut child = mpirun(2)
        .args(["--bricks", "2x1x1"])
        .args(case(&cut))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    common::wait_for(&cut.join("seed1/native_checkpoint.bin"), 300);
    std::thread::sleep(Duration::from_millis(500));
    // SAFETY: a signal to our own child's pid
    unsafe {
        libc::kill(child.id() as i32, libc::SIGTERM);
    }
    child.wait().unwrap();
    assert!(
        !cut.join("seed1/native.csv").exists(),
        "the run ended before it was stopped: the test stopped nothing"
    );
    let o = mpirun(3).args(case(&cut)).output().unwrap();
    ran(&o, "resumed on 3 ranks");
    let t = text(&o);
    assert!(
        t.contains("resumed from checkpoint at step") && t.contains("over 3 MPI ranks: 1 x 3 x 1"),
        "{t}"
    );
    same_outputs(&one, &cut, "killed on 2 ranks, resumed on 3");
}

/// `verify bench --ranks 1,2`: the 2-rank rows come from `mpirun -np 2` of the same binary
/// stepping the same trajectory (as many neighbour rebuilds as one process), with what rank
/// 0's exchanges carried; the link between the ranks is measured and the scaling model fitted
/// (issue #39). Under `mpirun` itself the bench refuses to run LIGGGHTS beside its ranks.
#[test]
fn the_bench_measures_two_ranks_beside_one() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b");
    let o = verify(&[
        "bench",
        "--native-only",
        "--ranks",
        "1,2",
        "--threads",
        "1",
        "--kernels",
        "scalar",
        "--steps",
        "200",
        "--compression-steps",
        "3000",
        "--out",
        out.to_str().unwrap(),
    ]);
    ran(&o, "verify bench --ranks 1,2");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("bench.json")).unwrap()).unwrap();
    let rows = r["rows"].as_array().unwrap();
    let of = |ranks: u64| {
        rows.iter()
            .find(|x| x["code"] == "native" && x["ranks"] == ranks)
            .unwrap_or_else(|| panic!("a native row of {ranks} rank(s): {r}"))
    };
    let (one, two) = (of(1), of(2));
    let rebuilds = one["rebuilds"].as_u64().unwrap();
    assert!(rebuilds > 0, "{one}");
    assert_eq!(
        two["rebuilds"].as_u64(),
        Some(rebuilds),
        "the same trajectory"
    );
    assert!(
        one["traffic"].is_null() && one["phases"]["comm"] == 0.0,
        "{one}"
    );
    let t = &two["traffic"];
    // two exchanges a step at least, each a message to the other rank with the ghosts
    assert!(t["calls"].as_u64().unwrap() >= 400, "{t}");
    assert!(t["messages"].as_u64().unwrap() >= 400, "{t}");
    assert!(t["bytes"].as_u64().unwrap() > 200 * 72 * 100, "{t}");
    assert!(two["phases"]["comm"].as_f64().unwrap() > 0.0, "{two}");
    assert!(
        two["per_particle"].is_null(),
        "a brick's counts are not the run's"
    );
    assert!(r["native_ranks_2_vs_1"].as_f64().unwrap() > 0.0);
    assert!(
        r["link"]["latency_s"].as_f64().unwrap() > 0.0,
        "{}",
        r["link"]
    );
    let points = r["scaling"]["points"].as_array().unwrap();
    let p2 = points
        .iter()
        .find(|p| p["ranks"] == 2)
        .expect("2 ranks modelled");
    assert!(p2["ghost_fraction"].as_f64().unwrap() > 0.0, "{p2}");
    assert!(p2["pair_overhead"].as_f64().unwrap() > 1.0, "{p2}");
    assert!(p2["here_built_s"].as_f64().unwrap() > 0.0, "{p2}");

    let o = mpirun(2)
        .args(["bench", "--out"])
        .arg(dir.path().join("c"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("`--native-only`"), "{}", text(&o));
}

/// A sweep's SLURM array with `--ranks-per-run 2`: each run one simulation over the 2 MPI
/// tasks `srun` starts, its series byte for byte the local one-process run's (issue #39).
#[test]
fn a_slurm_sweep_runs_each_run_over_two_ranks_to_one_process_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = |out: &Path, more: &[&str]| {
        let mut a = vec![
            "sweep", "--preset", "ci", "--points", "0.5:0.5", "--seeds", "1", "--engine", "native",
            "--strain", "0.1", "--out",
        ];
        a.push(out.to_str().unwrap());
        a.extend_from_slice(more);
        verify(&a)
    };
    let local = dir.path().join("local");
    ran(&sweep(&local, &["--threads", "1"]), "the local sweep");
    let _slurm = common::Slurm::start(&dir.path().join("slurm"));
    let cluster = dir.path().join("cluster");
    ran(
        &sweep(&cluster, &["--emit", "slurm", "--ranks-per-run", "2"]),
        "the SLURM script",
    );
    let script = std::fs::read_to_string(cluster.join("sweep.sbatch")).unwrap();
    assert!(
        script.contains("#SBATCH --ntasks=2") && script.contains("exec srun --mpi=pmix "),
        "{script}"
    );
    let sb = Command::new("sbatch")
        .arg("--wait")
        .arg(cluster.join("sweep.sbatch"))
        .output()
        .unwrap();
    ran(&sb, "sbatch");
    let log = std::fs::read_to_string(cluster.join("logs/run-0.log")).unwrap();
    assert!(log.contains("decomposed over 2 MPI ranks"), "{log}");
    let series = |d: &Path| {
        let p = d.join("runs/mur0.5_etar0.5_s1/seed1/native.csv");
        std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
    };
    let (a, b) = (series(&local), series(&cluster));
    assert!(a.len() > 1000);
    assert!(a == b, "the 2-rank run's series differs from one process's");
}
