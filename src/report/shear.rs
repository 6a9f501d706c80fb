//! The shear study's figures: mu(strain), plate forces, mobilisation, height and rotational
//! energy, each seed faint with its running mean on top, one legend entry per code.

use crate::error::{Error, Result};
use crate::profile::VelocityProfile;
use crate::report::plot::{decimate, line_plot, running_mean, Curve, CurveData};
use crate::run::shear::ShearSummary;
use crate::series::Series;
use std::path::Path;

/// Every figure of a finished study into `out`, from its outcome: the series' plots
/// ([`plots`]) and the steady velocity profiles ([`profile_plot`]).
pub fn figures(out: &Path, s: &ShearSummary) -> Result<()> {
    plots(out, &s.series.liggghts, &s.series.native)?;
    profile_plot(out, &s.profiles.liggghts, &s.profiles.native)
}

/// [`figures`] of a finished study from its folder: `summary.json` and the series each seed
/// folder holds (`seedN/{liggghts,native}.csv`, of the codes the summary says ran). A sweep
/// draws each run's figures so as it finishes.
pub fn figures_from_dir(out: &Path) -> Result<()> {
    let path = out.join("summary.json");
    let bytes = std::fs::read(&path).map_err(|e| Error::io(&path, e))?;
    let mut s: ShearSummary = serde_json::from_slice(&bytes)
        .map_err(|e| Error::invalid("summary.json", path.display(), e.to_string()))?;
    for (code, ran, into) in [
        ("liggghts", s.liggghts.is_some(), &mut s.series.liggghts),
        ("native", s.native.is_some(), &mut s.series.native),
    ] {
        if ran {
            for seed in &s.seeds {
                let csv = out
                    .join(format!("seed{}", seed.seed))
                    .join(format!("{code}.csv"));
                into.push(Series::read_csv(&csv)?);
            }
        }
    }
    figures(out, &s)
}

/// Points per curve in the shear plots.
const PLOT_POINTS: usize = 1500;

/// Writes the figures of a study's series into `out`.
pub fn plots(out: &Path, lig: &[Series], nat: &[Series]) -> Result<()> {
    let xy = |s: &Series, x: &str, y: &str| -> Vec<(f64, f64)> {
        let (cx, cy) = (s.col(x).expect("column"), s.col(y).expect("column"));
        s.rows.iter().map(|r| (r[cx], r[cy])).collect()
    };
    let mut data = Vec::new();
    for (k, s) in lig.iter().enumerate() {
        data.push((k, 0usize, s));
    }
    for (k, s) in nat.iter().enumerate() {
        data.push((k, 1usize, s));
    }
    for (file, title, x, xd, y, yd) in [
        (
            "mu_strain.svg",
            "friction coefficient mu = Fx / Fy on the top plate",
            "strain[-]",
            "shear strain",
            "mu[-]",
            "mu",
        ),
        (
            "top_force.svg",
            "normal force on the top plate",
            "time[s]",
            "time [s]",
            "top_f_y[N]",
            "Fy [N]",
        ),
        (
            "shear_force.svg",
            "shear force on the top plate",
            "strain[-]",
            "shear strain",
            "top_f_x[N]",
            "Fx [N]",
        ),
        (
            "mobilised.svg",
            "rolling contacts at full mobilisation (native; not in LIGGGHTS' output)",
            "strain[-]",
            "shear strain",
            "mobilised[-]",
            "fraction of touching pairs",
        ),
        (
            "height.svg",
            "sample height",
            "time[s]",
            "time [s]",
            "height[m]",
            "height [m]",
        ),
        (
            "kinetic_energy.svg",
            "rotational kinetic energy",
            "time[s]",
            "time [s]",
            "erot[J]",
            "E_rot [J]",
        ),
    ] {
        let pts: Vec<CurveData> = data
            .iter()
            .map(|(l, c, s)| {
                let mut p = xy(s, x, y);
                if x == "strain[-]" {
                    p.retain(|q| q.0 > 0.0);
                }
                (l.to_string(), *c, p)
            })
            .collect();
        // raw data faint, a running mean (+-10 outputs) per seed on top, one legend entry per code
        // (decimated to keep the SVGs light: the nightly report inlines them)
        let means: Vec<Vec<(f64, f64)>> = pts
            .iter()
            .map(|(_, _, p)| decimate(&running_mean(p, 10), PLOT_POINTS))
            .collect();
        let pts: Vec<CurveData> = pts
            .into_iter()
            .map(|(l, c, p)| (l, c, decimate(&p, PLOT_POINTS)))
            .collect();
        let mut cs: Vec<Curve> = pts
            .iter()
            .map(|(_, c, p)| Curve::new("", p, *c).faint())
            .collect();
        for ((seed, c, _), m) in pts.iter().zip(&means) {
            let label = if seed == "0" {
                format!(
                    "{} (running mean, each seed)",
                    if *c == 0 { "LIGGGHTS" } else { "native" }
                )
            } else {
                String::new()
            };
            cs.push(Curve::new(&label, m, *c));
        }
        line_plot(&out.join(file), title, xd, yd, &cs)?;
    }
    Ok(())
}

/// The steady velocity profile of every stage (mean over seeds): v_x / V against the
/// normalised height across the gouge, with 95 % CIs as bars (the grains' spread, about 0.5 of
/// V, is in the CSV and summary.json); `velocity_profile.svg`.
pub fn profile_plot(out: &Path, lig: &[VelocityProfile], nat: &[VelocityProfile]) -> Result<()> {
    let mut data: Vec<ProfileCurve> = Vec::new();
    for (code, color, profiles) in [("LIGGGHTS", 0usize, lig), ("native", 1, nat)] {
        for p in profiles {
            data.push(profile_curve(code, color, p));
        }
    }
    profiles_figure(
        &out.join("velocity_profile.svg"),
        "steady velocity profile across the gouge (bars: 95 % CI)",
        &data,
    )
}

/// The steady profiles of a run from its grains' displacements between snapshots
/// (`crate::profile::displacement_profile`), one colour per stage: `path`.
pub fn displacement_plot(path: &Path, profiles: &[VelocityProfile]) -> Result<()> {
    let data: Vec<ProfileCurve> = profiles
        .iter()
        .enumerate()
        .map(|(k, p)| profile_curve("native", k, p))
        .collect();
    profiles_figure(
        path,
        "steady profile from grain displacements between snapshots (bars: 95 % CI over blocks)",
        &data,
    )
}

/// (label, colour, (xi, u) per layer, CI per layer)
type ProfileCurve = (String, usize, Vec<(f64, f64)>, Vec<f64>);

fn profile_curve(code: &str, color: usize, p: &VelocityProfile) -> ProfileCurve {
    (
        format!(
            "{code} stage {} ({} m/s): slip {:.0} % / {:.0} %",
            p.stage + 1,
            p.speed,
            100.0 * p.slip_bottom,
            100.0 * p.slip_top
        ),
        color,
        p.layers.iter().map(|l| (l.xi, l.u)).collect(),
        p.layers.iter().map(|l| l.u_ci95).collect(),
    )
}

fn profiles_figure(path: &Path, title: &str, data: &[ProfileCurve]) -> Result<()> {
    if data.is_empty() {
        return Ok(());
    }
    let curves: Vec<Curve> = data
        .iter()
        .map(|(label, c, pts, err)| {
            let mut cv = Curve::new(label, pts, *c);
            cv.err = Some(err);
            cv
        })
        .collect();
    line_plot(
        path,
        title,
        "height between the tooth tips (0 bottom plate, 1 top plate)",
        "v_x / bottom plate speed",
        &curves,
    )
}
