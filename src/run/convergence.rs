//! `verify convergence`: the same shear case from the same compacted state at successively
//! smaller time steps (same strain), to tell physics from time-step artefacts such as the
//! unstable explicit rolling dashpot (see [`crate::spec::stability_shear`]).

pub use super::convergence_outcome::*;
use super::shear::ShearRequest;
use super::sweep::run_input_hash;
use super::utc_stamp;
use crate::compare::{equivalence, equivalence_one_seed, steady, Equivalence, Outcome};
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::packing::loose_packing;
use crate::run::progress::Progress;
use crate::run::tell::say;
use crate::series::Series;
use crate::shear::{run_liggghts, run_native, write_series, Checkpointing, CHECKPOINT_EVERY};
use crate::solver::shear::compact;
use crate::spec::shear::ShearCase;
use crate::spec::stability_shear::stability;
use crate::spec::windows::steady_window;
use crate::spec::RollingModel;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A convergence study: the shear request's case (its engine, seeds, output directory) at each
/// dt factor, from one compacted state per seed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceRequest {
    /// The case; its protocol's dt factor must be 1 (the study's factors are `dt_factors`).
    pub shear: ShearRequest,
    /// Factors applied to the preset's dt.
    pub dt_factors: Vec<f64>,
    /// The dt factors at which LIGGGHTS runs (a subset of `dt_factors`; None: all).
    pub liggghts_dt_factors: Option<Vec<f64>>,
    /// Also run `epsd_implicit` at the largest dt factor (with epsd only).
    pub with_implicit: bool,
}

/// The stored series of a run if it is current: its record ([`crate::fsutil::read_recorded`])
/// names the run's input hash and the CSV's SHA-256; a series that does not verify is said so
/// and run again.
fn stored_series(dir: &Path, code: &str, hash: &str) -> Option<Series> {
    let path = dir.join(format!("{code}.csv"));
    match crate::fsutil::read_recorded(&path, hash) {
        Ok(Some(_)) => Series::read_csv(&path).ok(),
        Ok(None) => None,
        Err(why) => {
            crate::run::tell::warning(&format!(
                "{} is not reused: {why}; run again",
                path.display()
            ));
            None
        }
    }
}

/// The time step of `case` scaled by a study's factor, from the compacted state: one servo step
/// of compression, no snapshots ([`ShearCase::scale_dt`] is the scaling rule).
fn at_factor(case: &ShearCase, f: f64) -> Result<ShearCase> {
    let mut c = case.clone().scale_dt("--dt-factors", f)?;
    c.compression_steps = 1;
    c.snapshot_every = 0;
    Ok(c)
}

impl ConvergenceRequest {
    /// The study's own rules (the run and a study's `--dry-run` plan call this one function):
    /// the shear request's, two or more distinct dt factors in (0, 1], the protocol's dt factor
    /// 1, `--with-implicit` with epsd only, LIGGGHTS' factors a subset of the study's.
    pub fn validate(&self) -> Result<()> {
        self.shear.validate()?;
        let mut distinct = self.dt_factors.clone();
        distinct.sort_by(f64::total_cmp);
        distinct.dedup();
        if distinct.len() < 2
            || distinct.len() != self.dt_factors.len()
            || self
                .dt_factors
                .iter()
                .any(|f| !(f.is_finite() && *f > 0.0 && *f <= 1.0))
        {
            // a study of one dt (or a factor twice) compares a run with itself: no verdict
            return Err(Error::invalid(
                "--dt-factors",
                format!("{:?}", self.dt_factors),
                "two or more distinct factors in (0, 1], e.g. 1,0.5,0.25",
            ));
        }
        let sh = &self.shear;
        if sh.case.protocol.dt_factor != 1.0 {
            return Err(Error::invalid(
            "--dt-factor",
            sh.case.protocol.dt_factor,
            "1 with verify convergence: its time steps are --dt-factors (the two would multiply)",
        ));
        }
        if self.with_implicit && sh.case.rolling != RollingModel::Epsd {
            return Err(Error::invalid(
                "--with-implicit",
                sh.case.rolling,
                "--rolling epsd (epsd_implicit is the stable-dashpot variant of epsd)",
            ));
        }
        if let Some(lf) = &self.liggghts_dt_factors {
            if lf.is_empty() || lf.iter().any(|f| !self.dt_factors.contains(f)) {
                return Err(Error::invalid(
                    "--liggghts-dt-factors",
                    format!("{lf:?}"),
                    format!("a non-empty subset of --dt-factors {:?}", self.dt_factors),
                ));
            }
        }
        Ok(())
    }

