//! The paper's rotation maps (its Figs 8-11): the sample seen along z, every particle a disc
//! of its radius at (x wrapped into the periodic box, y), coloured by the magnitude of its
//! accumulated rotation (the integral of omega dt since the start of the run) with a colour bar,
//! and the plates' profiles. Written by the native solver at the end of each run
//! (`seedN/rotation_map.svg`), an output of the run as its ParaView snapshots are
//! ([`crate::vtk`]); LIGGGHTS' dumps do not integrate rotations.

use crate::error::{draw_err, Result};
use crate::fsutil::write_atomic;
use crate::solver::shear::observe::Snapshot;
use plotters::prelude::*;
use std::path::Path;

/// Colour of a rotation on the scale 0 ..= `hi` [rad]: white, through orange, to dark red.
fn color(v: f64, hi: f64) -> RGBColor {
    let t = if hi > 0.0 {
        (v / hi).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (a, b, c) = if t < 0.5 {
        let u = t / 0.5;
        ((255.0, 255.0, 255.0), (253.0, 141.0, 60.0), u)
    } else {
        let u = (t - 0.5) / 0.5;
        ((253.0, 141.0, 60.0), (128.0, 0.0, 38.0), u)
    };
    let lerp = |x: f64, y: f64| (x + (y - x) * c).round() as u8;
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

/// The top of a map's colour scale: the 99th percentile of the rotations `mag` (a few
/// spinning grains do not wash the map out); 1 where there is none.
pub fn scale_top(mag: &[f64]) -> f64 {
    let mut sorted: Vec<f64> = mag.iter().copied().filter(|v| v.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    sorted
        .get(((sorted.len() as f64 * 0.99) as usize).min(sorted.len().saturating_sub(1)))
        .copied()
        .unwrap_or(1.0)
}

/// The magnitude of each rotation vector [rad].
pub fn magnitudes(rotation: &[[f64; 3]]) -> Vec<f64> {
    rotation
        .iter()
        .map(|r| (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt())
        .collect()
}

/// Writes the rotation map of `s` (box length `box_x` along x) to `path`: its accumulated
/// rotations, the colour scale from 0 to [`scale_top`] of them (labelled).
pub fn rotation_map(path: &Path, title: &str, s: &Snapshot, box_x: f64) -> Result<()> {
    let mag = magnitudes(&s.rotation);
    let hi = scale_top(&mag);
    draw(path, title, s, &mag, hi, box_x)
}

/// Writes the map of the rotations `mag` [rad] the particles of `s` (where they are in `s`)
/// made over some interval, on the colour scale 0 ..= `hi` (e.g. one scale for the three
/// stages of a run, so that their maps compare; the title says over what).
pub fn draw(
    path: &Path,
    title: &str,
    s: &Snapshot,
    mag: &[f64],
    hi: f64,
    box_x: f64,
) -> Result<()> {
    let plate_y: Vec<f64> = s.plates.iter().flatten().flatten().map(|n| n[1]).collect();
    let (y0, y1) = plate_y
        .iter()
        .chain(s.x.iter().map(|p| &p[1]))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
            (a.min(*y), b.max(*y))
        });
    let (w_px, h_px) = (
        620u32,
        (620.0 * (y1 - y0) / box_x).clamp(300.0, 1400.0) as u32 + 60,
    );
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w_px + 110, h_px)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let (area, bar) = root.split_horizontally(w_px);
        let mut chart = ChartBuilder::on(&area)
            .caption(title, ("sans-serif", 14))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(55)
            .build_cartesian_2d(0.0..box_x * 1e3, y0 * 1e3..y1 * 1e3)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x [mm]")
            .y_desc("y [mm]")
            .draw()
            .map_err(draw_err)?;
        // pixels per metre along x, for the discs' radii
        let scale = {
            let (a, _) = chart.backend_coord(&(0.0, y0 * 1e3));
            let (b, _) = chart.backend_coord(&(box_x * 1e3, y0 * 1e3));
            (b - a) as f64 / box_x
        };
        let mut order: Vec<usize> = (0..s.x.len()).collect();
        // the most rotated on top
        order.sort_by(|a, b| mag[*a].total_cmp(&mag[*b]));
        // centre [mm] and radius [px] of particle i's disc
        let disc = |i: usize| {
            let x = s.x[i][0].rem_euclid(box_x);
            (
                (x * 1e3, s.x[i][1] * 1e3),
                ((s.radius[i] * scale).round() as i32).max(1),
            )
        };
        for &i in &order {
            let (c, r) = disc(i);
            chart
                .draw_series([
                    Circle::new(c, r, ShapeStyle::from(&color(mag[i], hi)).filled()),
                    Circle::new(c, r, BLACK.mix(0.3).stroke_width(1)),
                ])
                .map_err(draw_err)?;
        }
        for tri in s.plates.iter().flatten() {
            let pts: Vec<(f64, f64)> = tri
                .iter()
                .chain(std::iter::once(&tri[0]))
                .map(|n| (n[0].rem_euclid(box_x) * 1e3, n[1] * 1e3))
                .collect();
            // skip the segments that wrap around the periodic boundary
            if pts
                .windows(2)
                .all(|w| (w[0].0 - w[1].0).abs() < 0.5 * box_x * 1e3)
            {
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        pts,
                        BLACK.stroke_width(1),
                    )))
                    .map_err(draw_err)?;
            }
        }
        // colour bar
        let (top, bottom) = (40i32, h_px as i32 - 50);
        let n = 24;
        for k in 0..n {
            let ya = bottom - (bottom - top) * (k + 1) / n;
            let yb = bottom - (bottom - top) * k / n;
            let v = hi * (k as f64 + 0.5) / n as f64;
            bar.draw(&Rectangle::new([(10, ya), (30, yb)], color(v, hi).filled()))
                .map_err(draw_err)?;
        }
        for (v, y) in [(0.0, bottom), (hi, top)] {
            bar.draw(&Text::new(
                format!("{v:.2}"),
                (36, y - 6),
                ("sans-serif", 12),
            ))
            .map_err(draw_err)?;
        }
        bar.draw(&Text::new(
            "|rotation| [rad]",
            (4, top - 22),
            ("sans-serif", 12),
        ))
        .map_err(draw_err)?;
    }
    write_atomic(path, svg.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_particle_is_a_disc_coloured_by_its_rotation() {
        let tri = [[0.0, 0.0, 0.0], [1e-3, 0.0, 0.0], [0.0, 0.0, 1e-3]];
        let s = Snapshot {
            step: 10,
            x: vec![[1e-3, 1e-3, 0.0], [5e-3, 2e-3, 0.0]],
            v: vec![[0.0; 3]; 2],
            omega: vec![[0.0; 3]; 2],
            radius: vec![1e-4, 2e-4],
            rotation: vec![[0.0, 0.0, 0.0], [0.0, 0.0, 3.0]],
            plates: [vec![tri], vec![tri]],
        };
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.svg");
        rotation_map(&p, "test", &s, 4e-3).unwrap();
        let t = std::fs::read_to_string(p).unwrap();
        // two filled discs and their outlines; the unrotated one white, the other dark red
        assert_eq!(t.matches("<circle").count(), 4, "{t}");
        assert!(t.contains("#FFFFFF") && t.contains("#800026"), "{t}");
        assert!(t.contains("|rotation| [rad]"));
    }
}
