//! The built-in contact cases. Their TOML files live in `cases/` (so users can copy them as
//! templates) and are compiled in, so the binary needs no data files.

use super::CaseFile;
use crate::error::{Error, Result};
use std::path::Path;

/// Name and TOML text of every built-in case, in the order `--list` shows them.
pub const BUILTIN_CASES: &[(&str, &str)] = &[
    (
        "normal_elastic",
        include_str!("../../cases/normal_elastic.toml"),
    ),
    (
        "normal_damped",
        include_str!("../../cases/normal_damped.toml"),
    ),
    (
        "tangential_stick",
        include_str!("../../cases/tangential_stick.toml"),
    ),
    (
        "tangential_slip",
        include_str!("../../cases/tangential_slip.toml"),
    ),
    (
        "rolling_elastic",
        include_str!("../../cases/rolling_elastic.toml"),
    ),
    (
        "rolling_plastic",
        include_str!("../../cases/rolling_plastic.toml"),
    ),
    (
        "rolling_unload",
        include_str!("../../cases/rolling_unload.toml"),
    ),
    (
        "rolling_damped",
        include_str!("../../cases/rolling_damped.toml"),
    ),
    (
        "wall_rolling_plastic",
        include_str!("../../cases/wall_rolling_plastic.toml"),
    ),
];

/// Names of the built-in cases.
pub fn builtin_names() -> impl Iterator<Item = &'static str> {
    BUILTIN_CASES.iter().map(|(n, _)| *n)
}

/// Parses a built-in case by name; an unknown name lists the valid ones.
pub fn builtin_case(name: &str) -> Result<CaseFile> {
    let (_, text) = BUILTIN_CASES
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| Error::Unknown {
            what: "case",
            name: name.to_string(),
            valid: builtin_names().collect::<Vec<_>>().join(", "),
        })?;
    CaseFile::from_toml(text, Path::new(&format!("cases/{name}.toml")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_match_files() {
        for name in builtin_names() {
            assert_eq!(builtin_case(name).unwrap().name, name);
        }
    }

    #[test]
    fn unknown_case_lists_valid_names() {
        let e = builtin_case("rolling_plastik").unwrap_err().to_string();
        assert!(
            e.contains("rolling_plastik") && e.contains("rolling_plastic"),
            "{e}"
        );
    }
}
