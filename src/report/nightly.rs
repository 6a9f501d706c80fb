//! The nightly report page: verdicts, tables, per-case figures and trends over the history of
//! nights, one self-contained HTML file.

use crate::compare::CONTACT_RTOL;
use crate::error::Result;
use crate::fsutil::write_atomic;
use crate::report::bars::{bar_chart, Bar, BarGroup};
use crate::report::html::{table, text, text_rows, Cell, Page};
use crate::report::plot::{line_plot, log_error_plot, Curve, CurveData};
use crate::run::history::Record;
use crate::run::nightly_outcome::{CodeStats, NightlySummary, ShearRow};
use crate::run::tell::say;
use maud::{html, Markup};
use std::path::Path;

fn status(pass: bool, error: &Option<String>) -> (&'static str, &'static str) {
    match (error, pass) {
        (Some(_), _) => ("ERROR", "fail"),
        (None, true) => ("agree", "pass"),
        (None, false) => ("DISAGREE", "fail"),
    }
}

fn status_cell(pass: bool, error: &Option<String>) -> Cell {
    let (st, class) = status(pass, error);
    (text(st), class)
}

/// A shear row's status: as [`status`], and "inconclusive" (amber) when its seeds could not
/// decide.
fn shear_status(r: &ShearRow) -> (&'static str, &'static str) {
    match status(r.pass, &r.error) {
        ("agree", _) if r.inconclusive => ("inconclusive", "warn"),
        other => other,
    }
}

fn num(v: Option<f64>, prec: usize) -> String {
    match v {
        Some(x) if x.is_finite() => format!("{x:.prec$}"),
        Some(x) => format!("{x}"),
        None => "–".into(),
    }
}

fn sci(v: f64) -> String {
    if v == 0.0 {
        "0 (bit for bit)".into()
    } else if v.is_finite() {
        format!("{v:.3e}")
    } else {
        format!("{v}")
    }
}

/// The measured steady-mu figure of a shear row: the paired difference with the 90 % CI its
/// verdict was judged on (and the seeds that would decide an inconclusive row); nights stored
/// before the equivalence test show the difference of the means and whether the CIs overlap.
fn mu_measured(r: &ShearRow) -> String {
    match &r.mu_equivalence {
        Some(eq) => format!("paired Δμ = {}", eq.figures()),
        None => format!(
            "|Δμ| = {}{}",
            num(r.dmu, 4),
            match r.ci_overlap {
                Some(true) => ", CIs overlap",
                Some(false) => ", CIs do NOT overlap",
                None => "",
            }
        ),
    }
}

/// The figures a night draws as each run finishes ([`crate::run::nightly::Figures`]): a shear
/// point's ([`crate::report::shear::figures`]), a replay's plots and its table on stdout.
pub struct NightFigures;

impl crate::run::nightly::Figures for NightFigures {
    fn seed(&self, s: &crate::run::shear::SeedResult) {
        crate::report::shear_text::print_seed(s);
    }

    fn shear(&self, out: &Path, s: &crate::run::shear::ShearSummary) -> Result<()> {
        crate::report::shear::figures(out, s)?;
        crate::report::shear_text::print_summary(s, out);
        Ok(())
    }

    fn replay(&self, out: &Path, o: &crate::run::replay::ReplayOutcome, ran: bool) -> Result<()> {
        if ran {
            crate::report::replay::plot(out, o)?;
        }
        say!("{}", crate::report::replay::table(o).trim_end_matches('\n'));
        Ok(())
    }
}

/// Writes `report.html` of a night into its folder `out` ([`report`]) and says where; the
/// night's outcome ([`Night::finish`]).
pub fn write_page(night: crate::run::nightly::Night, out: &Path) -> Result<NightlySummary> {
    let html = report(&night.summary, &night.history, out)?;
    let page = out.join("report.html");
    write_atomic(&page, html.as_bytes())?;
    let s = &night.summary;
    match &s.rejudged {
        Some(by) => say!(
            "nightly of {} judged again by {by}: {}; report {}",
            s.date_utc,
            format!("{:?}", s.verdict()).to_lowercase(),
            page.display()
        ),
        None => say!(
            "\nnightly {}: {} contact runs, {} shear cases, {:.0} s; report {}",
            if s.pass { "PASS" } else { "FAIL" },
            s.contact.len(),
            s.shear.len(),
            s.wall_time_s,
            page.display()
        ),
    }
    night.finish(&page)
}

