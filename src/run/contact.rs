//! The contact study: two-body cases (particle-particle, particle-wall) in both codes, or
//! native against the stored LIGGGHTS reference, compared channel by channel.

use super::utc_stamp;
use crate::compare::{compare, ChannelResult};
use crate::deck::{contact_deck, run_name, Deck, ATOM_DUMP, CONTACT_DUMP};
use crate::error::{Error, Result};
use crate::fsutil::{sha256_hex, write_atomic};
use crate::liggghts::{read_contact_frames, Liggghts};
use crate::series::{contact_series, Series};
use crate::solver::two_body;
use crate::spec::builtin::{builtin_case, builtin_names};
use crate::spec::{Case, CaseFile, RollingModel};
use serde::Serialize;
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

/// Runs every case ([`contact_one`]), tells `on_case` of each (its results or error, and wall
/// time [s]), writes `out/summary.json` and returns the summary. A case that fails does not
/// stop the others: its error is in the summary, and after the summary is written the
/// failures are returned as [`Error::Cases`]. `against` names the LIGGGHTS side (`live` or
/// `reference`), `version` its version.
pub fn run_all(
    runs: &[Case],
    req: &ContactRequest,
    lig: Option<&Liggghts>,
    out: &Path,
    against: &str,
    version: String,
    on_case: impl Fn(&Case, std::result::Result<&[ChannelResult], &Error>, f64),
) -> Result<ContactSummary> {
    let mut all = Vec::new();
    let mut errors = Vec::new();
    for case in runs {
        let t0 = std::time::Instant::now();
        match contact_one(case, req, lig, out) {
            Ok(results) => {
                on_case(case, Ok(&results), t0.elapsed().as_secs_f64());
                all.extend(results);
            }
            Err(e) => {
                on_case(case, Err(&e), t0.elapsed().as_secs_f64());
                errors.push(CaseError {
                    case: case.name.clone(),
                    model: case.models.rolling.keyword().into(),
                    error: e.to_string(),
                });
            }
        }
    }
    let summary = ContactSummary::new(against, version, req.rtol, all, errors);
    let path = out.join("summary.json");
    summary.write(&path)?;
    super::note_summary(&path);
    if !summary.errors.is_empty() {
        let list: Vec<String> = summary
            .errors
            .iter()
            .map(|e| format!("  {}/{}: {}", e.case, e.model, e.error))
            .collect();
        return Err(Error::Cases(format!(
            "{} of {} contact run(s) could not be compared (the others' results are in {}):\n{}",
            summary.errors.len(),
            runs.len(),
            path.display(),
            list.join("\n")
        )));
    }
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
    let native_run = contact_series(case, &two_body::run(&case.two_body())?)?;
    let (lig_series, native) = match lig {
        None => {
            let reference = read_reference(&a.reference_dir, &name)?;
            // the native run at exactly the steps a complete reference keeps: a reference
            // with rows missing (or of another case) is an error, never a shorter comparison
            let native = native_run.decimate(REFERENCE_STRIDE);
            if reference.steps != native.steps {
                return Err(Error::Reference {
                    path: reference_path(&a.reference_dir, &name),
                    msg: format!(
                        "it holds {} rows (steps {}), the case writes {} (every \
                         {REFERENCE_STRIDE}th output step and the last, steps {}): the \
                         reference is incomplete or of another case",
                        reference.steps.len(),
                        step_range(&reference.steps),
                        native.steps.len(),
                        step_range(&native.steps)
                    ),
                });
            }
            (reference, native)
        }
        Some(l) => {
            let s = liggghts_contact_series(case, &deck, l, &dir)?;
            if a.update_reference {
                store_reference(case, &s, l, &a.reference_dir)?;
            }
            (s, native_run)
        }
    };
    lig_series.write_csv(&dir.join("liggghts.csv"))?;
    native.write_csv(&dir.join("native.csv"))?;
    compare(
        &case.name,
        case.models.rolling.keyword(),
        &lig_series,
        &native,
        a.rtol,
    )
}

/// Runs the deck in `dir/liggghts/` and returns its channels. After a success the dumps are
/// deleted (they are large and the CSV holds what they say) and the log is kept; after any
/// failure (LIGGGHTS', or dumps that do not read) every file stays, so the error's paths
/// point at files that exist.
pub fn liggghts_contact_series(
    case: &Case,
    deck: &Deck,
    lig: &Liggghts,
    dir: &Path,
) -> Result<Series> {
    let run_dir = dir.join("liggghts");
    std::fs::create_dir_all(&run_dir).map_err(|e| Error::io(&run_dir, e))?;
    lig.run(deck, &run_dir)?;
    let n_hist = if case.models.rolling.has_history() {
        6
    } else {
        3
    };
    let series = contact_series(
        case,
        &read_contact_frames(&run_dir, n_hist, case.wall.is_some())?,
    )?;
    for dump in [ATOM_DUMP, CONTACT_DUMP] {
        let p = run_dir.join(dump);
        std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?;
    }
    Ok(series)
}

/// Stored references keep every `REFERENCE_STRIDE`-th output step (and the last), to keep
/// the repository small; `--reference` compares the native run at exactly those steps.
pub const REFERENCE_STRIDE: u64 = 10;

/// What a stored reference is and where it came from; `rows` and `sha256` (of liggghts.csv's
/// bytes) let `--reference` refuse a file that was cut, edited or replaced.
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Provenance {
    liggghts_version: String,
    command: String,
    deck: String,
    date_utc: String,
    rows: usize,
    sha256: String,
}

