//! A self-contained HTML page: inline SVG plots, inline CSS, a few lines of inline script that
//! let a browser test check the page (no network, no external files). Built with maud: every
//! value interpolated into the markup is escaped, so no case or file name can inject markup.

use crate::error::{Error, Result};
use maud::{html, Markup, PreEscaped, DOCTYPE};
use std::path::Path;

/// An HTML page under construction; counts its plots.
pub struct Page {
    title: String,
    body: Vec<Markup>,
    plots: usize,
}

const STYLE: &str = "body{font-family:sans-serif;margin:24px;color:#222;max-width:1900px}\
h1{margin-bottom:4px}h2{border-bottom:2px solid #ccc;padding-bottom:4px;margin-top:36px}\
table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:left;font-size:14px}\
th{background:#f0f0f0}td.num{text-align:right;font-family:monospace}\
.pass{background:#c8f0c8}.fail{background:#f7c0c0}.warn{background:#fbe8b0}\
.banner{font-size:22px;font-weight:bold;padding:10px 16px;margin:12px 0;display:inline-block}\
.plots{display:flex;flex-wrap:wrap;gap:8px}.plots figure{margin:0;width:calc(50% - 8px);min-width:420px}\
svg.plot{width:100%;height:auto;border:1px solid #eee}figcaption{font-size:13px;color:#555}\
.meta{color:#555;font-size:14px}";

/// Records script errors and, once loaded, how many plots rendered with content and a size,
/// as attributes of <body> (read back by the browser test with --dump-dom).
const SCRIPT: &str = "window.__errors=[];\
window.addEventListener('error',function(e){window.__errors.push(String(e.message));});\
document.addEventListener('DOMContentLoaded',function(){\
var p=document.querySelectorAll('svg.plot'),ok=0;\
for(var i=0;i<p.length;i++){var r=p[i].getBoundingClientRect();\
if(r.width>0&&r.height>0&&p[i].querySelectorAll('path,polyline,rect,circle,line').length>2)ok++;}\
document.body.setAttribute('data-plots-found',p.length);\
document.body.setAttribute('data-plots-ok',ok);\
document.body.setAttribute('data-script-errors',window.__errors.length);});";

impl Page {
    pub fn new(title: &str) -> Self {
        Page {
            title: title.to_string(),
            body: Vec::new(),
            plots: 0,
        }
    }

    /// Appends markup (maud escapes every interpolated value unless marked [`PreEscaped`]).
    pub fn push(&mut self, m: Markup) {
        self.body.push(m);
    }

    /// Appends a section heading with an anchor.
    pub fn heading(&mut self, id: &str, text: &str) {
        self.push(html! { h2 id=(id) { (text) } });
    }

    /// Appends a paragraph of text.
    pub fn para(&mut self, text: &str) {
        self.push(html! { p { (text) } });
    }

    /// A figure with an inline SVG (the document's XML prolog dropped, class `plot` added).
    /// The SVG comes from plotters, never from case text.
    pub fn svg(&mut self, svg: &str, caption: &str) -> Markup {
        let start = svg.find("<svg").unwrap_or(0);
        let svg = svg[start..].replacen("<svg", "<svg class=\"plot\"", 1);
        self.plots += 1;
        html! { figure { (PreEscaped(svg)) figcaption { (caption) } } }
    }

    /// Like [`Page::svg`], reading the SVG from a file.
    pub fn svg_file(&mut self, path: &Path, caption: &str) -> Result<Markup> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Ok(self.svg(&text, caption))
    }

    /// Figures side by side.
    pub fn figures(&mut self, figs: &[Markup]) {
        self.push(html! { div.plots { @for f in figs { (f) } } });
    }

    pub fn plots(&self) -> usize {
        self.plots
    }

    /// The finished document.
    pub fn finish(self) -> String {
        html! {
            (DOCTYPE)
            html lang="en" {
                head {
                    meta charset="utf-8";
                    title { (self.title) }
                    style { (PreEscaped(STYLE)) }
                    script { (PreEscaped(SCRIPT)) }
                }
                body data-plots-expected=(self.plots) {
                    @for b in &self.body { (b) }
                }
            }
        }
        .into_string()
    }
}

/// A table cell: its content and a CSS class (`""` for none).
pub type Cell = (Markup, &'static str);

/// A text cell (escaped).
pub fn text(s: impl AsRef<str>) -> Markup {
    html! { (s.as_ref()) }
}

/// Rows of text cells (escaped).
pub fn text_rows(rows: Vec<Vec<(String, &'static str)>>) -> Vec<Vec<Cell>> {
    rows.into_iter()
        .map(|r| r.into_iter().map(|(t, c)| (text(t), c)).collect())
        .collect()
}

/// A table: header cells, then rows of cells.
pub fn table(header: &[&str], rows: &[Vec<Cell>]) -> Markup {
    html! {
        table {
            tr { @for h in header { th { (h) } } }
            @for r in rows {
                tr {
                    @for (cell, class) in r {
                        @if class.is_empty() { td { (cell) } } @else { td class=(class) { (cell) } }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn page_counts_plots_and_escapes() {
        let mut p = Page::new("a & b");
        let f = p.svg("<?xml version=\"1.0\"?>\n<svg width=\"1\"></svg>", "x<y");
        p.figures(&[f]);
        p.push(table(&["h"], &[vec![(text("1 < 2"), "pass")]]));
        let s = p.finish();
        assert!(s.contains("<title>a &amp; b</title>"));
        assert!(s.contains("<svg class=\"plot\" width=\"1\">") && !s.contains("<?xml"));
        assert!(s.contains("data-plots-expected=\"1\"") && s.contains("x&lt;y"));
        assert!(s.contains("<td class=\"pass\">1 &lt; 2</td>"), "{s}");
    }
}