/// The report page: the headline (verdict, what ran, the counts), then its sections.
pub fn report(s: &NightlySummary, history: &[Record], out: &Path) -> Result<String> {
    let plots = out.join("plots");
    let mut p = Page::new(&format!("verify nightly {}", s.date_utc));
    headline(&mut p, s);
    overview(&mut p, s);
    steady_friction(&mut p, s, &plots)?;
    p.heading("trends", "Trends over nights");
    let figs = trend_plots(&mut p, history, s, &plots)?;
    p.figures(&figs);

    p.heading("shear", "Shear cases");
    for r in &s.shear {
        shear_section(&mut p, r, out)?;
    }

    performance(&mut p, s);
    contact_cases(&mut p, s, out)?;
    Ok(p.finish())
}

/// The night's verdict banner, what ran where, errors, and the agreement counts.
fn headline(p: &mut Page, s: &NightlySummary) {
    p.push(html! { h1 { "Native DEM vs LIGGGHTS: nightly agreement report" } });
    let undecided = s.shear.iter().filter(|r| r.inconclusive).count();
    let (verdict, class) = if s.pass && undecided > 0 {
        (
            "NO DISAGREEMENT; SOME CASES INCONCLUSIVE (more seeds would decide)",
            "warn",
        )
    } else if s.pass {
        ("ALL CASES AGREE", "pass")
    } else if s.errors.is_empty() {
        ("DISAGREEMENT", "fail")
    } else {
        ("ERRORS", "fail")
    };
    p.push(html! { div class={"banner " (class)} { (verdict) } });
    let budget = match s.budget_s {
        Some(b) => format!(
            " (budget {:.1} h: {})",
            b / 3600.0,
            if s.wall_time_s <= b {
                "within"
            } else {
                "OVER BUDGET"
            }
        ),
        None => String::new(),
    };
    let kind = if s.quick { "quick" } else { "full" };
    // the shear rows say what ran (a night's seeds have changed over time)
    let what = s.shear.first().map_or("no shear cases".to_string(), |r| {
        format!("{} shear preset, {} seed(s)", r.preset, r.seeds)
    });
    p.push(html! {
        p.meta {
            "Night " (s.date_utc) " UTC, " (kind) " night (" (what) ") · project commit "
            b { (s.commit) } " · " (s.liggghts_version) " · machine " (s.machine.describe())
            " · wall time " b { (format!("{:.1} min", s.wall_time_s / 60.0)) } (budget)
        }
    });
    if let Some(by) = &s.rejudged {
        p.push(html! {
            p.meta {
                "The shear rows were judged again from the night's stored per-seed figures by "
                b { (by) } " (`verify nightly --rerender`): the verdicts and figures below are \
                 this version's reading of that evidence, not the night's own words."
            }
        });
    }
    for e in &s.errors {
        p.push(html! { p.fail { (e) } });
    }
    let c_ok = s.contact.iter().filter(|c| c.pass).count();
    let c_bit = s.contact.iter().filter(|c| c.max_rel_err == 0.0).count();
    let s_ok = s.shear.iter().filter(|r| r.pass && !r.inconclusive).count();
    let dmu_max = s.shear.iter().filter_map(|r| r.dmu).fold(0.0, f64::max);
    p.push(html! {
        p style="font-size:18px" {
            "Contact laws: " b { (c_ok) "/" (s.contact.len()) } " runs agree (" (c_bit)
            " bit for bit). Shear box: " b { (s_ok) "/" (s.shear.len()) }
            " cases agree, " (undecided) " inconclusive; largest |Δμ| between the codes " (format!("{dmu_max:.3}")) "."
        }
    });
}

/// One row per shear and contact case: status, what was measured, the tolerance.
fn overview(p: &mut Page, s: &NightlySummary) {
    p.heading("overview", "Overview");
    let mut rows = Vec::new();
    for r in &s.shear {
        let (st, class) = shear_status(r);
        rows.push(vec![
            (text(st), class),
            (text("shear"), ""),
            (html! { a href={"#" (anchor(&r.dir))} { (r.name) } }, ""),
            (
                text(format!(
                    "{}; normal stress off by {}",
                    mu_measured(r),
                    r.stress_rel_err
                        .map(|e| format!("{:.2} %", 100.0 * e))
                        .unwrap_or("–".into())
                )),
                "",
            ),
            (
                text(format!(
                    "paired Δμ within ±{} (equivalence: agree when its 90 % CI lies inside); stress within {} %",
                    r.mu_atol,
                    100.0 * r.stress_rtol
                )),
                "",
            ),
            match r.dashpot_stable {
                Some(true) => (text("stable"), "pass"),
                Some(false) => (text("explicit dashpot UNSTABLE at this dt"), "warn"),
                None => (text("–"), ""),
            },
        ]);
    }
    for r in &s.contact {
        rows.push(vec![
            status_cell(r.pass, &r.error),
            (text("contact"), ""),
            (
                html! { a href={"#" (anchor(&r.dir))} { (r.case) " / " (r.model) } },
                "",
            ),
            (
                text(match &r.error {
                    Some(e) => e.clone(),
                    None if r.max_rel_err == 0.0 => "bit for bit in every channel".into(),
                    None => format!("max rel err {} ({})", sci(r.max_rel_err), r.worst_channel),
                }),
                "",
            ),
            (text(format!("≤ {:.0e} of the channel peak", r.rtol)), ""),
            (text("–"), ""),
        ]);
    }
    p.push(table(
        &[
            "status",
            "kind",
            "case",
            "measured",
            "tolerance",
            "rolling dashpot",
        ],
        &rows,
    ));
}

