//! Grouped bar chart with 95 % confidence-interval whiskers, as a standalone SVG (steady mu of
//! both codes per shear case), drawn with plotters' primitives (rectangles, paths, text).

use crate::error::{draw_err, Result};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One bar: value, CI half-width (drawn when finite), colour index (0 LIGGGHTS, 1 native).
pub struct Bar {
    pub value: f64,
    pub ci95: f64,
    pub color: usize,
}

/// Bars side by side under one label.
pub struct BarGroup {
    pub label: String,
    pub bars: Vec<Bar>,
}

/// Escapes text for XML/HTML.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// LIGGGHTS blue, native orange (as the line plots).
const COLORS: [RGBColor; 2] = [RGBColor(31, 119, 180), RGBColor(255, 127, 14)];

/// The chart as an SVG document (plotters); `legend` names the colours.
pub fn bar_chart(
    title: &str,
    y_desc: &str,
    groups: &[BarGroup],
    legend: &[&str],
) -> Result<String> {
    let top_value = groups
        .iter()
        .flat_map(|g| &g.bars)
        .filter(|b| b.value.is_finite())
        .map(|b| b.value + if b.ci95.is_finite() { b.ci95 } else { 0.0 })
        .fold(0.0, f64::max);
    let ymax = if top_value > 0.0 {
        top_value * 1.15
    } else {
        1.0
    };
    let n = groups.len().max(1) as f64;
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, (900, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .margin_top(30)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..n, 0.0..ymax)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .y_desc(y_desc)
            .y_label_formatter(&|v| format!("{v:.2}"))
            .draw()
            .map_err(draw_err)?;
        let whisker = BLACK.stroke_width(2);
        for (i, g) in groups.iter().enumerate() {
            let bw = 0.7 / g.bars.len().max(1) as f64;
            for (j, b) in g.bars.iter().enumerate() {
                if !b.value.is_finite() {
                    continue;
                }
                let x = i as f64 + 0.15 + bw * j as f64;
                let color = COLORS[b.color % COLORS.len()];
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x, 0.0), (x + 0.9 * bw, b.value.clamp(0.0, ymax))],
                        color.filled(),
                    )))
                    .map_err(draw_err)?;
                if b.ci95.is_finite() {
                    let cx = x + 0.45 * bw;
                    let (lo, hi) = ((b.value - b.ci95).max(0.0), (b.value + b.ci95).min(ymax));
                    let w = 0.1 * bw;
                    chart
                        .draw_series([
                            PathElement::new(vec![(cx, lo), (cx, hi)], whisker),
                            PathElement::new(vec![(cx - w, lo), (cx + w, lo)], whisker),
                            PathElement::new(vec![(cx - w, hi), (cx + w, hi)], whisker),
                        ])
                        .map_err(draw_err)?;
                }
            }
            let (px, py) = chart.backend_coord(&(i as f64 + 0.5, 0.0));
            root.draw(&Text::new(
                g.label.clone(),
                (px, py + 8),
                ("sans-serif", 12)
                    .into_font()
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Center, VPos::Top)),
            ))
            .map_err(draw_err)?;
        }
        for (k, name) in legend.iter().enumerate() {
            let x = 80 + 170 * k as i32;
            root.draw(&Rectangle::new(
                [(x, 34), (x + 14, 48)],
                COLORS[k % COLORS.len()].filled(),
            ))
            .map_err(draw_err)?;
            root.draw(&Text::new(
                name.to_string(),
                (x + 20, 34),
                ("sans-serif", 13),
            ))
            .map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_bars_and_whiskers() {
        let g = vec![BarGroup {
            label: "a<b".into(),
            bars: vec![
                Bar {
                    value: 0.4,
                    ci95: 0.05,
                    color: 0,
                },
                Bar {
                    value: 0.38,
                    ci95: f64::INFINITY,
                    color: 1,
                },
            ],
        }];
        let s = bar_chart("mu", "mu", &g, &["LIGGGHTS", "native"]).unwrap();
        assert!(
            s.starts_with("<svg") && s.trim_end().ends_with("</svg>"),
            "{s}"
        );
        // 2 bars and 2 legend boxes in the codes' colours
        assert_eq!(s.matches("fill=\"#1F77B4\"").count(), 2, "{s}");
        assert_eq!(s.matches("fill=\"#FF7F0E\"").count(), 2, "{s}");
        // one finite CI: its three whisker strokes
        assert_eq!(s.matches("stroke-width=\"2\"").count(), 3, "{s}");
        assert!(
            s.contains("\na&lt;b\n") && s.contains("\nLIGGGHTS\n"),
            "{s}"
        );
    }
}
