//! The sweep's report: the paper's figures (mu against mu_r per speed, mu against speed, heat
//! maps), its three conclusions checked at the sweep's dt and on converged-dt results, and the
//! table of points (DIR/report.html, DIR/report.json).

use crate::compare::within_cis;
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::report::claim_rates::{claim_rates, TestRates, DRAWS, POWER};
use crate::report::html::{table, text_rows, Page};
use crate::report::paper::{
    aggregate, conclusions, heat_map, mu_range, ClaimVerdict, Conclusion, HeatStyle, Point,
};
use crate::report::plot::{line_plot, Curve};
use crate::run::convergence_outcome::{ConvergenceSummary, StudyCode};
use crate::run::sweep::{collect, Manifest, RunResult};
use crate::run::tell::say;
use crate::run::Code;
use maud::html;
use serde::Serialize;
use std::path::{Path, PathBuf};

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
    schema: u32,
    points: Vec<Point>,
    conclusions: Vec<(Code, Vec<Conclusion>)>,
    /// How often the claim tests err at this study's shape and scatter, per code.
    claim_rates: Vec<(Code, Vec<TestRates>)>,
    converged_points: Vec<Point>,
    converged_conclusions: Vec<(Code, Vec<Conclusion>)>,
    /// Every point as the conclusions on trustworthy numbers use it, with its source.
    judged: Vec<JudgedPoint>,
    /// Another study's conclusions on the same claims (`--beside`), claim by claim.
    #[serde(skip_serializing_if = "Option::is_none")]
    beside: Option<BesideReport>,
    runs: usize,
    run_wall_s_liggghts: f64,
    run_wall_s_native: f64,
}

/// The last component of a directory's path, for labels.
fn dir_name(dir: &Path) -> String {
    dir.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| dir.display().to_string())
}

/// A sweep's points labelled with their model and dt.
fn sweep_points(m: &Manifest, results: &[RunResult], tag: &str) -> Vec<Point> {
    let dt = results.first().map_or(f64::NAN, |r| r.dt);
    let mut points = aggregate(results);
    for p in &mut points {
        p.source = format!("{} at dt {dt:.3e} s{tag}", m.base.rolling);
    }
    points
}

/// The points of `dir` that stand in for points unstable at the sweep's dt: a sweep at a
/// smaller dt or with the stable dashpot (manifest.json: every result aggregated) or a `verify
/// convergence` output (summary.json: native at its finest dt, with the study's verdict).
/// Each is labelled with where it comes from.
fn converged_points(dir: &Path) -> Result<Vec<Point>> {
    let name = dir_name(dir);
    if dir.join("manifest.json").is_file() {
        let cm = Manifest::load(&dir.join("manifest.json"))?;
        let (res, _) = collect(&cm, dir);
        return Ok(sweep_points(&cm, &res, &format!(" ({name})")));
    }
    let bad = || {
        Error::invalid(
            "--converged",
            dir.display(),
            "a sweep directory (with manifest.json) or the output directory of `verify \
             convergence` (with a summary.json naming mu_r and eta_r)",
        )
    };
    let path = dir.join("summary.json");
    if !path.is_file() {
        return Err(bad());
    }
    let v: ConvergenceSummary = crate::run::load(&path)?;
    let finest = v
        .points
        .iter()
        .filter(|p| p.code == StudyCode::Native)
        .min_by(|a, b| a.dt_factor.total_cmp(&b.dt_factor))
        .ok_or_else(bad)?;
    Ok(vec![Point {
        code: Code::Native,
        mu_r: v.mu_r,
        eta_r: v.eta_r,
        stage: v.stage,
        speed: v.speed,
        mu: finest.steady.mu,
        mu_ci95: if finest.steady.mu_ci95.is_finite() {
            finest.steady.mu_ci95
        } else {
            f64::INFINITY
        },
        run_ci95: match finest.steady.per_seed_mu.len() {
            1 => finest.steady.mu_ci95,
            _ => f64::NAN,
        },
        seeds: finest.steady.per_seed_mu.len(),
        erot: finest.steady.erot,
        dashpot_stable: finest.stability.stable,
        stability_s: finest.stability.entries.first().ok_or_else(bad)?.criterion,
        per_seed_mu: (1..)
            .zip(finest.steady.per_seed_mu.iter().copied())
            .collect(),
        source: format!(
            "{} at dt {:.3e} s (convergence study {name}: {})",
            v.rolling,
            finest.dt,
            if v.converged {
                "converged"
            } else {
                "NOT shown converged"
            }
        ),
    }])
}

/// A point as the conclusions on trustworthy numbers use it: as run where the explicit dashpot
/// is stable, else the first stand-in given for it (in `--converged` order), checked against
/// any further stand-ins; None where there is none.
#[derive(Clone, Debug, Serialize)]
pub struct JudgedPoint {
    pub code: Code,
    pub stage: usize,
    pub mu_r: f64,
    pub eta_r: f64,
    pub point: Option<Point>,
    pub substituted: bool,
    /// Where the number comes from and what it was checked against.
    pub note: String,
}