/// Both codes' steady mu per shear case, as bars with their 95 % CIs (also written to
/// plots/steady_mu.svg).
fn steady_friction(p: &mut Page, s: &NightlySummary, plots: &Path) -> Result<()> {
    p.heading("steady", "Steady friction coefficient, both codes");
    let groups: Vec<BarGroup> = s
        .shear
        .iter()
        .map(|r| BarGroup {
            label: format!("{} μr={} ηr={}", r.rolling, r.mu_r, r.eta_r),
            bars: [&r.liggghts, &r.native]
                .iter()
                .enumerate()
                .map(|(k, c)| Bar {
                    value: c.as_ref().map(|c| c.steady.mu).unwrap_or(f64::NAN),
                    ci95: c.as_ref().map(|c| c.steady.mu_ci95).unwrap_or(f64::NAN),
                    color: k,
                })
                .collect(),
        })
        .collect();
    let bars = bar_chart(
        "steady mu = Fx / Fy (mean of the steady window, 95 % CI)",
        "mu",
        &groups,
        &["LIGGGHTS", "native"],
    )?;
    write_atomic(&plots.join("steady_mu.svg"), bars.as_bytes())?;
    let fig = p.svg(
        &bars,
        "Steady μ per shear case; whiskers: 95 % confidence interval (over seeds; one seed: over 10 blocks of the window).",
    );
    p.figures(&[fig]);
    Ok(())
}

/// Each shear case's wall time and throughput in both codes, and the night's totals.
fn performance(p: &mut Page, s: &NightlySummary) {
    p.heading("performance", "Wall time and throughput");
    let mut rows = Vec::new();
    for r in &s.shear {
        let c = |c: &Option<CodeStats>| {
            c.as_ref()
                .map(|c| {
                    (
                        format!("{:.0}", c.wall_s),
                        format!("{:.3e}", c.particle_steps_per_s),
                    )
                })
                .unwrap_or(("–".into(), "–".into()))
        };
        let (lw, lt) = c(&r.liggghts);
        let (nw, nt) = c(&r.native);
        let ratio = match (&r.liggghts, &r.native) {
            (Some(l), Some(n)) => format!("{:.2}", n.particle_steps_per_s / l.particle_steps_per_s),
            _ => "–".into(),
        };
        rows.push(vec![
            (text(&r.name), ""),
            (text(lw), "num"),
            (text(lt), "num"),
            (text(nw), "num"),
            (text(nt), "num"),
            (text(ratio), "num"),
        ]);
    }
    let contact_wall: f64 = s.contact.iter().map(|c| c.wall_s).sum();
    p.push(table(
        &[
            "shear case",
            "LIGGGHTS wall [s]",
            "LIGGGHTS particle-steps/s",
            "native wall [s]",
            "native particle-steps/s",
            "native / LIGGGHTS",
        ],
        &rows,
    ));
    p.para(&format!(
        "Each seed runs both codes side by side on this machine (LIGGGHTS one process, the native \
         solver on the remaining cores), so the throughputs are measured under the same load; \
         `verify bench` measures them on an idle machine. Contact cases: {} runs, {:.1} s in total \
         (both codes). Whole night: {:.1} min.",
        s.contact.len(),
        contact_wall,
        s.wall_time_s / 60.0
    ));
}

