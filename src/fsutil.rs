//! File helpers at the I/O edge: atomic writes (temp file in the same directory, then
//! rename), so an interrupted run never leaves a truncated result behind.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically, creating parent directories.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(|e| Error::io(dir, e))?;
    tmp.write_all(bytes).map_err(|e| Error::io(path, e))?;
    // temporary files are created 0600; results are meant to be read by others (a lab's web
    // server serving the nightly report, colleagues on a cluster)
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))
            .map_err(|e| Error::io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// The SHA-256 of `bytes` in lower-case hex (checksums of stored references and results).
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The record of a derived file a resume reuses (a sweep run's `result.json`, a convergence
/// run's series): `<file>.sha256` beside it, holding the input hash the file was made from and
/// the SHA-256 of its bytes.
fn record_path(path: &Path) -> std::path::PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".sha256");
    path.with_file_name(name)
}

/// Writes the record of `path` (already written, atomically) for `input`: written after the
/// file, so that a crash between the two leaves a record that does not match and the file is
/// made again.
pub fn write_record(path: &Path, input: &str) -> Result<()> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    write_atomic(
        &record_path(path),
        format!("{input} {}\n", sha256_hex(&bytes)).as_bytes(),
    )
}

/// The bytes of `path` when its record names `input` and the bytes' SHA-256; otherwise why it
/// is not reused (a sentence for the user; a missing file is `Ok(None)`).
pub fn read_recorded(path: &Path, input: &str) -> std::result::Result<Option<Vec<u8>>, String> {
    let Ok(bytes) = std::fs::read(path) else {
        return Ok(None);
    };
    let rec = std::fs::read_to_string(record_path(path)).map_err(|e| {
        format!(
            "its record {} cannot be read ({e})",
            record_path(path).display()
        )
    })?;
    let mut f = rec.split_whitespace();
    match (f.next(), f.next(), f.next()) {
        (Some(i), Some(_), None) if i != input => {
            Err("it was made from other inputs (its input hash differs)".into())
        }
        (Some(_), Some(h), None) if h != sha256_hex(&bytes) => {
            Err("its bytes differ from those written (SHA-256 mismatch)".into())
        }
        (Some(_), Some(_), None) => Ok(Some(bytes)),
        _ => Err(format!(
            "its record {} is malformed",
            record_path(path).display()
        )),
    }
}

/// Reads a file to a string with the path in the error.
pub fn read_to_string(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| Error::io(path, e))
}

/// The last `n` lines of a text.
pub fn tail(text: &str, n: usize) -> String {
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}

/// NaN: the `#[serde(default)]` of a figure that older stored files lack (unknown, so judged
/// by the rule that needs no such figure).
pub fn nan() -> f64 {
    f64::NAN
}

/// Deserializes an f64 that may be `null`: serde_json writes NaN and infinities as `null`, so
/// reading a stored summary back maps `null` to NaN (use with `#[serde(deserialize_with)]` on
/// fields that can be NaN: one-seed CIs, quantities a code does not report).
pub fn f64_or_nan<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    use serde::Deserialize;
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// [`f64_or_nan`] for a list: each `null` reads back as NaN.
pub fn vec_f64_or_nan<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Vec<f64>, D::Error> {
    use serde::Deserialize;
    Ok(Vec::<Option<f64>>::deserialize(d)?
        .into_iter()
        .map(|v| v.unwrap_or(f64::NAN))
        .collect())
}

/// First line of a sealed file ([`seal`]).
const SEAL_MAGIC: &str = "dem-verify sealed file";

/// The header line of a sealed file: what it is, its format version, the SHA-256 of the input
/// it belongs to (the case), and the length and SHA-256 of the payload that follows.
#[derive(serde::Serialize, serde::Deserialize)]
struct SealHeader {
    kind: String,
    version: u32,
    input_sha256: String,
    payload_len: usize,
    payload_sha256: String,
}

/// A file that proves itself: `SEAL_MAGIC`, a JSON [`SealHeader`] line, then `payload`. What a
/// resume trusts (checkpoints) is written this way, so that a bit flipped on disk, a cut or an
/// edited value, a file of another case or of another format is refused by [`unseal`].
pub fn seal(kind: &str, version: u32, input: &[u8], payload: &[u8]) -> Vec<u8> {
    let header = SealHeader {
        kind: kind.into(),
        version,
        input_sha256: sha256_hex(input),
        payload_len: payload.len(),
        payload_sha256: sha256_hex(payload),
    };
    let mut out = format!(
        "{SEAL_MAGIC}\n{}\n",
        serde_json::to_string(&header).expect("a header of strings and numbers")
    )
    .into_bytes();
    out.extend_from_slice(payload);
    out
}

/// The payload of a file written by [`seal`] with the same `kind`, `version` and `input`, or
/// why it is refused (a sentence for the user).
pub fn unseal<'a>(
    bytes: &'a [u8],
    kind: &str,
    version: u32,
    input: &[u8],
) -> std::result::Result<&'a [u8], String> {
    let mut parts = bytes.splitn(3, |b| *b == b'\n');
    let (Some(magic), Some(header), Some(payload)) = (parts.next(), parts.next(), parts.next())
    else {
        return Err("it has no header (not a sealed file, or cut short)".into());
    };
    if magic != SEAL_MAGIC.as_bytes() {
        return Err("it has no header (not a sealed file, or of an older format)".into());
    }
    let h: SealHeader =
        serde_json::from_slice(header).map_err(|e| format!("its header is unreadable ({e})"))?;
    if h.kind != kind {
        return Err(format!("it is a {}, not a {kind}", h.kind));
    }
    if h.version != version {
        return Err(format!(
            "it is of format {} (this verify reads {version})",
            h.version
        ));
    }
    if h.input_sha256 != sha256_hex(input) {
        return Err("it belongs to another case".into());
    }
    if payload.len() != h.payload_len {
        return Err(format!(
            "it holds {} bytes where its header says {} (cut short or grown)",
            payload.len(),
            h.payload_len
        ));
    }
    if sha256_hex(payload) != h.payload_sha256 {
        return Err("its checksum does not match its content (corrupted or edited)".into());
    }
    Ok(payload)
}

