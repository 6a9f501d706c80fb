//! How often the tests behind the paper-claim verdicts ([`crate::report::paper`]) err, measured
//! on a study's own shape and spread: its speeds, its curves, its seeds per point, and the
//! seed-to-seed scatter of its own runs.
//!
//! The scatter: each run's deviation from its point's mean at every stage (one vector per run,
//! so a run's stages keep their correlation: they share its packing), scaled by
//! sqrt(n / (n - 1)) so that its spread is a single seed's, pooled over the study's points
//! with 2 or more seeds. A synthetic study of the same shape draws each point's n runs from
//! that pool (distinct runs within a point, independently between points), adds them to a
//! truth with no effect (the false-alarm rate: how often the claim's verdict says anything but
//! "not resolved") or with an effect of a given size (the power), and judges it with the
//! report's own tests ([`rises`], [`falls`], [`speed_effect`], combined over curves and speeds
//! by [`combine`] as the report combines them). The effect found 80 % of the time is searched
//! by bisection on common random numbers (the same draws at every size: deterministic, on
//! every machine).
//!
//! Points judged on stand-ins and the LIGGGHTS code are judged by the same tests; the rates
//! here are those of the study's native points as run.

use crate::calibration::SplitMix;
use crate::compare::mean_ci95;
use crate::report::paper::{
    combine, common_seeds, falls, rises, speed_effect, speed_slope, ClaimVerdict, Point, Verdict,
};
use crate::run::Code;
use serde::Serialize;

/// Draws per rate (a rate of 5 % is known to about +-0.35 %).
pub const DRAWS: usize = 4000;
/// The power the effect sizes are quoted at.
pub const POWER: f64 = 0.8;

/// How often one claim's test errs, under one model of the scatter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Rates {
    /// How often the verdict resolves anything when there is no effect.
    pub false_alarm: f64,
    /// The effect the verdict finds [`POWER`] of the time; None when not even an effect of 50
    /// scatter standard deviations is.
    pub found: Option<f64>,
}

/// The error rates of one claim's test in one study.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TestRates {
    /// 1, 2 or 3: the paper's claim, in the report's order.
    pub claim: usize,
    /// The test as this study's shape makes it.
    pub test: String,
    /// What `found` measures.
    pub unit: &'static str,
    /// Seeds per synthetic point (the fewest of the study's points with 2 or more).
    pub seeds: usize,
    /// Runs in the scatter pool.
    pub pool: usize,
    /// Normal scatter with the pool's covariance between stages: the rates the tests' t
    /// quantiles are built for.
    pub normal: Rates,
    /// The pool's runs resampled: the study's own scatter, tails and all, but only as many
    /// distinct runs as the pool holds: a rare false alarm's rate then depends on the pool
    /// (measured 2026-12-06 on two normal pools of 30 runs, 3 seeds, the slope test at each
    /// point: 2.2 % and 0.15 % where the t quantile promises 0.5 %).
    pub resampled: Rates,
    pub draws: usize,
}

/// A study's shape, as the claim tests see it.
#[derive(Clone, Debug, PartialEq)]
struct Shape {
    /// Speed of each stage [m/s].
    speeds: Vec<f64>,
    seeds: usize,
    /// An eta_r = 0 curve with 2 or more mu_r values.
    claim1: bool,
    /// Lengths of the eta_r > 0 curves with 3 or more mu_r values (their mu_r = 0 end, borrowed
    /// from eta_r = 0 where the curve has none, included).
    claim2: Vec<usize>,
    /// Points with every stage.
    claim3: usize,
}

/// One run's deviation from its point's mean at each stage, scaled to a seed's spread.
type Unit = Vec<f64>;

fn distinct<T: PartialEq + Copy>(v: impl Iterator<Item = T>) -> Vec<T> {
    let mut out: Vec<T> = Vec::new();
    for x in v {
        if !out.contains(&x) {
            out.push(x);
        }
    }
    out
}