/// Each contact run: both codes' main channel overlaid and the error against time.
fn contact_cases(p: &mut Page, s: &NightlySummary, out: &Path) -> Result<()> {
    p.heading("contact", "Contact cases");
    p.para(
        "Per run: the main channel (rolling moment, tangential or normal force) of LIGGGHTS (solid) \
         and the native solver (dashed) overlaid, and the largest relative error over every channel \
         (forces, moments, contact history, positions, velocities, angular velocities, torques) \
         against time.",
    );
    for r in &s.contact {
        p.push(html! {
            h3 id=(anchor(&r.dir)) {
                (r.case) " / " (r.model) " — "
                @match &r.error {
                    Some(e) => span.fail { "error: " (e) },
                    None => (format!("max rel err {} (tolerance {:.0e})", sci(r.max_rel_err), r.rtol)),
                }
            }
        });
        let dir = out.join(&r.dir);
        // a night's run left its CSVs: draw from them; a stored night keeps its figures only
        let csvs = ["liggghts.csv", "native.csv"].map(|f| dir.join(f).is_file());
        if r.error.is_none() && csvs == [true, true] {
            let title = dir.file_name().map(|n| n.to_string_lossy().into_owned());
            super::contact::plots_of_run(&dir, &title.unwrap_or_default(), r.model != "off")?;
        }
        let mut figs = Vec::new();
        for (f, cap) in [
            ("history.svg", "both codes overlaid"),
            ("error.svg", "relative error against time"),
        ] {
            if dir.join(f).is_file() {
                figs.push(p.svg_file(&dir.join(f), cap)?);
            }
        }
        p.figures(&figs);
    }
    p.para(
        "Files: summary.json (schema in docs/nightly.md), contact/<case>_<model>/ and shear/<case>/ \
         with each code's CSV, decks and logs; the history file holds one JSON line per case per night.",
    );
    Ok(())
}

fn anchor(dir: &str) -> String {
    dir.replace(['/', '.'], "-")
}

