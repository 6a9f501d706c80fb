//! Prints the verdict's calibration (docs/verdicts.md) from the stored paired sets: the
//! markdown table per preset and the `CITED` entries of src/calibration.rs.
//!
//! `cargo run --release --example calibration_table [reference/calibration/ci.json ...]`

use dem_verify::calibration::{cited, markdown, table, Stored, SEED_COUNTS};
use dem_verify::compare::MU_MARGIN;

fn main() {
    let mut paths: Vec<String> = std::env::args().skip(1).collect();
    if paths.is_empty() {
        paths = ["ci", "fast"]
            .map(|p| {
                format!(
                    "{}/reference/calibration/{p}.json",
                    env!("CARGO_MANIFEST_DIR")
                )
            })
            .to_vec();
    }
    let mut consts = Vec::new();
    for p in &paths {
        let s = match Stored::read(std::path::Path::new(p)) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("error: {e}");
                std::process::exit(2);
            }
        };
        let rows = table(&s, MU_MARGIN);
        println!(
            "### {} preset\n\n{}\n{}\n",
            s.preset,
            s.provenance,
            markdown(&rows)
        );
        for n in SEED_COUNTS {
            if let Some(c) = cited(&rows, s.preset, n) {
                let f = |v: f64| {
                    if v.is_nan() {
                        "f64::NAN".to_string()
                    } else {
                        format!("{v:?}")
                    }
                };
                consts.push(format!(
                    "    Cited {{ preset: Preset::{:?}, seeds: {n}, false_alarm: {}, agree: {}, power_mup: {}, power_shift: {} }},",
                    s.preset,
                    f(c.false_alarm),
                    f(c.agree),
                    f(c.power_mup),
                    f(c.power_shift)
                ));
            }
        }
    }
    println!("CITED:\n{}", consts.join("\n"));
}