fn judge(points: &[Point], stand_ins: &[Point]) -> Vec<JudgedPoint> {
    points
        .iter()
        .map(|p| {
            let base = |point: Option<Point>, substituted, note: String| JudgedPoint {
                code: p.code,
                stage: p.stage,
                mu_r: p.mu_r,
                eta_r: p.eta_r,
                point,
                substituted,
                note,
            };
            if p.dashpot_stable {
                return base(
                    Some(p.clone()),
                    false,
                    format!("as run ({}; stable, S = {:.2})", p.source, p.stability_s),
                );
            }
            let cands: Vec<&Point> = stand_ins
                .iter()
                .filter(|c| {
                    c.code == p.code && c.stage == p.stage && c.mu_r == p.mu_r && c.eta_r == p.eta_r
                })
                .collect();
            let Some((c, rest)) = cands.split_first() else {
                return base(
                    None,
                    false,
                    format!(
                        "unstable at the sweep's dt (S = {:.2}) and no stable or converged result \
                         given",
                        p.stability_s
                    ),
                );
            };
            // checked against the code's other stand-ins, then the other code's stable or
            // converged results at the point (LIGGGHTS at dt/4 checking a native stand-in)
            let other_code = stand_ins.iter().filter(|q| {
                q.code != p.code && q.stage == p.stage && q.mu_r == p.mu_r && q.eta_r == p.eta_r
            });
            let checks: Vec<String> = rest
                .iter()
                .copied()
                .chain(other_code)
                .map(|q| {
                    format!(
                        "{} {}{} ({})",
                        if within_cis(c.mu, c.mu_ci95, q.mu, q.mu_ci95) {
                            "agrees with"
                        } else {
                            "DIFFERS from"
                        },
                        if q.code == p.code {
                            String::new()
                        } else {
                            format!("{} ", q.code)
                        },
                        q.source,
                        q.mu_words()
                    )
                })
                .collect();
            base(
                Some((*c).clone()),
                true,
                format!(
                    "from {} (unstable at the sweep's dt, S = {:.2}); {}",
                    c.source,
                    p.stability_s,
                    if checks.is_empty() {
                        "not checked against another dt or model".to_string()
                    } else {
                        checks.join("; ")
                    }
                ),
            )
        })
        .collect()
}

/// The sweep's points and the paper's conclusions, as run and as judged on stable or
/// converged numbers.
struct Judgement {
    points: Vec<Point>,
    conv_points: Vec<Point>,
    /// Each point as judged: stable as it is, by its stand-in, or left out.
    judged_points: Vec<JudgedPoint>,
    judged: Vec<Point>,
    codes: Vec<Code>,
    concl: Vec<(Code, Vec<Conclusion>)>,
    conv_concl: Vec<(Code, Vec<Conclusion>)>,
}

impl Judgement {
    fn new(points: Vec<Point>, conv_points: Vec<Point>) -> Self {
        let codes: Vec<Code> = {
            let mut c: Vec<Code> = points.iter().map(|p| p.code).collect();
            c.dedup();
            c
        };
        let concl: Vec<(Code, Vec<Conclusion>)> = codes
            .iter()
            .map(|&c| (c, conclusions(&points, c)))
            .collect();
        // the conclusions judged on trustworthy numbers: each point where the explicit
        // dashpot is stable as it is, each unstable point by its stand-in, unstable points
        // without one left out (and said so)
        let judged_points = judge(&points, &conv_points);
        let judged: Vec<Point> = judged_points
            .iter()
            .filter_map(|j| j.point.clone())
            .collect();
        let conv_concl: Vec<(Code, Vec<Conclusion>)> = if conv_points.is_empty() {
            Vec::new()
        } else {
            codes
                .iter()
                .filter(|c| judged.iter().any(|p| p.code == **c))
                .map(|&c| (c, conclusions(&judged, c)))
                .collect()
        };
        Judgement {
            points,
            conv_points,
            judged_points,
            judged,
            codes,
            concl,
            conv_concl,
        }
    }
}

/// Another sweep whose conclusions a report shows beside its own (`--beside DIR
/// [--beside-converged DIR2 ...]`): e.g. the paper protocol's verdicts beside those of the fast
/// preset's speed study, the same claims at 20 times the speeds.
#[derive(Clone, Debug)]
pub struct Beside {
    pub dir: PathBuf,
    /// Its stand-ins, as `--converged` is this sweep's.
    pub converged: Vec<PathBuf>,
}

/// The conclusions of a [`Beside`] study, judged from its own results by this version.
#[derive(Serialize)]
struct BesideReport {
    /// The study's folder and its parent (`sweep/speed-explicit-e1`: no machine's path).
    dir: String,
    runs: usize,
    missing: usize,
    conclusions: Vec<(Code, Vec<Conclusion>)>,
    converged_conclusions: Vec<(Code, Vec<Conclusion>)>,
}

impl BesideReport {
    fn judge(b: &Beside) -> Result<Self> {
        let m = Manifest::load(&b.dir.join("manifest.json"))?;
        let (results, missing) = collect(&m, &b.dir);
        if results.is_empty() {
            return Err(Error::invalid(
                "--beside",
                b.dir.display(),
                "a sweep directory with results (it has none)",
            ));
        }
        let mut conv_points = Vec::new();
        for c in &b.converged {
            conv_points.extend(converged_points(c)?);
        }
        let j = Judgement::new(sweep_points(&m, &results, ""), conv_points);
        let parent = b.dir.parent().map(dir_name).unwrap_or_default();
        Ok(BesideReport {
            dir: format!("{parent}/{}", dir_name(&b.dir)),
            runs: results.len(),
            missing: missing.len(),
            conclusions: j.concl,
            converged_conclusions: j.conv_concl,
        })
    }
}