fn shear_section(p: &mut Page, r: &ShearRow, out: &Path) -> Result<()> {
    let (st, class) = shear_status(r);
    p.push(html! { h3 id=(anchor(&r.dir)) { (r.name) " — " span class=(class) { (st) } } });
    if let Some(e) = &r.error {
        p.push(html! { pre.fail { (e) } });
    }
    if let Some(rp) = &r.replay {
        let (st, class) = status(rp.pass, &None);
        p.push(html! {
            p {
                "Contact by contact (" code { "verify replay" } ", seed 1): "
                (format!(
                    "{} windows of {} steps from LIGGGHTS' recorded states, worst step-1 error {} \
                     (limit {}), shortest horizon {} steps: ",
                    rp.windows,
                    rp.steps,
                    sci(rp.worst_step1),
                    sci(rp.rtol),
                    rp.min_horizon
                ))
                span class=(class) { (st) } "."
            }
        });
    }
    if let Some(pd) = &r.paired_dmu {
        p.para(&format!(
            "Paired over the same seeds, native − LIGGGHTS: {:+.4} ± {:.4} (95 % CI, {} seeds), \
             t = {:.2}, native higher in {} of {}.",
            pd.mean, pd.ci95, pd.n, pd.t, pd.b_higher, pd.n
        ));
    }
    let mut rows = Vec::new();
    for (code, c) in [("LIGGGHTS", &r.liggghts), ("native", &r.native)] {
        if let Some(c) = c {
            rows.push(vec![
                (code.to_string(), ""),
                (
                    format!("{:.4} ± {:.4}", c.steady.mu, c.steady.mu_ci95),
                    "num",
                ),
                (
                    c.steady
                        .per_seed_mu
                        .iter()
                        .map(|m| format!("{m:.4}"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    "num",
                ),
                (format!("{:.3}", c.steady.normal_stress / 1e6), "num"),
                (format!("{:.3e}", c.steady.erot), "num"),
                (format!("{:.3e}", c.steady.ke), "num"),
                (
                    if c.steady.mobilised.is_finite() {
                        format!("{:.3}", c.steady.mobilised)
                    } else {
                        "not output".into()
                    },
                    "num",
                ),
                (
                    c.profile
                        .as_ref()
                        .map(|p| {
                            format!(
                                "{:.1} % / {:.1} %, band {:.2} of {:.2} mm",
                                100.0 * p.slip_bottom,
                                100.0 * p.slip_top,
                                1e3 * p.band_width,
                                1e3 * p.gap
                            )
                        })
                        .unwrap_or("–".into()),
                    "num",
                ),
                (format!("{:.0}", c.wall_s), "num"),
            ]);
        }
    }
    p.push(table(
        &[
            "code",
            "steady μ (95 % CI)",
            "per seed",
            "normal stress [MPa]",
            "mean E_rot [J]",
            "mean E_kin [J]",
            "rolling mobilised",
            "slip bottom / top plate",
            "wall [s]",
        ],
        &text_rows(rows),
    ));
    p.para(&format!(
        "Lockstep from a common compacted state: the codes agree (1e-6 of the peak: plate forces, \
         top plate position, kinetic energies) for {} shear steps (shortest over seeds); chaos baseline (native vs native \
         one ulp apart): {} steps. Stability of the explicit rolling dashpot: {}{}.",
        r.lockstep_steps
            .map(|v| v.saturating_sub(1).to_string())
            .unwrap_or("–".into()),
        r.chaos_baseline_steps
            .map(|v| v.saturating_sub(1).to_string())
            .unwrap_or("–".into()),
        match r.dashpot_stable {
            Some(true) => "stable",
            Some(false) =>
                "UNSTABLE (results may show the dashpot artefact; see `verify convergence`)",
            None => "–",
        },
        r.worst_stability
            .as_ref()
            .map(|l| format!("; worst contact: {l}"))
            .unwrap_or_default()
    ));
    let dir = out.join(&r.dir);
    let mut figs = Vec::new();
    for (f, cap) in [
        ("mu_strain.svg", "μ(strain), both codes, every seed"),
        (
            "velocity_profile.svg",
            "steady velocity profile across the gouge: does the gouge slip at the plates?",
        ),
        ("shear_force.svg", "shear force on the top plate"),
        ("top_force.svg", "normal force on the top plate"),
        ("kinetic_energy.svg", "rotational kinetic energy"),
        (
            "mobilised.svg",
            "fraction of touching pairs at full rolling mobilisation (native)",
        ),
    ] {
        if dir.join(f).is_file() {
            figs.push(p.svg_file(&dir.join(f), cap)?);
        }
    }
    p.figures(&figs);
    Ok(())
}

/// Trend plots from the history: largest contact error per case, steady mu per code and shear
/// case, against days since the first night in the history.
fn trend_plots(
    p: &mut Page,
    history: &[Record],
    s: &NightlySummary,
    plots: &Path,
) -> Result<Vec<Markup>> {
    let t0 = history.iter().map(|r| r.unix_time).min().unwrap_or(0);
    let day = |r: &Record| (r.unix_time - t0) as f64 / 86400.0;
    let nights = {
        let mut n: Vec<&str> = history.iter().map(|r| r.night.as_str()).collect();
        n.sort();
        n.dedup();
        n.len()
    };
    let mut figs = Vec::new();
    // contact: one curve per case (largest over its models), and the tolerance
    let mut cases: Vec<String> = s.contact.iter().map(|c| c.case.clone()).collect();
    cases.dedup();
    let mut data: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for case in &cases {
        let mut pts: Vec<(f64, f64)> = Vec::new();
        for r in history
            .iter()
            .filter(|r| r.kind == "contact" && r.case.split('/').next() == Some(case))
        {
            let e = r.max_err.unwrap_or(f64::NAN);
            match pts.iter_mut().find(|q| q.0 == day(r)) {
                Some(q) => q.1 = q.1.max(e),
                None => pts.push((day(r), e)),
            }
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        data.push((case.clone(), pts));
    }
    let path = plots.join("trend_contact.svg");
    log_error_plot(
        &path,
        "contact cases: largest relative error per night",
        "days since the first night in the history",
        &data,
        CONTACT_RTOL,
        1e-17,
    )?;
    figs.push(p.svg_file(
        &path,
        &format!(
            "{nights} night(s) in the history; log axis, tolerance dashed, a bit-identical \
             night (error 0) on the 1e-17 floor."
        ),
    )?);
    // shear: steady mu of both codes per case (colour per case; native dashed)
    // entries alternate LIGGGHTS, native
    let mut data: Vec<CurveData> = Vec::new();
    for (k, r) in s.shear.iter().enumerate() {
        for (code, native) in [("LIGGGHTS", false), ("native", true)] {
            let mut v: Vec<(f64, f64)> = history
                .iter()
                .filter(|h| h.kind == "shear" && h.case == r.name)
                .filter_map(|h| {
                    let m = if native { h.mu_native } else { h.mu_liggghts };
                    m.map(|m| (day(h), m))
                })
                .collect();
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
            data.push((format!("{} {code}", r.name), k, v));
        }
    }
    let curves: Vec<Curve> = data
        .iter()
        .enumerate()
        .map(|(i, (l, k, v))| {
            let c = Curve::new(l, v, *k);
            if i % 2 == 1 {
                c.dashed()
            } else {
                c
            }
        })
        .collect();
    let path = plots.join("trend_shear.svg");
    line_plot(
        &path,
        "shear cases: steady mu per night",
        "days since the first night in the history",
        "steady mu",
        &curves,
    )?;
    figs.push(p.svg_file(
        &path,
        "Steady μ per night and shear case: LIGGGHTS solid, native dashed, one colour per case.",
    )?);
    Ok(figs)
}
