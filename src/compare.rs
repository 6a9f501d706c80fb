//! Alignment, metrics and verdicts. Knows nothing of which code produced a series.

use crate::error::{Error, Result};
use crate::series::Series;
use serde::Serialize;

/// Default relative tolerance of contact-level comparisons (max error / channel peak).
pub const CONTACT_RTOL: f64 = 1e-9;

/// Agreement of one channel of one case run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChannelResult {
    pub case: String,
    pub model: String,
    pub channel: String,
    pub unit: String,
    /// Largest |a - b| over steps and components.
    pub max_abs_err: f64,
    /// `max_abs_err / peak`; 0 when both series are identically zero.
    pub max_rel_err: f64,
    /// Largest magnitude of the channel (vector norm) over both series.
    pub peak: f64,
    /// Step at which `max_abs_err` occurs.
    pub worst_step: u64,
    pub rtol: f64,
    pub pass: bool,
}

/// Compares every channel of `a` (reference, e.g. LIGGGHTS) and `b` (e.g. native) step by
/// step. Both must have the same columns and the same steps.
pub fn compare(
    case: &str,
    model: &str,
    a: &Series,
    b: &Series,
    rtol: f64,
) -> Result<Vec<ChannelResult>> {
    if a.columns != b.columns {
        return Err(Error::Reference(format!(
            "{case}/{model}: the two series have different columns ({} vs {})",
            a.columns.len(),
            b.columns.len()
        )));
    }
    if a.steps != b.steps {
        let first = a.steps.iter().zip(&b.steps).find(|(x, y)| x != y);
        return Err(Error::Reference(format!(
            "{case}/{model}: output steps differ ({} vs {} rows{})",
            a.steps.len(),
            b.steps.len(),
            first
                .map(|(x, y)| format!(", first mismatch {x} vs {y}"))
                .unwrap_or_default()
        )));
    }
    let mut out = Vec::new();
    for ch in a.channels() {
        let mut peak: f64 = 0.0;
        let mut max_abs: f64 = 0.0;
        let mut worst = a.steps.first().copied().unwrap_or(0);
        for (k, (ra, rb)) in a.rows.iter().zip(&b.rows).enumerate() {
            let na: f64 = ch.cols.iter().map(|&c| ra[c] * ra[c]).sum::<f64>().sqrt();
            let nb: f64 = ch.cols.iter().map(|&c| rb[c] * rb[c]).sum::<f64>().sqrt();
            peak = peak.max(na).max(nb);
            for &c in &ch.cols {
                let d = (ra[c] - rb[c]).abs();
                // NaN in either series is the worst possible disagreement.
                let d = if d.is_nan() { f64::INFINITY } else { d };
                if d > max_abs {
                    max_abs = d;
                    worst = a.steps[k];
                }
            }
        }
        let rel = if max_abs == 0.0 {
            0.0
        } else if peak > 0.0 {
            max_abs / peak
        } else {
            f64::INFINITY
        };
        out.push(ChannelResult {
            case: case.to_string(),
            model: model.to_string(),
            channel: ch.name,
            unit: ch.unit,
            max_abs_err: max_abs,
            max_rel_err: rel,
            peak,
            worst_step: worst,
            rtol,
            pass: rel <= rtol,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(v: &[[f64; 3]]) -> Series {
        Series {
            columns: vec!["fn[N]".into(), "ft_x[N]".into(), "ft_y[N]".into()],
            steps: (0..v.len() as u64).collect(),
            rows: v.iter().map(|r| r.to_vec()).collect(),
        }
    }

    #[test]
    fn relative_error_is_against_the_vector_peak() {
        let a = series(&[[1.0, 3.0, 4.0], [2.0, 0.0, 1e-20]]);
        let b = series(&[[1.0, 3.0, 4.0], [2.0, 0.0, 2e-20]]);
        let r = compare("c", "m", &a, &b, 1e-9).unwrap();
        assert_eq!(r[0].max_rel_err, 0.0);
        assert!(r[1].pass);
        assert_eq!(r[1].peak, 5.0);
        assert!((r[1].max_rel_err - 2e-21).abs() < 1e-30);
    }

    #[test]
    fn disagreement_fails_and_names_the_step() {
        let a = series(&[[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]);
        let b = series(&[[1.0, 0.0, 0.0], [2.1, 0.0, 0.0]]);
        let r = compare("c", "m", &a, &b, 1e-9).unwrap();
        assert!(!r[0].pass);
        assert_eq!(r[0].worst_step, 1);
        let mut c = b.clone();
        c.rows[1][0] = f64::NAN;
        assert!(!compare("c", "m", &a, &c, 1e-9).unwrap()[0].pass);
    }

    #[test]
    fn misaligned_steps_are_an_error() {
        let a = series(&[[1.0, 0.0, 0.0]]);
        let b = series(&[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]);
        assert!(compare("c", "m", &a, &b, 1e-9).is_err());
    }
}
