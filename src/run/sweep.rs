//! The parametric study: a manifest of runs (one per (mu_r, eta_r, seed)), each run's result
//! written atomically next to the hash of its inputs, and the collection of results.
//!
//! Resumption rule: a run is done when `runs/<id>/result.json` exists, its record
//! `result.json.sha256` names the manifest entry's input hash and the file's SHA-256, and the
//! result is that entry's; anything else (missing, edited, older inputs, another code version)
//! is made again (from the run's stored seed when that still verifies). The hash covers the full shear case of the seed (materials, box, protocol, dt,
//! rolling model and coefficients), the engine and the crate version, as FNV-1a 64 of its JSON.

use super::shear::{ShearRequest, ShearSummary};
pub use super::Engine;
use crate::compare::{steady, Steady};
use crate::error::{Error, Result};
use crate::fsutil::{read_to_string, write_atomic};
use crate::run::tell::say;
use crate::series::Series;
use crate::spec::shear::{CaseRequest, Overrides, Preset, Protocol, ShearCase};
use crate::spec::stability_shear::stability;
use crate::spec::windows::steady_window;
use crate::spec::RollingModel;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// What every run of a sweep shares.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepBase {
    pub preset: Preset,
    pub rolling: RollingModel,
    pub engine: Engine,
    /// Speeds, strain per stage, dt factor (flattened: the manifest keeps them at top level).
    #[serde(flatten)]
    pub protocol: Protocol,
}

/// One run: a parameter point and a seed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunSpec {
    pub index: usize,
    pub id: String,
    pub mu_r: f64,
    pub eta_r: f64,
    pub seed: u64,
    pub input_hash: String,
}

/// `DIR/manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub schema: u32,
    pub created_utc: String,
    pub base: SweepBase,
    pub runs: Vec<RunSpec>,
}

/// FNV-1a, 64 bit: a stable hash (std's hasher may change between Rust versions).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

impl Manifest {
    /// The runs of a sweep over `mu_r x eta_r x seeds`, validated (each case is built once).
    pub fn plan(
        base: SweepBase,
        mu_r: &[f64],
        eta_r: &[f64],
        seeds: u64,
        created_utc: String,
    ) -> Result<Self> {
        if mu_r.is_empty() || eta_r.is_empty() {
            return Err(Error::invalid(
                "--mu-r/--eta-r",
                "(empty)",
                "at least one value each",
            ));
        }
        let points: Vec<(f64, f64)> = mu_r
            .iter()
            .flat_map(|&m| eta_r.iter().map(move |&e| (m, e)))
            .collect();
        Self::plan_points(base, &points, seeds, created_utc)
    }

    /// The runs of a sweep over a list of (mu_r, eta_r) points x seeds (`--points`: points
    /// that are not a grid, e.g. the speed study's five).
    pub fn plan_points(
        base: SweepBase,
        points: &[(f64, f64)],
        seeds: u64,
        created_utc: String,
    ) -> Result<Self> {
        if points.is_empty() {
            return Err(Error::invalid("--points", "(empty)", "at least one point"));
        }
        if seeds == 0 || seeds > 1000 {
            return Err(Error::invalid("--seeds", seeds, "1 ..= 1000"));
        }
        let mut runs = Vec::new();
        // seed-major: a partly finished sweep already covers the whole map with its first seeds
        for seed in 1..=seeds {
            for &(m, e) in points {
                let index = runs.len();
                let mut r = RunSpec {
                    index,
                    id: Self::run_id(m, e, seed),
                    mu_r: m,
                    eta_r: e,
                    seed,
                    input_hash: String::new(),
                };
                r.input_hash = input_hash(&base, &r)?;
                runs.push(r);
            }
        }
        let mut ids: Vec<&str> = runs.iter().map(|r| r.id.as_str()).collect();
        ids.sort();
        if ids.windows(2).any(|w| w[0] == w[1]) {
            return Err(Error::invalid(
                "--mu-r/--eta-r",
                "repeated values",
                "distinct values",
            ));
        }
        Ok(Manifest {
            schema: 1,
            created_utc,
            base,
            runs,
        })
    }