fn reference_path(root: &Path, name: &str) -> PathBuf {
    root.join("contact").join(name).join("liggghts.csv")
}

fn step_range(steps: &[u64]) -> String {
    match (steps.first(), steps.last()) {
        (Some(a), Some(b)) => format!("{a}..={b}"),
        _ => "none".into(),
    }
}

/// Reads the stored reference of run `name`, checked against its provenance (row count and
/// checksum).
fn read_reference(root: &Path, name: &str) -> Result<Series> {
    let csv_path = reference_path(root, name);
    let prov_path = csv_path.with_file_name("provenance.json");
    let err = |msg: String| Error::Reference {
        path: csv_path.clone(),
        msg,
    };
    if !csv_path.is_file() {
        return Err(err(format!(
            "no stored LIGGGHTS output for {name} (built-in cases only; run without \
             --reference to use LIGGGHTS)"
        )));
    }
    let prov_text = std::fs::read_to_string(&prov_path).map_err(|e| {
        err(format!(
            "its provenance {} cannot be read: {e}",
            prov_path.display()
        ))
    })?;
    let prov: Provenance = serde_json::from_str(&prov_text).map_err(|e| Error::JsonFile {
        path: prov_path.clone(),
        line: None,
        source: e,
    })?;
    let bytes = std::fs::read(&csv_path).map_err(|e| Error::io(&csv_path, e))?;
    let sum = sha256_hex(&bytes);
    if sum != prov.sha256 {
        return Err(err(format!(
            "checksum {sum} differs from the provenance's {} (the file was changed after \
             it was stored; restore it or store it again with --update-reference)",
            prov.sha256
        )));
    }
    let s = Series::read_csv(&csv_path)?;
    if s.rows.len() != prov.rows {
        return Err(err(format!(
            "{} rows, the provenance says {}",
            s.rows.len(),
            prov.rows
        )));
    }
    Ok(s)
}

/// Refuses to store a reference for a user's case (`--spec`) under a built-in case's name:
/// the built-in reference would be replaced and then agree with itself.
pub fn check_reference_target(case_name: &str, from_spec: bool) -> Result<()> {
    if from_spec && builtin_names().any(|b| b == case_name) {
        return Err(Error::invalid(
            "name (case file, with --update-reference)",
            case_name,
            "a name that is not a built-in case's (the built-in references are not \
             overwritten by a user's case; rename the case)",
        ));
    }
    Ok(())
}

fn store_reference(case: &Case, s: &Series, lig: &Liggghts, root: &Path) -> Result<()> {
    let name = run_name(case);
    let dir = root.join("contact").join(&name);
    let csv_path = dir.join("liggghts.csv");
    let kept = s.decimate(REFERENCE_STRIDE);
    let bytes = kept.csv_bytes(&csv_path)?;
    write_atomic(&csv_path, &bytes)?;
    let prov = Provenance {
        liggghts_version: lig.version(),
        command: format!("{} -in in.deck -log log.liggghts", lig.binary.display()),
        deck: format!("liggghts_inputs/contact/{name}/in.deck"),
        date_utc: utc_stamp(),
        rows: kept.rows.len(),
        sha256: sha256_hex(&bytes),
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

/// `summary.json` of `verify contact`.
#[derive(Clone, Debug, Serialize)]
pub struct ContactSummary {
    pub pass: bool,
    /// `live` (LIGGGHTS run now) or `reference` (stored LIGGGHTS outputs).
    pub against: String,
    pub liggghts_version: String,
    pub rtol: f64,
    pub results: Vec<ChannelResult>,
    /// Largest relative error per case and model.
    pub worst: Vec<Worst>,
    /// Runs that could not be compared (the others still ran and are in `results`).
    pub errors: Vec<CaseError>,
}

/// A run of a multi-case study that failed, with the error's text.
#[derive(Clone, Debug, Serialize)]
pub struct CaseError {
    pub case: String,
    pub model: String,
    pub error: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct Worst {
    pub case: String,
    pub model: String,
    pub channel: String,
    pub max_rel_err: f64,
    pub pass: bool,
}

impl ContactSummary {
    pub fn new(
        against: &str,
        liggghts_version: String,
        rtol: f64,
        results: Vec<ChannelResult>,
        errors: Vec<CaseError>,
    ) -> Self {
        let mut worst: Vec<Worst> = Vec::new();
        for r in &results {
            match worst
                .iter_mut()
                .find(|w| w.case == r.case && w.model == r.model)
            {
                Some(w) => {
                    if r.max_rel_err > w.max_rel_err || r.max_rel_err.is_nan() {
                        w.max_rel_err = r.max_rel_err;
                        w.channel = r.channel.clone();
                    }
                    w.pass &= r.pass;
                }
                None => worst.push(Worst {
                    case: r.case.clone(),
                    model: r.model.clone(),
                    channel: r.channel.clone(),
                    max_rel_err: r.max_rel_err,
                    pass: r.pass,
                }),
            }
        }
        ContactSummary {
            pass: results.iter().all(|r| r.pass) && !results.is_empty() && errors.is_empty(),
            against: against.into(),
            liggghts_version,
            rtol,
            results,
            worst,
            errors,
        }
    }

    pub fn write(&self, path: &Path) -> Result<()> {
        write_atomic(path, serde_json::to_string_pretty(self)?.as_bytes())
    }
}
