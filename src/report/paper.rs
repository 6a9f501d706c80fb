//! The paper's figures and conclusions from a sweep's results (Sac-Morane, Rattez & Veveakis
//! 2022): steady mu against mu_r per eta_r and speed (their Figs 5-7), mu against shear speed
//! (Figs 12-15), a heat map over (mu_r, eta_r), and the three conclusions checked in numbers.

use crate::compare::{mean_ci95, seeds_for, t95, t_two_sided, within_cis, MAX_SEEDS_NEEDED};
use crate::error::draw_err;
use crate::error::Result;
use crate::run::sweep::RunResult;
use crate::run::Code;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use serde::{Deserialize, Serialize};

/// Mean over seeds of one code at one (mu_r, eta_r, stage).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Point {
    pub code: Code,
    pub mu_r: f64,
    pub eta_r: f64,
    pub stage: usize,
    pub speed: f64,
    pub mu: f64,
    /// 95 % CI half-width over seeds (infinite with one seed).
    pub mu_ci95: f64,
    /// With one seed, the 95 % CI of the run's own window (block means, `compare::block_ci95`):
    /// how steady that one run's mu is, not how another sample would differ. NaN otherwise.
    pub run_ci95: f64,
    pub seeds: usize,
    pub erot: f64,
    pub dashpot_stable: bool,
    pub stability_s: f64,
    /// Where the number comes from: rolling model and dt, and for substitutes the directory
    /// and the study's verdict (set by the report; empty from [`aggregate`]).
    pub source: String,
    /// (seed, steady mu) of each seed: a speed effect is judged seed by seed (the stages of one
    /// run share its packing).
    pub per_seed_mu: Vec<(u64, f64)>,
}

/// Aggregates run results into points, sorted by code, stage, eta_r, mu_r.
pub fn aggregate(results: &[RunResult]) -> Vec<Point> {
    let mut pts: Vec<Point> = Vec::new();
    let mut keys: Vec<(Code, u64, u64, usize)> = Vec::new();
    for r in results {
        for (k, st) in r.stages.iter().enumerate() {
            for (code, c) in [(Code::Liggghts, &st.liggghts), (Code::Native, &st.native)] {
                if c.is_some() {
                    let key = (code, r.run.mu_r.to_bits(), r.run.eta_r.to_bits(), k);
                    if !keys.contains(&key) {
                        keys.push(key);
                    }
                }
            }
        }
    }
    for (code, m, e, k) in keys {
        let (mu_r, eta_r) = (f64::from_bits(m), f64::from_bits(e));
        let runs: Vec<&RunResult> = results
            .iter()
            .filter(|r| r.run.mu_r == mu_r && r.run.eta_r == eta_r && r.stages.len() > k)
            .collect();
        let vals: Vec<(f64, f64, u64, f64)> = runs
            .iter()
            .filter_map(|r| {
                let st = &r.stages[k];
                let c = if code == Code::Native {
                    &st.native
                } else {
                    &st.liggghts
                };
                c.as_ref().map(|c| (c.mu, c.erot, r.run.seed, c.mu_ci95))
            })
            .collect();
        let mus: Vec<f64> = vals.iter().map(|v| v.0).collect();
        let (mu, ci) = mean_ci95(&mus);
        pts.push(Point {
            code,
            mu_r,
            eta_r,
            stage: k,
            speed: runs[0].stages[k].speed,
            mu,
            mu_ci95: ci,
            run_ci95: match vals.as_slice() {
                [one] => one.3,
                _ => f64::NAN,
            },
            seeds: mus.len(),
            erot: vals.iter().map(|v| v.1).sum::<f64>() / vals.len() as f64,
            dashpot_stable: runs.iter().all(|r| r.dashpot_stable),
            stability_s: runs.iter().map(|r| r.stability_s).fold(0.0, f64::max),
            source: String::new(),
            per_seed_mu: vals.iter().map(|v| (v.2, v.0)).collect(),
        });
    }
    pts.sort_by(|a, b| {
        (a.code, a.stage)
            .cmp(&(b.code, b.stage))
            .then(a.eta_r.total_cmp(&b.eta_r))
            .then(a.mu_r.total_cmp(&b.mu_r))
    });
    pts
}

/// One parameter curve's answer to a claim.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Verdict {
    Agree,
    Disagree,
    /// The difference is within the confidence intervals.
    Unresolved,
}

/// The verdict on one of the paper's claims (written as the words in report.json).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ClaimVerdict {
    /// Every resolved curve agrees.
    #[serde(rename = "agrees")]
    Agrees,
    /// Some resolved curves agree, some disagree.
    #[serde(rename = "partly agrees")]
    PartlyAgrees,
    /// Every resolved curve disagrees.
    #[serde(rename = "disagrees")]
    Disagrees,
    /// No curve resolved: the differences are within the CIs.
    #[serde(rename = "not resolved")]
    NotResolved,
    /// The sweep lacks the points.
    #[serde(rename = "not assessable")]
    NotAssessable,
}

impl ClaimVerdict {
    pub fn words(self) -> &'static str {
        match self {
            ClaimVerdict::Agrees => "agrees",
            ClaimVerdict::PartlyAgrees => "partly agrees",
            ClaimVerdict::Disagrees => "disagrees",
            ClaimVerdict::NotResolved => "not resolved",
            ClaimVerdict::NotAssessable => "not assessable",
        }
    }
}

impl std::fmt::Display for ClaimVerdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.words())
    }
}

