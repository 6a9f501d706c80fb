//! The convergence study's figures: steady mu and rotational energy against dt per code.

use crate::error::Result;
use crate::report::plot::{line_plot, Curve};
use crate::run::convergence_outcome::{DtPoint, StudyCode};
use std::path::Path;

/// One code's curve: label, colour, points, CI half-widths.
type ErrSet = (String, usize, Vec<(f64, f64)>, Vec<f64>);

/// Writes `mu_dt.svg` and `erot_dt.svg` into `out`.
pub fn plots(out: &Path, points: &[DtPoint]) -> Result<()> {
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
            |p: &DtPoint| p.steady.erot.max(1e-300).log10(),
            |_: &DtPoint| 0.0,
        ),
    ] {
        let sets: Vec<ErrSet> = [StudyCode::Liggghts, StudyCode::Native, StudyCode::Implicit]
            .iter()
            .enumerate()
            .map(|(k, code)| {
                let sel: Vec<&DtPoint> = points.iter().filter(|p| p.code == *code).collect();
                (
                    if *code == StudyCode::Implicit {
                        "native epsd_implicit".to_string()
                    } else {
                        code.keyword().to_string()
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