    /// The id (and folder name under `runs/`) of a run.
    fn run_id(mu_r: f64, eta_r: f64, seed: u64) -> String {
        format!("mur{mu_r}_etar{eta_r}_s{seed}")
    }

    /// Whether this manifest can replace `old` in the same directory: the same shared settings,
    /// and every run id in both with the same inputs (more seeds or points may be added).
    pub fn compatible_with(&self, old: &Manifest) -> bool {
        self.base == old.base
            && old.runs.iter().all(|o| {
                self.runs
                    .iter()
                    .find(|r| r.id == o.id)
                    .is_none_or(|r| r.input_hash == o.input_hash)
            })
    }

    pub fn load(path: &Path) -> Result<Self> {
        let m: Manifest =
            serde_json::from_str(&read_to_string(path)?).map_err(|source| Error::JsonFile {
                path: path.to_path_buf(),
                line: None,
                source,
            })?;
        if m.schema != 1 {
            return Err(Error::invalid("manifest schema", m.schema, "1"));
        }
        // a manifest travels between machines (SLURM): its ids become folder names, so each
        // must be the one its point and seed give (never a path out of the sweep's folder)
        for (k, r) in m.runs.iter().enumerate() {
            let want = Self::run_id(r.mu_r, r.eta_r, r.seed);
            if r.index != k || r.id != want {
                return Err(Error::invalid(
                    format!("{}: runs[{k}]", path.display()),
                    format!("index {} id {:?}", r.index, r.id),
                    format!("index {k} and id {want:?} (what its mu_r, eta_r and seed give; plan the sweep again)"),
                ));
            }
        }
        Ok(m)
    }

    pub fn save(&self, path: &Path) -> Result<()> {
        write_atomic(path, serde_json::to_string_pretty(self)?.as_bytes())
    }

    pub fn run(&self, index: usize) -> Result<&RunSpec> {
        self.runs.get(index).ok_or_else(|| {
            Error::invalid(
                "--index",
                index,
                match self.runs.len() {
                    0 => "none: the manifest lists no runs (plan the sweep again)".to_string(),
                    n => format!("0 ..= {} (the manifest's runs)", n - 1),
                },
            )
        })
    }
}

/// The shear request of one run (one seed).
pub fn shear_request(base: &SweepBase, r: &RunSpec, dir: &Path, threads: usize) -> ShearRequest {
    let case = CaseRequest {
        preset: base.preset,
        rolling: base.rolling,
        mu_r: r.mu_r,
        eta_r: r.eta_r,
        seed: r.seed,
        protocol: base.protocol.clone(),
        overrides: Overrides::default(),
        allow_inertial: false,
    };
    let mut q = ShearRequest::new(case, 1, base.engine, dir.to_path_buf());
    q.threads = Some(threads);
    q.quiet = true;
    // a run of the paper's protocol lasts hours: a line per 10 % with its ETA
    q.progress_label = Some(r.id.clone());
    q
}

fn input_hash(base: &SweepBase, r: &RunSpec) -> Result<String> {
    case_hash(&run_case(base, r)?, base.engine)
}

/// The input hash of a seed's case run by `engine`.
fn case_hash(case: &ShearCase, engine: Engine) -> Result<String> {
    run_input_hash(case, &format!("{engine:?}"))
}

/// The input hash of a run: FNV-1a 64 of the case JSON, what runs it (`tag`: a sweep's
/// engine, a convergence study's code), the crate version and the outcome schema, as 16 hex
/// digits. A stored result is reused only when its hash matches (a result of another schema
/// is run again, never misread).
pub fn run_input_hash(case: &ShearCase, tag: &str) -> Result<String> {
    let text = format!(
        "{}|{tag}|{}|{}",
        serde_json::to_string(case)?,
        env!("CARGO_PKG_VERSION"),
        super::SCHEMA
    );
    Ok(format!("{:016x}", fnv1a(text.as_bytes())))
}