    /// The dt factors, largest first (the order the study runs and reports them).
    pub fn factors(&self) -> Vec<f64> {
        let mut f = self.dt_factors.clone();
        f.sort_by(|x, y| y.total_cmp(x));
        f
    }

    /// Every run of the study, in the order it runs them (seed by seed, each from one
    /// compacted state; the factors largest first; per factor native, LIGGGHTS where asked,
    /// and epsd_implicit at the largest factor): the seed, the code, the factor and the case
    /// as it runs. What the study runs and what a plan counts are this one list.
    pub fn planned_runs(&self) -> Result<Vec<(u64, StudyCode, f64, ShearCase)>> {
        let sh = &self.shear;
        let (run_nat, run_lig) = (sh.engine.runs_native(), sh.engine.runs_liggghts());
        let factors = self.factors();
        let lig_factors = self
            .liggghts_dt_factors
            .clone()
            .unwrap_or_else(|| factors.clone());
        let mut runs = Vec::new();
        for seed in sh.seed_range() {
            let (case, _) = sh.seed_case(seed)?;
            for &f in &factors {
                let c = at_factor(&case, f)?;
                for code in StudyCode::ALL {
                    let on = match code {
                        StudyCode::Native => run_nat,
                        StudyCode::Liggghts => run_lig && lig_factors.contains(&f),
                        StudyCode::Implicit => self.with_implicit && f == factors[0],
                    };
                    if on {
                        let mut cc = c.clone();
                        if code == StudyCode::Implicit {
                            cc.models.rolling = RollingModel::EpsdImplicit;
                        }
                        runs.push((seed, code, f, cc));
                    }
                }
            }
        }
        Ok(runs)
    }
}

/// Every planned run's series, by code and dt factor (seeds in order): a run whose current
/// series is stored (same input hash) is read, not run again; the others run from their seed's
/// compacted state at the preset's dt (native, made once per seed, shared by every dt and code).
fn series_by_point(
    a: &ConvergenceRequest,
    lig: Option<&crate::liggghts::Liggghts>,
) -> Result<Vec<(StudyCode, f64, Vec<Series>)>> {
    let sh = &a.shear;
    let mut per: Vec<(StudyCode, f64, Vec<Series>)> = Vec::new();
    let mut seed_state: Option<(u64, ShearCase, Option<crate::packing::Packing>)> = None;
    for (seed, code, f, cc) in a.planned_runs()? {
        if seed_state.as_ref().is_none_or(|s| s.0 != seed) {
            seed_state = Some((seed, sh.seed_case(seed)?.0, None));
        }
        let (_, case, state) = seed_state.as_mut().expect("set above");
        let dir = sh.out.join(format!("dt{f}")).join(format!("seed{seed}"));
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let hash = run_input_hash(&cc, code.keyword())?;
        let s = match stored_series(&dir, code.keyword(), &hash) {
            Some(s) => {
                say!("  seed {seed}, dt factor {f}, {code}: current result kept");
                s
            }
            None => {
                if state.is_none() {
                    let loose = loose_packing(case);
                    *state = Some(compact(&case.setup(), &loose, case.compression_steps)?);
                }
                let state = state.as_ref().expect("compacted");
                say!(
                    "  seed {seed}, dt factor {f} ({:e} s), {code}: {} steps",
                    cc.dt,
                    cc.total_steps()
                );
                let run = if code == StudyCode::Liggghts {
                    run_liggghts(
                        &cc,
                        state,
                        lig.expect("located"),
                        &dir,
                        &Progress::hidden(),
                        Checkpointing::Every(CHECKPOINT_EVERY),
                    )?
                } else {
                    run_native(
                        &cc,
                        state,
                        &dir,
                        &Progress::hidden(),
                        Checkpointing::Every(CHECKPOINT_EVERY),
                    )?
                };
                let path = dir.join(format!("{code}.csv"));
                let s = write_series(&cc, &run, &path)?;
                crate::fsutil::write_record(&path, &hash)?;
                s
            }
        };
        match per.iter_mut().find(|p| p.0 == code && p.1 == f) {
            Some(p) => p.2.push(s),
            None => per.push((code, f, vec![s])),
        }
    }
    Ok(per)
}