/// The claim's verdict over its curves: agrees / disagrees (every resolved curve one way),
/// partly agrees (both), not resolved (no curve resolved), not assessable (no curve).
pub(crate) fn combine(v: &[Verdict]) -> ClaimVerdict {
    let agree = v.contains(&Verdict::Agree);
    let disagree = v.contains(&Verdict::Disagree);
    match (v.is_empty(), agree, disagree) {
        (true, _, _) => ClaimVerdict::NotAssessable,
        (_, true, false) => ClaimVerdict::Agrees,
        (_, false, true) => ClaimVerdict::Disagrees,
        (_, true, true) => ClaimVerdict::PartlyAgrees,
        (_, false, false) => ClaimVerdict::NotResolved,
    }
}

/// One of the paper's conclusions, checked in numbers.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Conclusion {
    pub claim: String,
    pub verdict: ClaimVerdict,
    pub evidence: String,
}

/// The point's CI half-width; infinite with one seed (nothing is significant then).
fn ci(p: &Point) -> f64 {
    if p.mu_ci95.is_nan() {
        f64::INFINITY
    } else {
        p.mu_ci95
    }
}

impl Point {
    /// Its mu for tables: "0.6318 ± 0.0312" over seeds; with one seed "0.6318 (one seed;
    /// within the run ± 0.0099)" (no CI over samples exists, and "± inf" is not a number).
    pub fn mu_words(&self) -> String {
        if self.mu_ci95.is_finite() {
            format!("{:.4} ± {:.4}", self.mu, self.mu_ci95)
        } else if self.run_ci95.is_finite() {
            format!(
                "{:.4} (one seed; within the run ± {:.4})",
                self.mu, self.run_ci95
            )
        } else {
            format!("{:.4} (one seed, no CI)", self.mu)
        }
    }
}

/// A point's CI for the evidence: its half-width, or "no CI (one seed)" (an infinite
/// half-width is not a number to print).
fn ci_words(p: &Point) -> String {
    let c = ci(p);
    if c.is_finite() {
        format!("{c:.3}")
    } else {
        "no CI (one seed)".into()
    }
}

