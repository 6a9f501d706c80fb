//! Helpers shared by the end-to-end tests.
#![allow(dead_code)]

use dem_verify::liggghts::Liggghts;
use std::time::Duration;

/// The LIGGGHTS binary. Tests that need it fail (never skip) when it is missing: CI installs
/// it, and a developer without it is told how to get it.
pub fn liggghts() -> Liggghts {
    match Liggghts::locate(None, Duration::from_secs(600)) {
        Ok(l) => l,
        Err(e) => panic!("this test runs LIGGGHTS and it is not installed: {e}"),
    }
}

/// Path of the `verify` binary built for the tests.
pub fn verify_bin() -> &'static str {
    env!("CARGO_BIN_EXE_verify")
}

/// Runs the `verify` binary with `args`.
pub fn verify(args: &[&str]) -> std::process::Output {
    std::process::Command::new(verify_bin())
        .args(args)
        .output()
        .expect("run verify")
}

/// A finished command's stdout and stderr, for assertion messages.
pub fn text(o: &std::process::Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// `verify shear` of one ci-preset seed sheared to strain 0.05 (seconds), writing to `out`,
/// with `extra` flags.
pub fn short_ci_shear(out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "shear",
        "--preset",
        "ci",
        "--seeds",
        "1",
        "--strain",
        "0.05",
        "--out",
        out.to_str().expect("a UTF-8 path"),
    ];
    args.extend_from_slice(extra);
    verify(&args)
}

/// `verify contact --case rolling_unload --reference` (no LIGGGHTS needed) into `out`, with
/// `extra` flags.
pub fn reference_contact(out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "contact",
        "--case",
        "rolling_unload",
        "--reference",
        "--out",
        out.to_str().expect("a UTF-8 path"),
    ];
    args.extend_from_slice(extra);
    verify(&args)
}