/// The scatter pool and the shape of one code's points; None without a point of 2 seeds.
fn pool_and_shape(points: &[Point], code: Code) -> Option<(Vec<Unit>, Shape)> {
    let pts: Vec<&Point> = points.iter().filter(|p| p.code == code).collect();
    let mut stages: Vec<(usize, f64)> = distinct(pts.iter().map(|p| (p.stage, p.speed)));
    stages.sort_by_key(|s| s.0);
    let keys = distinct(pts.iter().map(|p| (p.mu_r.to_bits(), p.eta_r.to_bits())));
    let mut pool = Vec::new();
    let mut complete = 0;
    for &(m, e) in &keys {
        let at: Vec<&Point> = pts
            .iter()
            .copied()
            .filter(|p| p.mu_r.to_bits() == m && p.eta_r.to_bits() == e)
            .collect();
        let by_stage: Vec<&Point> = stages
            .iter()
            .filter_map(|s| at.iter().copied().find(|p| p.stage == s.0))
            .collect();
        if by_stage.len() != stages.len() {
            continue;
        }
        complete += 1;
        // the seeds run at every stage
        let seeds = common_seeds(&by_stage);
        let n = seeds.len();
        if n < 2 {
            continue;
        }
        let mu = |p: &Point, s: u64| p.per_seed_mu.iter().find(|q| q.0 == s).map_or(0.0, |q| q.1);
        let means: Vec<f64> = by_stage
            .iter()
            .map(|p| seeds.iter().map(|&s| mu(p, s)).sum::<f64>() / n as f64)
            .collect();
        let scale = (n as f64 / (n - 1) as f64).sqrt();
        for &s in &seeds {
            pool.push(
                by_stage
                    .iter()
                    .zip(&means)
                    .map(|(p, m)| (mu(p, s) - m) * scale)
                    .collect(),
            );
        }
    }
    let seeds = pts.iter().map(|p| p.seeds).filter(|&n| n >= 2).min()?;
    if pool.len() < seeds {
        return None;
    }
    let curve_len = |eta: u64| {
        let mut mr = distinct(keys.iter().filter(|k| k.1 == eta).map(|k| k.0));
        let zero_here = mr.contains(&0f64.to_bits());
        let zero_borrowed = keys.contains(&(0f64.to_bits(), 0f64.to_bits()));
        if !zero_here && zero_borrowed && eta != 0f64.to_bits() {
            mr.push(0f64.to_bits());
        }
        mr.len()
    };
    let etas = distinct(keys.iter().map(|k| k.1));
    let shape = Shape {
        speeds: stages.iter().map(|s| s.1).collect(),
        seeds,
        claim1: curve_len(0f64.to_bits()) >= 2 && etas.contains(&0f64.to_bits()),
        claim2: etas
            .iter()
            .filter(|&&e| f64::from_bits(e) > 0.0)
            .map(|&e| curve_len(e))
            .filter(|&k| k >= 3)
            .collect(),
        claim3: if stages.len() >= 2 { complete } else { 0 },
    };
    Some((pool, shape))
}

/// A synthetic point: `values` per seed (seeds 1, 2, ...), judged as the report judges one.
fn point(mu_r: f64, stage: usize, speed: f64, values: &[f64]) -> Point {
    let (mu, mu_ci95) = mean_ci95(values);
    Point {
        code: Code::Native,
        mu_r,
        eta_r: 0.0,
        stage,
        speed,
        mu,
        mu_ci95,
        run_ci95: f64::NAN,
        seeds: values.len(),
        erot: 0.0,
        dashpot_stable: true,
        stability_s: 0.0,
        source: String::new(),
        per_seed_mu: (1..).zip(values.iter().copied()).collect(),
    }
}

/// Where a synthetic point's runs come from.
#[derive(Clone, Copy)]
enum Scatter<'a> {
    /// Distinct runs of the study's pool.
    Runs(&'a [Unit]),
    /// Normal deviations with the pool's covariance between stages (its lower Cholesky factor,
    /// row-major, stages x stages): the scatter the tests' t quantiles assume.
    Normal(&'a [f64]),
}

/// Draws for synthetic points.
struct Draw<'a> {
    scatter: Scatter<'a>,
    idx: Vec<usize>,
    rng: SplitMix,
}

impl<'a> Draw<'a> {
    fn new(scatter: Scatter<'a>, seed: u64) -> Self {
        let idx = match scatter {
            Scatter::Runs(pool) => (0..pool.len()).collect(),
            Scatter::Normal(_) => Vec::new(),
        };
        Draw {
            scatter,
            idx,
            rng: SplitMix(seed),
        }
    }

