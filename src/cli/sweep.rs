//! `verify sweep`: the paper's parametric study. Plans a manifest, runs it locally N at a time
//! (resumable), or emits a SLURM job array that calls `verify sweep run-one` per entry;
//! `collect` gathers results, `report` draws the paper's figures and checks its conclusions.

use crate::cli::args::{EngineArg, PresetArg, RollingArg};
use crate::cli::shear::ProtocolArgs;
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::report::sweep::{report, Beside};
use crate::run::sweep::{
    collect_dir, plan, run_dir, run_one, run_pending, slurm_script, Manifest, RunResult, SweepBase,
    SweepRequest,
};
use crate::run::Verdict;
use clap::{Args, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    pub action: Option<SweepAction>,
    #[command(flatten)]
    pub plan: PlanArgs,
}

#[derive(Subcommand, Debug)]
pub enum SweepAction {
    /// Runs one entry of a manifest (what each SLURM array task calls); skips it when its
    /// current result exists.
    RunOne {
        #[arg(long)]
        manifest: PathBuf,
        #[arg(long)]
        index: usize,
        /// Native solver threads (default: 1).
        #[arg(long, default_value_t = 1)]
        threads: usize,
    },
    /// Gathers every run's result into DIR/results.json and DIR/results.csv.
    Collect { dir: PathBuf },
    /// The paper's figures and conclusions from DIR's results (DIR/report.html).
    Report {
        dir: PathBuf,
        /// Results at a smaller dt, shown beside these; the conclusions are judged on them
        /// too. Either a second sweep of the same points (`--dt-factor`) or the output of a
        /// `verify convergence` study (its finest native dt); repeat for several.
        #[arg(long)]
        converged: Vec<PathBuf>,
        /// Another sweep whose conclusions are shown beside these, claim by claim, judged
        /// from its own results (e.g. the fast preset's speed study beside the paper
        /// protocol).
        #[arg(long)]
        beside: Option<PathBuf>,
        /// The stand-ins of the --beside sweep, as --converged are this one's; repeat for
        /// several.
        #[arg(long, requires = "beside")]
        beside_converged: Vec<PathBuf>,
    },
}

#[derive(Args, Debug)]
pub struct PlanArgs {
    /// Rolling friction coefficients, comma separated.
    #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.25, 0.5, 0.75, 1.0])]
    pub mu_r: Vec<f64>,
    /// Rolling viscous damping coefficients, comma separated.
    #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.25, 0.5, 0.75])]
    pub eta_r: Vec<f64>,
    /// (mu_r, eta_r) points instead of the grid --mu-r x --eta-r, each `mu_r:eta_r`, comma
    /// separated (e.g. `0.5:0.5,0.5:0,1:0.5`).
    #[arg(long, value_delimiter = ',', value_parser = point, conflicts_with_all = ["mu_r", "eta_r"])]
    pub points: Option<Vec<(f64, f64)>>,
    /// Seeds per point.
    #[arg(long, default_value_t = 3)]
    pub seeds: u64,
    /// Shear preset: ci, fast, paper.
    #[arg(long, value_enum, default_value = "fast")]
    pub preset: PresetArg,
    /// Rolling model.
    #[arg(long, value_enum, default_value = "epsd")]
    pub rolling: RollingArg,
    /// Codes: native, liggghts, both.
    #[arg(long, value_enum, default_value = "native")]
    pub engine: EngineArg,
    #[command(flatten)]
    pub protocol: ProtocolArgs,
    /// Sweep directory (manifest, runs, results, report).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Runs at a time (each uses one core per code).
    #[arg(long, default_value_t = 1)]
    pub jobs: usize,
    /// Native solver threads per run (default: every core with one job of the native engine,
    /// else 1).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Write a scheduler script for the manifest instead of running: `slurm`.
    #[arg(long, value_enum)]
    pub emit: Option<Scheduler>,
    /// With `--emit slurm`: MPI ranks of each run (`srun`; a verify built with the `mpi`
    /// feature), 1 ..= 1024.
    #[arg(long, default_value_t = 1, requires = "emit")]
    pub ranks_per_run: usize,
}

/// Schedulers a sweep can emit a script for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Scheduler {
    Slurm,
}

/// `--points`: one `mu_r:eta_r` pair.
fn point(s: &str) -> std::result::Result<(f64, f64), String> {
    let bad = || format!("{s}: valid is mu_r:eta_r, two numbers, e.g. 0.5:0.25");
    let (m, e) = s.split_once(':').ok_or_else(bad)?;
    Ok((
        m.trim().parse().map_err(|_| bad())?,
        e.trim().parse().map_err(|_| bad())?,
    ))
}

pub fn sweep(a: SweepArgs) -> Result<Verdict> {
    match a.action {
        Some(SweepAction::RunOne {
            manifest,
            index,
            threads,
        }) => {
            let m = Manifest::load(&manifest)?;
            let dir = manifest
                .parent()
                .filter(|p| !p.as_os_str().is_empty())
                .unwrap_or(Path::new("."));
            crate::run::check_threads("--threads", threads)?;
            let t = Instant::now();
            let (res, ran) = run_one(&m, dir, index, threads)?;
            if ran {
                crate::report::shear::figures_from_dir(&run_dir(dir, m.run(index)?))?;
            }
            println!(
                "run {index} ({}): {} in {:.1} s; {}",
                res.run.id,
                if ran {
                    "done"
                } else {
                    "result current, skipped"
                },
                t.elapsed().as_secs_f64(),
                stage_line(&res)
            );
            Ok(Verdict::Done)
        }
        Some(SweepAction::Collect { dir }) => {
            let (results, total) = collect_dir(&dir)?;
            println!(
                "collected {} of {total} runs into {}",
                results.len(),
                dir.join("results.csv").display()
            );
            Ok(Verdict::Done)
        }
        Some(SweepAction::Report {
            dir,
            converged,
            beside,
            beside_converged,
        }) => {
            let beside = beside.map(|dir| Beside {
                dir,
                converged: beside_converged,
            });
            report(&dir, &converged, beside.as_ref())?;
            Ok(Verdict::Done)
        }
        None => plan_and_run(a.plan),
    }
}

