//! The lines `verify shear` (and the nightly's shear points) print of a seed as it finishes
//! and of a study: the run layer's outcome as text.

use crate::run::shear::{SeedResult, ShearSummary};
use crate::run::tell::say;
use std::path::Path;

/// Prints a study's steady figures, paired differences and verdicts.
pub fn print_summary(summary: &ShearSummary, out: &Path) {
    let (ls, ns) = (&summary.liggghts, &summary.native);
    let window = summary.steady_window_steps;
    say!();
    say!(
        "steady window: steps {}..{} (second half of the last stage)",
        window.0,
        window.1
    );
    for (code, st) in [("LIGGGHTS", &ls), ("native", &ns)] {
        if let Some(st) = st {
            say!(
                "  {code:<8} mu = {:.4} +- {:.4} (95 % CI)  per seed [{}]  normal stress [{}] MPa, mean {:.3} +- {:.3}",
                st.mu,
                st.mu_ci95,
                st.per_seed_mu
                    .iter()
                    .map(|m| format!("{m:.4}"))
                    .collect::<Vec<_>>()
                    .join(", "),
                st.per_seed_stress
                    .iter()
                    .map(|s| format!("{:.3}", s / 1e6))
                    .collect::<Vec<_>>()
                    .join(", "),
                st.normal_stress / 1e6,
                st.normal_stress_ci95 / 1e6
            );
        }
    }
    for (code, profiles) in [
        ("LIGGGHTS", &summary.profiles.liggghts),
        ("native", &summary.profiles.native),
    ] {
        for p in profiles {
            // a slip is a fraction of the plate speed: a CI wider than that range is no figure
            let slip = |v: f64, ci: f64| {
                if ci <= 1.0 {
                    format!("{:.1} +- {:.1} %", 100.0 * v, 100.0 * ci)
                } else {
                    format!(
                        "not resolved (95 % CI +-{:.0} % of the plate speed)",
                        100.0 * ci
                    )
                }
            };
            let band = if p.slip_bottom_ci95 <= 1.0 && p.slip_top_ci95 <= 1.0 {
                format!("{:.2} mm", 1e3 * p.band_width)
            } else {
                "not resolved".to_string()
            };
            say!(
                "  {code:<8} stage {} ({} m/s): slip at the bottom plate {}, at the top plate {}, shear band {} of a {:.2} mm gap ({} layers)",
                p.stage + 1,
                p.speed,
                slip(p.slip_bottom, p.slip_bottom_ci95),
                slip(p.slip_top, p.slip_top_ci95),
                band,
                1e3 * p.gap,
                p.layers.len()
            );
        }
    }
    if let Some(p) = &summary.paired_dmu {
        say!(
            "  paired (native - LIGGGHTS, same seeds): {:+.4} +- {:.4} (95 % CI, {} seeds), t = {:.2}, native higher in {} of {}",
            p.mean,
            p.ci95,
            p.n,
            p.t,
            p.b_higher,
            p.n
        );
    }
    if let Some(e) = &summary.mu_equivalence {
        for line in crate::calibration::describe(e, summary.preset) {
            say!("  {line}");
        }
    }
    for r in &summary.results {
        say!(
            "  {:<22} {:>10.4e} (limit {:.2e} {})  {}",
            r.channel,
            if r.channel == "mu_steady" {
                r.max_abs_err
            } else {
                r.max_rel_err
            },
            r.rtol,
            match r.channel.as_str() {
                "mu_steady" => "abs, equivalence margin of the paired mean",
                "slip_bottom" | "slip_top" => "x the CIs summed",
                _ => "rel",
            },
            match (r.pass, r.inconclusive) {
                (false, _) => "FAIL",
                (true, true) => "inconclusive",
                (true, false) => "ok",
            }
        );
    }
    say!(
        "plots: {}  summary: {}",
        out.join("mu_strain.svg").display(),
        out.join("summary.json").display()
    );
}

pub fn print_seed(s: &SeedResult) {
    let mut line = format!("  seed {}:", s.seed);
    if let Some(w) = s.liggghts_wall_s {
        line += &format!(
            " LIGGGHTS {w:.1} s ({:.3e} particle-steps/s)",
            s.liggghts_particle_steps_per_s.unwrap_or(0.0)
        );
    }
    if let Some(w) = s.native_wall_s {
        line += &format!(
            " native {w:.1} s ({:.3e} particle-steps/s)",
            s.native_particle_steps_per_s.unwrap_or(0.0)
        );
    }
    say!("{line}");
    if let Some(h) = &s.horizon {
        match (&h.first_diverge_step, &h.first_diverge_channel) {
            (Some(st), Some(ch)) => say!(
                "    lockstep: agree (rel {:.0e}) through step {} (compression {} steps, shear steps agreed {}); first divergence: {ch} at step {st}",
                h.rtol,
                h.last_agree_step,
                s.compression_steps,
                s.shear_steps_agreed.unwrap_or(0)
            ),
            _ => say!("    lockstep: agree (rel {:.0e}) through the whole run (step {})", h.rtol, h.last_agree_step),
        }
    }
    for (what, h) in [
        (
            "shear lockstep from the compacted state, LIGGGHTS vs native",
            &s.shear_lockstep,
        ),
        (
            "chaos baseline, native vs native 1 ulp apart",
            &s.shear_chaos_baseline,
        ),
    ] {
        if let Some(h) = h {
            match (&h.first_diverge_step, &h.first_diverge_channel) {
                (Some(st), Some(ch)) => say!(
                    "    {what}: agree through shear step {} (first divergence: {ch} at step {st})",
                    h.last_agree_step.saturating_sub(1)
                ),
                _ => say!(
                    "    {what}: agree through all {} shear steps",
                    h.last_agree_step.saturating_sub(1)
                ),
            }
        }
    }
}
