//! The plates' grip: the steady velocity profile v_x(y) across the gouge, the slip at each
//! plate and the width of the shear band, from particle samples that both codes write at the
//! same steps ([`schedule`]): LIGGGHTS as dumps (`id y vx`, 17 digits), the native solver in
//! memory. One function ([`profile`]) bins both.
//!
//! Definitions (one stage, its steady window):
//! - the gouge spans the tooth tips: from `y_lo = tooth_height` above the bottom plate's base
//!   (at y = 0) to `y_hi = top_y - tooth_height`; grains between the teeth (below `y_lo` or
//!   above `y_hi`) belong to the plates and are not binned;
//! - layers: `n = max(4, round(gap0 / d_mean))` equal slices of the normalised height
//!   `xi = (y - y_lo) / (y_hi - y_lo)`, `gap0` the case's estimated tip-to-tip gap (the same
//!   for every seed and both codes, [`layer_count`]) and `d_mean` the number-weighted mean
//!   diameter; each layer holds the mean and the standard
//!   deviation (over grains and samples) of `u = v_x / V`, V the bottom plate's speed (the top
//!   plate does not move along x);
//! - slip: the plate's speed minus the gouge's at the tooth tips, as a fraction of V (0: the
//!   gouge moves with the plate), the gouge's speed there extrapolated linearly from the two
//!   layers next to the plate (`u_0 + (u_0 - u_1) / 2`; a layer's mean alone would read
//!   `1 / (2 n)` of slip from a uniform shear that grips): `1 - u(0)` at the bottom plate,
//!   `u(1)` at the top one;
//! - shear-band width: `(gap / n) / max_k (u_k - u_{k+1})`, the thickness over which the whole
//!   plate speed would be lost at the steepest layer-to-layer gradient: the gap for uniform
//!   shear without slip, less when the shear localises.

use crate::compare::mean_ci95;
use crate::error::{Error, Result};
use crate::spec::shear::ShearCase;
use crate::spec::windows::{schedule, SampleWindow};
use serde::{Deserialize, Serialize};
use std::fmt::Write;

/// The codes' slips at a plate agree when their difference is within the two CIs summed:
/// |a - b| / (ci_a + ci_b) at most this (NaN, a comparison of nothing, fails).
pub const SLIP_CI_LIMIT: f64 = 1.0;

/// Heights and shear velocities of every grain at one step, and where the top plate's base was.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProfileSample {
    pub step: u64,
    pub top_y: f64,
    pub y: Vec<f64>,
    pub vx: Vec<f64>,
}

/// One layer of the profile.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Layer {
    /// Centre of the layer in normalised height (0: bottom tooth tips, 1: top tooth tips).
    pub xi: f64,
    /// Mean and standard deviation of v_x / V over the layer's grains and samples (NaN when
    /// the layer held no grain).
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub u: f64,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub u_spread: f64,
    /// 95 % CI half-width of `u`: over seeds for a mean over seeds, else over the samples
    /// (each sample's layer mean one value, as the block means of the steady mu).
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub u_ci95: f64,
    /// Mean number of grains in the layer per sample.
    pub grains: f64,
}

/// The steady velocity profile of one stage of one run (or the mean over seeds).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VelocityProfile {
    pub stage: usize,
    /// Bottom plate speed V [m/s].
    pub speed: f64,
    pub samples: usize,
    /// Mean tip-to-tip gap [m].
    pub gap: f64,
    pub layers: Vec<Layer>,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub slip_bottom: f64,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub slip_top: f64,
    /// 95 % CI half-widths of the slips, from the CIs of the two layers they come from.
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub slip_bottom_ci95: f64,
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub slip_top_ci95: f64,
    /// [m]; NaN when no layer moves faster than the one above it.
    #[serde(deserialize_with = "crate::fsutil::f64_or_nan")]
    pub band_width: f64,
}