fn stage_line(r: &RunResult) -> String {
    r.stages
        .iter()
        .map(|s| {
            // only the codes that ran: "mu native 0.511", "mu LIGGGHTS 0.52, native 0.51"
            let codes: Vec<String> = [("LIGGGHTS", &s.liggghts), ("native", &s.native)]
                .into_iter()
                .filter_map(|(name, c)| c.as_ref().map(|c| format!("{name} {:.3}", c.mu)))
                .collect();
            format!("v {} m/s: mu {}", s.speed, codes.join(", "))
        })
        .collect::<Vec<_>>()
        .join("; ")
}

impl PlanArgs {
    /// The request these flags describe, into `out` (what the sweep and a study's plan use).
    pub fn request(&self, out: PathBuf) -> SweepRequest {
        SweepRequest {
            base: SweepBase {
                preset: self.preset.into(),
                rolling: self.rolling.into(),
                engine: self.engine.into(),
                protocol: (&self.protocol).into(),
            },
            mu_r: self.mu_r.clone(),
            eta_r: self.eta_r.clone(),
            points: self.points.clone(),
            seeds: self.seeds,
            out,
            jobs: self.jobs,
            threads: self.threads,
        }
    }
}

fn plan_and_run(p: PlanArgs) -> Result<Verdict> {
    let out = p
        .out
        .clone()
        .ok_or_else(|| Error::invalid("--out", "(missing)", "the sweep directory (required)"))?;
    if !(1..=1024).contains(&p.ranks_per_run) {
        return Err(Error::invalid(
            "--ranks-per-run",
            p.ranks_per_run,
            "1 ..= 1024",
        ));
    }
    if p.ranks_per_run > 1 && !cfg!(feature = "mpi") {
        return Err(Error::invalid(
            "--ranks-per-run",
            p.ranks_per_run,
            "1 in a build without MPI (install with `cargo install --path . --features mpi`)",
        ));
    }
    let req = p.request(out.clone());
    let m = plan(&req)?;
    let mpath = out.join("manifest.json");
    let points = match &p.points {
        Some(pts) => format!("{} points", pts.len()),
        None => format!("{} mu_r x {} eta_r", p.mu_r.len(), p.eta_r.len()),
    };
    println!(
        "verify sweep: {} runs ({points} x {} seeds), preset {}, {}, engine {}, dt factor {}; {}",
        m.runs.len(),
        p.seeds,
        m.base.preset,
        m.base.rolling,
        m.base.engine.keyword(),
        p.protocol.dt_factor,
        mpath.display()
    );
    if p.emit == Some(Scheduler::Slurm) {
        let exe = std::env::current_exe().map_err(|e| Error::io("verify binary", e))?;
        let script = slurm_script(&m, &out, &exe, p.ranks_per_run)?;
        std::fs::create_dir_all(out.join("logs")).map_err(|e| Error::io(&out, e))?;
        write_atomic(&out.join("sweep.sbatch"), script.as_bytes())?;
        println!(
            "wrote {} ({} array tasks). Submit with\n  sbatch {}\nthen\n  verify sweep collect {}\n  verify sweep report {}",
            out.join("sweep.sbatch").display(),
            m.runs.len(),
            out.join("sweep.sbatch").display(),
            out.display(),
            out.display()
        );
        return Ok(Verdict::Done);
    }
    let done = m
        .runs
        .iter()
        .filter(|r| crate::run::sweep::current_result(&out, r).is_some())
        .count();
    if done > 0 {
        println!("  {done} runs already have a current result: skipped");
    }
    let bar = ProgressBar::new(m.runs.len() as u64).with_position(done as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "sweep {bar:30} {pos}/{len} runs  elapsed {elapsed_precise}  ETA {eta_precise}  {msg}",
        )
        .expect("template"),
    );
    let o = run_pending(&req, &m, &|r, res| {
        match res {
            Ok(res) => {
                bar.println(format!("  {}: {}", res.run.id, stage_line(res)));
                // the run's own figures, drawn as it finishes (a failure to draw keeps its
                // result and is said)
                if let Err(e) = crate::report::shear::figures_from_dir(&run_dir(&req.out, r)) {
                    bar.println(format!("  {}: figures not drawn: {e}", r.id));
                }
            }
            Err(msg) => bar.println(format!("  FAILED {msg}")),
        }
        bar.inc(1);
        bar.set_message(format!("last: {}", r.id));
    })?;
    bar.finish();
    println!(
        "ran {} runs in {:.1} min",
        o.results.len() + o.failures.len(),
        o.wall_s / 60.0
    );
    if !o.failures.is_empty() {
        return Err(Error::Cases(format!(
            "{} run(s) failed (the others are kept; rerun the command to retry them):\n  {}",
            o.failures.len(),
            o.failures.join("\n  ")
        )));
    }
    collect_dir(&out)?;
    report(&out, &[], None)?;
    Ok(Verdict::Done)
}