/// Name of the lock file a run holds in its output folder ([`DirLock`]).
pub const LOCK_NAME: &str = ".verify.lock";

/// One owner per output folder: an exclusive advisory lock on `DIR/.verify.lock`
/// (`flock`, through `std::fs::File::try_lock`), held until dropped, released by the kernel
/// when the process ends in any way (SIGKILL included), so a stale lock never blocks a rerun.
/// The file holds the owner's pid and start time, for the message a second run gets.
#[derive(Debug)]
pub struct DirLock {
    _file: std::fs::File,
}

impl DirLock {
    /// Takes the lock of `dir` (created if needed), or refuses naming `field` (`--out`) and
    /// the run that holds it. Temporary files a killed run left behind (`.tmp*` of
    /// [`write_atomic`], in `dir` and its sub-folders) are removed once the lock is held: no
    /// one else writes there.
    pub fn acquire(dir: &Path, field: &str) -> Result<DirLock> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let path = dir.join(LOCK_NAME);
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(|e| Error::io(&path, e))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                let holder = std::fs::read_to_string(&path).unwrap_or_default();
                return Err(Error::invalid(
                    field,
                    dir.display(),
                    format!(
                        "a folder no other run is writing (it is in use by {}): wait for that run, or choose another {field}",
                        if holder.trim().is_empty() {
                            "another verify run".to_string()
                        } else {
                            holder.trim().to_string()
                        }
                    ),
                ));
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(Error::io(&path, e)),
        }
        file.set_len(0).map_err(|e| Error::io(&path, e))?;
        let _ = write!(
            file,
            "verify pid {} since {}",
            std::process::id(),
            jiff::Timestamp::now()
        );
        remove_stale_temps(dir, 2);
        Ok(DirLock { _file: file })
    }
}

/// Removes `.tmp*` files (unfinished atomic writes of a killed run) in `dir` and `depth`
/// levels of sub-folders.
fn remove_stale_temps(dir: &Path, depth: usize) {
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let p = e.path();
        let Ok(t) = e.file_type() else { continue };
        if t.is_dir() && depth > 0 {
            remove_stale_temps(&p, depth - 1);
        } else if t.is_file() && e.file_name().to_string_lossy().starts_with(".tmp") {
            let _ = std::fs::remove_file(&p);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sealed_file_refuses_every_change() {
        let sealed = seal("native checkpoint", 4, b"case A", b"payload bytes");
        assert_eq!(
            unseal(&sealed, "native checkpoint", 4, b"case A").unwrap(),
            b"payload bytes"
        );
        let refused = |b: &[u8], kind, v, input: &[u8]| unseal(b, kind, v, input).unwrap_err();
        assert!(refused(&sealed, "native checkpoint", 4, b"case B").contains("another case"));
        assert!(refused(&sealed, "native checkpoint", 3, b"case A").contains("format 4"));
        assert!(refused(&sealed, "sweep cache", 4, b"case A").contains("not a sweep cache"));
        // one bit of the payload flipped, the payload cut, bytes appended
        let mut flipped = sealed.clone();
        *flipped.last_mut().unwrap() ^= 1;
        assert!(refused(&flipped, "native checkpoint", 4, b"case A").contains("checksum"));
        let cut = &sealed[..sealed.len() - 1];
        assert!(refused(cut, "native checkpoint", 4, b"case A").contains("cut short"));
        let mut grown = sealed.clone();
        grown.push(0);
        assert!(refused(&grown, "native checkpoint", 4, b"case A").contains("grown"));
        assert!(refused(b"random", "native checkpoint", 4, b"case A").contains("no header"));
        assert!(refused(b"", "native checkpoint", 4, b"case A").contains("no header"));
    }

    #[test]
    fn a_folder_has_one_owner_and_loses_its_stale_temporaries() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("seed1")).unwrap();
        std::fs::write(dir.path().join("seed1/.tmpAbC123"), b"half").unwrap();
        std::fs::write(dir.path().join("seed1/kept.csv"), b"x").unwrap();
        let first = DirLock::acquire(dir.path(), "--out").unwrap();
        assert!(!dir.path().join("seed1/.tmpAbC123").exists());
        assert!(dir.path().join("seed1/kept.csv").exists());
        let e = DirLock::acquire(dir.path(), "--out")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--out") && e.contains(&format!("pid {}", std::process::id())),
            "{e}"
        );
        drop(first);
        DirLock::acquire(dir.path(), "--out").unwrap();
    }

    #[test]
    fn atomic_write_replaces_content() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a/b.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "two");
        assert_eq!(std::fs::read_dir(p.parent().unwrap()).unwrap().count(), 1);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&p).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o644);
        }
        assert_eq!(tail("a\nb\nc", 2), "b\nc");
    }
}