impl VelocityProfile {
    /// The profile of these layers, with its slips and band width (module definitions).
    fn from_layers(stage: usize, speed: f64, samples: usize, gap: f64, layers: Vec<Layer>) -> Self {
        VelocityProfile {
            stage,
            speed,
            samples,
            gap,
            layers,
            slip_bottom: f64::NAN,
            slip_top: f64::NAN,
            slip_bottom_ci95: f64::NAN,
            slip_top_ci95: f64::NAN,
            band_width: f64::NAN,
        }
        .finish()
    }

    fn finish(mut self) -> Self {
        let n = self.layers.len();
        let u = |k: usize| self.layers[k].u;
        self.slip_bottom = 1.0 - (u(0) + 0.5 * (u(0) - u(1)));
        self.slip_top = u(n - 1) + 0.5 * (u(n - 1) - u(n - 2));
        let ci = |k: usize| self.layers[k].u_ci95;
        let extrapolated_ci = |a: f64, b: f64| (2.25 * a * a + 0.25 * b * b).sqrt();
        self.slip_bottom_ci95 = extrapolated_ci(ci(0), ci(1));
        self.slip_top_ci95 = extrapolated_ci(ci(n - 1), ci(n - 2));
        let steepest = (0..n - 1).map(|k| u(k) - u(k + 1)).fold(f64::NAN, f64::max);
        self.band_width = if steepest > 0.0 {
            self.gap / n as f64 / steepest
        } else {
            f64::NAN
        };
        self
    }

    /// The layer-by-layer mean of profiles of the same stage (seeds), with their slips and
    /// width recomputed from it; None without profiles or when their layers differ.
    pub fn mean(profiles: &[&VelocityProfile]) -> Option<VelocityProfile> {
        let first = profiles.first()?;
        let n = first.layers.len();
        if profiles.iter().any(|p| p.layers.len() != n) {
            return None;
        }
        let m = profiles.len() as f64;
        let avg =
            |f: &dyn Fn(&VelocityProfile) -> f64| profiles.iter().map(|p| f(p)).sum::<f64>() / m;
        let layers = (0..n)
            .map(|k| {
                let (u, ci) =
                    mean_ci95(&profiles.iter().map(|p| p.layers[k].u).collect::<Vec<_>>());
                Layer {
                    xi: first.layers[k].xi,
                    u,
                    u_spread: avg(&|p| p.layers[k].u_spread),
                    u_ci95: if profiles.len() == 1 {
                        first.layers[k].u_ci95
                    } else {
                        ci
                    },
                    grains: avg(&|p| p.layers[k].grains),
                }
            })
            .collect();
        Some(VelocityProfile::from_layers(
            first.stage,
            first.speed,
            profiles.iter().map(|p| p.samples).sum(),
            avg(&|p| p.gap),
            layers,
        ))
    }
}

/// Layers of every profile of a case: `max(4, round(gap0 / d_mean))` with `gap0` the case's
/// estimated tip-to-tip gap, so that all seeds and both codes bin alike and their profiles
/// can be averaged and compared layer by layer.
pub fn layer_count(case: &ShearCase) -> usize {
    let gap0 = case.estimated_height() - case.plates.tooth_height();
    ((gap0 / (2.0 * case.mean_radius())).round() as usize).max(4)
}

