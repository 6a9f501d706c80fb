//! `verify sweep`: the paper's parametric study. Plans a manifest, runs it locally N at a time
//! (resumable), or emits a SLURM job array that calls `verify sweep run-one` per entry;
//! `collect` gathers results, `report` draws the paper's figures and checks its conclusions.

use crate::cli::{utc_stamp, Outcome};
use crate::cli_shear::Protocol;
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::report::bars::escape;
use crate::report::html::{table, Page};
use crate::report::paper::{aggregate, conclusions, heat_map, Conclusion, Point};
use crate::report::plot::{line_plot, Curve};
use crate::sweep::{collect, results_csv, run_one, Engine, Manifest, RunResult, SweepBase};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
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
    /// Seeds per point.
    #[arg(long, default_value_t = 3)]
    pub seeds: u64,
    /// Shear preset: ci, fast, paper.
    #[arg(long, default_value = "fast")]
    pub preset: String,
    /// Rolling model.
    #[arg(long, default_value = "epsd")]
    pub rolling: String,
    /// Codes: native, liggghts, both.
    #[arg(long, default_value = "native")]
    pub engine: String,
    #[command(flatten)]
    pub protocol: Protocol,
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
    #[arg(long)]
    pub emit: Option<String>,
}

pub fn sweep(a: SweepArgs) -> Result<Outcome> {
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
            if threads == 0 {
                return Err(Error::invalid("--threads", 0, ">= 1"));
            }
            let t = Instant::now();
            let (res, ran) = run_one(&m, dir, index, threads)?;
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
            Ok(Outcome::Agree)
        }
        Some(SweepAction::Collect { dir }) => {
            let (results, total) = collect_dir(&dir)?;
            println!(
                "collected {} of {total} runs into {}",
                results.len(),
                dir.join("results.csv").display()
            );
            Ok(Outcome::Agree)
        }
        Some(SweepAction::Report { dir, converged }) => {
            report(&dir, &converged)?;
            Ok(Outcome::Agree)
        }
        None => plan_and_run(a.plan),
    }
}