/// Steady figures of one shear stage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StageResult {
    pub speed: f64,
    pub window_steps: (u64, u64),
    /// Each code's figures over the stage's steady window (its second half), one seed.
    pub liggghts: Option<Steady>,
    pub native: Option<Steady>,
}

/// `runs/<id>/result.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    /// The manifest entry (flattened: index, id, mu_r, eta_r, seed, input_hash).
    #[serde(flatten)]
    pub run: RunSpec,
    pub dt: f64,
    /// Explicit rolling dashpot stable at this dt, and the worst criterion S (unstable >= 4).
    pub dashpot_stable: bool,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub stability_s: f64,
    pub stages: Vec<StageResult>,
    pub liggghts_wall_s: Option<f64>,
    pub native_wall_s: Option<f64>,
    pub date_utc: String,
}

pub fn run_dir(sweep: &Path, r: &RunSpec) -> PathBuf {
    sweep.join("runs").join(&r.id)
}

/// The stored result of a run if it is current, else None: its record
/// ([`crate::fsutil::read_recorded`]) names the run's input hash and the file's SHA-256, and
/// the result is the manifest entry's.
pub fn current_result(sweep: &Path, r: &RunSpec) -> Option<RunResult> {
    stored_result(sweep, r).ok().flatten()
}

/// [`current_result`] with the reason a stored result is not reused (`Ok(None)`: none stored).
fn stored_result(sweep: &Path, r: &RunSpec) -> std::result::Result<Option<RunResult>, String> {
    let Some(bytes) =
        crate::fsutil::read_recorded(&run_dir(sweep, r).join("result.json"), &r.input_hash)?
    else {
        return Ok(None);
    };
    let res: RunResult =
        serde_json::from_slice(&bytes).map_err(|e| format!("it is not a run result ({e})"))?;
    if res.run != *r {
        return Err("it is the result of another manifest entry".into());
    }
    Ok(Some(res))
}

/// Runs one entry of the manifest (unless its current result exists) and writes its result
/// atomically. Returns the result and whether it was run now.
pub fn run_one(
    m: &Manifest,
    sweep: &Path,
    index: usize,
    threads: usize,
) -> Result<(RunResult, bool)> {
    let r = m.run(index)?;
    match stored_result(sweep, r) {
        Ok(Some(res)) => return Ok((res, false)),
        Ok(None) => {}
        Err(why) => crate::run::tell::warning(&format!(
            "run {} ({}): the stored result.json is not reused: {why}; made again",
            r.index, r.id
        )),
    }
    let dir = run_dir(sweep, r);
    let req = shear_request(&m.base, r, &dir, threads);
    let (case, warnings) = req.seed_case(r.seed)?;
    if case_hash(&case, m.base.engine)? != r.input_hash {
        return Err(Error::invalid(
            "manifest",
            format!("run {} ({})", r.index, r.id),
            "a manifest written by this version of verify (its input hash no longer matches: \
             plan the sweep again)",
        ));
    }
    let summary: ShearSummary =
        super::shear::run_cases(&req, vec![(case.clone(), warnings)], &|_| {})?;
    let ends = case.run_ends();
    // the study's series in memory (one seed; none for a code that did not run)
    let (ls, ns): (Option<Series>, Option<Series>) = (
        summary.series.liggghts.first().cloned(),
        summary.series.native.first().cloned(),
    );
    let area = case.box_x * case.box_z;
    let stage = |s: &Option<Series>, w: (u64, u64)| {
        s.as_ref().map(|s| steady(std::slice::from_ref(s), w, area))
    };
    let stages = case
        .stages
        .iter()
        .enumerate()
        .map(|(k, st)| {
            let w = steady_window(ends[k], ends[k + 1]);
            StageResult {
                speed: st.speed,
                window_steps: w,
                liggghts: stage(&ls, w),
                native: stage(&ns, w),
            }
        })
        .collect();
    let stab = stability(&case);
    let seed = summary.seeds.first();
    let res = RunResult {
        run: r.clone(),
        dt: case.dt,
        dashpot_stable: stab.stable,
        stability_s: stab.entries.first().map(|e| e.criterion).unwrap_or(0.0),
        stages,
        liggghts_wall_s: seed.and_then(|s| s.liggghts_wall_s),
        native_wall_s: seed.and_then(|s| s.native_wall_s),
        date_utc: super::utc_stamp(),
    };
    let path = dir.join("result.json");
    write_atomic(&path, serde_json::to_string_pretty(&res)?.as_bytes())?;
    crate::fsutil::write_record(&path, &r.input_hash)?;
    Ok((res, true))
}

