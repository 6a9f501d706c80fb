//! Grouped bar chart with 95 % confidence-interval whiskers, as a standalone SVG (steady mu of
//! both codes per shear case). Written by hand: plotters has no grouped bars with error bars.

use std::fmt::Write;

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

const COLORS: [&str; 2] = ["#1f77b4", "#ff7f0e"];

/// Escapes text for XML/HTML.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The chart as an SVG document; `legend` names the colours.
pub fn bar_chart(title: &str, y_desc: &str, groups: &[BarGroup], legend: &[&str]) -> String {
    let (w, h) = (900.0, 420.0);
    let (left, right, top, bottom) = (70.0, 20.0, 40.0, 90.0);
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
    let y = |v: f64| top + (h - top - bottom) * (1.0 - v.clamp(0.0, ymax) / ymax);
    let mut s = String::new();
    let _ = write!(
        s,
        r#"<svg width="{w}" height="{h}" viewBox="0 0 {w} {h}" xmlns="http://www.w3.org/2000/svg"><rect width="{w}" height="{h}" fill="white"/><text x="{}" y="24" font-family="sans-serif" font-size="18" text-anchor="middle">{}</text>"#,
        w / 2.0,
        escape(title)
    );
    for k in 0..=5 {
        let v = ymax * k as f64 / 5.0;
        let _ = write!(
            s,
            r##"<line x1="{left}" x2="{}" y1="{yy:.1}" y2="{yy:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" font-family="sans-serif" font-size="12" text-anchor="end">{v:.2}</text>"##,
            w - right,
            left - 6.0,
            y(v) + 4.0,
            yy = y(v)
        );
    }
    let _ = write!(
        s,
        r#"<text transform="translate(18 {}) rotate(-90)" font-family="sans-serif" font-size="13" text-anchor="middle">{}</text>"#,
        (top + h - bottom) / 2.0,
        escape(y_desc)
    );
    let gw = (w - left - right) / groups.len().max(1) as f64;
    for (i, g) in groups.iter().enumerate() {
        let x0 = left + gw * i as f64;
        let bw = gw * 0.7 / g.bars.len().max(1) as f64;
        for (j, b) in g.bars.iter().enumerate() {
            let x = x0 + gw * 0.15 + bw * j as f64;
            let color = COLORS[b.color % COLORS.len()];
            if b.value.is_finite() {
                let _ = write!(
                    s,
                    r#"<rect x="{x:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="{color}"><title>{:.4} ± {:.4}</title></rect>"#,
                    y(b.value),
                    bw * 0.9,
                    y(0.0) - y(b.value),
                    b.value,
                    b.ci95
                );
                if b.ci95.is_finite() {
                    let cx = x + bw * 0.45;
                    let (lo, hi) = (y(b.value - b.ci95), y(b.value + b.ci95));
                    let _ = write!(
                        s,
                        r#"<path d="M{cx:.1} {lo:.1}V{hi:.1}M{:.1} {lo:.1}h{:.1}M{:.1} {hi:.1}h{:.1}" stroke="black" stroke-width="1.5"/>"#,
                        cx - 5.0,
                        10.0,
                        cx - 5.0,
                        10.0
                    );
                }
            }
        }
        let _ = write!(
            s,
            r#"<text x="{:.1}" y="{:.1}" font-family="sans-serif" font-size="12" text-anchor="middle">{}</text>"#,
            x0 + gw / 2.0,
            h - bottom + 18.0,
            escape(&g.label)
        );
    }
    let _ = write!(
        s,
        r#"<line x1="{left}" x2="{}" y1="{b:.1}" y2="{b:.1}" stroke="black"/>"#,
        w - right,
        b = y(0.0)
    );
    for (k, name) in legend.iter().enumerate() {
        let x = left + 10.0 + 170.0 * k as f64;
        let _ = write!(
            s,
            r#"<rect x="{x}" y="{}" width="14" height="14" fill="{}"/><text x="{}" y="{}" font-family="sans-serif" font-size="13">{}</text>"#,
            h - 40.0,
            COLORS[k % COLORS.len()],
            x + 20.0,
            h - 28.0,
            escape(name)
        );
    }
    s += "</svg>";
    s
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
        let s = bar_chart("mu", "mu", &g, &["LIGGGHTS", "native"]);
        assert!(s.starts_with("<svg") && s.ends_with("</svg>"));
        assert_eq!(s.matches("<rect x=").count(), 4); // 2 bars + 2 legend boxes
        assert_eq!(s.matches("stroke-width=\"1.5\"").count(), 1); // one finite CI
        assert!(s.contains("a&lt;b"));
    }
}
