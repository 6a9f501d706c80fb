//! `verify convergence`: the same shear case from the same compacted state at successively
//! smaller time steps (same strain), to tell physics from time-step artefacts such as the
//! unstable explicit rolling dashpot (see [`crate::spec::stability_shear`]).

use crate::cli::{utc_stamp, Outcome};
use crate::cli_shear::{shear_case, ShearArgs};
use crate::compare::{block_ci95, mean_ci95, steady, steady_window, Steady};
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::liggghts::Liggghts;
use crate::packing::loose_packing;
use crate::report::plot::{line_plot, Curve};
use crate::report::progress::Progress;
use crate::series::Series;
use crate::shear::{run_ends, run_liggghts, run_native, write_series};
use crate::solver::shear::compact;
use crate::spec::stability_shear::{stability, StabilityReport};
use crate::spec::RollingModel;
use crate::sweep::run_input_hash;
use clap::Args;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(Args, Debug, Clone)]
pub struct ConvergenceArgs {
    /// The shear case: every `verify shear` option (preset, mu_r, eta_r, rolling, seeds, ...).
    #[command(flatten)]
    pub case: ShearArgs,
    /// Factors applied to the preset's dt, largest first.
    #[arg(long, value_delimiter = ',', default_value = "1,0.5,0.25")]
    pub dt_factors: Vec<f64>,
    /// native, liggghts or both.
    #[arg(long, default_value = "native")]
    pub engine: String,
    /// The dt factors at which LIGGGHTS runs (with --engine liggghts|both); a subset of
    /// --dt-factors. Default: all of them. LIGGGHTS at the smallest dt is the costliest run.
    #[arg(long, value_delimiter = ',')]
    pub liggghts_dt_factors: Option<Vec<f64>>,
    /// Also run the native stable-dashpot model (`epsd_implicit`) at the largest dt factor,
    /// from the same compacted state: does it give at that dt what epsd gives converged?
    /// Only with --rolling epsd.
    #[arg(long)]
    pub with_implicit: bool,
}

/// The codes a convergence study can run: LIGGGHTS, the native solver with the case's rolling
/// model, and the native solver with the stable-dashpot model `epsd_implicit`.
const CODES: [&str; 3] = ["native", "liggghts", "implicit"];

/// The stored series of a run if it is current (its `.hash` file matches).
fn stored_series(dir: &Path, code: &str, hash: &str) -> Option<Series> {
    let h = std::fs::read_to_string(dir.join(format!("{code}.hash"))).ok()?;
    if h.trim() != hash {
        return None;
    }
    Series::read_csv(&dir.join(format!("{code}.csv"))).ok()
}

/// Figures of one (dt, code).
#[derive(Clone, Debug, Serialize)]
pub struct DtPoint {
    pub code: String,
    pub dt_factor: f64,
    pub dt: f64,
    pub steady: Steady,
    /// Mean rotational kinetic energy in the steady window, over seeds [J], with 95 % CI
    /// (over seeds; with one seed from 10 block means of the window).
    pub erot: f64,
    pub erot_ci95: f64,
    pub stability: StabilityReport,
}

/// The convergence verdict of one code.
#[derive(Clone, Debug, Serialize)]
pub struct CodeVerdict {
    pub code: String,
    pub finest_factor: f64,
    /// Its two smallest dt agree within their CIs.
    pub converged: bool,
    /// Largest factor from which every step to the next smaller dt agrees (when converged).
    pub largest_converged_factor: Option<f64>,
}

#[derive(Clone, Debug, Serialize)]
pub struct ConvergenceSummary {
    /// The case studied (what `verify sweep report --converged` matches points by).
    pub preset: String,
    pub rolling: String,
    pub mu_r: f64,
    pub eta_r: f64,
    /// Index and speed [m/s] of the stage whose steady window is measured (the last one).
    pub stage: usize,
    pub speed: f64,
    pub converged: bool,
    /// Largest dt factor from which every step to the next smaller dt agrees within the CIs
    /// (over codes: the smallest such factor).
    pub largest_converged_factor: Option<f64>,
    pub points: Vec<DtPoint>,
    /// Per code: its finest dt factor, converged there or not, its largest converged factor.
    pub per_code: Vec<CodeVerdict>,
    /// Per dt factor where both codes ran: their steady mu agree within the CIs.
    pub codes_agree: Vec<(f64, bool)>,
    /// With --with-implicit: whether epsd_implicit at the largest dt agrees (within the CIs)
    /// with the native epsd result at the smallest dt.
    pub implicit_matches_finest: Option<bool>,
    pub date_utc: String,
}