/// Every current result of the manifest, and the runs that have none.
pub fn collect(m: &Manifest, sweep: &Path) -> (Vec<RunResult>, Vec<RunSpec>) {
    let mut done = Vec::new();
    let mut missing = Vec::new();
    for r in &m.runs {
        match current_result(sweep, r) {
            Some(res) => done.push(res),
            None => missing.push(r.clone()),
        }
    }
    (done, missing)
}

/// The runs' manifest indices, comma-separated (for messages).
pub fn indices(runs: &[RunSpec]) -> String {
    runs.iter()
        .map(|r| r.index.to_string())
        .collect::<Vec<_>>()
        .join(",")
}

/// `results.csv`: one row per run, stage and code.
pub fn results_csv(results: &[RunResult]) -> String {
    let mut s = String::from(
        "index,id,mu_r,eta_r,seed,speed[m/s],code,mu[-],normal_stress[Pa],erot[J],dt[s],dashpot_stable,stability_S\n",
    );
    for r in results {
        for st in &r.stages {
            for (code, c) in [("liggghts", &st.liggghts), ("native", &st.native)] {
                if let Some(c) = c {
                    s += &format!(
                        "{},{},{},{},{},{},{code},{:.17e},{:.17e},{:.17e},{},{},{}\n",
                        r.run.index,
                        r.run.id,
                        r.run.mu_r,
                        r.run.eta_r,
                        r.run.seed,
                        st.speed,
                        c.mu,
                        c.normal_stress,
                        c.erot,
                        r.dt,
                        r.dashpot_stable,
                        r.stability_s
                    );
                }
            }
        }
    }
    s
}

/// Collects DIR's results, writes results.json/.csv; errors naming the runs without a result.
pub fn collect_dir(dir: &Path) -> Result<(Vec<RunResult>, usize)> {
    let m = Manifest::load(&dir.join("manifest.json"))?;
    let (results, missing) = collect(&m, dir);
    write_atomic(
        &dir.join("results.json"),
        serde_json::to_string_pretty(&results)?.as_bytes(),
    )?;
    super::note_summary(&dir.join("results.json"));
    write_atomic(&dir.join("results.csv"), results_csv(&results).as_bytes())?;
    if !missing.is_empty() {
        return Err(Error::Cases(format!(
            "{} of {} runs have no current result (indices {}); run them with `verify sweep \
             run-one --manifest {} --index I`, resubmit the array, or rerun the sweep command \
             (it resumes)",
            missing.len(),
            m.runs.len(),
            indices(&missing),
            dir.join("manifest.json").display()
        )));
    }
    Ok((results, m.runs.len()))
}

/// A path that can go into a shell script between single quotes.
fn shell_path(p: &Path) -> Result<String> {
    let s = p.display().to_string();
    if s.contains(|c: char| c == '\'' || c == '"' || c.is_whitespace()) {
        return Err(Error::invalid(
            "path",
            &s,
            "a path without quotes or white space (it goes into a job script)",
        ));
    }
    Ok(format!("'{s}'"))
}

