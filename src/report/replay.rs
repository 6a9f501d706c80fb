//! The replay's report: the terminal table of windows and `error.svg`.

use crate::error::Result;
use crate::run::replay::outcome::{ReplayOutcome, StepResult};
use std::path::Path;

/// A curve of the error plot.
type Points = Vec<(f64, f64)>;

/// `error.svg`: largest error against the step within each window, LIGGGHTS vs native
/// (solid) and the chaos envelope (faint), log10.
pub fn plot(out: &Path, o: &ReplayOutcome) -> Result<()> {
    use crate::report::plot::{line_plot, Curve};
    let floor = 1e-20f64;
    let data: Vec<(Points, Points, String)> = o
        .windows
        .iter()
        .map(|w| {
            let curve = |e: fn(&StepResult) -> f64| -> Points {
                w.steps
                    .iter()
                    .enumerate()
                    .map(|(i, s)| ((i + 1) as f64, e(s).max(floor).log10()))
                    .collect()
            };
            let (a, b) = (curve(|s| s.max_rel_err), curve(|s| s.chaos_rel_err));
            (a, b, format!("from step {}", w.start))
        })
        .collect();
    let mut curves = Vec::new();
    for (k, (a, b, label)) in data.iter().enumerate() {
        curves.push(Curve::new(label, a, k));
        curves.push(Curve::new("", b, k).faint());
    }
    line_plot(
        &out.join("error.svg"),
        "replay: LIGGGHTS vs native (solid), native vs 1-ulp twin (faint)",
        "step after the recorded state",
        "log10 max relative error",
        &curves,
    )
}

/// The terminal table.
pub fn table(o: &ReplayOutcome) -> String {
    let mut s = format!(
        "replay {} ({}, mu_r {}, eta_r {}, e {}): step 1 within {:e}, later steps within {}x the 1-ulp chaos envelope\n",
        o.case, o.rolling, o.mu_r, o.eta_r, o.restitution, o.rtol, o.chaos_factor
    );
    s.push_str("  start  phase       pairs per sl rl  wall f/e  rb seam tri  step-1 err  worst step-1 channel (item)                      horizon\n");
    for w in &o.windows {
        let c = &w.coverage;
        let s1 = &w.steps[0];
        s.push_str(&format!(
            "  {:>6} {:<11} {:>5} {:>3} {:>3} {:>3} {:>4}/{:<3} {:>3} {:>4} {:>3}  {:>10.3e}  {:<48} {:>3}/{} {}\n",
            w.start,
            w.phase,
            c.pairs,
            c.periodic_pairs,
            c.sliding_pairs,
            c.rolling_limit_pairs,
            c.wall_face,
            c.wall_edge_corner,
            c.rebuilds,
            c.seam_crossings,
            c.triangle_changes,
            s1.max_rel_err,
            format!("{} ({})", s1.worst.channel, s1.worst.worst),
            w.horizon,
            w.steps.len(),
            if w.pass { "ok" } else { "FAIL" }
        ));
    }
    s.push_str(if o.pass {
        "replay: agree\n"
    } else {
        "replay: DISAGREE\n"
    });
    s
}