pub fn convergence(a: ConvergenceArgs) -> Result<Outcome> {
    if a.dt_factors.is_empty()
        || a.dt_factors
            .iter()
            .any(|f| !(f.is_finite() && *f > 0.0 && *f <= 1.0))
    {
        return Err(Error::invalid(
            "--dt-factors",
            format!("{:?}", a.dt_factors),
            "factors in (0, 1], e.g. 1,0.5,0.25",
        ));
    }
    if a.case.native_only || a.case.liggghts_only {
        return Err(Error::invalid(
            "--native-only/--liggghts-only",
            "given",
            "--engine native|liggghts|both for verify convergence",
        ));
    }
    if a.with_implicit && a.case.rolling != "epsd" {
        return Err(Error::invalid(
            "--with-implicit",
            &a.case.rolling,
            "--rolling epsd (epsd_implicit is the stable-dashpot variant of epsd)",
        ));
    }
    if let Some(lf) = &a.liggghts_dt_factors {
        if lf.is_empty() || lf.iter().any(|f| !a.dt_factors.contains(f)) {
            return Err(Error::invalid(
                "--liggghts-dt-factors",
                format!("{lf:?}"),
                format!("a non-empty subset of --dt-factors {:?}", a.dt_factors),
            ));
        }
    }
    let (run_nat, run_lig) = match a.engine.as_str() {
        "native" => (true, false),
        "liggghts" => (false, true),
        "both" => (true, true),
        e => {
            return Err(Error::Unknown {
                what: "engine",
                name: e.into(),
                valid: "native, liggghts, both".into(),
            })
        }
    };
    let lig = if run_lig {
        Some(Liggghts::locate(
            a.case.liggghts.as_deref(),
            Duration::from_secs(7 * 24 * 3600),
        )?)
    } else {
        None
    };
    let out = a
        .case
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join(format!("convergence-{}", utc_stamp())));
    let mut sargs = a.case.clone();
    sargs.native_only = !run_lig;
    sargs.liggghts_only = !run_nat;
    let mut factors = a.dt_factors.clone();
    factors.sort_by(|x, y| y.total_cmp(x));
    println!(
        "verify convergence: preset {}, dt factors {factors:?}, engine {}, {} seed(s), output {}",
        a.case.preset,
        a.engine,
        a.case.seeds,
        out.display()
    );
    let lig_factors = a
        .liggghts_dt_factors
        .clone()
        .unwrap_or_else(|| factors.clone());
    // per seed: the compacted state at the preset's dt (native), shared by every dt and code;
    // a run whose current series is stored (same input hash) is not run again
    let mut per: Vec<(String, f64, Vec<Series>)> = Vec::new();
    for seed in 1..=a.case.seeds {
        let (case, _) = shear_case(&sargs, seed)?;
        let loose = loose_packing(&case);
        let mut state = None;
        for &f in &factors {
            let mut c = case.clone();
            c.dt = case.dt * f;
            c.compression_steps = 1;
            c.output_every = ((case.output_every as f64 / f).round() as u64).max(1);
            c.snapshot_every = 0;
            let dir = out.join(format!("dt{f}")).join(format!("seed{seed}"));
            std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
            for code in CODES {
                let on = match code {
                    "native" => run_nat,
                    "liggghts" => run_lig && lig_factors.contains(&f),
                    _ => a.with_implicit && f == factors[0],
                };
                if !on {
                    continue;
                }
                let mut cc = c.clone();
                if code == "implicit" {
                    cc.models.rolling = RollingModel::EpsdImplicit;
                }
                let hash = run_input_hash(&cc, code)?;
                let s = match stored_series(&dir, code, &hash) {
                    Some(s) => {
                        println!("  seed {seed}, dt factor {f}, {code}: current result kept");
                        s
                    }
                    None => {
                        if state.is_none() {
                            state = Some(compact(&case, &loose, case.compression_steps)?);
                        }
                        let state = state.as_ref().expect("compacted");
                        println!(
                            "  seed {seed}, dt factor {f} ({:e} s), {code}: {} steps",
                            cc.dt,
                            cc.total_steps()
                        );
                        let run = if code == "liggghts" {
                            run_liggghts(
                                &cc,
                                state,
                                lig.as_ref().expect("located"),
                                &dir,
                                &Progress::hidden(),
                            )?
                        } else {
                            run_native(&cc, state, &dir, &Progress::hidden())?
                        };
                        let s = write_series(&cc, &run, &dir.join(format!("{code}.csv")))?;
                        write_atomic(&dir.join(format!("{code}.hash")), hash.as_bytes())?;
                        s
                    }
                };
                match per.iter_mut().find(|p| p.0 == code && p.1 == f) {
                    Some(p) => p.2.push(s),
                    None => per.push((code.to_string(), f, vec![s])),
                }
            }
        }
    }
    let (case0, _) = shear_case(&sargs, 1)?;
    let mut points = Vec::new();
    for (code, f, series) in &per {
        let mut c = case0.clone();
        c.dt = case0.dt * f;
        c.compression_steps = 1;
        let ends = run_ends(&c);
        let window = steady_window(ends[ends.len() - 2], ends[ends.len() - 1]);
        let st = steady(series, window, c.box_x * c.box_z);
        let erots: Vec<f64> = series
            .iter()
            .map(|s| s.window_mean("erot[J]", window))
            .collect();
        let (erot, erot_ci95) = if series.len() == 1 {
            (
                erots[0],
                block_ci95(
                    &series[0]
                        .window_values("erot[J]", window)
                        .unwrap_or_default(),
                ),
            )
        } else {
            mean_ci95(&erots)
        };
        if code == "implicit" {
            c.models.rolling = RollingModel::EpsdImplicit;
        }
        points.push(DtPoint {
            code: code.clone(),
            dt_factor: *f,
            dt: c.dt,
            steady: st,
            erot,
            erot_ci95,
            stability: stability(&c),
        });
    }
    // verdict per code: converged when its two smallest dt agree within their CIs; the
    // study's verdict comes from the codes that ran down to the smallest factor (LIGGGHTS
    // limited by --liggghts-dt-factors is judged, and reported, but does not decide it)
    let agree = |x: &DtPoint, y: &DtPoint| {
        (x.steady.mu - y.steady.mu).abs() <= x.steady.mu_ci95 + y.steady.mu_ci95
    };
    let finest_factor = factors[factors.len() - 1];
    let mut per_code = Vec::new();
    for code in ["native", "liggghts"] {
        let pts: Vec<&DtPoint> = points.iter().filter(|p| p.code == code).collect();
        let Some(finest) = pts.last() else {
            continue;
        };
        let converged = pts.len() >= 2 && agree(pts[pts.len() - 2], finest);
        // walk up from the finest dt while each step agrees with the next finer one
        let mut lc = finest.dt_factor;
        for k in (0..pts.len() - 1).rev() {
            if agree(pts[k], pts[k + 1]) {
                lc = pts[k].dt_factor;
            } else {
                break;
            }
        }
        per_code.push(CodeVerdict {
            code: code.into(),
            finest_factor: finest.dt_factor,
            converged,
            largest_converged_factor: converged.then_some(lc),
        });
    }
    let deciding: Vec<&CodeVerdict> = per_code
        .iter()
        .filter(|v| v.finest_factor == finest_factor)
        .collect();
    let converged = !deciding.is_empty() && deciding.iter().all(|v| v.converged);
    let largest = if converged {
        deciding
            .iter()
            .filter_map(|v| v.largest_converged_factor)
            .min_by(f64::total_cmp)
    } else {
        None
    };
    // the two codes at each dt both ran: agreement within the CIs
    let codes_agree: Vec<(f64, bool)> = factors
        .iter()
        .filter_map(|f| {
            let n = points
                .iter()
                .find(|p| p.code == "native" && p.dt_factor == *f)?;
            let l = points
                .iter()
                .find(|p| p.code == "liggghts" && p.dt_factor == *f)?;
            Some((*f, agree(n, l)))
        })
        .collect();
    // the stable-dashpot model at the largest dt against native epsd at the smallest
    let implicit_matches_finest = points.iter().find(|p| p.code == "implicit").and_then(|im| {
        let finest = points.iter().rfind(|p| p.code == "native")?;
        Some(agree(im, finest))
    });
    println!(
        "\n  {:<9} {:>9} {:>10} {:>18} {:>22} {:>8}",
        "code", "dt factor", "dt [s]", "steady mu (95 % CI)", "E_rot [J] (95 % CI)", "S max"
    );
    for p in &points {
        println!(
            "  {:<9} {:>9} {:>10.3e} {:>9.4} +- {:<6.4} {:>11.3e} +- {:<8.2e} {:>8.2}",
            p.code,
            p.dt_factor,
            p.dt,
            p.steady.mu,
            p.steady.mu_ci95,
            p.erot,
            p.erot_ci95,
            p.stability.entries[0].criterion
        );
    }
    for v in &per_code {
        println!(
            "  {}: down to dt factor {}: {}{}",
            v.code,
            v.finest_factor,
            if v.converged {
                "its two smallest dt agree"
            } else {
                "its two smallest dt differ beyond the CIs (or one dt only)"
            },
            if v.finest_factor == finest_factor {
                ""
            } else {
                " (not the study's smallest dt: reported, not deciding)"
            }
        );
    }
    for (f, ok) in &codes_agree {
        println!(
            "  dt factor {f}: LIGGGHTS and native {} within the CIs",
            if *ok { "agree" } else { "DIFFER" }
        );
    }
    println!(
        "  verdict: {}; largest converged dt factor: {}",
        if converged {
            "converged (the two smallest dt agree within their CIs)"
        } else {
            "NOT converged"
        },
        largest
            .map(|f| f.to_string())
            .unwrap_or_else(|| "none".into())
    );
    if let Some(m) = implicit_matches_finest {
        println!(
            "  epsd_implicit at dt factor {} {} native epsd at dt factor {} (within the CIs)",
            factors[0],
            if m { "agrees with" } else { "DIFFERS from" },
            factors[factors.len() - 1]
        );
    }
    plots(&out, &points)?;
    let summary = ConvergenceSummary {
        preset: a.case.preset.clone(),
        rolling: a.case.rolling.clone(),
        mu_r: case0.material.rolling_friction,
        eta_r: case0.material.rolling_damping,
        stage: case0.stages.len() - 1,
        speed: case0.stages[case0.stages.len() - 1].speed,
        converged,
        largest_converged_factor: largest,
        per_code,
        codes_agree,
        implicit_matches_finest,
        points,
        date_utc: utc_stamp(),
    };
    write_atomic(
        &out.join("summary.json"),
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    println!(
        "  plots: {} and erot_dt.svg; summary: {}",
        out.join("mu_dt.svg").display(),
        out.join("summary.json").display()
    );
    Ok(if converged {
        Outcome::Agree
    } else {
        Outcome::Disagree
    })
}