/// The paper's figures, the conclusions and a report page from DIR's (current) results,
/// with another study's conclusions beside them when `beside` is given.
pub fn report(dir: &Path, converged: &[PathBuf], beside: Option<&Beside>) -> Result<()> {
    let m = Manifest::load(&dir.join("manifest.json"))?;
    let (results, missing) = collect(&m, dir);
    if results.is_empty() {
        return Err(Error::Cases(format!(
            "no results in {} yet (run the sweep first)",
            dir.display()
        )));
    }
    let mut conv_points = Vec::new();
    for c in converged {
        conv_points.extend(converged_points(c)?);
    }
    let j = Judgement::new(sweep_points(&m, &results, ""), conv_points);
    let beside = beside.map(BesideReport::judge).transpose()?;
    let mut page = Page::new("DEM sweep: the paper's parametric study");
    page.push(html! { h1 { "Parametric study: steady friction over (mu_r, eta_r)" } });
    let (wall_l, wall_n) = meta(&mut page, &m, &results, dir);
    if !missing.is_empty() {
        page.push(html! { p.warn {
            (missing.len()) " runs have no result yet: the figures show what exists."
        } });
    }
    page.heading("bottom-line", "Bottom line");
    bottom_line(&mut page, &j);
    if let Some(b) = &beside {
        page.heading("beside", "Beside another study");
        beside_section(&mut page, &j, b);
    }
    page.heading("conclusions", "The paper's conclusions, checked");
    conclusions_section(&mut page, &j);
    let rates: Vec<(Code, Vec<TestRates>)> = j
        .codes
        .iter()
        .map(|&c| (c, claim_rates(&j.points, c)))
        .collect();
    page.heading("error-rates", "How often these tests err");
    error_rates(&mut page, &rates);
    unstable_note(&mut page, &j.points);
    page.heading("figures", "Figures");
    let figs = dir.join("figures");
    let mut fig_html = mu_against_mu_r(&mut page, &j, &figs)?;
    fig_html.extend(mu_against_speed(&mut page, &j, &figs)?);
    fig_html.extend(heat_maps(&mut page, &j, &figs)?);
    page.figures(&fig_html);
    convergence_figures(&mut page, converged)?;
    displacement_profiles(&mut page, &m, dir);
    rotation_maps(&mut page, &m, dir);
    points_table(&mut page, &j);
    write_atomic(&dir.join("report.html"), page.finish().as_bytes())?;
    let Judgement {
        points,
        conv_points,
        judged_points,
        concl,
        conv_concl,
        ..
    } = j;
    let rep = SweepReport {
        schema: crate::run::SCHEMA,
        points,
        conclusions: concl,
        claim_rates: rates,
        converged_points: conv_points,
        converged_conclusions: conv_concl,
        judged: judged_points,
        beside,
        runs: results.len(),
        run_wall_s_liggghts: wall_l,
        run_wall_s_native: wall_n,
    };
    write_atomic(
        &dir.join("report.json"),
        serde_json::to_string_pretty(&rep)?.as_bytes(),
    )?;
    crate::run::note_summary(&dir.join("report.json"));
    for (code, cs) in rep.conclusions.iter().chain(&rep.converged_conclusions) {
        for c in cs {
            say!("  {code}: {} -> {} ({})", c.claim, c.verdict, c.evidence);
        }
    }
    say!("report: {}", dir.join("report.html").display());
    if !missing.is_empty() {
        // the page is written (it shows what exists), but an incomplete sweep is not a
        // finished report: say so where scripts look, in the exit status
        return Err(Error::Cases(format!(
            "the report is partial: {} of {} runs have no current result (indices {}); run \
             them (rerun the sweep command, or `verify sweep run-one`) and report again",
            missing.len(),
            m.runs.len(),
            crate::run::sweep::indices(&missing)
        )));
    }
    Ok(())
}