/// Each code's point at each dt factor: its steady values over the seeds, in the last stage's
/// steady window, and the case's stability figures.
fn points_of(case0: &ShearCase, per: &[(StudyCode, f64, Vec<Series>)]) -> Result<Vec<DtPoint>> {
    let mut points = Vec::new();
    for (code, f, series) in per {
        let mut c = at_factor(case0, *f)?;
        let ends = c.run_ends();
        let window = steady_window(ends[ends.len() - 2], ends[ends.len() - 1]);
        let st = steady(series, window, c.box_x * c.box_z);
        if *code == StudyCode::Implicit {
            c.models.rolling = RollingModel::EpsdImplicit;
        }
        points.push(DtPoint {
            code: *code,
            dt_factor: *f,
            dt: c.dt,
            steady: st,
            stability: stability(&c),
        });
    }
    Ok(points)
}

/// Two points' steady mu equivalent within `margin`: the paired difference over seeds (each
/// seed from one compacted state, [`equivalence`]); one seed: the two block CIs.
fn equivalent(x: &DtPoint, y: &DtPoint, margin: f64) -> Equivalence {
    let (a, b) = (&x.steady, &y.steady);
    equivalence(&a.per_seed_mu, &b.per_seed_mu, margin)
        .unwrap_or_else(|| equivalence_one_seed(a.mu, a.mu_ci95, b.mu, b.mu_ci95, margin))
}

/// The study's judgement of its points.
struct Judged {
    per_code: Vec<CodeVerdict>,
    converged: bool,
    inconclusive: bool,
    largest: Option<f64>,
    codes_agree: Vec<(f64, Equivalence)>,
    implicit_matches_finest: Option<Equivalence>,
}

/// Verdict per code: converged when its two smallest dt are equivalent; the study's verdict
/// comes from the codes that ran down to the smallest factor (LIGGGHTS limited by
/// --liggghts-dt-factors is judged, and reported, but does not decide it). Beside it: the
/// two codes at each dt both ran (native - LIGGGHTS, paired by seed), and the stable-dashpot
/// model at the largest dt against native epsd at the smallest.
fn judge(points: &[DtPoint], factors: &[f64], margin: f64) -> Judged {
    let test = |x: &DtPoint, y: &DtPoint| equivalent(x, y, margin);
    let finest_factor = factors[factors.len() - 1];
    let mut per_code = Vec::new();
    for code in [StudyCode::Native, StudyCode::Liggghts] {
        let pts: Vec<&DtPoint> = points.iter().filter(|p| p.code == code).collect();
        let Some(finest) = pts.last() else {
            continue;
        };
        let finest_step = (pts.len() >= 2).then(|| test(pts[pts.len() - 2], finest));
        let converged = finest_step
            .as_ref()
            .is_some_and(|e| e.outcome == Outcome::Agree);
        // walk up from the finest dt while each step is equivalent to the next finer one
        let mut lc = finest.dt_factor;
        for k in (0..pts.len() - 1).rev() {
            if test(pts[k], pts[k + 1]).outcome == Outcome::Agree {
                lc = pts[k].dt_factor;
            } else {
                break;
            }
        }
        per_code.push(CodeVerdict {
            code,
            finest_factor: finest.dt_factor,
            converged,
            finest_step,
            largest_converged_factor: converged.then_some(lc),
        });
    }
    let deciding: Vec<&CodeVerdict> = per_code
        .iter()
        .filter(|v| v.finest_factor == finest_factor)
        .collect();
    let converged = !deciding.is_empty() && deciding.iter().all(|v| v.converged);
    let inconclusive = !converged
        && deciding.iter().all(|v| {
            v.finest_step
                .as_ref()
                .is_some_and(|e| e.outcome != Outcome::Disagree)
        })
        && !deciding.is_empty();
    let largest = if converged {
        deciding
            .iter()
            .filter_map(|v| v.largest_converged_factor)
            .min_by(f64::total_cmp)
    } else {
        None
    };
    let codes_agree: Vec<(f64, Equivalence)> = factors
        .iter()
        .filter_map(|f| {
            let n = points
                .iter()
                .find(|p| p.code == StudyCode::Native && p.dt_factor == *f)?;
            let l = points
                .iter()
                .find(|p| p.code == StudyCode::Liggghts && p.dt_factor == *f)?;
            Some((*f, test(l, n)))
        })
        .collect();
    let implicit_matches_finest = points
        .iter()
        .find(|p| p.code == StudyCode::Implicit)
        .and_then(|im| {
            let finest = points.iter().rfind(|p| p.code == StudyCode::Native)?;
            Some(test(finest, im))
        });
    Judged {
        per_code,
        converged,
        inconclusive,
        largest,
        codes_agree,
        implicit_matches_finest,
    }
}