/// The sample standard deviation of a point's per-seed mu (NaN below 2 seeds).
fn seed_sd(p: &Point) -> f64 {
    let n = p.per_seed_mu.len();
    if n < 2 {
        return f64::NAN;
    }
    let m = p.per_seed_mu.iter().map(|s| s.1).sum::<f64>() / n as f64;
    (p.per_seed_mu.iter().map(|s| (s.1 - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
}

/// Seeds per point that would resolve the difference between two points at the spread their
/// seeds show: the smallest n whose 95 % CIs, t95(n-1) sd / sqrt(n) each, no longer overlap
/// (`within_cis` false) at the measured difference. None below 2 seeds at either point (no
/// spread known) or beyond [`MAX_SEEDS_NEEDED`].
pub fn seeds_to_resolve(a: &Point, b: &Point) -> Option<usize> {
    let (sa, sb) = (seed_sd(a), seed_sd(b));
    let gap = (a.mu - b.mu).abs();
    if !(sa.is_finite() && sb.is_finite() && gap > 0.0) {
        return None;
    }
    seeds_for(t95, sa + sb, gap)
}

/// What an unresolved comparison of two points needs: the seeds that would resolve it, or
/// why that is not known.
fn to_resolve(a: &Point, b: &Point) -> String {
    match seeds_to_resolve(a, b) {
        Some(n) => format!("about {n} seeds per point would resolve it"),
        None if a.per_seed_mu.len() < 2 || b.per_seed_mu.len() < 2 => {
            "one seed: 2 or more give the spread that says how many would resolve it".into()
        }
        None => format!("more than {MAX_SEEDS_NEEDED} seeds per point would be needed"),
    }
}

/// Claim 1 on one eta_r = 0 curve, from its ends: Agree when mu at the largest mu_r is above
/// mu at the smallest by more than the two CIs, Disagree when below by as much, else
/// Unresolved.
pub(crate) fn rises(first: &Point, last: &Point) -> Verdict {
    if within_cis(first.mu, ci(first), last.mu, ci(last)) {
        Verdict::Unresolved
    } else if last.mu > first.mu {
        Verdict::Agree
    } else {
        Verdict::Disagree
    }
}

/// Claim 2 on one eta_r > 0 curve (mu_r increasing, its mu_r = 0 end included): Agree when it
/// has a critical mu_r ([`critical_mu_r`]), Disagree when instead mu at the largest mu_r is
/// above mu at the smallest by more than the two CIs, else Unresolved.
/// Returns the critical mu_r and mu's fall beyond it with the verdict.
pub(crate) fn falls(c: &[&Point]) -> (Verdict, Option<(f64, f64)>) {
    let critical = critical_mu_r(c);
    let verdict = match (critical, c.first(), c.last()) {
        (Some(_), _, _) => Verdict::Agree,
        (None, Some(first), Some(last)) if rises(first, last) == Verdict::Agree => {
            Verdict::Disagree
        }
        _ => Verdict::Unresolved,
    };
    (verdict, critical)
}

/// The critical mu_r of one (code, stage, eta_r) curve: the mu_r of the largest mu when mu at
/// the largest mu_r is significantly lower (by more than the two CIs), else None.
pub fn critical_mu_r(curve: &[&Point]) -> Option<(f64, f64)> {
    let best = curve.iter().max_by(|a, b| a.mu.total_cmp(&b.mu))?;
    let last = curve.last()?;
    let drop = best.mu - last.mu;
    (best.mu_r < last.mu_r && drop > 0.0 && !within_cis(best.mu, ci(best), last.mu, ci(last)))
        .then_some((best.mu_r, drop))
}

/// A curve of eta_r > 0 with its mu_r = 0 end: a point of its own there, else the eta_r = 0
/// curve's (returned true). At mu_r = 0 every rolling model's torque is zero whatever eta_r
/// (k_r = 0: the spring, its cap and the dashpot `eta_r 2 sqrt(I_r k_r)` vanish; tested bit for
/// bit on sheared states, `solver::shear` `eta_r_acts_on_nothing_at_mu_r_zero`), so a study
/// need not run (0, eta_r) beside (0, 0): the paper protocol runs only the latter.
fn with_mu_r_zero<'a>(mut curve: Vec<&'a Point>, undamped: &[&'a Point]) -> (Vec<&'a Point>, bool) {
    if curve.iter().any(|p| p.mu_r == 0.0) {
        return (curve, false);
    }
    match undamped.iter().find(|p| p.mu_r == 0.0) {
        Some(z) => {
            curve.insert(0, z);
            (curve, true)
        }
        None => (curve, false),
    }
}

/// The three conclusions for one code's points (the paper: with eta_r = 0 mu rises with mu_r;
/// with eta_r > 0 there is a critical mu_r beyond which mu falls; a speed effect only near that
/// critical point).
pub fn conclusions(points: &[Point], code: Code) -> Vec<Conclusion> {
    let pts: Vec<&Point> = points.iter().filter(|p| p.code == code).collect();
    let stages: Vec<usize> = {
        let mut s: Vec<usize> = pts.iter().map(|p| p.stage).collect();
        s.dedup();
        s
    };
    let curve = |stage: usize, eta: f64| -> Vec<&Point> {
        pts.iter()
            .copied()
            .filter(|p| p.stage == stage && p.eta_r == eta)
            .collect()
    };
    let mut etas: Vec<f64> = pts.iter().map(|p| p.eta_r).collect();
    etas.sort_by(f64::total_cmp);
    etas.dedup();
    let mut out = Vec::new();

    // 1. eta_r = 0: mu rises with mu_r
    let mut ev = Vec::new();
    let mut verdicts = Vec::new();
    for &s in &stages {
        let c = curve(s, 0.0);
        if c.len() < 2 {
            continue;
        }
        let (first, last) = (c[0], c[c.len() - 1]);
        let rise = last.mu - first.mu;
        let verdict = rises(first, last);
        let resolved = verdict != Verdict::Unresolved;
        verdicts.push(verdict);
        ev.push(format!(
            "v = {} m/s: mu {:.3} at mu_r {} -> {:.3} at mu_r {} (change {:+.3}, CIs {}/{}){}",
            first.speed,
            first.mu,
            first.mu_r,
            last.mu,
            last.mu_r,
            rise,
            ci_words(first),
            ci_words(last),
            if resolved {
                String::new()
            } else {
                format!(": within the CIs, {}", to_resolve(first, last))
            }
        ));
    }
    out.push(Conclusion {
        claim: "with eta_r = 0, mu rises with mu_r".into(),
        verdict: combine(&verdicts),
        evidence: if ev.is_empty() {
            "the sweep has no eta_r = 0 curve with two mu_r values".into()
        } else {
            ev.join("; ")
        },
    });

    // 2. eta_r > 0: a critical mu_r beyond which mu falls
    let mut ev = Vec::new();
    let mut verdicts = Vec::new();
    let mut criticals: Vec<(usize, f64, f64)> = Vec::new();
    for &s in &stages {
        for &e in etas.iter().filter(|&&e| e > 0.0) {
            let (c, borrowed) = with_mu_r_zero(curve(s, e), &curve(s, 0.0));
            if c.len() < 3 {
                continue;
            }
            let borrowed = if borrowed {
                " (mu_r 0: the eta_r 0 run, eta_r acting on nothing at mu_r 0)"
            } else {
                ""
            };
            let unstable = if c.iter().any(|p| !p.dashpot_stable) {
                " [explicit dashpot unstable at some of these points]"
            } else {
                ""
            };
            let (verdict, critical) = falls(&c);
            verdicts.push(verdict);
            match critical {
                Some((m, drop)) => {
                    criticals.push((s, e, m));
                    ev.push(format!(
                        "v = {} m/s, eta_r {e}: critical mu_r = {m} (mu falls by {drop:.3} up to mu_r {}){unstable}{borrowed}",
                        c[0].speed,
                        c[c.len() - 1].mu_r,
                    ));
                }
                None => {
                    let (first, last) = (c[0], c[c.len() - 1]);
                    let rises = verdict == Verdict::Disagree;
                    // unresolved: the comparison that would decide it, the largest mu against
                    // the last (a fall) where the largest comes first, else the ends (a rise)
                    let best = c
                        .iter()
                        .copied()
                        .max_by(|a, b| a.mu.total_cmp(&b.mu))
                        .unwrap_or(first);
                    let (a, z) = if best.mu_r < last.mu_r {
                        (best, last)
                    } else {
                        (first, last)
                    };
                    ev.push(format!(
                        "v = {} m/s, eta_r {e}: no significant fall of mu up to mu_r {} ({}){unstable}{borrowed}",
                        c[0].speed,
                        last.mu_r,
                        if rises {
                            "mu rises with mu_r".to_string()
                        } else {
                            format!("differences within the CIs; {}", to_resolve(a, z))
                        }
                    ));
                }
            }
        }
    }
    out.push(Conclusion {
        claim: "with eta_r > 0, there is a critical mu_r beyond which mu falls".into(),
        verdict: combine(&verdicts),
        evidence: if ev.is_empty() {
            "needs eta_r > 0 with at least three mu_r values".into()
        } else {
            ev.join("; ")
        },
    });

    // 3. speed effect only near the critical mu_r
    let claim3 = "a speed effect only near the critical mu_r".to_string();
    if stages.len() < 2 {
        out.push(Conclusion {
            claim: claim3,
            verdict: ClaimVerdict::NotAssessable,
            evidence: "the sweep ran one shear speed; pass --speeds v1,v2,v3 to test it".into(),
        });
        return out;
    }
    // the test: per seed, the least-squares slope of mu against log10(speed) over the stages
    // (the stages of a seed share one packing); a speed effect where the mean slope's CI (t over
    // seeds) excludes 0, at 95 % for the points tested together (Bonferroni: each at
    // 1 - 0.05 / tested). Each point alone at 95 % made a false speed effect somewhere 17-24 %
    // of the time on the speed studies' five points (measured, report::claim_rates)
    let mut mu_rs: Vec<f64> = pts.iter().map(|p| p.mu_r).collect();
    mu_rs.sort_by(f64::total_cmp);
    mu_rs.dedup();
    let step = mu_rs
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    let mut near_ok = true;
    let mut ev = Vec::new();
    let mut any_effect = false;
    let slopes: Vec<(f64, f64, Option<SpeedSlope>)> = etas
        .iter()
        .flat_map(|&e| mu_rs.iter().map(move |&m| (e, m)))
        .filter_map(|(e, m)| {
            let by_stage: Vec<&Point> = stages
                .iter()
                .filter_map(|&k| curve(k, e).into_iter().find(|p| p.mu_r == m))
                .collect();
            (by_stage.len() == stages.len()).then(|| (e, m, speed_slope(&by_stage)))
        })
        .collect();
    let tested = slopes
        .iter()
        .filter(|s| s.2.is_some_and(|sl| sl.ci95.is_finite()))
        .count();
    for &(e, m, sl) in &slopes {
        let Some(sl) = sl else {
            continue;
        };
        if !sl.ci95.is_finite() {
            // one seed: the slope has no spread over seeds, so no CI; its number alone
            // would read as a measurement it is not
            ev.push(format!(
                "(mu_r {m}, eta_r {e}): one seed, so the slope over the speeds has no CI \
                     (2 or more seeds give one)"
            ));
            continue;
        }
        let family = if tested > 1 {
            format!(", 95 % over the {tested} points tested")
        } else {
            String::new()
        };
        if !speed_effect(&sl, tested) {
            ev.push(format!(
                "(mu_r {m}, eta_r {e}): slope {:+.4} ± {:.4} per decade of speed{family}, no \
                     effect resolved ({})",
                sl.mean,
                sl.family_ci(tested),
                sl.seeds_to_resolve(tested).map_or_else(
                    || format!("more than {MAX_SEEDS_NEEDED} seeds would be needed"),
                    |n| format!("about {n} seeds would resolve a slope of this size")
                )
            ));
            continue;
        }
        any_effect = true;
        let near = criticals
            .iter()
            .any(|&(_, ce, cm)| ce == e && (cm - m).abs() <= step * 1.01);
        near_ok &= near;
        ev.push(format!(
            "(mu_r {m}, eta_r {e}): slope {:+.4} ± {:.4} per decade of speed ({} seeds{family}), \
                 a speed effect {} the critical mu_r",
            sl.mean,
            sl.family_ci(tested),
            sl.n,
            if near { "near" } else { "away from" }
        ));
    }
    out.push(Conclusion {
        claim: claim3,
        verdict: if ev.is_empty() {
            ClaimVerdict::NotAssessable
        } else if !any_effect {
            // no speed effect resolved anywhere: neither the effect the paper finds near the
            // critical mu_r nor its absence is shown (absence would need an equivalence
            // margin; a slope below what the test finds, report::claim_rates, goes unseen)
            ClaimVerdict::NotResolved
        } else if !near_ok {
            ClaimVerdict::Disagrees
        } else {
            ClaimVerdict::Agrees
        },
        evidence: if ev.is_empty() {
            "needs every stage at a point with the same seeds".into()
        } else {
            ev.join("; ")
        },
    });
    out
}

/// Mean over seeds of the least-squares slope of steady mu against log10(speed), with its 95 %
/// CI half-width (t, n - 1 dof).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedSlope {
    pub mean: f64,
    pub ci95: f64,
    pub n: usize,
}

/// The t quantile of a CI that is 95 % over `tested` points together (Bonferroni: two-sided
/// 0.05 / tested each), `dof` degrees of freedom; t95 for one point.
fn t_family(tested: usize, dof: usize) -> f64 {
    t_two_sided(0.05 / tested.max(1) as f64, dof)
}

impl SpeedSlope {
    /// Its CI half-width when `tested` points are tested together: t_family(tested, n - 1)
    /// sd / sqrt(n), i.e. `ci95` widened so that all of them hold together 95 % of the time
    /// (`ci95` itself for one point; infinite with one seed).
    pub fn family_ci(&self, tested: usize) -> f64 {
        if self.n < 2 {
            return f64::INFINITY;
        }
        self.ci95 * t_family(tested, self.n - 1) / t95(self.n - 1)
    }

    /// The seeds whose CI, 95 % over `tested` points at the spread these show (sd = ci95
    /// sqrt(n) / t95(n-1)), would exclude 0 at this mean: None below 2 seeds, at a zero mean or
    /// beyond [`MAX_SEEDS_NEEDED`].
    pub fn seeds_to_resolve(&self, tested: usize) -> Option<usize> {
        if self.n < 2 || !self.ci95.is_finite() || self.mean == 0.0 {
            return None;
        }
        let sd = self.ci95 * (self.n as f64).sqrt() / t95(self.n - 1);
        seeds_for(|dof| t_family(tested, dof), sd, self.mean.abs())
    }
}

/// Claim 3 at one of `tested` points: a speed effect when the CI of its mean slope over seeds,
/// 95 % over the points tested together ([`SpeedSlope::family_ci`]), excludes 0 (one seed, an
/// infinite CI, resolves nothing).
pub(crate) fn speed_effect(sl: &SpeedSlope, tested: usize) -> bool {
    let half = sl.family_ci(tested);
    half.is_finite() && sl.mean.abs() > half
}

/// The seeds present at every one of a point's stages, in the first stage's order.
pub(crate) fn common_seeds(by_stage: &[&Point]) -> Vec<u64> {
    let Some(first) = by_stage.first() else {
        return Vec::new();
    };
    first
        .per_seed_mu
        .iter()
        .map(|s| s.0)
        .filter(|s| {
            by_stage
                .iter()
                .all(|p| p.per_seed_mu.iter().any(|q| q.0 == *s))
        })
        .collect()
}

/// The speed slope of one point's stages (`by_stage`: one point per stage, faster or slower):
/// one slope per seed present in every stage; None without such a seed or 2 distinct speeds.
pub fn speed_slope(by_stage: &[&Point]) -> Option<SpeedSlope> {
    let x: Vec<f64> = by_stage.iter().map(|p| p.speed.log10()).collect();
    let xm = x.iter().sum::<f64>() / x.len() as f64;
    let sxx: f64 = x.iter().map(|v| (v - xm) * (v - xm)).sum();
    if sxx.is_nan() || sxx <= 0.0 {
        return None;
    }
    let seeds = common_seeds(by_stage);
    let slopes: Vec<f64> = seeds
        .iter()
        .map(|s| {
            let y: Vec<f64> = by_stage
                .iter()
                .map(|p| p.per_seed_mu.iter().find(|q| q.0 == *s).expect("present").1)
                .collect();
            let ym = y.iter().sum::<f64>() / y.len() as f64;
            x.iter()
                .zip(&y)
                .map(|(a, b)| (a - xm) * (b - ym))
                .sum::<f64>()
                / sxx
        })
        .collect();
    if slopes.is_empty() {
        return None;
    }
    // one seed: a slope without a CI (infinite), nothing resolved
    let (mean, ci95) = mean_ci95(&slopes);
    Some(SpeedSlope {
        mean,
        ci95,
        n: slopes.len(),
    })
}

/// How a heat map draws its cells: the colour scale, a mark appended to a cell's value, and
/// legend lines under the map.
pub struct HeatStyle<'a> {
    /// Colour scale (low, high); None: the points' own range. Maps that are compared share one.
    pub range: Option<(f64, f64)>,
    /// A mark after the value (e.g. a source's symbol); unstable points get " †" regardless.
    pub mark: &'a dyn Fn(&Point) -> String,
    pub legend: Vec<String>,
}

impl Default for HeatStyle<'_> {
    fn default() -> Self {
        HeatStyle {
            range: None,
            mark: &|_| String::new(),
            legend: Vec::new(),
        }
    }
}