fn stage_line(r: &RunResult) -> String {
    r.stages
        .iter()
        .map(|s| {
            let f = |c: &Option<crate::sweep::CodeStage>| {
                c.as_ref()
                    .map(|c| format!("{:.3}", c.mu))
                    .unwrap_or("-".into())
            };
            format!(
                "v {} m/s: mu LIGGGHTS {} native {}",
                s.speed,
                f(&s.liggghts),
                f(&s.native)
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// Collects DIR's results, writes results.json/.csv; errors naming the runs without a result.
fn collect_dir(dir: &Path) -> Result<(Vec<RunResult>, usize)> {
    let m = Manifest::load(&dir.join("manifest.json"))?;
    let (results, missing) = collect(&m, dir);
    write_atomic(
        &dir.join("results.json"),
        serde_json::to_string_pretty(&results)?.as_bytes(),
    )?;
    write_atomic(&dir.join("results.csv"), results_csv(&results).as_bytes())?;
    if !missing.is_empty() {
        return Err(Error::Cases(format!(
            "{} of {} runs have no current result (indices {}); run them with `verify sweep \
             run-one --manifest {} --index I`, resubmit the array, or rerun the sweep command \
             (it resumes)",
            missing.len(),
            m.runs.len(),
            missing
                .iter()
                .map(|r| r.index.to_string())
                .collect::<Vec<_>>()
                .join(","),
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

/// The SLURM job-array script of a manifest.
pub fn slurm_script(m: &Manifest, dir: &Path, verify: &Path) -> Result<String> {
    let cores = m.base.engine.cores();
    let dir = std::path::absolute(dir).map_err(|e| Error::io(dir, e))?;
    Ok(format!(
        "#!/bin/bash\n\
         # DEM sweep: {n} runs ({preset} preset, {rolling}, engine {engine:?}), one array task each.\n\
         # Submit: sbatch {script}; then: verify sweep collect {d}; verify sweep report {d}\n\
         #SBATCH --job-name=dem-sweep\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --ntasks=1\n\
         #SBATCH --cpus-per-task={cores}\n\
         #SBATCH --output={logs}/run-%a.log\n\
         set -euo pipefail\n\
         exec {verify} sweep run-one --manifest {manifest} --index \"$SLURM_ARRAY_TASK_ID\" --threads 1\n",
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

fn plan_and_run(p: PlanArgs) -> Result<Outcome> {
    let out = p
        .out
        .clone()
        .ok_or_else(|| Error::invalid("--out", "(missing)", "the sweep directory (required)"))?;
    for (flag, v) in p
        .mu_r
        .iter()
        .map(|v| ("--mu-r", v))
        .chain(p.eta_r.iter().map(|v| ("--eta-r", v)))
    {
        if !(v.is_finite() && *v >= 0.0) {
            return Err(Error::invalid(flag, v, "finite numbers >= 0"));
        }
    }
    if let Some(e) = p.emit.as_deref().filter(|e| *e != "slurm") {
        return Err(Error::Unknown {
            what: "scheduler (--emit)",
            name: e.into(),
            valid: "slurm".into(),
        });
    }
    if p.jobs == 0 || p.jobs > 256 {
        return Err(Error::invalid("--jobs", p.jobs, "1 ..= 256"));
    }
    let base = SweepBase {
        preset: p.preset.clone(),
        rolling: p.rolling.clone(),
        engine: Engine::parse(&p.engine)?,
        protocol: p.protocol.clone(),
    };
    let mut m = Manifest::plan(base, &p.mu_r, &p.eta_r, p.seeds, utc_stamp())?;
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
            println!(
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
    println!(
        "verify sweep: {} runs ({} mu_r x {} eta_r x {} seeds), preset {}, {}, engine {}, dt factor {}; {}",
        m.runs.len(),
        p.mu_r.len(),
        p.eta_r.len(),
        p.seeds,
        p.preset,
        p.rolling,
        p.engine,
        p.protocol.dt_factor,
        mpath.display()
    );
    if p.emit.is_some() {
        let exe = std::env::current_exe().map_err(|e| Error::io("verify binary", e))?;
        let script = slurm_script(&m, &out, &exe)?;
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
        return Ok(Outcome::Agree);
    }
    let t0 = Instant::now();
    let (done, pending): (Vec<_>, Vec<_>) = m
        .runs
        .iter()
        .partition(|r| crate::sweep::current_result(&out, r).is_some());
    if !done.is_empty() {
        println!(
            "  {} runs already have a current result: skipped",
            done.len()
        );
    }
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let threads = match p.threads {
        Some(0) => return Err(Error::invalid("--threads", 0, ">= 1")),
        Some(t) => t,
        None if p.jobs == 1 && m.base.engine == Engine::Native => cores,
        None => 1,
    };
    let bar = ProgressBar::new(m.runs.len() as u64).with_position(done.len() as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "sweep {bar:30} {pos}/{len} runs  elapsed {elapsed_precise}  ETA {eta_precise}  {msg}",
        )
        .expect("template"),
    );
    let next = AtomicUsize::new(0);
    let failures: Mutex<Vec<String>> = Mutex::new(Vec::new());
    std::thread::scope(|sc| {
        for _ in 0..p.jobs.min(pending.len().max(1)) {
            sc.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::SeqCst);
                let Some(r) = pending.get(k) else { break };
                match run_one(&m, &out, r.index, threads) {
                    Ok((res, _)) => bar.println(format!("  {}: {}", res.run.id, stage_line(&res))),
                    Err(e) => {
                        let msg = format!("run {} ({}): {e}", r.index, r.id);
                        let _ = write_atomic(
                            &crate::sweep::run_dir(&out, r).join("error.txt"),
                            msg.as_bytes(),
                        );
                        bar.println(format!("  FAILED {msg}"));
                        failures.lock().expect("lock").push(msg);
                    }
                }
                bar.inc(1);
                bar.set_message(format!("last: {}", r.id));
            });
        }
    });
    bar.finish();
    let wall = t0.elapsed().as_secs_f64();
    write_atomic(
        &out.join("last_invocation.json"),
        serde_json::to_string_pretty(&serde_json::json!({
            "date_utc": utc_stamp(), "wall_s": wall, "jobs": p.jobs,
            "runs_run": pending.len(), "runs_total": m.runs.len(),
        }))?
        .as_bytes(),
    )?;
    println!("ran {} runs in {:.1} min", pending.len(), wall / 60.0);
    let failures = failures.into_inner().expect("lock");
    if !failures.is_empty() {
        return Err(Error::Cases(format!(
            "{} run(s) failed (the others are kept; rerun the command to retry them):\n  {}",
            failures.len(),
            failures.join("\n  ")
        )));
    }
    collect_dir(&out)?;
    report(&out, &[])?;
    Ok(Outcome::Agree)
}

/// An owned curve with error bars (one colour per eta_r; LIGGGHTS and converged dt dashed).
struct ErrCurve {
    label: String,
    color: usize,
    dashed: bool,
    points: Vec<(f64, f64)>,
    err: Vec<f64>,
}

fn err_plot(path: &Path, title: &str, x_desc: &str, data: &[ErrCurve]) -> Result<()> {
    let curves: Vec<Curve> = data
        .iter()
        .map(|d| {
            let c = Curve::new(&d.label, &d.points, d.color).with_err(&d.err);
            if d.dashed {
                c.dashed()
            } else {
                c
            }
        })
        .collect();
    line_plot(path, title, x_desc, "steady mu", &curves)
}

/// `DIR/report.json`: the aggregated points and the conclusions per code.
#[derive(Serialize)]
struct SweepReport {
    points: Vec<Point>,
    conclusions: Vec<(String, Vec<Conclusion>)>,
    converged_points: Vec<Point>,
    converged_conclusions: Vec<(String, Vec<Conclusion>)>,
    runs: usize,
    run_wall_s_liggghts: f64,
    run_wall_s_native: f64,
}

/// The smaller-dt points of `dir`: a sweep (manifest.json: every result aggregated) or a
/// `verify convergence` output (summary.json: native at its finest dt).
fn converged_points(dir: &Path) -> Result<Vec<Point>> {
    if dir.join("manifest.json").is_file() {
        let cm = Manifest::load(&dir.join("manifest.json"))?;
        return Ok(aggregate(&collect(&cm, dir).0));
    }
    let bad = || {
        Error::invalid(
            "--converged",
            dir.display(),
            "a sweep directory (with manifest.json) or the output directory of `verify \
             convergence` (with a summary.json naming mu_r and eta_r)",
        )
    };
    let text = std::fs::read_to_string(dir.join("summary.json")).map_err(|_| bad())?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|_| bad())?;
    let num = |x: &serde_json::Value| x.as_f64().ok_or_else(bad);
    let finest = v["points"]
        .as_array()
        .ok_or_else(bad)?
        .iter()
        .filter(|p| p["code"] == "native")
        .min_by(|a, b| {
            let f = |p: &serde_json::Value| p["dt_factor"].as_f64().unwrap_or(f64::INFINITY);
            f(a).total_cmp(&f(b))
        })
        .ok_or_else(bad)?;
    Ok(vec![Point {
        code: "native".into(),
        mu_r: num(&v["mu_r"])?,
        eta_r: num(&v["eta_r"])?,
        stage: v["stage"].as_u64().ok_or_else(bad)? as usize,
        speed: num(&v["speed"])?,
        mu: num(&finest["steady"]["mu"])?,
        mu_ci95: num(&finest["steady"]["mu_ci95"]).unwrap_or(f64::INFINITY),
        seeds: finest["steady"]["per_seed_mu"]
            .as_array()
            .map_or(0, |a| a.len()),
        erot: num(&finest["erot"])?,
        dashpot_stable: finest["stability"]["stable"].as_bool().ok_or_else(bad)?,
        stability_s: num(&finest["stability"]["entries"][0]["criterion"])?,
    }])
}

/// The paper's figures, the conclusions and a report page from DIR's (current) results.
pub fn report(dir: &Path, converged: &[PathBuf]) -> Result<()> {
    let m = Manifest::load(&dir.join("manifest.json"))?;
    let (results, missing) = collect(&m, dir);
    if results.is_empty() {
        return Err(Error::Cases(format!(
            "no results in {} yet (run the sweep first)",
            dir.display()
        )));
    }
    let points = aggregate(&results);
    let mut conv_points = Vec::new();
    for c in converged {
        conv_points.extend(converged_points(c)?);
    }
    let codes: Vec<String> = {
        let mut c: Vec<String> = points.iter().map(|p| p.code.clone()).collect();
        c.dedup();
        c
    };
    let concl: Vec<(String, Vec<Conclusion>)> = codes
        .iter()
        .map(|c| (c.clone(), conclusions(&points, c)))
        .collect();
    // the conclusions judged on trustworthy numbers: each point where the explicit dashpot is
    // stable as it is, each unstable point by its converged-dt result, unstable points
    // without one left out
    let judged: Vec<Point> = points
        .iter()
        .filter_map(|p| {
            if p.dashpot_stable {
                return Some(p.clone());
            }
            conv_points
                .iter()
                .find(|c| {
                    c.code == p.code && c.stage == p.stage && c.mu_r == p.mu_r && c.eta_r == p.eta_r
                })
                .cloned()
        })
        .collect();
    let conv_concl: Vec<(String, Vec<Conclusion>)> = if conv_points.is_empty() {
        Vec::new()
    } else {
        codes
            .iter()
            .filter(|c| judged.iter().any(|p| &p.code == *c))
            .map(|c| (c.clone(), conclusions(&judged, c)))
            .collect()
    };
    let figs = dir.join("figures");
    let mut page = Page::new("DEM sweep: the paper's parametric study");
    page.html("<h1>Parametric study: steady friction over (mu_r, eta_r)</h1>");
    let wall_l: f64 = results.iter().filter_map(|r| r.liggghts_wall_s).sum();
    let wall_n: f64 = results.iter().filter_map(|r| r.native_wall_s).sum();
    let inv: Option<serde_json::Value> = std::fs::read_to_string(dir.join("last_invocation.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    page.html(&format!(
        "<p class=\"meta\">{} of {} runs ({} preset, {}, engine {:?}, dt factor {}, created {}). \
         Run wall time summed over runs: native {:.2} h, LIGGGHTS {:.2} h{}.</p>",
        results.len(),
        m.runs.len(),
        escape(&m.base.preset),
        escape(&m.base.rolling),
        m.base.engine,
        m.base.protocol.dt_factor,
        escape(&m.created_utc),
        wall_n / 3600.0,
        wall_l / 3600.0,
        inv.map(|v| format!(
            "; last local invocation: {:.2} h wall with {} job(s) for {} runs",
            v["wall_s"].as_f64().unwrap_or(f64::NAN) / 3600.0,
            v["jobs"],
            v["runs_run"]
        ))
        .unwrap_or_default()
    ));
    if !missing.is_empty() {
        page.html(&format!(
            "<p class=\"warn\">{} runs have no result yet: the figures show what exists.</p>",
            missing.len()
        ));
    }
    page.heading("conclusions", "The paper's conclusions, checked");
    for (title, set) in [
        ("at the sweep's dt", &concl),
        (
            "on stable or converged-dt results: unstable points replaced by their converged \
             result, those without one left out",
            &conv_concl,
        ),
    ] {
        for (code, cs) in set.iter() {
            let rows: Vec<Vec<(String, &str)>> = cs
                .iter()
                .map(|c| {
                    vec![
                        (escape(&c.claim), ""),
                        (
                            escape(&c.verdict),
                            match c.verdict.as_str() {
                                "agrees" => "pass",
                                "not assessable" | "not resolved" | "partly agrees" => "warn",
                                _ => "fail",
                            },
                        ),
                        (escape(&c.evidence), ""),
                    ]
                })
                .collect();
            page.html(&format!("<h3>{} ({title})</h3>", escape(code)));
            page.html(&table(&["paper's claim", "our result", "evidence"], &rows));
            for c in cs.iter().filter(|c| c.verdict != "agrees") {
                page.para(&format!(
                    "Where we differ from the paper ({code}, {title}): \"{}\" {} — {}.",
                    c.claim, c.verdict, c.evidence
                ));
            }
        }
    }
    let unstable: Vec<String> = points
        .iter()
        .filter(|p| !p.dashpot_stable && p.stage == 0)
        .map(|p| format!("(mu_r {}, eta_r {})", p.mu_r, p.eta_r))
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    if !unstable.is_empty() {
        page.para(&format!(
            "The explicit rolling dashpot is expected to be unstable at this dt at {} point(s): {}. \
             Results there may show the numerical artefact (spurious rotational energy, low mu); \
             judge them on converged-dt results: a sweep at `--dt-factor 0.25` or `verify \
             convergence` studies of single points, passed as `verify sweep report DIR --converged \
             DIR2 [--converged DIR3 ...]`.",
            unstable.len(),
            unstable.join(", ")
        ));
    }
    page.heading("figures", "Figures");
    let mut fig_html = Vec::new();
    let stages: Vec<(usize, f64)> = {
        let mut s: Vec<(usize, f64)> = points.iter().map(|p| (p.stage, p.speed)).collect();
        s.sort_by_key(|a| a.0);
        s.dedup();
        s
    };
    let mut etas: Vec<f64> = points.iter().map(|p| p.eta_r).collect();
    etas.sort_by(f64::total_cmp);
    etas.dedup();
    let mut mus: Vec<f64> = points.iter().map(|p| p.mu_r).collect();
    mus.sort_by(f64::total_cmp);
    mus.dedup();
    // mu against mu_r, one curve per eta_r and code, one panel per speed (paper Figs 5-7)
    for &(k, speed) in &stages {
        let mut data: Vec<ErrCurve> = Vec::new();
        for (ci, &e) in etas.iter().enumerate() {
            for (set, tag) in [(&points, ""), (&conv_points, " converged dt")] {
                for code in &codes {
                    let sel: Vec<&Point> = set
                        .iter()
                        .filter(|p| &p.code == code && p.stage == k && p.eta_r == e)
                        .collect();
                    if sel.is_empty() {
                        continue;
                    }
                    data.push(ErrCurve {
                        label: format!("eta_r {e} {code}{tag}"),
                        color: ci,
                        dashed: code == "liggghts" || !tag.is_empty(),
                        points: sel.iter().map(|p| (p.mu_r, p.mu)).collect(),
                        err: sel.iter().map(|p| p.mu_ci95).collect(),
                    });
                }
            }
        }
        let path = figs.join(format!("mu_vs_mur_stage{k}.svg"));
        err_plot(
            &path,
            &format!("steady mu against mu_r, shear speed {speed} m/s"),
            "mu_r",
            &data,
        )?;
        fig_html.push(page.svg_file(
            &path,
            &format!("Steady μ against μr at {speed} m/s, one curve per ηr (95 % CI bars; LIGGGHTS and converged-dt results dashed)."),
        )?);
    }
    // mu against speed, one panel per mu_r (paper Figs 12-15)
    if stages.len() > 1 {
        for &m_r in &mus {
            let mut data: Vec<ErrCurve> = Vec::new();
            for (ci, &e) in etas.iter().enumerate() {
                for code in &codes {
                    let sel: Vec<&Point> = points
                        .iter()
                        .filter(|p| &p.code == code && p.mu_r == m_r && p.eta_r == e)
                        .collect();
                    if !sel.is_empty() {
                        data.push(ErrCurve {
                            label: format!("eta_r {e} {code}"),
                            color: ci,
                            dashed: code == "liggghts",
                            points: sel.iter().map(|p| (p.speed, p.mu)).collect(),
                            err: sel.iter().map(|p| p.mu_ci95).collect(),
                        });
                    }
                }
            }
            let path = figs.join(format!("mu_vs_speed_mur{m_r}.svg"));
            err_plot(
                &path,
                &format!("steady mu against shear speed, mu_r {m_r}"),
                "shear speed [m/s]",
                &data,
            )?;
            fig_html.push(page.svg_file(&path, &format!("Steady μ against speed at μr = {m_r}."))?);
        }
    }
    // heat maps
    for code in &codes {
        for &(k, speed) in &stages {
            for (set, tag) in [(&points, ""), (&conv_points, "_converged")] {
                let sel: Vec<&Point> = set
                    .iter()
                    .filter(|p| &p.code == code && p.stage == k)
                    .collect();
                if sel.is_empty() {
                    continue;
                }
                let svg = heat_map(
                    &format!(
                        "steady mu, {code}, {speed} m/s{}",
                        if tag.is_empty() { "" } else { ", converged dt" }
                    ),
                    &sel,
                );
                write_atomic(
                    &figs.join(format!("heat_{code}_stage{k}{tag}.svg")),
                    svg.as_bytes(),
                )?;
                fig_html.push(page.svg(&svg, &format!("Steady μ over (μr, ηr), {code}.")));
            }
        }
    }
    page.figures(&fig_html);
    page.heading("table", "Points");
    let rows: Vec<Vec<(String, &str)>> = points
        .iter()
        .map(|p| {
            let conv = conv_points
                .iter()
                .find(|q| {
                    q.code == p.code && q.stage == p.stage && q.mu_r == p.mu_r && q.eta_r == p.eta_r
                })
                .map(|q| format!("{:.4} ± {:.4}", q.mu, q.mu_ci95))
                .unwrap_or("–".into());
            vec![
                (p.code.clone(), ""),
                (format!("{}", p.speed), "num"),
                (format!("{}", p.mu_r), "num"),
                (format!("{}", p.eta_r), "num"),
                (format!("{:.4} ± {:.4}", p.mu, p.mu_ci95), "num"),
                (p.seeds.to_string(), "num"),
                (format!("{:.2e}", p.erot), "num"),
                (
                    format!("{:.2}", p.stability_s),
                    if p.dashpot_stable { "pass" } else { "warn" },
                ),
                (conv, "num"),
            ]
        })
        .collect();
    page.html(&table(
        &[
            "code",
            "speed [m/s]",
            "mu_r",
            "eta_r",
            "steady mu (95 % CI)",
            "seeds",
            "E_rot [J]",
            "stability S (unstable ≥ 4)",
            "converged dt mu",
        ],
        &rows,
    ));
    write_atomic(&dir.join("report.html"), page.finish().as_bytes())?;
    let rep = SweepReport {
        points,
        conclusions: concl,
        converged_points: conv_points,
        converged_conclusions: conv_concl,
        runs: results.len(),
        run_wall_s_liggghts: wall_l,
        run_wall_s_native: wall_n,
    };
    write_atomic(
        &dir.join("report.json"),
        serde_json::to_string_pretty(&rep)?.as_bytes(),
    )?;
    for (code, cs) in rep.conclusions.iter().chain(&rep.converged_conclusions) {
        for c in cs {
            println!("  {code}: {} -> {} ({})", c.claim, c.verdict, c.evidence);
        }
    }
    println!("report: {}", dir.join("report.html").display());
    Ok(())
}