/// The study's table (a line per code and dt) and its verdicts, said line by line.
fn say_table(points: &[DtPoint], j: &Judged, factors: &[f64], margin: f64) {
    let finest_factor = factors[factors.len() - 1];
    say!(
        "\n  {:<9} {:>9} {:>10} {:>18} {:>22} {:>8}",
        "code",
        "dt factor",
        "dt [s]",
        "steady mu (95 % CI)",
        "E_rot [J] (95 % CI)",
        "S max"
    );
    for p in points {
        say!(
            "  {:<9} {:>9} {:>10.3e} {:>9.4} +- {:<6.4} {:>11.3e} +- {:<8.2e} {:>8.2}",
            p.code,
            p.dt_factor,
            p.dt,
            p.steady.mu,
            p.steady.mu_ci95,
            p.steady.erot,
            p.steady.erot_ci95,
            p.stability.entries[0].criterion
        );
    }
    let says = |e: &Equivalence| {
        format!(
            "{} (difference {}; margin {margin})",
            e.outcome.words(),
            e.figures()
        )
    };
    for v in &j.per_code {
        say!(
            "  {}: down to dt factor {}: its two smallest dt: {}{}",
            v.code,
            v.finest_factor,
            v.finest_step
                .as_ref()
                .map_or("one dt only".to_string(), &says),
            if v.finest_factor == finest_factor {
                ""
            } else {
                " (not the study's smallest dt: reported, not deciding)"
            }
        );
    }
    for (f, e) in &j.codes_agree {
        say!("  dt factor {f}: native - LIGGGHTS: {}", says(e));
    }
    say!(
        "  verdict: {}; largest converged dt factor: {}",
        if j.converged {
            "converged (the two smallest dt are equivalent)"
        } else if j.inconclusive {
            "inconclusive (more seeds would decide)"
        } else {
            "NOT converged"
        },
        j.largest
            .map(|f| f.to_string())
            .unwrap_or_else(|| "none".into())
    );
    if let Some(e) = &j.implicit_matches_finest {
        say!(
            "  epsd_implicit at dt factor {} - native epsd at dt factor {}: {}",
            factors[0],
            finest_factor,
            says(e)
        );
    }
}

/// Runs the study (reusing every stored current run), prints its table and writes
/// `summary.json`; the figures are the report's ([`crate::report::convergence::plots`], drawn
/// by the command from the summary's points).
pub fn run(a: &ConvergenceRequest) -> Result<ConvergenceSummary> {
    a.validate()?;
    let sh = &a.shear;
    let lig = if sh.engine.runs_liggghts() {
        Some(sh.liggghts.locate()?)
    } else {
        None
    };
    let factors = a.factors();
    say!(
        "verify convergence: preset {}, dt factors {factors:?}, engine {}, {} seed(s), output {}",
        sh.case.preset,
        format!("{:?}", sh.engine).to_lowercase(),
        sh.seeds,
        sh.out.display()
    );
    let per = series_by_point(a, lig.as_ref())?;
    let (case0, _) = sh.seed_case(sh.case.seed)?;
    let points = points_of(&case0, &per)?;
    let margin = sh.mu_margin;
    let j = judge(&points, &factors, margin);
    say_table(&points, &j, &factors, margin);
    let summary = ConvergenceSummary {
        schema: super::SCHEMA,
        preset: sh.case.preset,
        rolling: sh.case.rolling,
        mu_r: case0.material.rolling_friction,
        eta_r: case0.material.rolling_damping,
        stage: case0.stages.len() - 1,
        speed: case0.stages[case0.stages.len() - 1].speed,
        converged: j.converged,
        inconclusive: j.inconclusive,
        mu_margin: margin,
        largest_converged_factor: j.largest,
        per_code: j.per_code,
        codes_agree: j.codes_agree,
        implicit_matches_finest: j.implicit_matches_finest,
        points,
        date_utc: utc_stamp(),
    };
    let file = sh.out.join("summary.json");
    write_atomic(&file, serde_json::to_string_pretty(&summary)?.as_bytes())?;
    super::note_summary(&file);
    say!("  summary: {}", file.display());
    Ok(summary)
}