/// The page's first line: runs done, preset, model, wall times; returns the summed wall
/// times (LIGGGHTS, native) [s].
fn meta(page: &mut Page, m: &Manifest, results: &[RunResult], dir: &Path) -> (f64, f64) {
    let wall_l: f64 = results.iter().filter_map(|r| r.liggghts_wall_s).sum();
    let wall_n: f64 = results.iter().filter_map(|r| r.native_wall_s).sum();
    let inv: Option<serde_json::Value> = std::fs::read_to_string(dir.join("last_invocation.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    let hours = |w: f64, code: &str| {
        if results.iter().any(|r| match code {
            "native" => r.native_wall_s.is_some(),
            _ => r.liggghts_wall_s.is_some(),
        }) {
            format!("{code} {:.2} h", w / 3600.0)
        } else {
            format!("{code} not run")
        }
    };
    page.push(html! { p.meta { (format!(
        "{} of {} runs ({} preset, {}, engine {}, dt factor {}, created {}). \
         Run wall time summed over runs: {}, {}{}.",
        results.len(),
        m.runs.len(),
        m.base.preset,
        m.base.rolling,
        m.base.engine.keyword(),
        m.base.protocol.dt_factor,
        m.created_utc,
        hours(wall_n, "native"),
        hours(wall_l, "LIGGGHTS"),
        inv.map(|v| format!(
            "; last local invocation: {:.2} h wall with {} job(s) for {} runs",
            v["wall_s"].as_f64().unwrap_or(f64::NAN) / 3600.0,
            v["jobs"],
            v["runs_run"]
        ))
        .unwrap_or_default()
    )) } });
    (wall_l, wall_n)
}

/// How often each claim's test errs at this study's shape and scatter (report::claim_rates):
/// false alarms and the effect found 80 % of the time, under a normal scatter and with the
/// study's own runs resampled.
fn error_rates(page: &mut Page, rates: &[(Code, Vec<TestRates>)]) {
    page.para(&format!(
        "Each test run on {DRAWS} synthetic studies of this study's shape (its speeds, curves \
         and seeds per point) with no effect (false alarm: the verdict resolves anything) and \
         with an effect of a given size (the size found {:.0} % of the time, by bisection), \
         the scatter of seeds taken two ways: normal, with the covariance between speeds of \
         this study's runs about their points' means (the scatter the tests' t quantiles are \
         built for), and those runs themselves resampled (their own tails, but only as many \
         distinct runs as the study has: with 15-30 runs a rare false alarm's rate depends on \
         which runs the study happened to draw). Points are drawn independently: the seeds \
         this study shares between points (one packing per seed) are not modelled. Rates of \
         the points as run. Margin: none; a claim holds when its test resolves the change at \
         95 % (CIs apart, a slope's CI apart from 0), whatever its size: an effect smaller \
         than the column at right is found less than {:.0} % of the time.",
        100.0 * POWER,
        100.0 * POWER
    ));
    let pct = |x: f64| format!("{:.1} %", 100.0 * x);
    let size = |f: Option<f64>| f.map_or("not within 50 sd".to_string(), |v| format!("{v:.3}"));
    let mut rows: Vec<Vec<(String, &str)>> = Vec::new();
    for (code, rs) in rates {
        if rs.is_empty() {
            page.para(&format!(
                "{code}: no error rates: no point has 2 seeds (then no test resolves \
                 anything, so none errs) or too few runs to estimate the seeds' scatter from; \
                 2 or more seeds at the points give both."
            ));
        }
        for r in rs {
            rows.push(vec![
                (format!("{code}"), ""),
                (format!("{}. {}", r.claim, r.test), ""),
                (format!("{} ({} runs)", r.seeds, r.pool), ""),
                (
                    format!(
                        "{} / {}",
                        pct(r.normal.false_alarm),
                        pct(r.resampled.false_alarm)
                    ),
                    if r.normal.false_alarm.max(r.resampled.false_alarm) > 0.1 {
                        "warn"
                    } else {
                        ""
                    },
                ),
                (
                    format!(
                        "{} / {} ({})",
                        size(r.normal.found),
                        size(r.resampled.found),
                        r.unit
                    ),
                    "",
                ),
            ]);
        }
    }
    if !rows.is_empty() {
        page.push(table(
            &[
                "code",
                "claim: the test here",
                "seeds per point (pool)",
                "false alarm: normal / resampled",
                &format!(
                    "found {:.0} % of the time: normal / resampled",
                    100.0 * POWER
                ),
            ],
            &text_rows(rows),
        ));
    }
}

/// The bottom line: each claim as run and on stable or converged numbers, and which points
/// were judged on a stand-in.
fn bottom_line(page: &mut Page, j: &Judgement) {
    let mut rows: Vec<Vec<(String, &str)>> = Vec::new();
    let class = |v: ClaimVerdict| match v {
        ClaimVerdict::Agrees => "pass",
        ClaimVerdict::Disagrees => "fail",
        _ => "warn",
    };
    for (code, cs) in &j.concl {
        let conv = j.conv_concl.iter().find(|(c, _)| c == code).map(|c| &c.1);
        for (k, c) in cs.iter().enumerate() {
            let jc = conv.and_then(|v| v.get(k));
            rows.push(vec![
                (format!("{code}"), ""),
                (c.claim.clone(), ""),
                (c.verdict.words().to_string(), class(c.verdict)),
                jc.map_or(
                    ("no stable or converged results given".into(), "warn"),
                    |c| (c.verdict.words().to_string(), class(c.verdict)),
                ),
                (jc.map_or(c.evidence.clone(), |c| c.evidence.clone()), ""),
            ]);
        }
    }
    page.push(table(
        &[
            "code",
            "the paper's claim",
            "at the sweep's dt (as the paper ran it)",
            "on stable or converged numbers",
            "evidence (stable or converged numbers where given)",
        ],
        &text_rows(rows),
    ));
    let missing_judged = left_out(&j.points, &j.judged_points);
    let substituted = j.judged_points.iter().filter(|j| j.substituted).count();
    page.para(&format!(
        "{} of {} points are unstable at the sweep's dt; {substituted} of them are judged on \
         a stand-in (its source and checks in the table){}.",
        j.points.iter().filter(|p| !p.dashpot_stable).count(),
        j.points.len(),
        if missing_judged.is_empty() {
            String::new()
        } else {
            format!(
                "; without one, left out of the judgement: {}",
                missing_judged.join(", ")
            )
        }
    ));
}

/// The points left out of the judgement on trustworthy numbers (unstable, no stand-in), one
/// entry per code and (mu_r, eta_r) naming the speeds of its stages left out: "native (mu_r
/// 0.5, eta_r 0.5) at 0.0001, 0.0003, 0.001 m/s".
fn left_out(points: &[Point], judged: &[JudgedPoint]) -> Vec<String> {
    let mut missing: Vec<(Code, f64, f64, Vec<f64>)> = Vec::new();
    for m in judged.iter().filter(|j| j.point.is_none()) {
        let speed = points
            .iter()
            .find(|p| {
                p.code == m.code && p.stage == m.stage && p.mu_r == m.mu_r && p.eta_r == m.eta_r
            })
            .map(|p| p.speed);
        let at = match missing
            .iter()
            .position(|(c, mr, er, _)| *c == m.code && *mr == m.mu_r && *er == m.eta_r)
        {
            Some(at) => at,
            None => {
                missing.push((m.code, m.mu_r, m.eta_r, Vec::new()));
                missing.len() - 1
            }
        };
        missing[at].3.extend(speed);
    }
    missing
        .iter()
        .map(|(code, mu_r, eta_r, speeds)| {
            let at: Vec<String> = speeds.iter().map(|v| v.to_string()).collect();
            format!(
                "{code} (mu_r {mu_r}, eta_r {eta_r}) at {} m/s",
                at.join(", ")
            )
        })
        .collect()
}

/// Each claim here and in the study beside, as run and on stable or converged numbers, whether
/// the verdicts are the same, and both sides' evidence (where they differ, the numbers say
/// why).
fn beside_section(page: &mut Page, j: &Judgement, b: &BesideReport) {
    page.para(&format!(
        "The same claims judged by this version on the {} runs of {}{}: as run, and on stable \
         or converged numbers where that study was given stand-ins. \"The same\" compares \
         the verdicts on stable or converged numbers where both have them, else as run.",
        b.runs,
        b.dir,
        if b.missing > 0 {
            format!(" ({} of its runs have no result yet)", b.missing)
        } else {
            String::new()
        }
    ));
    let find = |set: &[(Code, Vec<Conclusion>)], code: Code, k: usize| {
        set.iter()
            .find(|(c, _)| *c == code)
            .and_then(|(_, cs)| cs.get(k))
            .cloned()
    };
    let words = |c: &Option<Conclusion>| {
        c.as_ref()
            .map_or("not given".to_string(), |c| c.verdict.words().to_string())
    };
    let mut rows: Vec<Vec<(String, &str)>> = Vec::new();
    for (code, cs) in &j.concl {
        for (k, here) in cs.iter().enumerate() {
            let here_stable = find(&j.conv_concl, *code, k);
            let there = find(&b.conclusions, *code, k);
            let there_stable = find(&b.converged_conclusions, *code, k);
            let (a, z) = match (&here_stable, &there_stable) {
                (Some(a), Some(z)) => (Some(a.clone()), Some(z.clone())),
                _ => (Some(here.clone()), there.clone()),
            };
            let decided = |c: &Conclusion| {
                matches!(
                    c.verdict,
                    ClaimVerdict::Agrees | ClaimVerdict::PartlyAgrees | ClaimVerdict::Disagrees
                )
            };
            // "the same" only where both decided the same way (two "not resolved" are
            // not an agreement)
            let same = match (&a, &z) {
                (Some(a), Some(_)) if !decided(a) => ("not decided here yet", "warn"),
                (Some(_), Some(z)) if !decided(z) => ("not decided beside", "warn"),
                (Some(a), Some(z)) if a.verdict == z.verdict => ("the same", "pass"),
                (Some(_), Some(_)) => ("DIFFERENT", "fail"),
                _ => ("not compared", "warn"),
            };
            rows.push(vec![
                (format!("{code}"), ""),
                (here.claim.clone(), ""),
                (here.verdict.words().to_string(), ""),
                (words(&here_stable), ""),
                (words(&there), ""),
                (words(&there_stable), ""),
                (same.0.to_string(), same.1),
                (
                    format!(
                        "here: {} | beside: {}",
                        a.map_or(String::new(), |c| c.evidence),
                        z.map_or(String::new(), |c| c.evidence)
                    ),
                    "",
                ),
            ]);
        }
    }
    page.push(table(
        &[
            "code",
            "the paper's claim",
            "here, as run",
            "here, stable or converged",
            "beside, as run",
            "beside, stable or converged",
            "verdicts",
            "evidence compared",
        ],
        &text_rows(rows),
    ));
}

/// The paper's conclusions, checked: at the sweep's dt and on stable or converged numbers.
fn conclusions_section(page: &mut Page, j: &Judgement) {
    for (title, set) in [
        ("at the sweep's dt", &j.concl),
        (
            "on stable or converged-dt results: unstable points replaced by their converged \
             result, those without one left out",
            &j.conv_concl,
        ),
    ] {
        for (code, cs) in set.iter() {
            let rows: Vec<Vec<(String, &str)>> = cs
                .iter()
                .map(|c| {
                    vec![
                        (c.claim.clone(), ""),
                        (
                            c.verdict.words().to_string(),
                            match c.verdict {
                                ClaimVerdict::Agrees => "pass",
                                ClaimVerdict::NotAssessable
                                | ClaimVerdict::NotResolved
                                | ClaimVerdict::PartlyAgrees => "warn",
                                ClaimVerdict::Disagrees => "fail",
                            },
                        ),
                        (c.evidence.clone(), ""),
                    ]
                })
                .collect();
            page.push(html! { h3 { (code) " (" (title) ")" } });
            page.push(table(
                &["paper's claim", "our result", "evidence"],
                &text_rows(rows),
            ));
            // a difference only where the numbers decided one (not resolved or not
            // assessable is no difference: the table says what it lacks)
            for c in cs.iter().filter(|c| {
                matches!(
                    c.verdict,
                    ClaimVerdict::Disagrees | ClaimVerdict::PartlyAgrees
                )
            }) {
                page.para(&format!(
                    "Where we differ from the paper ({code}, {title}): \"{}\" {} — {}.",
                    c.claim, c.verdict, c.evidence
                ));
            }
        }
    }
}

/// Where the explicit rolling dashpot is expected to be unstable, and how to judge it.
fn unstable_note(page: &mut Page, points: &[Point]) {
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
}

/// The stages (index, speed), the eta_r and the mu_r of the points, each sorted.
fn axes(points: &[Point]) -> (Vec<(usize, f64)>, Vec<f64>, Vec<f64>) {
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
    (stages, etas, mus)
}

/// Steady mu against mu_r, one curve per eta_r and code, one panel per speed (paper Figs
/// 5-7).
fn mu_against_mu_r(page: &mut Page, j: &Judgement, figs: &Path) -> Result<Vec<maud::Markup>> {
    let (stages, etas, _) = axes(&j.points);
    let mut fig_html = Vec::new();
    for &(k, speed) in &stages {
        let mut data: Vec<ErrCurve> = Vec::new();
        for (ci, &e) in etas.iter().enumerate() {
            for (set, tag) in [(&j.points, ""), (&j.conv_points, " converged dt")] {
                for code in &j.codes {
                    let sel: Vec<&Point> = set
                        .iter()
                        .filter(|p| p.code == *code && p.stage == k && p.eta_r == e)
                        .collect();
                    if sel.is_empty() {
                        continue;
                    }
                    data.push(ErrCurve {
                        label: format!("eta_r {e} {code}{tag}"),
                        color: ci,
                        dashed: *code == Code::Liggghts || !tag.is_empty(),
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
    Ok(fig_html)
}

/// Steady mu against speed, one panel per mu_r (paper Figs 12-15), when the sweep has
/// several stages.
fn mu_against_speed(page: &mut Page, j: &Judgement, figs: &Path) -> Result<Vec<maud::Markup>> {
    let (stages, etas, mus) = axes(&j.points);
    let mut fig_html = Vec::new();
    if stages.len() > 1 {
        for &m_r in &mus {
            let mut data: Vec<ErrCurve> = Vec::new();
            for (ci, &e) in etas.iter().enumerate() {
                for code in &j.codes {
                    let sel: Vec<&Point> = j
                        .points
                        .iter()
                        .filter(|p| p.code == *code && p.mu_r == m_r && p.eta_r == e)
                        .collect();
                    if !sel.is_empty() {
                        data.push(ErrCurve {
                            label: format!("eta_r {e} {code}"),
                            color: ci,
                            dashed: *code == Code::Liggghts,
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
    Ok(fig_html)
}

/// Heat maps of steady mu over (mu_r, eta_r): as run, and as judged (stand-ins marked), on
/// one colour scale.
fn heat_maps(page: &mut Page, j: &Judgement, figs: &Path) -> Result<Vec<maud::Markup>> {
    let (stages, _, _) = axes(&j.points);
    let mut fig_html = Vec::new();
    let range = mu_range(j.points.iter().chain(&j.judged));
    for code in &j.codes {
        for &(k, speed) in &stages {
            let sel: Vec<&Point> = j
                .points
                .iter()
                .filter(|p| p.code == *code && p.stage == k)
                .collect();
            if sel.is_empty() {
                continue;
            }
            let style = HeatStyle {
                range,
                ..HeatStyle::default()
            };
            let svg = heat_map(
                &format!("steady mu, {code}, {speed} m/s, {}", sel[0].source),
                &sel,
                &style,
            )?;
            write_atomic(
                &figs.join(format!("heat_{code}_stage{k}.svg")),
                svg.as_bytes(),
            )?;
            fig_html.push(page.svg(
                &svg,
                &format!("Steady μ over (μr, ηr), {code}, as run at the sweep's dt."),
            ));
            let jsel: Vec<&Point> = j
                .judged_points
                .iter()
                .filter(|j| j.code == *code && j.stage == k)
                .filter_map(|j| j.point.as_ref())
                .collect();
            if j.conv_points.is_empty() || jsel.is_empty() {
                continue;
            }
            let substituted = |p: &Point| {
                j.judged_points.iter().any(|j| {
                    j.substituted
                        && j.code == p.code
                        && j.stage == p.stage
                        && j.mu_r == p.mu_r
                        && j.eta_r == p.eta_r
                })
            };
            let mut sources: Vec<String> = jsel
                .iter()
                .filter(|p| substituted(p))
                .map(|p| format!("‡ from {}", p.source))
                .collect();
            sources.sort();
            sources.dedup();
            let mark = |p: &Point| {
                if substituted(p) {
                    " ‡".into()
                } else {
                    String::new()
                }
            };
            let style = HeatStyle {
                range,
                mark: &mark,
                legend: sources,
            };
            let svg = heat_map(
                &format!("steady mu, {code}, {speed} m/s, on stable or converged numbers"),
                &jsel,
                &style,
            )?;
            write_atomic(
                &figs.join(format!("heat_{code}_stage{k}_judged.svg")),
                svg.as_bytes(),
            )?;
            fig_html.push(page.svg(
                &svg,
                &format!(
                    "Steady μ over (μr, ηr), {code}, on stable or converged numbers: each point \
                     unstable at the sweep's dt replaced by its stand-in (‡, same colour scale)."
                ),
            ));
        }
    }
    Ok(fig_html)
}

/// The time-step convergence studies used as stand-ins: their mu(dt) and E_rot(dt) figures.
fn convergence_figures(page: &mut Page, converged: &[PathBuf]) -> Result<()> {
    let studies: Vec<&PathBuf> = converged
        .iter()
        .filter(|d| d.join("summary.json").is_file() && d.join("mu_dt.svg").is_file())
        .collect();
    if !studies.is_empty() {
        page.heading("convergence", "Time-step convergence of the stand-ins");
        for d in studies {
            let v: ConvergenceSummary = crate::run::load(&d.join("summary.json"))?;
            let mut figs = Vec::new();
            for (f, what) in [
                ("mu_dt.svg", "steady μ"),
                ("erot_dt.svg", "rotational energy"),
            ] {
                if d.join(f).is_file() {
                    figs.push(page.svg_file(
                        &d.join(f),
                        &format!(
                            "{what} against dt at (μr {}, ηr {}), {} ({}: {})",
                            v.mu_r,
                            v.eta_r,
                            v.rolling,
                            dir_name(d),
                            if v.converged {
                                "converged"
                            } else {
                                "NOT shown converged"
                            }
                        ),
                    )?);
                }
            }
            page.figures(&figs);
        }
    }
    Ok(())
}

/// Slip at both plates and the shear band per run and stage from the grains' displacements
/// between snapshots (`verify profile`: `runs/<id>/seed<k>/native_displacement_profile.json`,
/// where a run has one), as a table; a file that is not a profile list is said, not skipped.
fn displacement_profiles(page: &mut Page, m: &Manifest, dir: &Path) {
    let mut rows: Vec<Vec<(String, &'static str)>> = Vec::new();
    let mut unreadable = Vec::new();
    for r in &m.runs {
        let rel = format!(
            "runs/{}/seed{}/native_displacement_profile.json",
            r.id, r.seed
        );
        let path = dir.join(&rel);
        if !path.is_file() {
            continue;
        }
        let read = crate::fsutil::read_to_string(&path).and_then(|t| {
            serde_json::from_str::<Vec<crate::profile::VelocityProfile>>(&t).map_err(Error::from)
        });
        let profiles = match read {
            Ok(p) if !p.is_empty() => p,
            Ok(_) => {
                unreadable.push(format!("{rel} (no profile in it)"));
                continue;
            }
            Err(e) => {
                unreadable.push(format!("{rel} ({e})"));
                continue;
            }
        };
        for p in &profiles {
            let slip = |v: f64, ci: f64| format!("{v:+.3} ± {ci:.3}");
            rows.push(vec![
                (r.id.clone(), ""),
                (format!("{}", p.speed), "num"),
                (slip(p.slip_bottom, p.slip_bottom_ci95), "num"),
                (slip(p.slip_top, p.slip_top_ci95), "num"),
                (format!("{:.2}", p.band_width * 1e3), "num"),
                (format!("{:.2}", p.gap * 1e3), "num"),
                (p.samples.to_string(), "num"),
            ]);
        }
    }
    if rows.is_empty() && unreadable.is_empty() {
        return;
    }
    page.heading("slip", "Slip and shear band, from grain displacements");
    page.para(
        "Per run and stage, from each grain's displacement between ParaView snapshots over the \
         stage's steady window (`verify profile`; 95 % CIs over 10 blocks): slip as a fraction \
         of the plate speed (0: the gouge moves with the plate), the band the thickness over \
         which the plate speed would be lost at the steepest layer-to-layer gradient.",
    );
    page.push(table(
        &[
            "run",
            "speed [m/s]",
            "slip bottom",
            "slip top",
            "band [mm]",
            "gap [mm]",
            "snapshots",
        ],
        &text_rows(rows),
    ));
    for u in unreadable {
        page.push(html! { p.warn { "Not read: " (u) } });
    }
}

/// The paper's rotation maps (its Figs 8-11): seed 1 of each point, as each run drew it at
/// its end, and stage by stage where `verify profile` made them from the snapshots (the
/// rotation over each stage's steady window: `seed1/rotation_map_stage<k>.svg`).
fn rotation_maps(page: &mut Page, m: &Manifest, dir: &Path) {
    let maps: Vec<(String, Vec<(String, String)>)> = m
        .runs
        .iter()
        .filter(|r| r.seed == 1)
        .filter_map(|r| {
            let seed = format!("runs/{}/seed1", r.id);
            let mut figs = Vec::new();
            let whole = format!("{seed}/rotation_map.svg");
            if dir.join(&whole).is_file() {
                figs.push(("the whole run, at its end".to_string(), whole));
            }
            for k in 1.. {
                let rel = format!("{seed}/rotation_map_stage{k}.svg");
                if !dir.join(&rel).is_file() {
                    break;
                }
                figs.push((format!("stage {k}, its steady window"), rel));
            }
            (!figs.is_empty()).then(|| (format!("mu_r {}, eta_r {}", r.mu_r, r.eta_r), figs))
        })
        .collect();
    if !maps.is_empty() {
        page.heading("rotation", "Rotation maps");
        page.para(
            "Particles seen along z (seed 1 of each point; the paper's Figs 8-11), coloured by \
             their accumulated rotation at the end of the run, and, where the run's snapshots \
             gave them, by the rotation each grain made over each stage's steady window (the \
             same strain at every speed; one colour scale for a run's stages, so that they \
             compare). Each opens at full size.",
        );
        page.push(html! {
            @for (point, figs) in &maps {
                h3 { (point) }
                div.plots {
                    @for (label, rel) in figs {
                        figure {
                            a href=(rel) { img src=(rel) alt=(format!("{point}: {label}")) style="max-width: 280px"; }
                            figcaption { (label) }
                        }
                    }
                }
            }
        });
    }
}

/// Every point: as run, its stability, and as judged.
fn points_table(page: &mut Page, j: &Judgement) {
    page.heading("table", "Points");
    let rows: Vec<Vec<(String, &'static str)>> = j
        .points
        .iter()
        .map(|p| {
            let judged = j.judged_points.iter().find(|q| {
                q.code == p.code && q.stage == p.stage && q.mu_r == p.mu_r && q.eta_r == p.eta_r
            });
            let conv = judged
                .and_then(|j| j.point.as_ref())
                .map(Point::mu_words)
                .unwrap_or("–".into());
            let note = judged.map(|j| j.note.clone()).unwrap_or_default();
            vec![
                (p.code.to_string(), ""),
                (format!("{}", p.speed), "num"),
                (format!("{}", p.mu_r), "num"),
                (format!("{}", p.eta_r), "num"),
                (p.mu_words(), "num"),
                (p.seeds.to_string(), "num"),
                (format!("{:.2e}", p.erot), "num"),
                (
                    format!("{:.2}", p.stability_s),
                    if p.dashpot_stable { "pass" } else { "warn" },
                ),
                (conv, "num"),
                (note, ""),
            ]
        })
        .collect();
    page.push(table(
        &[
            "code",
            "speed [m/s]",
            "mu_r",
            "eta_r",
            "steady mu (95 % CI)",
            "seeds",
            "E_rot [J]",
            "stability S (unstable ≥ 4)",
            "judged mu",
            "judged from",
        ],
        &text_rows(rows),
    ));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(mu_r: f64, mu: f64, stable: bool, source: &str) -> Point {
        Point {
            code: Code::Native,
            mu_r,
            eta_r: 0.5,
            stage: 0,
            speed: 0.02,
            mu,
            mu_ci95: 0.01,
            run_ci95: f64::NAN,
            seeds: 3,
            erot: 0.0,
            dashpot_stable: stable,
            stability_s: if stable { 1.0 } else { 10.0 },
            source: source.into(),
            per_seed_mu: Vec::new(),
        }
    }

    #[test]
    fn unstable_points_take_the_first_stand_in_checked_against_the_others() {
        let points = [
            point(0.25, 0.5, true, "epsd at dt 1.5e-6"),
            point(0.5, 0.2, false, "epsd at dt 1.5e-6"),
            point(1.0, 0.2, false, "epsd at dt 1.5e-6"),
        ];
        let stand_ins = [
            point(0.5, 0.60, true, "epsd_implicit"),
            point(0.5, 0.61, true, "epsd dt/4"),
            point(0.5, 0.70, true, "epsd dt/8"),
            Point {
                code: Code::Liggghts,
                ..point(0.5, 0.605, true, "epsd dt/4 (LIGGGHTS)")
            },
        ];
        let j = judge(&points, &stand_ins);
        assert!(!j[0].substituted && j[0].point.as_ref().unwrap().mu == 0.5);
        assert!(j[1].substituted && j[1].point.as_ref().unwrap().mu == 0.60);
        assert!(
            j[1].note.contains("from epsd_implicit")
                && j[1].note.contains("agrees with epsd dt/4")
                && j[1].note.contains("DIFFERS from epsd dt/8")
                && j[1]
                    .note
                    .contains("agrees with liggghts epsd dt/4 (LIGGGHTS)"),
            "{}",
            j[1].note
        );
        // no stand-in: left out, and said so
        assert!(j[2].point.is_none() && j[2].note.contains("no stable or converged result"));
        // once per point, whatever the number of its stages left out, with their speeds
        let slow = |stage, speed| Point {
            stage,
            speed,
            ..point(1.0, 0.2, false, "epsd at dt 1.5e-6")
        };
        let staged = [
            points[1].clone(),
            slow(0, 1e-4),
            slow(1, 3e-4),
            slow(2, 1e-3),
        ];
        let j = judge(&staged, &stand_ins);
        assert_eq!(
            left_out(&staged, &j),
            ["native (mu_r 1, eta_r 0.5) at 0.0001, 0.0003, 0.001 m/s"]
        );
    }
}
