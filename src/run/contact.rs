//! The contact study: two-body cases (particle-particle, particle-wall) in both codes, or
//! native against the stored LIGGGHTS reference, compared channel by channel.

use super::utc_stamp;
use crate::compare::{compare, ChannelResult};
use crate::deck::{contact_deck, run_name, Deck};
use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::liggghts::{read_contact_frames, Liggghts, LOG_NAME};
use crate::report::ContactSummary;
use crate::series::{contact_series, Series};
use crate::solver::two_body;
use crate::spec::{builtin_case, builtin_names, Case, CaseFile, RollingModel};
use std::path::{Path, PathBuf};

/// Which rolling models of a case to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RollingChoice {
    /// Every model the case lists.
    All,
    One(RollingModel),
}

/// How one contact run is compared.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactRequest {
    /// Relative tolerance: max |error| / channel peak.
    pub rtol: f64,
    /// Directory of stored reference outputs (read with no LIGGGHTS, written with
    /// `update_reference`).
    pub reference_dir: PathBuf,
    /// Store LIGGGHTS' outputs as the new reference (with provenance).
    pub update_reference: bool,
}

/// The (case, rolling model) runs a `verify contact` invocation asks for, validated.
pub fn contact_runs(case: &str, spec: Option<&Path>, rolling: RollingChoice) -> Result<Vec<Case>> {
    let files: Vec<CaseFile> = match spec {
        Some(p) => vec![CaseFile::load(p)?],
        None if case == "all" => builtin_names().map(builtin_case).collect::<Result<_>>()?,
        None => vec![builtin_case(case)?],
    };
    let mut runs = Vec::new();
    for f in files {
        let models = match rolling {
            RollingChoice::All => f.applicable_rolling(),
            RollingChoice::One(m) => vec![m],
        };
        for m in models {
            runs.push(f.with_rolling(m).validate()?);
        }
    }
    Ok(runs)
}

/// Writes the decks of every built-in case and rolling model under `out/contact/`.
pub fn write_decks(out: &Path) -> Result<usize> {
    let runs = contact_runs("all", None, RollingChoice::All)?;
    for c in &runs {
        write_deck(&contact_deck(c), &out.join("contact").join(run_name(c)))?;
    }
    Ok(runs.len())
}

fn write_deck(deck: &Deck, dir: &Path) -> Result<()> {
    for (name, text) in &deck.files {
        write_atomic(&dir.join(name), text.as_bytes())?;
    }
    Ok(())
}

/// Runs every case ([`contact_one`]), tells `on_case` of each (its results and wall time [s]),
/// writes `out/summary.json` and returns the summary. `against` names the LIGGGHTS side
/// (`live` or `reference`), `version` its version.
pub fn run_all(
    runs: &[Case],
    req: &ContactRequest,
    lig: Option<&Liggghts>,
    out: &Path,
    against: &str,
    version: String,
    on_case: impl Fn(&Case, &[ChannelResult], f64),
) -> Result<ContactSummary> {
    let mut all = Vec::new();
    for case in runs {
        let t0 = std::time::Instant::now();
        let results = contact_one(case, req, lig, out)?;
        on_case(case, &results, t0.elapsed().as_secs_f64());
        all.extend(results);
    }
    let summary = ContactSummary::new(against, version, req.rtol, all);
    summary.write(&out.join("summary.json"))?;
    Ok(summary)
}

/// Runs one case in both codes (or native against the stored reference) and compares.
pub fn contact_one(
    case: &Case,
    a: &ContactRequest,
    lig: Option<&Liggghts>,
    out: &Path,
) -> Result<Vec<ChannelResult>> {
    let name = run_name(case);
    let dir = out.join(&name);
    let deck = contact_deck(case);
    write_deck(&deck, &dir.join("deck"))?;
    let reference_csv = a
        .reference_dir
        .join("contact")
        .join(&name)
        .join("liggghts.csv");
    let lig_series = match lig {
        None => {
            if !reference_csv.is_file() {
                return Err(Error::Reference {
                    path: reference_csv,
                    msg: format!(
                        "no stored LIGGGHTS output for {name} (built-in cases only; run \
                         without --reference to use LIGGGHTS)"
                    ),
                });
            }
            Series::read_csv(&reference_csv)?
        }
        Some(l) => {
            let s = liggghts_contact_series(case, &deck, l, &dir)?;
            if a.update_reference {
                store_reference(case, &s, l, &a.reference_dir)?;
            }
            s
        }
    };
    lig_series.write_csv(&dir.join("liggghts.csv"))?;
    let mut native = contact_series(case, &two_body::run(case)?);
    if lig.is_none() {
        native = native.at_steps(&lig_series.steps)?;
    }
    native.write_csv(&dir.join("native.csv"))?;
    crate::report::contact::contact_plots(
        &dir,
        &name,
        &lig_series,
        &native,
        case.models.rolling != RollingModel::Off,
    )?;
    compare(
        &case.name,
        case.models.rolling.keyword(),
        &lig_series,
        &native,
        a.rtol,
    )
}

/// Runs the deck in a temporary directory and returns its channels; keeps the log in `dir`.
pub fn liggghts_contact_series(
    case: &Case,
    deck: &Deck,
    lig: &Liggghts,
    dir: &Path,
) -> Result<Series> {
    let tmp = tempfile::tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?;
    let result = lig.run(deck, tmp.path());
    if let Ok(log) = std::fs::read(tmp.path().join(LOG_NAME)) {
        write_atomic(&dir.join(LOG_NAME), &log)?;
    }
    result?;
    let n_hist = if case.models.rolling.has_history() {
        6
    } else {
        3
    };
    let frames = read_contact_frames(tmp.path(), n_hist, case.wall.is_some())?;
    Ok(contact_series(case, &frames))
}

/// Stored references keep every `REFERENCE_STRIDE`-th output step (and the last), to keep
/// the repository small; `--reference` compares the native run at exactly those steps.
pub const REFERENCE_STRIDE: u64 = 10;

#[derive(serde::Serialize, serde::Deserialize)]
struct Provenance {
    liggghts_version: String,
    command: String,
    deck: String,
    date_utc: String,
}

fn store_reference(case: &Case, s: &Series, lig: &Liggghts, root: &Path) -> Result<()> {
    let name = run_name(case);
    let dir = root.join("contact").join(&name);
    s.decimate(REFERENCE_STRIDE)
        .write_csv(&dir.join("liggghts.csv"))?;
    let prov = Provenance {
        liggghts_version: lig.version(),
        command: format!("{} -in in.deck -log log.liggghts", lig.binary.display()),
        deck: format!("liggghts_inputs/contact/{name}/in.deck"),
        date_utc: utc_stamp(),
    };
    write_atomic(
        &dir.join("provenance.json"),
        serde_json::to_string_pretty(&prov)?.as_bytes(),
    )
}

pub fn read_reference_version(root: &Path) -> String {
    let p = root.join("contact/rolling_plastic__epsd/provenance.json");
    std::fs::read_to_string(p)
        .ok()
        .and_then(|t| serde_json::from_str::<Provenance>(&t).ok())
        .map(|p| format!("{} (stored {})", p.liggghts_version, p.date_utc))
        .unwrap_or_else(|| "stored reference (no provenance found)".into())
}