    /// A standard normal deviate (Box-Muller on two uniforms in (0, 1]).
    fn normal(&mut self) -> f64 {
        let mut u = || ((self.rng.next() >> 11) as f64 + 1.0) / (1u64 << 53) as f64;
        let (a, b) = (u(), u());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }

    /// `n` runs' deviations: the first n of a partial Fisher-Yates shuffle of the pool, or n
    /// normal vectors L z.
    fn runs(&mut self, n: usize) -> Vec<Unit> {
        match self.scatter {
            Scatter::Runs(pool) => {
                let len = self.idx.len();
                for i in 0..n {
                    let j = i + self.rng.below(len - i);
                    self.idx.swap(i, j);
                }
                self.idx[..n].iter().map(|&i| pool[i].clone()).collect()
            }
            Scatter::Normal(l) => {
                let k = (l.len() as f64).sqrt().round() as usize;
                (0..n)
                    .map(|_| {
                        let z: Vec<f64> = (0..k).map(|_| self.normal()).collect();
                        (0..k)
                            .map(|r| (0..=r).map(|c| l[r * k + c] * z[c]).sum())
                            .collect()
                    })
                    .collect()
            }
        }
    }
}

/// The lower Cholesky factor (row-major) of the pool's covariance between stages (about 0:
/// the pool's deviations are from their points' means); None when it is not positive definite
/// (e.g. fewer runs than stages).
fn cholesky(pool: &[Unit]) -> Option<Vec<f64>> {
    let k = pool.first()?.len();
    let cov = nalgebra::DMatrix::from_fn(k, k, |r, c| {
        pool.iter().map(|u| u[r] * u[c]).sum::<f64>() / pool.len() as f64
    });
    let l = nalgebra::linalg::Cholesky::new(cov)?.l();
    Some((0..k * k).map(|i| l[(i / k, i % k)]).collect())
}

/// One synthetic point per stage: truth `base(stage)` plus each run's deviation there.
fn stages_of(shape: &Shape, mu_r: f64, runs: &[Unit], base: impl Fn(usize) -> f64) -> Vec<Point> {
    shape
        .speeds
        .iter()
        .enumerate()
        .map(|(s, &v)| {
            let vals: Vec<f64> = runs.iter().map(|u| base(s) + u[s]).collect();
            point(mu_r, s, v, &vals)
        })
        .collect()
}

/// The rate at which `trial` (given the draws and an effect size) succeeds over [`DRAWS`].
fn rate(scatter: Scatter, salt: u64, effect: f64, trial: &dyn Fn(&mut Draw, f64) -> bool) -> f64 {
    let mut d = Draw::new(scatter, 0x5eed_c1a1 ^ salt);
    (0..DRAWS).filter(|_| trial(&mut d, effect)).count() as f64 / DRAWS as f64
}

