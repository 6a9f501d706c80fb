//! The Chung & Ooi (2011) benchmark ([`crate::chung_ooi`]) in both codes: each case run by
//! LIGGGHTS and by the native solver, each code's figures judged against the benchmark's
//! values, and the two codes compared channel by channel (the contact rule, bit for bit).

use crate::chung_ooi::{cases, judge, BenchmarkCase, Check};
use crate::compare::{compare, CONTACT_RTOL};
use crate::deck::contact_deck;
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::liggghts::Liggghts;
use crate::series::contact_series;
use crate::solver::two_body;
use std::path::Path;

/// One benchmark case's outcome: each code's checks and the codes' largest difference.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchmarkOutcome {
    pub test: u8,
    pub case: String,
    pub description: String,
    pub native: Vec<Check>,
    pub liggghts: Vec<Check>,
    /// Largest |native - LIGGGHTS| over every channel and step (0: bit for bit).
    pub max_abs_diff: f64,
    /// Every channel within the contact rule's rtol.
    pub codes_agree: bool,
}

impl BenchmarkOutcome {
    /// Every figure of both codes within its tolerance and the codes in agreement.
    pub fn pass(&self) -> bool {
        self.codes_agree
            && !self.native.is_empty()
            && !self.liggghts.is_empty()
            && self.native.iter().chain(&self.liggghts).all(|c| c.pass)
    }
}

/// Runs one case in both codes under `out/<case>/` and judges it.
pub fn run_case(b: &BenchmarkCase, lig: &Liggghts, out: &Path) -> Result<BenchmarkOutcome> {
    let case = b.case.clone().validate()?;
    let dir = out.join(&case.name);
    let native = contact_series(&case, &two_body::run(&case.two_body())?)?;
    native.write_csv(&dir.join("native.csv"))?;
    let deck = contact_deck(&case);
    let lig_series = super::contact::liggghts_contact_series(&case, &deck, lig, &dir)?;
    lig_series.write_csv(&dir.join("liggghts.csv"))?;
    let channels = compare(
        &case.name,
        case.models.rolling.keyword(),
        &lig_series,
        &native,
        CONTACT_RTOL,
    )?;
    if channels.is_empty() {
        return Err(Error::Mismatch(format!(
            "{}: no channel compared",
            case.name
        )));
    }
    Ok(BenchmarkOutcome {
        test: b.test,
        case: case.name.clone(),
        description: case.description.clone(),
        native: judge(b, &native)?,
        liggghts: judge(b, &lig_series)?,
        max_abs_diff: channels.iter().map(|c| c.max_abs_err).fold(0.0, f64::max),
        codes_agree: channels.iter().all(|c| c.pass),
    })
}

/// The benchmark cases whose name contains `filter` (all with `None`); an error when none
/// does.
pub fn select(filter: Option<&str>) -> Result<Vec<BenchmarkCase>> {
    let chosen: Vec<BenchmarkCase> = cases()
        .into_iter()
        .filter(|b| filter.is_none_or(|f| b.case.name.contains(f)))
        .collect();
    if chosen.is_empty() {
        return Err(Error::invalid(
            "--case",
            filter.unwrap_or(""),
            "a part of a benchmark case's name (chung_ooi_1 .. chung_ooi_4, chung_ooi_unequal)",
        ));
    }
    Ok(chosen)
}

/// Runs the `chosen` cases, tells `on_case` of each, writes `out/summary.json` and returns
/// the outcomes; a case that cannot run is an error naming it after the others have run and
/// been written.
pub fn run_all(
    chosen: &[BenchmarkCase],
    lig: &Liggghts,
    out: &Path,
    on_case: impl Fn(&BenchmarkOutcome),
) -> Result<Vec<BenchmarkOutcome>> {
    let mut outcomes = Vec::new();
    let mut errors = Vec::new();
    for b in chosen {
        match run_case(b, lig, out) {
            Ok(o) => {
                on_case(&o);
                outcomes.push(o);
            }
            Err(e) => errors.push(format!("  {}: {e}", b.case.name)),
        }
    }
    let path = out.join("summary.json");
    write_atomic(&path, serde_json::to_string_pretty(&outcomes)?.as_bytes())?;
    super::note_summary(&path);
    if !errors.is_empty() {
        return Err(Error::Cases(format!(
            "{} of {} benchmark case(s) could not run (the others' results are in {}):\n{}",
            errors.len(),
            chosen.len(),
            path.display(),
            errors.join("\n")
        )));
    }
    Ok(outcomes)
}
