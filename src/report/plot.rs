//! SVG line plots (plotters), e.g. mu(strain) of both codes overlaid.

use crate::error::{Error, Result};
use plotters::prelude::*;
use std::path::Path;

/// Owned data of a curve: label, colour index, points.
pub type CurveData = (String, usize, Vec<(f64, f64)>);

/// Borrows owned curve data as [`Curve`]s.
pub fn curves(data: &[CurveData]) -> Vec<Curve<'_>> {
    data.iter().map(|(l, c, p)| Curve::new(l, p, *c)).collect()
}

/// One curve: label (empty: not in the legend), points, colour index (0 LIGGGHTS blue,
/// 1 native orange, 2.. others), whether it is drawn faint (raw data under a mean) and whether
/// dashed (a curve drawn over an identical one stays visible).
pub struct Curve<'a> {
    pub label: String,
    pub points: &'a [(f64, f64)],
    pub color: usize,
    pub faint: bool,
    pub dashed: bool,
    /// Half-widths of vertical error bars, one per point (non-finite: none drawn).
    pub err: Option<&'a [f64]>,
}

impl<'a> Curve<'a> {
    /// A solid curve.
    pub fn new(label: &str, points: &'a [(f64, f64)], color: usize) -> Self {
        Curve {
            label: label.to_string(),
            points,
            color,
            faint: false,
            dashed: false,
            err: None,
        }
    }
    /// With vertical error bars of half-width `err[i]` at point i.
    pub fn with_err(mut self, err: &'a [f64]) -> Self {
        self.err = Some(err);
        self
    }
    /// Drawn faint (thin, transparent).
    pub fn faint(mut self) -> Self {
        self.faint = true;
        self
    }
    /// Drawn dashed.
    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }
}

/// At most `n` points of `p`, evenly strided (first and last kept): keeps SVGs small.
pub fn decimate(p: &[(f64, f64)], n: usize) -> Vec<(f64, f64)> {
    if p.len() <= n || n < 2 {
        return p.to_vec();
    }
    (0..n).map(|k| p[k * (p.len() - 1) / (n - 1)]).collect()
}

/// Centred running mean over `2 half + 1` points (fewer at the ends).
pub fn running_mean(p: &[(f64, f64)], half: usize) -> Vec<(f64, f64)> {
    (0..p.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(half), (i + half + 1).min(p.len()));
            let m = p[a..b].iter().map(|q| q.1).sum::<f64>() / (b - a) as f64;
            (p[i].0, m)
        })
        .collect()
}

const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

/// Axis labels: scientific notation for very small or large magnitudes.
fn tick(v: &f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-2..1e4).contains(&a) {
        format!("{v:.2e}")
    } else {
        format!("{}", (v * 1e4).round() / 1e4)
    }
}

/// Draws `curves` into an SVG file at `path`.
pub fn line_plot(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    curves: &[Curve],
) -> Result<()> {
    plot_with(path, title, x_desc, y_desc, curves, &tick, None)
}

/// Relative errors drawn on a log axis against a tolerance: each curve's values clipped below
/// at `floor` (an error of 0, bit-identical results, sits on the floor), the tolerance as a
/// dashed line, the axis from the floor to above the larger of the tolerance and the largest
/// error.
pub fn log_error_plot(
    path: &Path,
    title: &str,
    x_desc: &str,
    curves: &[(String, Vec<(f64, f64)>)],
    tolerance: f64,
    floor: f64,
) -> Result<()> {
    let lg = |v: f64| v.max(floor).log10();
    let logged: Vec<(String, Vec<(f64, f64)>)> = curves
        .iter()
        .map(|(l, pts)| (l.clone(), pts.iter().map(|p| (p.0, lg(p.1))).collect()))
        .collect();
    let (x0, x1) = curves
        .iter()
        .flat_map(|c| c.1.iter().map(|p| p.0))
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    let (x0, x1) = if x0.is_finite() { (x0, x1) } else { (0.0, 1.0) };
    let tol = vec![(x0, lg(tolerance)), (x1, lg(tolerance))];
    let mut drawn: Vec<Curve> = logged
        .iter()
        .enumerate()
        .map(|(k, (l, pts))| Curve::new(l, pts, k + 2))
        .collect();
    drawn.push(Curve::new("tolerance", &tol, 3).dashed());
    let fmt = |v: &f64| format!("1e{}", v.round() as i64);
    // finite values only: an infinite error (a NaN or inf in a series) would make the axis
    // infinite, and plotters' tick search never ends on one
    let top = logged
        .iter()
        .flat_map(|c| c.1.iter().map(|p| p.1))
        .chain([lg(tolerance)])
        .filter(|v| v.is_finite())
        .fold(lg(floor), f64::max)
        .ceil()
        + 1.0;
    plot_with(
        path,
        title,
        x_desc,
        &format!("relative error (log; 0 drawn at {floor:.0e})"),
        &drawn,
        &fmt,
        Some((lg(floor), top)),
    )
}