/// The (low, high) of the finite mu of several point sets: one colour scale for maps that are
/// read side by side.
pub fn mu_range<'a>(points: impl IntoIterator<Item = &'a Point>) -> Option<(f64, f64)> {
    let (lo, hi) = points
        .into_iter()
        .filter(|p| p.mu.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.mu), b.max(p.mu))
        });
    (lo <= hi).then_some((lo, hi))
}

/// Heat map of mu over (mu_r, eta_r) for one code and stage, as an SVG document (plotters):
/// one cell per point, light yellow (low mu) to dark blue (high mu) with a colour bar, its mu
/// written in it; points where the explicit dashpot is unstable get a red frame and a dagger;
/// a cell without a point says "none".
pub fn heat_map(title: &str, points: &[&Point], style: &HeatStyle) -> Result<String> {
    let mut mus: Vec<f64> = points.iter().map(|p| p.mu_r).collect();
    mus.sort_by(f64::total_cmp);
    mus.dedup();
    let mut etas: Vec<f64> = points.iter().map(|p| p.eta_r).collect();
    etas.sort_by(f64::total_cmp);
    etas.dedup();
    let (lo, hi) = style
        .range
        .or_else(|| mu_range(points.iter().copied()))
        .unwrap_or((0.0, 1.0));
    // colour: light yellow (low mu) to dark blue (high mu)
    let color = |v: f64| {
        let t = if hi > lo {
            ((v - lo) / (hi - lo)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let lerp = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
        (
            RGBColor(lerp(255.0, 8.0), lerp(247.0, 48.0), lerp(188.0, 107.0)),
            t,
        )
    };
    let mut legend =
        vec!["† red frame: explicit rolling dashpot unstable at this dt (S ≥ 4)".to_string()];
    legend.extend(style.legend.iter().cloned());
    let (cw, ch) = (110u32, 60u32);
    // map, then the colour bar and its labels; wide enough for the legend's longest line
    let map_w = 120 + cw * mus.len() as u32;
    let legend_w = legend.iter().map(|l| l.chars().count()).max().unwrap_or(0) as u32 * 7 + 40;
    // wide enough for the title too (16 px sans-serif: about 8 px a character)
    let title_w = title.chars().count() as u32 * 8 + 40;
    let w = (map_w + 110).max(legend_w).max(title_w);
    let h = 60 + ch * etas.len() as u32 + 70 + 18 * legend.len() as u32;
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        // the title over the whole width, the map under it
        let body = root.titled(title, ("sans-serif", 16)).map_err(draw_err)?;
        let (map_area, _) = body.split_horizontally(map_w + 10);
        let map_area = map_area.margin(0, 18 * legend.len() as u32, 0, 0);
        let mut chart = ChartBuilder::on(&map_area)
            .margin(10)
            .margin_bottom(20)
            .x_label_area_size(45)
            .y_label_area_size(90)
            .build_cartesian_2d(0.0..mus.len() as f64, 0.0..etas.len() as f64)
            .map_err(draw_err)?;
        let (mus_l, etas_l) = (mus.clone(), etas.clone());
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(mus.len() * 2 + 1)
            .y_labels(etas.len() * 2 + 1)
            .x_desc("mu_r")
            .y_desc("eta_r")
            // labels at the cell centres only
            .x_label_formatter(&move |v| {
                let k = v - 0.5;
                (k >= 0.0 && k.fract() == 0.0)
                    .then(|| mus_l.get(k as usize).map(|m| m.to_string()))
                    .flatten()
                    .unwrap_or_default()
            })
            .y_label_formatter(&move |v| {
                let k = v - 0.5;
                (k >= 0.0 && k.fract() == 0.0)
                    .then(|| etas_l.get(k as usize).map(|e| e.to_string()))
                    .flatten()
                    .unwrap_or_default()
            })
            .draw()
            .map_err(draw_err)?;
        let text = |label: String, at: (i32, i32), size: u32, ink: &RGBColor| {
            root.draw(&Text::new(
                label,
                at,
                ("sans-serif", size)
                    .into_font()
                    .color(ink)
                    .pos(Pos::new(HPos::Center, VPos::Center)),
            ))
            .map_err(draw_err)
        };
        for (j, e) in etas.iter().enumerate() {
            for (i, m) in mus.iter().enumerate() {
                let (x, y) = (i as f64, j as f64);
                let cell = [(x, y), (x + 1.0, y + 1.0)];
                let (px, py) = chart.backend_coord(&(x + 0.5, y + 0.5));
                let Some(p) = points.iter().find(|p| p.mu_r == *m && p.eta_r == *e) else {
                    text("none".into(), (px, py), 13, &RGBColor(128, 128, 128))?;
                    continue;
                };
                let (fill, t) = color(p.mu);
                chart
                    .draw_series([Rectangle::new(cell, fill.filled())])
                    .map_err(draw_err)?;
                let frame = if p.dashpot_stable {
                    WHITE.stroke_width(1)
                } else {
                    RED.stroke_width(3)
                };
                chart
                    .draw_series([Rectangle::new(cell, frame)])
                    .map_err(draw_err)?;
                let ink = if t > 0.55 { WHITE } else { BLACK };
                let label = format!(
                    "{:.3}{}{}",
                    p.mu,
                    if p.dashpot_stable { "" } else { " †" },
                    (style.mark)(p)
                );
                text(label, (px, py), 14, &ink)?;
            }
        }
        // colour bar: 20 steps from low (bottom) to high (top), labelled at both ends and
        // in the middle
        let (top, bottom) = (
            chart.backend_coord(&(0.0, etas.len() as f64)).1,
            chart.backend_coord(&(0.0, 0.0)).1,
        );
        let x0 = map_w as i32 + 20;
        let n = 20;
        for k in 0..n {
            let y1 = bottom - (bottom - top) * k / n;
            let y0 = bottom - (bottom - top) * (k + 1) / n;
            let v = lo + (hi - lo) * (k as f64 + 0.5) / n as f64;
            root.draw(&Rectangle::new(
                [(x0, y0), (x0 + 18, y1)],
                color(v).0.filled(),
            ))
            .map_err(draw_err)?;
        }
        for (v, y) in [
            (lo, bottom),
            (0.5 * (lo + hi), (top + bottom) / 2),
            (hi, top),
        ] {
            text(format!("{v:.3}"), (x0 + 50, y), 12, &BLACK)?;
        }
        text("mu".into(), (x0 + 9, top - 12), 12, &BLACK)?;
        for (k, line) in legend.iter().enumerate() {
            root.draw(&Text::new(
                line.clone(),
                (20, h as i32 - 18 * (legend.len() - k) as i32),
                ("sans-serif", 12),
            ))
            .map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::Steady;
    use crate::run::sweep::StageResult;

    fn run(mu_r: f64, eta_r: f64, seed: u64, mus: &[f64]) -> RunResult {
        RunResult {
            run: crate::run::sweep::RunSpec {
                index: 0,
                id: format!("{mu_r}_{eta_r}_{seed}"),
                mu_r,
                eta_r,
                seed,
                input_hash: String::new(),
            },
            dt: 1e-6,
            dashpot_stable: mu_r < 1.0,
            stability_s: 1.0,
            stages: mus
                .iter()
                .enumerate()
                .map(|(k, &mu)| StageResult {
                    speed: 0.01 * (k + 1) as f64,
                    window_steps: (0, 1),
                    liggghts: None,
                    native: Some(Steady {
                        per_seed_mu: vec![mu],
                        mu,
                        mu_ci95: 0.01,
                        per_seed_stress: vec![1e7],
                        normal_stress: 1e7,
                        normal_stress_ci95: 1e4,
                        erot: 1e-6,
                        erot_ci95: 1e-7,
                        ke: 1e-5,
                        mobilised: 0.2,
                    }),
                })
                .collect(),
            liggghts_wall_s: None,
            native_wall_s: Some(1.0),
            date_utc: String::new(),
        }
    }

    /// A synthetic map shaped like the paper's: rising at eta_r = 0, a peak at mu_r 0.5 with
    /// eta_r 0.5, a speed effect only there.
    fn paper_like() -> Vec<RunResult> {
        let mut r = Vec::new();
        for seed in 1..=3 {
            let n = 0.002 * seed as f64;
            for (m, a, b) in [(0.0, 0.30, 0.30), (0.5, 0.40, 0.40), (1.0, 0.50, 0.50)] {
                r.push(run(m, 0.0, seed, &[a + n, b + n]));
            }
            for (m, a, b) in [(0.0, 0.30, 0.30), (0.5, 0.45, 0.35), (1.0, 0.25, 0.25)] {
                r.push(run(m, 0.5, seed, &[a + n, b + n]));
            }
        }
        r
    }

    /// Claim 3 tests its points together: a slope whose 95 % CI alone excludes 0 (per-seed
    /// changes -0.10, -0.08, -0.12: t = 8.7 against t95(2) = 4.30) is no effect among the six
    /// points of the map (each at 1 - 0.05 / 6: t = 10.9), and is one when its point is the only
    /// one tested. With a critical mu_r but no speed effect resolved anywhere the claim is not
    /// resolved (the absence of the paper's effect is not shown by failing to see it).
    #[test]
    fn speed_effects_are_tested_together() {
        let noisy = |r: &mut Vec<RunResult>| {
            for x in r.iter_mut() {
                if x.run.mu_r == 0.5 && x.run.eta_r == 0.5 {
                    let d = [-0.10, -0.08, -0.12][x.run.seed as usize - 1];
                    let a = x.stages[0].native.as_ref().unwrap().mu;
                    x.stages[1].native.as_mut().unwrap().mu = a + d;
                }
            }
        };
        let mut r = paper_like();
        noisy(&mut r);
        let c = conclusions(&aggregate(&r), Code::Native);
        assert_eq!(c[1].verdict, ClaimVerdict::Agrees, "{}", c[1].evidence);
        assert_eq!(c[2].verdict, ClaimVerdict::NotResolved, "{}", c[2].evidence);
        assert!(
            c[2].evidence
                .contains("95 % over the 6 points tested, no effect resolved"),
            "{}",
            c[2].evidence
        );
        let alone: Vec<RunResult> = r
            .into_iter()
            .filter(|x| x.run.mu_r == 0.5 && x.run.eta_r == 0.5)
            .collect();
        let c = conclusions(&aggregate(&alone), Code::Native);
        assert!(
            c[2].evidence.contains("(3 seeds), a speed effect"),
            "{}",
            c[2].evidence
        );
    }

    #[test]
    fn aggregates_over_seeds() {
        let p = aggregate(&paper_like());
        assert_eq!(p.len(), 12);
        let q = p
            .iter()
            .find(|p| p.mu_r == 0.5 && p.eta_r == 0.5 && p.stage == 0)
            .unwrap();
        assert!((q.mu - 0.454).abs() < 1e-12 && q.seeds == 3);
        assert!(q.mu_ci95 > 0.0 && q.mu_ci95 < 0.01);
        assert!(!p.iter().find(|p| p.mu_r == 1.0).unwrap().dashpot_stable);
    }

    #[test]
    fn speed_slope_is_per_seed_against_log_speed() {
        let stage = |speed: f64, mus: &[(u64, f64)]| Point {
            code: Code::Native,
            mu_r: 0.5,
            eta_r: 0.5,
            stage: 0,
            speed,
            mu: 0.0,
            mu_ci95: 0.0,
            run_ci95: f64::NAN,
            seeds: mus.len(),
            erot: 0.0,
            dashpot_stable: true,
            stability_s: 0.0,
            source: String::new(),
            per_seed_mu: mus.to_vec(),
        };
        // seed 1: +0.05 per decade; seed 2: +0.03; seed 3 misses a stage (left out)
        let a = stage(0.002, &[(1, 0.50), (2, 0.60), (3, 0.1)]);
        let b = stage(0.02, &[(1, 0.55), (2, 0.63)]);
        let s = speed_slope(&[&a, &b]).unwrap();
        assert_eq!(s.n, 2);
        assert!((s.mean - 0.04).abs() < 1e-12, "{s:?}");
        // t(1) = 12.71, standard error 0.01
        assert!((s.ci95 - 12.706 * 0.01).abs() < 1e-3, "{s:?}");
        assert!(speed_slope(&[&a, &a]).is_none(), "one speed has no slope");
    }

    #[test]
    fn one_seed_resolves_nothing() {
        let one: Vec<RunResult> = paper_like()
            .into_iter()
            .filter(|r| r.run.seed == 1)
            .collect();
        let points = aggregate(&one);
        // a table shows one seed's mu with its run's own CI, never "± inf"
        assert_eq!(
            points[0].mu_words(),
            format!("{:.4} (one seed; within the run ± 0.0100)", points[0].mu)
        );
        let c = conclusions(&points, Code::Native);
        assert_eq!(c[0].verdict, ClaimVerdict::NotResolved, "{}", c[0].evidence);
        assert_eq!(c[1].verdict, ClaimVerdict::NotResolved, "{}", c[1].evidence);
        assert_eq!(c[2].verdict, ClaimVerdict::NotResolved, "{}", c[2].evidence);
        // a slope or a CI without a number is not printed as one (it was "+0.0224 ± inf",
        // "CIs inf/inf")
        for k in 0..3 {
            assert!(
                !c[k].evidence.contains("inf") && c[k].evidence.contains("one seed"),
                "{}",
                c[k].evidence
            );
        }
    }

    /// With 2 seeds an unresolved comparison says how many seeds its spread needs: two points
    /// 0.05 apart with per-seed sd 0.0141 each resolve at n = 4 (t95(3) 0.0283 / 2 = 0.045 <
    /// 0.05; n = 3 gives 0.070).
    #[test]
    fn an_unresolved_claim_says_how_many_seeds_would_resolve_it() {
        let point = |mu_r: f64, mus: [f64; 2]| Point {
            code: Code::Native,
            mu_r,
            eta_r: 0.0,
            stage: 0,
            speed: 0.01,
            mu: (mus[0] + mus[1]) / 2.0,
            mu_ci95: mean_ci95(&mus).1,
            run_ci95: f64::NAN,
            seeds: 2,
            erot: 0.0,
            dashpot_stable: true,
            stability_s: 0.0,
            source: String::new(),
            per_seed_mu: vec![(1, mus[0]), (2, mus[1])],
        };
        let (a, b) = (point(0.0, [0.50, 0.52]), point(1.0, [0.55, 0.57]));
        assert_eq!(seeds_to_resolve(&a, &b), Some(4));
        let c = conclusions(&[a.clone(), b], Code::Native);
        assert_eq!(c[0].verdict, ClaimVerdict::NotResolved, "{}", c[0].evidence);
        assert!(
            c[0].evidence
                .contains("about 4 seeds per point would resolve it"),
            "{}",
            c[0].evidence
        );
        // equal means: no number of seeds resolves a zero difference
        assert_eq!(seeds_to_resolve(&a, &a), None);
        // a slope +0.01 ± 0.02 over 3 seeds: sd = 0.02 sqrt(3) / 4.303 = 0.00805, resolved
        // where t95(n-1) 0.00805 / sqrt(n) < 0.01: n = 5 (2.776 x 0.00360 = 0.009996; n = 4
        // gives 0.0128)
        let sl = SpeedSlope {
            mean: 0.01,
            ci95: 0.02,
            n: 3,
        };
        assert_eq!(sl.seeds_to_resolve(1), Some(5));
    }

    /// The paper protocol's points: (0, 0) but no (0, 0.5). Claim 2 takes the eta_r = 0 run as
    /// the mu_r = 0 end of the eta_r = 0.5 curve and says so; a curve with its own mu_r = 0
    /// point keeps it.
    #[test]
    fn mu_r_zero_ends_every_eta_r_curve() {
        let protocol: Vec<RunResult> = paper_like()
            .into_iter()
            .filter(|r| !(r.run.mu_r == 0.0 && r.run.eta_r == 0.5))
            .collect();
        let c = conclusions(&aggregate(&protocol), Code::Native);
        assert_eq!(c[1].verdict, ClaimVerdict::Agrees, "{}", c[1].evidence);
        assert!(
            c[1].evidence.contains("critical mu_r = 0.5")
                && c[1].evidence.contains("mu_r 0: the eta_r 0 run"),
            "{}",
            c[1].evidence
        );
        // without the (0, 0) run the curve has two mu_r values: not assessable
        let two: Vec<RunResult> = protocol.into_iter().filter(|r| r.run.mu_r != 0.0).collect();
        let c = conclusions(&aggregate(&two), Code::Native);
        assert_eq!(
            c[1].verdict,
            ClaimVerdict::NotAssessable,
            "{}",
            c[1].evidence
        );
        // the whole map has (0, 0.5) itself: nothing borrowed
        let c = conclusions(&aggregate(&paper_like()), Code::Native);
        assert!(!c[1].evidence.contains("eta_r 0 run"), "{}", c[1].evidence);
    }

    #[test]
    fn checks_the_three_conclusions() {
        let c = conclusions(&aggregate(&paper_like()), Code::Native);
        assert_eq!(c.len(), 3);
        assert_eq!(c[0].verdict, ClaimVerdict::Agrees, "{}", c[0].evidence);
        assert_eq!(c[1].verdict, ClaimVerdict::Agrees, "{}", c[1].evidence);
        assert!(c[1].evidence.contains("critical mu_r = 0.5"));
        assert_eq!(c[2].verdict, ClaimVerdict::Agrees, "{}", c[2].evidence);
        // a map where mu falls with mu_r at eta_r = 0 and rises everywhere else disagrees
        let mut r = paper_like();
        for x in &mut r {
            if x.run.eta_r == 0.0 {
                for st in &mut x.stages {
                    st.native.as_mut().unwrap().mu = 0.6 - 0.3 * x.run.mu_r;
                }
            } else {
                for st in &mut x.stages {
                    st.native.as_mut().unwrap().mu = 0.3 + 0.3 * x.run.mu_r;
                }
            }
        }
        let c = conclusions(&aggregate(&r), Code::Native);
        assert_eq!(c[0].verdict, ClaimVerdict::Disagrees);
        assert_eq!(c[1].verdict, ClaimVerdict::Disagrees);
        let h = heat_map(
            "mu",
            &aggregate(&r)
                .iter()
                .filter(|p| p.stage == 0)
                .collect::<Vec<_>>(),
            &HeatStyle::default(),
        )
        .unwrap();
        // 6 points (3 mu_r x 2 eta_r): a filled cell and a frame each, on the background,
        // and the colour bar's 20 steps; mu_r 1 (unstable) framed red, its values marked with
        // a dagger
        assert_eq!(h.matches("<rect").count(), 1 + 12 + 20, "{h}");
        assert_eq!(
            h.matches("stroke=\"#FF0000\"").count(),
            2,
            "mu_r 1 is unstable: {h}"
        );
        assert_eq!(h.matches(" †\n").count(), 2, "{h}");
    }
}