/// The SLURM job-array script of a manifest: one array task per run; with `ranks` > 1 each
/// run is one simulation decomposed over `ranks` MPI tasks started by `srun` (OpenMPI's
/// PMIx, as Debian's SLURM builds it: `srun --mpi=pmix`), rank 0 writing its files (issue
/// #39, `crate::ranks`), the binary built with the `mpi` feature.
pub fn slurm_script(m: &Manifest, dir: &Path, verify: &Path, ranks: usize) -> Result<String> {
    let cores = m.base.engine.cores();
    let dir = std::path::absolute(dir).map_err(|e| Error::io(dir, e))?;
    let (each, launch) = match ranks {
        1 => (String::new(), ""),
        r => (
            format!(" Each run over {r} MPI ranks (srun)."),
            "srun --mpi=pmix ",
        ),
    };
    Ok(format!(
        "#!/bin/bash\n\
         # DEM sweep: {n} runs ({preset} preset, {rolling}, engine {engine:?}), one array task each.{each}\n\
         # Submit: sbatch {script}; then: verify sweep collect {d}; verify sweep report {d}\n\
         #SBATCH --job-name=dem-sweep\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --ntasks={ranks}\n\
         #SBATCH --cpus-per-task={cores}\n\
         #SBATCH --output={logs}/run-%a.log\n\
         set -euo pipefail\n\
         exec {launch}{verify} sweep run-one --manifest {manifest} --index \"$SLURM_ARRAY_TASK_ID\" --threads 1\n",
        n = m.runs.len(),
        preset = m.base.preset,
        rolling = m.base.rolling,
        engine = m.base.engine,
        script = dir.join("sweep.sbatch").display(),
        d = dir.display(),
        last = m.runs.len() - 1,
        logs = shell_path(&dir.join("logs"))?.trim_matches('\''),
        verify = shell_path(verify)?,
        manifest = shell_path(&dir.join("manifest.json"))?,
    ))
}

/// A sweep: the manifest of `base` over mu_r x eta_r x seeds in `out`, run `jobs` at a time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepRequest {
    pub base: SweepBase,
    pub mu_r: Vec<f64>,
    pub eta_r: Vec<f64>,
    /// (mu_r, eta_r) points instead of the grid `mu_r x eta_r`.
    pub points: Option<Vec<(f64, f64)>>,
    pub seeds: u64,
    pub out: PathBuf,
    /// Runs at a time (each uses one core per code).
    pub jobs: usize,
    /// Native solver threads per run (default: every core with one job of the native engine,
    /// else 1).
    pub threads: Option<usize>,
}

impl SweepRequest {
    /// The manifest this request describes, validated (each run's case built once), without
    /// touching the disk: what [`plan`] stores and a study's `--dry-run` plan counts.
    pub fn manifest(&self) -> Result<Manifest> {
        let p = self;
        for (flag, v) in p
            .mu_r
            .iter()
            .map(|v| ("--mu-r", v))
            .chain(p.eta_r.iter().map(|v| ("--eta-r", v)))
            .chain(
                p.points
                    .iter()
                    .flatten()
                    .flat_map(|(m, e)| [("--points", m), ("--points", e)]),
            )
        {
            crate::spec::check_coefficient(flag, *v)?;
        }
        if p.jobs == 0 || p.jobs > 256 {
            return Err(Error::invalid("--jobs", p.jobs, "1 ..= 256"));
        }
        match &p.points {
            Some(points) => {
                Manifest::plan_points(p.base.clone(), points, p.seeds, super::utc_stamp())
            }
            None => Manifest::plan(
                p.base.clone(),
                &p.mu_r,
                &p.eta_r,
                p.seeds,
                super::utc_stamp(),
            ),
        }
    }
}

/// The case a manifest entry runs (its seed's, as [`run_one`] builds it).
pub fn run_case(base: &SweepBase, r: &RunSpec) -> Result<ShearCase> {
    Ok(shear_request(base, r, Path::new("."), 1)
        .seed_case(r.seed)?
        .0)
}

/// Plans the manifest of a request and stores it in `out`: a directory of the same sweep keeps
/// its manifest (more seeds or points may be added); one of another sweep is refused.
pub fn plan(p: &SweepRequest) -> Result<Manifest> {
    let out = &p.out;
    let mut m = p.manifest()?;
    let mpath = out.join("manifest.json");
    if mpath.is_file() {
        let old = Manifest::load(&mpath)?;
        if !m.compatible_with(&old) {
            return Err(Error::invalid(
                "--out",
                out.display(),
                "a new directory, or the directory of this sweep (it holds a different manifest: \
                 other shared settings, or runs whose inputs changed)",
            ));
        }
        if old.runs != m.runs {
            say!(
                "  the sweep grows from {} to {} runs (results of the common runs are kept)",
                old.runs.len(),
                m.runs.len()
            );
            m.save(&mpath)?;
        } else {
            m = old; // keep its creation time
        }
    } else {
        m.save(&mpath)?;
    }
    Ok(m)
}