/// The steady profile of one stage from its samples (see the module's definitions).
pub fn profile(
    case: &ShearCase,
    window: &SampleWindow,
    samples: &[&ProfileSample],
) -> Result<VelocityProfile> {
    let stage = &case.stages[window.stage];
    if samples.is_empty() {
        return Err(Error::Missing {
            what: format!("velocity-profile samples of stage {}", window.stage + 1),
            dir: std::path::PathBuf::from(&case.name),
        });
    }
    let t = case.plates.tooth_height();
    let gaps: Vec<f64> = samples.iter().map(|s| s.top_y - 2.0 * t).collect();
    let gap = gaps.iter().sum::<f64>() / gaps.len() as f64;
    let n = layer_count(case);
    let (mut sum, mut sum2, mut count) = (vec![0.0; n], vec![0.0; n], vec![0usize; n]);
    // each sample's layer means, for the CI
    let mut per_sample: Vec<Vec<f64>> = vec![Vec::new(); n];
    for (s, g) in samples.iter().zip(&gaps) {
        let (mut ss, mut sc) = (vec![0.0; n], vec![0usize; n]);
        for (y, vx) in s.y.iter().zip(&s.vx) {
            let xi = (y - t) / g;
            if (0.0..1.0).contains(&xi) {
                let k = ((xi * n as f64) as usize).min(n - 1);
                let u = vx / stage.speed;
                sum[k] += u;
                sum2[k] += u * u;
                count[k] += 1;
                ss[k] += u;
                sc[k] += 1;
            }
        }
        for k in (0..n).filter(|&k| sc[k] > 0) {
            per_sample[k].push(ss[k] / sc[k] as f64);
        }
    }
    let layers = (0..n)
        .map(|k| {
            let c = count[k] as f64;
            let u = sum[k] / c;
            Layer {
                xi: (k as f64 + 0.5) / n as f64,
                u,
                u_spread: (sum2[k] / c - u * u).max(0.0).sqrt(),
                u_ci95: mean_ci95(&per_sample[k]).1,
                grains: c / samples.len() as f64,
            }
        })
        .collect();
    Ok(VelocityProfile::from_layers(
        window.stage,
        stage.speed,
        samples.len(),
        gap,
        layers,
    ))
}

/// The profile of every stage from one run's samples.
pub fn profiles(case: &ShearCase, samples: &[ProfileSample]) -> Result<Vec<VelocityProfile>> {
    schedule(case)
        .iter()
        .map(|w| {
            let mine: Vec<&ProfileSample> = samples
                .iter()
                .filter(|s| s.step >= w.first && s.step <= w.last())
                .collect();
            if mine.len() as u64 != w.samples {
                return Err(Error::Missing {
                    what: format!(
                        "velocity-profile samples of stage {}: {} of {}",
                        w.stage + 1,
                        mine.len(),
                        w.samples
                    ),
                    dir: std::path::PathBuf::from(&case.name),
                });
            }
            profile(case, w, &mine)
        })
        .collect()
}

/// Grain positions at one snapshot (id order) and where the top plate's base was.
#[derive(Clone, Debug, PartialEq)]
pub struct PositionSample {
    pub step: u64,
    pub top_y: f64,
    pub x: Vec<[f64; 3]>,
}

/// Blocks of a displacement profile's window: its CI is over their layer means, as the
/// steady mu's is over the window's block means.
pub const DISPLACEMENT_BLOCKS: usize = 10;