/// [`line_plot`] with a y tick formatter and an optional fixed y range.
fn plot_with(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    curves: &[Curve],
    y_fmt: &dyn Fn(&f64) -> String,
    y_range: Option<(f64, f64)>,
) -> Result<()> {
    let err = |e: String| Error::io(path, std::io::Error::other(e));
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    let pts = curves
        .iter()
        .flat_map(|c| {
            c.points.iter().enumerate().flat_map(|(i, p)| {
                let e = c.err.and_then(|e| e.get(i)).copied().unwrap_or(0.0);
                let e = if e.is_finite() { e } else { 0.0 };
                [(p.0, p.1 - e), (p.0, p.1 + e)]
            })
        })
        .filter(|p| p.0.is_finite() && p.1.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in pts {
        x0 = x0.min(p.0);
        x1 = x1.max(p.0);
        y0 = y0.min(p.1);
        y1 = y1.max(p.1);
    }
    if !x0.is_finite() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    let pad = if y1 > y0 {
        0.05 * (y1 - y0)
    } else {
        0.5 * y0.abs().max(1.0)
    };
    let (y0, y1, pad) = match y_range {
        Some((a, b)) if a.is_finite() && b.is_finite() && a < b => (a, b, 0.0),
        _ => (y0, y1, pad),
    };
    let tmp = path.with_extension("svg.tmp");
    {
        let root = SVGBackend::new(&tmp, (900, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .x_label_formatter(&tick)
            .y_label_formatter(y_fmt)
            .draw()
            .map_err(|e| err(e.to_string()))?;
        for c in curves {
            let color = PALETTE[c.color % PALETTE.len()];
            let style = if c.faint {
                color.mix(0.25).stroke_width(1)
            } else {
                color.stroke_width(2)
            };
            let pts = c
                .points
                .iter()
                .copied()
                .filter(|p| p.0.is_finite() && p.1.is_finite());
            if !c.faint && c.points.len() <= 50 {
                // few points (e.g. one per time step): mark them
                let marks = c
                    .points
                    .iter()
                    .copied()
                    .filter(|p| p.0.is_finite() && p.1.is_finite());
                chart
                    .draw_series(marks.map(|p| Circle::new(p, 4, color.filled())))
                    .map_err(|e| err(e.to_string()))?;
            }
            if let Some(half) = c.err {
                let bars = c
                    .points
                    .iter()
                    .zip(half)
                    .filter(|(p, e)| p.0.is_finite() && p.1.is_finite() && e.is_finite());
                chart
                    .draw_series(bars.map(|(p, e)| {
                        PathElement::new(
                            vec![(p.0, p.1 - e), (p.0, p.1 + e)],
                            color.stroke_width(1),
                        )
                    }))
                    .map_err(|e| err(e.to_string()))?;
            }
            let series = if c.dashed {
                chart.draw_series(DashedLineSeries::new(pts, 8, 6, style))
            } else {
                chart.draw_series(LineSeries::new(pts, style))
            }
            .map_err(|e| err(e.to_string()))?;
            if !c.label.is_empty() {
                series.label(c.label.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(e.to_string()))?;
        root.present().map_err(|e| err(e.to_string()))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_errors_and_tolerances_end_in_a_plot_not_a_hang() {
        let dir = tempfile::tempdir().unwrap();
        for (v, tol) in [
            (f64::INFINITY, 1e-9),
            (f64::NAN, 1e-9),
            (f64::NEG_INFINITY, 1e-9),
            (1e-3, f64::INFINITY),
            (1e-3, f64::NAN),
        ] {
            let curves = vec![("c".to_string(), vec![(0.0, 1e-12), (1.0, v), (2.0, 0.0)])];
            let p = dir.path().join("e.svg");
            log_error_plot(&p, "t", "step", &curves, tol, 1e-17).unwrap();
            assert!(std::fs::read_to_string(&p).unwrap().contains("<svg"));
        }
    }

    #[test]
    fn writes_an_svg_with_both_labels() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("mu.svg");
        let a: Vec<(f64, f64)> = (0..50)
            .map(|i| (i as f64 * 0.01, 0.4 + 0.01 * (i as f64).sin()))
            .collect();
        let b: Vec<(f64, f64)> = a.iter().map(|(x, y)| (*x, y + 0.005)).collect();
        line_plot(
            &p,
            "mu",
            "strain",
            "mu",
            &[
                Curve::new("LIGGGHTS", &a, 0),
                Curve::new("", &b, 1).dashed().faint(),
            ],
        )
        .unwrap();
        let t = std::fs::read_to_string(&p).unwrap();
        assert!(t.starts_with("<svg") && t.contains("LIGGGHTS") && !t.contains("native"));
        let m = running_mean(&[(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)], 1);
        assert_eq!(m, vec![(0.0, 2.0), (1.0, 3.0), (2.0, 4.0)]);
        let d = decimate(&a, 5);
        assert_eq!((d.len(), d[0], d[4]), (5, a[0], a[49]));
    }
}