/// What a local sweep invocation did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepOutcome {
    /// Runs whose current result existed before.
    pub skipped: usize,
    pub results: Vec<RunResult>,
    /// One message per failed run (its files and `error.txt` are kept).
    pub failures: Vec<String>,
    pub wall_s: f64,
}

/// Runs every run of `m` without a current result, `p.jobs` at a time; `progress` hears of
/// each finished run (Ok) or failure (Err, with the message). Writes `last_invocation.json`.
pub fn run_pending(
    p: &SweepRequest,
    m: &Manifest,
    progress: &(dyn Fn(&RunSpec, std::result::Result<&RunResult, &str>) + Sync),
) -> Result<SweepOutcome> {
    let out = &p.out;
    let t0 = std::time::Instant::now();
    let (done, pending): (Vec<_>, Vec<_>) = m
        .runs
        .iter()
        .partition(|r| current_result(out, r).is_some());
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let threads = match p.threads {
        Some(t) => super::check_threads("--threads", t)?,
        None if p.jobs == 1 && m.base.engine == Engine::Native => cores,
        None => 1,
    };
    let next = AtomicUsize::new(0);
    let failures: Mutex<Vec<String>> = Mutex::new(Vec::new());
    let results: Mutex<Vec<RunResult>> = Mutex::new(Vec::new());
    std::thread::scope(|sc| {
        for _ in 0..p.jobs.min(pending.len().max(1)) {
            sc.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::SeqCst);
                let Some(r) = pending.get(k) else { break };
                match run_one(m, out, r.index, threads) {
                    Ok((res, _)) => {
                        progress(r, Ok(&res));
                        results.lock().expect("lock").push(res);
                    }
                    Err(e) => {
                        let msg = format!("run {} ({}): {e}", r.index, r.id);
                        let _ = write_atomic(&run_dir(out, r).join("error.txt"), msg.as_bytes());
                        progress(r, Err(&msg));
                        failures.lock().expect("lock").push(msg);
                    }
                }
            });
        }
    });
    let wall = t0.elapsed().as_secs_f64();
    write_atomic(
        &out.join("last_invocation.json"),
        serde_json::to_string_pretty(&serde_json::json!({
            "date_utc": super::utc_stamp(), "wall_s": wall, "jobs": p.jobs,
            "runs_run": pending.len(), "runs_total": m.runs.len(),
        }))?
        .as_bytes(),
    )?;
    let mut results = results.into_inner().expect("lock");
    results.sort_by_key(|r| r.run.index);
    Ok(SweepOutcome {
        skipped: done.len(),
        results,
        failures: failures.into_inner().expect("lock"),
        wall_s: wall,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> SweepBase {
        SweepBase {
            preset: Preset::Ci,
            rolling: RollingModel::Epsd,
            engine: Engine::Native,
            protocol: Protocol {
                speeds: None,
                strain: Some(0.2),
                dt_factor: 1.0,
            },
        }
    }

    #[test]
    fn fnv_is_the_reference_function() {
        // published FNV-1a 64 test vectors
        assert_eq!(fnv1a(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a(b"foobar"), 0x85944171f73967e8);
    }

    #[test]
    fn plan_hashes_inputs_and_rejects_bad_values() {
        let m = Manifest::plan(base(), &[0.0, 0.5], &[0.0, 0.25], 2, "t".into()).unwrap();
        assert_eq!(m.runs.len(), 8);
        // points that are not a grid: the same runs as the grid's where they coincide
        let pts = Manifest::plan_points(base(), &[(0.5, 0.25), (0.0, 0.0)], 2, "t".into()).unwrap();
        let ids: Vec<&str> = pts.runs.iter().map(|r| r.id.as_str()).collect();
        assert_eq!(
            ids,
            [
                "mur0.5_etar0.25_s1",
                "mur0_etar0_s1",
                "mur0.5_etar0.25_s2",
                "mur0_etar0_s2"
            ]
        );
        assert!(Manifest::plan_points(base(), &[], 1, "t".into()).is_err());

        assert_eq!(m.runs[3].id, "mur0.5_etar0.25_s1");
        assert_eq!(m.runs[4].id, "mur0_etar0_s2");
        let mut hashes: Vec<&str> = m.runs.iter().map(|r| r.input_hash.as_str()).collect();
        hashes.sort();
        hashes.dedup();
        assert_eq!(hashes.len(), 8, "every run has its own inputs");
        // the same plan hashes the same; another strain changes every hash
        let again = Manifest::plan(base(), &[0.0, 0.5], &[0.0, 0.25], 2, "t".into()).unwrap();
        assert_eq!(again, m);
        let mut b = base();
        b.protocol.strain = Some(0.3);
        let other = Manifest::plan(b, &[0.0, 0.5], &[0.0, 0.25], 2, "t".into()).unwrap();
        assert!(other
            .runs
            .iter()
            .zip(&m.runs)
            .all(|(a, b)| a.input_hash != b.input_hash));
        let e = Manifest::plan(base(), &[-0.5], &[0.0], 1, "t".into()).unwrap_err();
        assert!(e.to_string().contains("--mu-r"), "{e}");
        let e = Manifest::plan(base(), &[0.5, 0.5], &[0.0], 1, "t".into()).unwrap_err();
        assert!(e.to_string().contains("distinct"), "{e}");
        let e = Manifest::plan(base(), &[0.5], &[0.0], 0, "t".into()).unwrap_err();
        assert!(e.to_string().contains("--seeds"), "{e}");
        assert!(m.run(8).is_err());
        // more seeds extend a sweep; other shared settings do not
        let more = Manifest::plan(base(), &[0.0, 0.5], &[0.0, 0.25], 3, "t".into()).unwrap();
        assert!(more.compatible_with(&m) && m.compatible_with(&more));
        assert!(!other.compatible_with(&m));
    }

    #[test]
    fn a_result_of_nans_reads_back_so_the_sweep_does_not_rerun_it_forever() {
        // a blown-up seed's figures are NaN; serde_json writes them as null
        let m = Manifest::plan(base(), &[0.5], &[0.0], 1, "t".into()).unwrap();
        let nan_series = Series {
            columns: vec!["mu[-]".into(), "top_f_y[N]".into()],
            steps: vec![10],
            rows: vec![vec![f64::NAN, f64::NAN]],
        };
        let st = crate::compare::steady(&[nan_series], (0, 10), 1.0);
        let res = RunResult {
            run: m.runs[0].clone(),
            dt: 1e-7,
            dashpot_stable: true,
            stability_s: f64::NAN,
            stages: vec![StageResult {
                speed: 0.01,
                window_steps: (0, 10),
                liggghts: None,
                native: Some(st),
            }],
            liggghts_wall_s: None,
            native_wall_s: Some(1.0),
            date_utc: "now".into(),
        };
        let dir = tempfile::tempdir().unwrap();
        let path = run_dir(dir.path(), &m.runs[0]).join("result.json");
        write_atomic(&path, serde_json::to_string(&res).unwrap().as_bytes()).unwrap();
        // without its record a result is not trusted
        assert!(current_result(dir.path(), &m.runs[0]).is_none());
        crate::fsutil::write_record(&path, &m.runs[0].input_hash).unwrap();
        let back = current_result(dir.path(), &m.runs[0]).expect("a stored result reads back");
        let n = back.stages[0].native.as_ref().unwrap();
        assert!(n.mu.is_nan() && n.per_seed_mu[0].is_nan() && back.stability_s.is_nan());
        // one changed byte (a friction figure edited by hand) and it is made again
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, text.replacen("0.01", "0.02", 1)).unwrap();
        assert!(current_result(dir.path(), &m.runs[0]).is_none());
        assert!(stored_result(dir.path(), &m.runs[0])
            .unwrap_err()
            .contains("SHA-256"));
    }
}