/// One code's curve: label, colour, points, CI half-widths.
type ErrSet = (String, usize, Vec<(f64, f64)>, Vec<f64>);

fn plots(out: &Path, points: &[DtPoint]) -> Result<()> {
    type Get = fn(&DtPoint) -> f64;
    for (file, title, ylab, get, err) in [
        (
            "mu_dt.svg",
            "steady friction coefficient against time step (95 % CI bars)",
            "mu",
            (|p: &DtPoint| p.steady.mu) as Get,
            (|p: &DtPoint| p.steady.mu_ci95) as Get,
        ),
        (
            "erot_dt.svg",
            "mean rotational kinetic energy against time step (log scale)",
            "log10 E_rot [J]",
            |p: &DtPoint| p.erot.max(1e-300).log10(),
            |_: &DtPoint| 0.0,
        ),
    ] {
        let sets: Vec<ErrSet> = ["liggghts", "native", "implicit"]
            .iter()
            .enumerate()
            .map(|(k, code)| {
                let sel: Vec<&DtPoint> = points.iter().filter(|p| p.code == *code).collect();
                (
                    if *code == "implicit" {
                        "native epsd_implicit".to_string()
                    } else {
                        code.to_string()
                    },
                    k,
                    sel.iter().map(|p| (p.dt, get(p))).collect::<Vec<_>>(),
                    sel.iter()
                        .map(|p| {
                            let e = err(p);
                            if e.is_finite() {
                                e
                            } else {
                                0.0
                            }
                        })
                        .collect(),
                )
            })
            .filter(|d| !d.2.is_empty())
            .collect();
        let cs: Vec<Curve> = sets
            .iter()
            .map(|(label, k, pts, e)| Curve::new(label, pts, *k).with_err(e))
            .collect();
        line_plot(&out.join(file), title, "dt [s]", ylab, &cs)?;
    }
    Ok(())
}