/// The steady profile of one stage from grain displacements between snapshots instead of
/// instantaneous velocities (the module's layers, slips and band width): `u = dx / (V dt)`
/// of each grain over a block of consecutive snapshots, x unwrapped across the periodic side
/// by the nearest image from one snapshot to the next, each grain in the layer of its mean
/// height over the block. At the paper's speeds a grain's velocity fluctuates 20-40 times the
/// plate speed, so 20 velocity samples leave each layer's u uncertain by about 1 (the slip
/// by 2); a displacement integrates the fluctuations to a vibration of the grain's place,
/// which is small against the plate's travel over a block. `samples` are the stage's steady
/// window's snapshots in step order; `box_x` the periodic length. The CI is over
/// [`DISPLACEMENT_BLOCKS`] blocks (fewer when there are fewer intervals; at least 2).
pub fn displacement_profile(
    case: &ShearCase,
    stage: usize,
    samples: &[&PositionSample],
) -> Result<VelocityProfile> {
    let st = case.stages.get(stage).ok_or_else(|| {
        Error::invalid("stage", stage + 1, format!("1 ..= {}", case.stages.len()))
    })?;
    let missing = |what: String| Error::Missing {
        what,
        dir: std::path::PathBuf::from(&case.name),
    };
    let intervals = samples.len().saturating_sub(1);
    let blocks = intervals.min(DISPLACEMENT_BLOCKS);
    if blocks < 2 {
        return Err(missing(format!(
            "snapshots of stage {} (a displacement profile needs 3 or more in its steady \
             window, {} there)",
            stage + 1,
            samples.len()
        )));
    }
    let grains = samples[0].x.len();
    if samples.iter().any(|s| s.x.len() != grains) {
        return Err(missing(format!(
            "snapshots of stage {} with one grain count",
            stage + 1
        )));
    }
    // the nearest image tells a grain's way across the periodic side only while no grain
    // moves half a box between two snapshots; the plate, the fastest, must move under a
    // quarter
    for w in samples.windows(2) {
        let travel = st.speed * (w[1].step - w[0].step) as f64 * case.dt;
        if w[1].step <= w[0].step || travel > 0.25 * case.box_x {
            return Err(Error::invalid(
                "snapshots",
                format!("steps {} and {}", w[0].step, w[1].step),
                "snapshots in step order with the plate moving under a quarter of the box \
                 between two (to unwrap x)",
            ));
        }
    }
    let t = case.plates.tooth_height();
    let n = layer_count(case);
    let mut per_block: Vec<Vec<f64>> = vec![Vec::new(); n];
    let (mut sum, mut sum2, mut count) = (vec![0.0; n], vec![0.0; n], vec![0usize; n]);
    let mut gaps = Vec::new();
    for b in 0..blocks {
        let (a, z) = (b * intervals / blocks, (b + 1) * intervals / blocks);
        let span = &samples[a..=z];
        let gap = span.iter().map(|s| s.top_y - 2.0 * t).sum::<f64>() / span.len() as f64;
        gaps.push(gap);
        let time = (span[span.len() - 1].step - span[0].step) as f64 * case.dt;
        let (mut bs, mut bc) = (vec![0.0; n], vec![0usize; n]);
        for g in 0..grains {
            let mut dx = 0.0;
            let mut y = span[0].x[g][1];
            for w in span.windows(2) {
                let d = w[1].x[g][0] - w[0].x[g][0];
                dx += d - case.box_x * (d / case.box_x).round();
                y += w[1].x[g][1];
            }
            let xi = (y / span.len() as f64 - t) / gap;
            if (0.0..1.0).contains(&xi) {
                let k = ((xi * n as f64) as usize).min(n - 1);
                let u = dx / (st.speed * time);
                bs[k] += u;
                bc[k] += 1;
                sum[k] += u;
                sum2[k] += u * u;
                count[k] += 1;
            }
        }
        for k in (0..n).filter(|&k| bc[k] > 0) {
            per_block[k].push(bs[k] / bc[k] as f64);
        }
    }
    let layers = (0..n)
        .map(|k| {
            let (u, ci) = mean_ci95(&per_block[k]);
            let c = count[k] as f64;
            Layer {
                xi: (k as f64 + 0.5) / n as f64,
                u,
                u_spread: (sum2[k] / c - (sum[k] / c).powi(2)).max(0.0).sqrt(),
                u_ci95: ci,
                grains: c / blocks as f64,
            }
        })
        .collect();
    Ok(VelocityProfile::from_layers(
        stage,
        st.speed,
        samples.len(),
        gaps.iter().sum::<f64>() / gaps.len() as f64,
        layers,
    ))
}