/// The smallest effect found [`POWER`] of the time, by bisection up to `hi`.
fn found(
    scatter: Scatter,
    salt: u64,
    hi: f64,
    trial: &dyn Fn(&mut Draw, f64) -> bool,
) -> Option<f64> {
    if hi.is_nan() || hi <= 0.0 || rate(scatter, salt, hi, trial) < POWER {
        return None;
    }
    let (mut lo, mut hi) = (0.0, hi);
    // 10 halvings: the effect to 50 sd / 1024, 0.05 of a seed's standard deviation
    for _ in 0..10 {
        let mid = 0.5 * (lo + hi);
        if rate(scatter, salt, mid, trial) >= POWER {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}

/// Claim 1: the ends of one eta_r = 0 curve at every speed, the last raised by `rise`.
fn claim1(shape: &Shape, d: &mut Draw, rise: f64) -> ClaimVerdict {
    let n = shape.seeds;
    let a = stages_of(shape, 0.0, &d.runs(n), |_| 0.5);
    let b = stages_of(shape, 1.0, &d.runs(n), |_| 0.5 + rise);
    combine(
        &a.iter()
            .zip(&b)
            .map(|(a, b)| rises(a, b))
            .collect::<Vec<_>>(),
    )
}

/// Claim 2: the study's eta_r > 0 curves at every speed, flat but for the last point, lowered
/// by `fall`.
fn claim2(shape: &Shape, d: &mut Draw, fall: f64) -> ClaimVerdict {
    let n = shape.seeds;
    let mut v: Vec<Verdict> = Vec::new();
    for &k in &shape.claim2 {
        let curve: Vec<Vec<Point>> = (0..k)
            .map(|i| {
                let drop = if i + 1 == k { fall } else { 0.0 };
                stages_of(shape, i as f64 / (k - 1) as f64, &d.runs(n), |_| 0.5 - drop)
            })
            .collect();
        for s in 0..shape.speeds.len() {
            let c: Vec<&Point> = curve.iter().map(|p| &p[s]).collect();
            v.push(falls(&c).0);
        }
    }
    combine(&v)
}

/// Claim 3: the study's points with every stage, the first given a slope of `slope` per decade
/// of speed; whether (first, any) point shows a speed effect.
fn claim3(shape: &Shape, d: &mut Draw, slope: f64) -> (bool, bool) {
    let x: Vec<f64> = shape.speeds.iter().map(|v| v.log10()).collect();
    let xm = x.iter().sum::<f64>() / x.len() as f64;
    let mut first = false;
    let mut any = false;
    for k in 0..shape.claim3 {
        let s = if k == 0 { slope } else { 0.0 };
        let pts = stages_of(shape, 0.0, &d.runs(shape.seeds), |i| 0.5 + s * (x[i] - xm));
        let refs: Vec<&Point> = pts.iter().collect();
        let effect = speed_slope(&refs).is_some_and(|sl| speed_effect(&sl, shape.claim3));
        first |= k == 0 && effect;
        any |= effect;
    }
    (first, any)
}

/// The error rates of the claim tests that `code`'s points make possible: empty without a
/// point of 2 or more seeds (one seed resolves nothing, so no test errs, and there is no
/// scatter to measure them with).
pub fn claim_rates(points: &[Point], code: Code) -> Vec<TestRates> {
    let Some((pool, shape)) = pool_and_shape(points, code) else {
        return Vec::new();
    };
    let Some(chol) = cholesky(&pool) else {
        return Vec::new();
    };
    let stage_sd = {
        let v: Vec<f64> = pool.iter().flatten().copied().collect();
        (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
    };
    let hi = 50.0 * stage_sd;
    let speeds = shape.speeds.len();
    let per = |k: usize| if k == 1 { "" } else { "s" };
    // (claim, test, unit, false-alarm trial, power trial)
    type Trial<'s> = Box<dyn Fn(&mut Draw, f64) -> bool + 's>;
    let mut tests: Vec<(usize, String, &'static str, Trial, Trial)> = Vec::new();
    let shape = &shape;
    if shape.claim1 {
        tests.push((
            1,
            format!(
                "mu at the ends of the eta_r = 0 curve, CIs apart, at {speeds} speed{}",
                per(speeds)
            ),
            "rise in mu",
            Box::new(|d, e| claim1(shape, d, e) != ClaimVerdict::NotResolved),
            Box::new(|d, e| claim1(shape, d, e) == ClaimVerdict::Agrees),
        ));
    }
    if !shape.claim2.is_empty() {
        let lens: Vec<String> = shape.claim2.iter().map(|k| k.to_string()).collect();
        tests.push((
            2,
            format!(
                "the largest mu against mu at the largest mu_r, CIs apart, on {} curve{} of {} \
                 mu_r values at {speeds} speed{}",
                shape.claim2.len(),
                per(shape.claim2.len()),
                lens.join(", "),
                per(speeds)
            ),
            "fall in mu at the largest mu_r",
            Box::new(|d, e| claim2(shape, d, e) != ClaimVerdict::NotResolved),
            Box::new(|d, e| claim2(shape, d, e) == ClaimVerdict::Agrees),
        ));
    }
    if shape.claim3 > 0 {
        tests.push((
            3,
            format!(
                "the slope of mu against log10(speed), its CI over seeds (95 % over the {} \
                 point{} together) apart from 0",
                shape.claim3,
                per(shape.claim3)
            ),
            "slope per decade of speed at one point",
            Box::new(|d, e| claim3(shape, d, e).1),
            Box::new(|d, e| claim3(shape, d, e).0),
        ));
    }
    tests
        .into_iter()
        .map(|(claim, test, unit, alarm, power)| {
            let rates = |scatter: Scatter| Rates {
                false_alarm: rate(scatter, claim as u64, 0.0, &*alarm),
                found: found(scatter, claim as u64, hi, &*power),
            };
            TestRates {
                claim,
                test,
                unit,
                seeds: shape.seeds,
                pool: pool.len(),
                normal: rates(Scatter::Normal(&chol)),
                resampled: rates(Scatter::Runs(&pool)),
                draws: DRAWS,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points of a study: `mu_r` x `eta_r` at `speeds`, `n` seeds each, scatter of sd about
    /// `sd` (a fixed pseudo-random normal), no effect of anything.
    fn study(mu_rs: &[f64], eta_rs: &[f64], speeds: &[f64], n: usize, sd: f64) -> Vec<Point> {
        let mut d = Draw::new(Scatter::Normal(&[1.0]), 7);
        let mut normal = || d.normal();
        let mut out = Vec::new();
        for &e in eta_rs {
            for &m in mu_rs {
                for (s, &v) in speeds.iter().enumerate() {
                    let vals: Vec<f64> = (0..n).map(|_| 0.5 + sd * normal()).collect();
                    let mut p = point(m, s, v, &vals);
                    p.eta_r = e;
                    out.push(p);
                }
            }
        }
        out
    }

    /// The rates of the tests as the report runs them, on a normal scatter of sd 0.02, 3 seeds,
    /// 10 points at 3 speeds: the slope's test at 95 % over the 10 points together (each at
    /// 99.5 %) errs somewhere about 1 - 0.995^10 = 4.9 % of the time (each point alone at 95 %
    /// would err somewhere 40 % of the time); two points' CIs apart err far less than 5 % at
    /// each of 3 speeds; a rise of a few seed standard deviations is found 80 % of the time,
    /// and 6 seeds find a smaller one than 3; the resampled pool gives rates of the same order.
    #[test]
    fn rates_of_the_claim_tests_on_a_known_scatter() {
        let speeds = [0.002, 0.006, 0.02];
        let mu_rs = [0.0, 0.25, 0.5, 0.75, 1.0];
        let pts = study(&mu_rs, &[0.0, 0.5], &speeds, 3, 0.02);
        let r = claim_rates(&pts, Code::Native);
        assert_eq!(r.iter().map(|r| r.claim).collect::<Vec<_>>(), [1, 2, 3]);
        assert!(r
            .iter()
            .all(|r| r.seeds == 3 && r.pool == 30 && r.draws == DRAWS));
        let (c1, c2, c3) = (&r[0], &r[1], &r[2]);
        assert!(c1.normal.false_alarm < 0.03, "claim 1: {c1:?}");
        assert!(c2.normal.false_alarm < 0.05, "claim 2: {c2:?}");
        assert!(c2.test.contains("1 curve of 5 mu_r"), "{}", c2.test);
        assert!(c3.test.contains("10 points"), "{}", c3.test);
        assert!(
            (0.035..0.065).contains(&c3.normal.false_alarm),
            "claim 3: {c3:?}"
        );
        let f1 = c1.normal.found.expect("a rise is found");
        assert!(f1 > 0.02 && f1 < 0.2, "claim 1 found at {f1}");
        for t in &r {
            let (n, s) = (
                t.normal.found.expect("found"),
                t.resampled.found.expect("found"),
            );
            assert!(s > 0.5 * n && s < 2.0 * n, "{t:?}");
            assert!(t.resampled.false_alarm < 0.25, "{t:?}");
        }
        // 6 seeds: the same scatter finds a smaller rise
        let pts6 = study(&mu_rs, &[0.0, 0.5], &speeds, 6, 0.02);
        let f6 = claim_rates(&pts6, Code::Native)[0]
            .normal
            .found
            .expect("found");
        assert!(f6 < 0.8 * f1, "6 seeds find {f6}, 3 seeds {f1}");
        // one seed: no scatter, no rates
        assert!(
            claim_rates(&study(&[0.0, 1.0], &[0.0], &speeds, 1, 0.02), Code::Native).is_empty()
        );
    }
}
