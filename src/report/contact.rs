//! Plots of one contact run: the main channel of both codes overlaid, and the relative error of
//! every channel against time (what the nightly report and `verify contact --out` show).

use crate::compare::CONTACT_RTOL;
use crate::error::Result;
use crate::report::plot::{decimate, line_plot, log_error_plot, Curve};
use crate::series::Series;
use std::path::Path;

/// Points per curve in contact plots.
const PLOT_POINTS: usize = 800;

/// The channel a contact run is about: the largest component of the rolling moment when a
/// rolling model is on, else the largest tangential-force component if the tangential force
/// matters (above 1e-3 of the normal force), else the normal force.
pub fn main_column(s: &Series, rolling_on: bool) -> usize {
    let peak = |c: usize| s.rows.iter().map(|r| r[c].abs()).fold(0.0, f64::max);
    let largest = |prefix: &str| {
        s.columns
            .iter()
            .enumerate()
            .filter(|(_, h)| h.starts_with(prefix))
            .map(|(c, _)| (c, peak(c)))
            .fold(None, |best: Option<(usize, f64)>, x| match best {
                Some(b) if b.1 >= x.1 => Some(b),
                _ => Some(x),
            })
    };
    let fn_col = s.col("fn[N]").unwrap_or(1);
    if rolling_on {
        if let Some((c, _)) = largest("m_roll_") {
            return c;
        }
    }
    match largest("ft_") {
        Some((c, p)) if p > 1e-3 * peak(fn_col) => c,
        _ => fn_col,
    }
}

/// Per output step: the largest relative error over all columns, each relative to the larger
/// peak magnitude of that column in either code (columns that are zero throughout count 0).
pub fn relative_error(a: &Series, b: &Series) -> Vec<(f64, f64)> {
    let t = a.col("time[s]").unwrap_or(0);
    let ncol = a.columns.len().min(b.columns.len());
    let peaks: Vec<f64> = (0..ncol)
        .map(|c| {
            a.rows
                .iter()
                .chain(&b.rows)
                .map(|r| r[c].abs())
                .fold(0.0, f64::max)
        })
        .collect();
    a.rows
        .iter()
        .zip(&b.rows)
        .map(|(ra, rb)| {
            let e = (0..ncol)
                .filter(|&c| c != t && peaks[c] > 0.0)
                .map(|c| {
                    let d = (ra[c] - rb[c]).abs() / peaks[c];
                    if d.is_nan() {
                        f64::INFINITY
                    } else {
                        d
                    }
                })
                .fold(0.0, f64::max);
            (ra[t], e)
        })
        .collect()
}

/// The figures of one finished contact run, drawn from the series its run wrote
/// (`dir/liggghts.csv`, `dir/native.csv`): the report reads the run's outcome from disk, the
/// run layer draws nothing.
pub fn plots_of_run(dir: &Path, title: &str, rolling_on: bool) -> Result<()> {
    let lig = Series::read_csv(&dir.join("liggghts.csv"))?;
    let nat = Series::read_csv(&dir.join("native.csv"))?;
    contact_plots(dir, title, &lig, &nat, rolling_on)
}

/// Writes `history.svg` (main channel, LIGGGHTS solid, native dashed on top) and `error.svg`
/// (largest relative error over all channels against time) into `dir`.
pub fn contact_plots(
    dir: &Path,
    title: &str,
    lig: &Series,
    nat: &Series,
    rolling_on: bool,
) -> Result<()> {
    let c = main_column(lig, rolling_on);
    let t = lig.col("time[s]").unwrap_or(0);
    let xy = |s: &Series| {
        decimate(
            &s.rows.iter().map(|r| (r[t], r[c])).collect::<Vec<_>>(),
            PLOT_POINTS,
        )
    };
    let (l, n) = (xy(lig), xy(nat));
    let header = &lig.columns[c];
    line_plot(
        &dir.join("history.svg"),
        &format!("{title}: {header}"),
        "time [s]",
        header,
        &[
            Curve::new("LIGGGHTS", &l, 0),
            Curve::new("native (dashed)", &n, 1).dashed(),
        ],
    )?;
    let e = decimate(&relative_error(lig, nat), PLOT_POINTS);
    log_error_plot(
        &dir.join("error.svg"),
        &format!("{title}: largest |LIGGGHTS - native| / peak over all channels"),
        "time [s]",
        &[("relative error".to_string(), e)],
        CONTACT_RTOL,
        1e-17,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(rows: Vec<Vec<f64>>) -> Series {
        Series {
            columns: [
                "time[s]",
                "fn[N]",
                "ft_x[N]",
                "m_roll_x[N m]",
                "m_roll_y[N m]",
            ]
            .map(String::from)
            .to_vec(),
            steps: (0..rows.len() as u64).collect(),
            rows,
        }
    }

    #[test]
    fn picks_the_channel_and_measures_the_error() {
        let a = series(vec![
            vec![0.0, 1.0, 0.0, 0.0, 0.0],
            vec![1.0, 2.0, 0.5, 1e-6, -3e-6],
        ]);
        let mut b = a.clone();
        b.rows[1][1] = 2.2; // 10 % of the fn peak (2.2)
        assert_eq!(main_column(&a, true), 4);
        assert_eq!(main_column(&a, false), 2);
        let e = relative_error(&a, &b);
        assert_eq!(e[0], (0.0, 0.0));
        assert!((e[1].1 - 0.2 / 2.2).abs() < 1e-15);
        b.rows[0][3] = f64::NAN;
        assert_eq!(relative_error(&a, &b)[0].1, f64::INFINITY);
    }
}