/// The profiles as CSV: one row per stage and layer.
pub fn csv(profiles: &[VelocityProfile]) -> String {
    let mut s = String::from("stage,speed[m/s],xi[-],u[-],u_spread[-],grains[-],u_ci95[-],slip_bottom[-],slip_bottom_ci95[-],slip_top[-],slip_top_ci95[-],band_width[m]\n");
    for p in profiles {
        for l in &p.layers {
            writeln!(
                s,
                "{},{},{:.6},{:.17e},{:.17e},{:.3},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e}",
                p.stage + 1,
                p.speed,
                l.xi,
                l.u,
                l.u_spread,
                l.grains,
                l.u_ci95,
                p.slip_bottom,
                p.slip_bottom_ci95,
                p.slip_top,
                p.slip_top_ci95,
                p.band_width
            )
            .unwrap();
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::shear::Preset;
    use crate::spec::RollingModel;

    fn case() -> ShearCase {
        ShearCase::preset(Preset::Ci, RollingModel::Epsd, 0.0, 0.0, 1).unwrap()
    }

    fn sample(c: &ShearCase, step: u64, u: impl Fn(f64) -> f64) -> ProfileSample {
        // 400 grains spread evenly over the gap, plus one in a tooth valley
        let t = c.plates.tooth_height();
        let top_y = 2e-3 + 2.0 * t;
        let mut y: Vec<f64> = (0..400)
            .map(|k| t + (k as f64 + 0.5) / 400.0 * 2e-3)
            .collect();
        y.push(0.5 * t);
        let speed = c.stages[0].speed;
        let vx = y
            .iter()
            .map(|y| speed * if *y < t { 1.0 } else { u((y - t) / 2e-3) })
            .collect();
        ProfileSample { step, top_y, y, vx }
    }

    #[test]
    fn uniform_shear_grips_and_spans_the_gap() {
        let c = case();
        let w = schedule(&c)[0];
        let s: Vec<ProfileSample> = w.steps().map(|st| sample(&c, st, |xi| 1.0 - xi)).collect();
        let p = &profiles(&c, &s).unwrap()[0];
        let n = p.layers.len();
        // the case's layers (from its estimated gap), not the samples' 2 mm
        assert_eq!(n, layer_count(&c));
        assert!(
            p.slip_bottom.abs() < 0.01 && p.slip_top.abs() < 0.01,
            "{p:?}"
        );
        assert!((p.band_width / 2e-3 - 1.0).abs() < 0.01, "{p:?}");
        let grains: f64 = p.layers.iter().map(|l| l.grains).sum();
        assert_eq!(
            grains, 400.0,
            "the valley grain is the plate's, not the gouge's"
        );
        assert!(p.layers.iter().all(|l| l.u_spread < 0.5 / n as f64));
    }

    #[test]
    fn a_slipping_plate_and_a_narrow_band_are_measured() {
        let c = case();
        let w = schedule(&c)[0];
        // the gouge lags the bottom plate by 30 % and shears only in its middle fifth
        let u = |xi: f64| 0.7 * ((0.6 - xi) / 0.2).clamp(0.0, 1.0);
        let s: Vec<ProfileSample> = w.steps().map(|st| sample(&c, st, u)).collect();
        let p = &profiles(&c, &s).unwrap()[0];
        assert!((p.slip_bottom - 0.3).abs() < 0.01, "{p:?}");
        assert!(p.slip_top.abs() < 0.01, "{p:?}");
        assert!(p.band_width < 0.5 * p.gap, "{p:?}");
        let uni: Vec<ProfileSample> = w.steps().map(|st| sample(&c, st, |xi| 1.0 - xi)).collect();
        let q = &profiles(&c, &uni).unwrap()[0];
        assert!((p.layers[0].u - q.layers[0].u).abs() > 0.2);
        // identical samples: a spread but no sample-to-sample scatter, so zero CIs
        assert!(q
            .layers
            .iter()
            .all(|l| l.u_ci95 < 1e-12 && l.u_spread > 0.0));
        let m = VelocityProfile::mean(&[p, q]).unwrap();
        assert!((m.slip_bottom - 0.15).abs() < 0.01, "{m:?}");
        // over two seeds the CI comes from the seeds: wide where they differ
        assert!(m.layers[0].u_ci95 > 1.0, "{m:?}");
    }

    /// Grains sheared uniformly (u = 1 - xi) with a vibration 5 times the plate's travel
    /// per snapshot interval at every snapshot, starting at the periodic side so that they
    /// cross it back and forth: the displacement profile finds the line within its CIs, no
    /// slip; snapshots too far apart to unwrap, or too few, are errors.
    #[test]
    fn displacements_measure_the_profile_through_vibration_and_the_periodic_side() {
        let c = case();
        let (t, gap) = (c.plates.tooth_height(), 2e-3);
        let v = c.stages[0].speed;
        // the plate moves 1 um between snapshots
        let every = ((1e-6 / (v * c.dt)).round() as u64).max(1);
        let travel = v * every as f64 * c.dt;
        let grains = 400;
        let mut next = {
            let mut seed = 7u64;
            move || {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            }
        };
        let samples: Vec<PositionSample> = (0..41u64)
            .map(|k| PositionSample {
                step: 1_000_000 + k * every,
                top_y: gap + 2.0 * t,
                x: (0..grains)
                    .map(|g| {
                        let xi = (g as f64 + 0.5) / grains as f64;
                        let x = c.box_x - 2.0 * travel + (1.0 - xi) * travel * k as f64;
                        [
                            (x + 5.0 * travel * next()).rem_euclid(c.box_x),
                            t + xi * gap + 1e-6 * next(),
                            0.0,
                        ]
                    })
                    .collect(),
            })
            .collect();
        let refs: Vec<&PositionSample> = samples.iter().collect();
        let p = displacement_profile(&c, 0, &refs).unwrap();
        for l in &p.layers {
            assert!(
                (l.u - (1.0 - l.xi)).abs() <= l.u_ci95 && l.u_ci95 < 0.5,
                "{l:?}"
            );
        }
        assert!(p.slip_bottom.abs() < 0.2 && p.slip_top.abs() < 0.2, "{p:?}");
        // fewer than 3 snapshots, or snapshots too far apart to unwrap: errors
        assert!(displacement_profile(&c, 0, &refs[..2]).is_err());
        let far: Vec<PositionSample> = samples
            .iter()
            .map(|s| PositionSample {
                step: s.step * 1000,
                ..s.clone()
            })
            .collect();
        let e = displacement_profile(&c, 0, &far.iter().collect::<Vec<_>>())
            .unwrap_err()
            .to_string();
        assert!(e.contains("unwrap"), "{e}");
    }

    #[test]
    fn missing_samples_are_an_error() {
        let c = case();
        let w = schedule(&c)[0];
        let s: Vec<ProfileSample> = w
            .steps()
            .skip(1)
            .map(|st| sample(&c, st, |x| 1.0 - x))
            .collect();
        let e = profiles(&c, &s).unwrap_err().to_string();
        assert!(e.contains("19 of 20"), "{e}");
    }

    /// A stored profile read back and written again keeps every bit: a reused run (`verify
    /// shear` stores a finished seed's results again when it resumes) must not rewrite its
    /// figures. This file, written by a 25,000-particle run, came back one unit in the last
    /// place off in four numbers when serde_json parsed without its `float_roundtrip` feature.
    #[test]
    fn stored_profiles_read_back_to_the_same_bits() {
        let text = include_str!("../reference/scaled/25k/seed1/native_profile.json");
        let p: Vec<VelocityProfile> = serde_json::from_str(text).unwrap();
        assert!(!p.is_empty() && !p[0].layers.is_empty());
        assert_eq!(serde_json::to_string_pretty(&p).unwrap(), text);
        let x = 0.993_279_993_199_018_3_f64;
        assert_eq!(
            serde_json::from_str::<f64>("0.9932799931990183")
                .unwrap()
                .to_bits(),
            x.to_bits()
        );
    }
}
