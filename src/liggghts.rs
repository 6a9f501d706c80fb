//! The one place that spawns LIGGGHTS: writes a deck into a temporary directory, runs
//! `liggghts -in in.deck -log log.liggghts` with a timeout, and parses its dumps back into
//! the same [`Frame`]s the native solver produces. A missing binary says how to install it;
//! a failed run shows the tail of its log.

use crate::deck::{Deck, ATOM_DUMP, CONTACT_DUMP, DECK_NAME};
use crate::error::{Error, Result};
use crate::fsutil::{read_to_string, tail};
use crate::solver::contact::ContactHistory;
use crate::solver::{AtomState, Frame};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Name of the LIGGGHTS log file in a run directory.
pub const LOG_NAME: &str = "log.liggghts";

/// A located LIGGGHTS binary.
#[derive(Clone, Debug)]
pub struct Liggghts {
    pub binary: PathBuf,
    pub timeout: Duration,
    /// Run on this many MPI processes (`mpirun --allow-run-as-root -np N`); None: serial.
    pub mpi_procs: Option<usize>,
}

/// Finds `name` on PATH (`which`), or accepts an explicit path (a name with a directory part)
/// that is a file.
fn which(name: &Path) -> Option<PathBuf> {
    if name.components().count() > 1 {
        return name.is_file().then(|| name.to_path_buf());
    }
    which::which(name).ok()
}

impl Liggghts {
    /// Locates the binary (`liggghts` on PATH unless given).
    pub fn locate(binary: Option<&Path>, timeout: Duration) -> Result<Self> {
        let name = binary.unwrap_or(Path::new("liggghts"));
        let binary = which(name).ok_or_else(|| Error::LiggghtsMissing {
            binary: name.display().to_string(),
        })?;
        Ok(Liggghts {
            binary,
            timeout,
            mpi_procs: None,
        })
    }

    /// Debian package version of LIGGGHTS if dpkg knows it, else the binary path.
    pub fn version(&self) -> String {
        Command::new("dpkg-query")
            .args(["-W", "-f=${Version}", "liggghts"])
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| {
                format!(
                    "LIGGGHTS-PUBLIC 3.8.0 (Debian liggghts {})",
                    String::from_utf8_lossy(&o.stdout)
                )
            })
            .unwrap_or_else(|| format!("LIGGGHTS at {}", self.binary.display()))
    }

    /// Writes `deck` into `dir` and runs it there. On failure returns the log tail.
    pub fn run(&self, deck: &Deck, dir: &Path) -> Result<()> {
        self.run_with_progress(deck, dir, |_| {})
    }

    /// As [`Liggghts::run`], calling `poll` with the run directory about every 0.5 s while
    /// LIGGGHTS runs (for progress reports).
    pub fn run_with_progress(
        &self,
        deck: &Deck,
        dir: &Path,
        mut poll: impl FnMut(&Path),
    ) -> Result<()> {
        for (name, text) in &deck.files {
            let p = dir.join(name);
            std::fs::write(&p, text).map_err(|e| Error::io(&p, e))?;
        }
        let screen = dir.join("screen.txt");
        let out = std::fs::File::create(&screen).map_err(|e| Error::io(&screen, e))?;
        let err = out.try_clone().map_err(|e| Error::io(&screen, e))?;
        // stdout is redirected to a file: `-screen none` crashes LIGGGHTS 3.8 with STL meshes.
        let mut cmd = match self.mpi_procs {
            Some(n) => {
                let mut c = Command::new("mpirun");
                c.args(["--allow-run-as-root", "-np", &n.to_string()])
                    .arg(&self.binary);
                c
            }
            None => Command::new(&self.binary),
        };
        die_with_parent(&mut cmd);
        // LIGGGHTS is an MPI program of its own: started by a rank of `mpirun` (a decomposed
        // native run, issue #39) it would read that job's launcher variables and fail in
        // MPI_Init ("ompi_rte_init failed"); it starts as its own job
        for (k, _) in std::env::vars_os() {
            let k = k.to_string_lossy();
            if ["OMPI_", "PMIX_", "PMI_", "OPAL_", "ORTE_"]
                .iter()
                .any(|p| k.starts_with(p))
            {
                cmd.env_remove(k.as_ref());
            }
        }
        let mut child = cmd
            .args(["-in", DECK_NAME, "-log", LOG_NAME])
            .current_dir(dir)
            .stdin(Stdio::null())
            .stdout(out)
            .stderr(err)
            .spawn()
            .map_err(|e| Error::io(&self.binary, e))?;
        let start = Instant::now();
        let mut last_poll = Instant::now();
        let status = loop {
            if last_poll.elapsed() > Duration::from_millis(500) {
                poll(dir);
                last_poll = Instant::now();
            }
            if let Some(s) = child.try_wait().map_err(|e| Error::io(&self.binary, e))? {
                break s;
            }
            if start.elapsed() > self.timeout {
                kill_tree(child.id());
                let _ = child.kill();
                let _ = child.wait();
                return Err(self.failure(dir, format!("timed out after {:?}", self.timeout)));
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        let log = std::fs::read_to_string(dir.join(LOG_NAME)).unwrap_or_default();
        if !status.success() || log.contains("ERROR") {
            return Err(self.failure(dir, status.to_string()));
        }
        Ok(())
    }

    fn failure(&self, dir: &Path, reason: String) -> Error {
        // `status.to_string()` reads "exit status: 1" or "signal: 9 (SIGKILL)"
        let log = dir.join(LOG_NAME);
        let text = std::fs::read_to_string(&log)
            .or_else(|_| std::fs::read_to_string(dir.join("screen.txt")))
            .unwrap_or_else(|_| "(no log written)".into());
        Error::LiggghtsFailed {
            reason,
            log,
            tail: tail(&text, 25),
        }
    }
}

/// Makes the spawned process (LIGGGHTS or mpirun, which passes it on to its ranks) receive
/// SIGTERM when the thread that spawned it ends, whatever ends it: SIGTERM from SLURM or
/// systemd, SIGKILL, a panic. Without it a killed `verify` leaves LIGGGHTS running and
/// writing into the run's folder. The spawning thread waits for the child
/// ([`Liggghts::run_with_progress`]), so it outlives it in every normal run.
#[cfg(target_os = "linux")]
fn die_with_parent(cmd: &mut Command) {
    use std::os::unix::process::CommandExt;
    let parent = std::process::id();
    // SAFETY: the closure runs in the forked child before exec; it calls only prctl, getppid
    // and _exit, which are async-signal-safe, and allocates nothing. The getppid check
    // closes the race of a parent that died before prctl took effect.
    unsafe {
        cmd.pre_exec(move || {
            if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            if libc::getppid() as u32 != parent {
                libc::_exit(143);
            }
            Ok(())
        });
    }
}

#[cfg(not(target_os = "linux"))]
fn die_with_parent(_cmd: &mut Command) {}

/// One `ITEM: TIMESTEP` block of a LAMMPS text dump: step and the data rows.
fn dump_blocks(path: &Path) -> Result<Vec<(u64, Vec<Vec<f64>>)>> {
    let text = read_to_string(path)?;
    let bad = |msg: String| Error::Parse {
        path: path.to_path_buf(),
        msg,
    };
    let mut blocks = Vec::new();
    let mut lines = text.lines().enumerate().peekable();
    while let Some((ln, line)) = lines.next() {
        if line.trim() != "ITEM: TIMESTEP" {
            return Err(bad(format!(
                "line {}: expected `ITEM: TIMESTEP`, got {line:?}",
                ln + 1
            )));
        }
        let step: u64 = lines
            .next()
            .and_then(|(_, l)| l.trim().parse().ok())
            .ok_or_else(|| bad(format!("line {}: missing step", ln + 2)))?;
        let mut count = None;
        // Header items until the data item (ATOMS or ENTRIES).
        loop {
            let (ln, l) = lines.next().ok_or_else(|| bad("truncated header".into()))?;
            if l.starts_with("ITEM: NUMBER OF") {
                let n: usize = lines
                    .next()
                    .and_then(|(_, l)| l.trim().parse().ok())
                    .ok_or_else(|| bad(format!("line {}: missing count", ln + 2)))?;
                count = Some(n);
            } else if l.starts_with("ITEM: ATOMS") || l.starts_with("ITEM: ENTRIES") {
                break;
            }
        }
        let n = count.ok_or_else(|| bad(format!("step {step}: no count")))?;
        let mut rows = Vec::with_capacity(n);
        for _ in 0..n {
            let (ln, l) = lines
                .next()
                .ok_or_else(|| bad(format!("step {step}: truncated data")))?;
            let row: std::result::Result<Vec<f64>, _> =
                l.split_whitespace().map(str::parse).collect();
            rows.push(row.map_err(|e| bad(format!("line {}: {e}", ln + 1)))?);
        }
        blocks.push((step, rows));
    }
    Ok(blocks)
}

/// Parses `atoms.dump` and `contact.dump` of a finished contact run into frames.
/// Contact history is oriented as stored with atom 1 as `i`: if LIGGGHTS listed the pair
/// as (2, 1), the history (all slots are `newtonflag` 1) is negated.
pub fn read_contact_frames(dir: &Path, n_hist: usize, is_wall: bool) -> Result<Vec<Frame>> {
    let atoms = dump_blocks(&dir.join(ATOM_DUMP))?;
    let contacts = dump_blocks(&dir.join(CONTACT_DUMP))?;
    let cpath = dir.join(CONTACT_DUMP);
    let mut frames = Vec::with_capacity(atoms.len());
    let mut cit = contacts.into_iter().peekable();
    for (step, rows) in atoms {
        let mut fr = Frame {
            step,
            atoms: Vec::with_capacity(rows.len()),
            touching: false,
            history: ContactHistory::default(),
        };
        for r in rows {
            if r.len() != 16 {
                return Err(Error::Parse {
                    path: dir.join(ATOM_DUMP),
                    msg: format!("step {step}: expected 16 columns, got {}", r.len()),
                });
            }
            let v = |k: usize| [r[k], r[k + 1], r[k + 2]];
            fr.atoms.push(AtomState {
                x: v(1),
                v: v(4),
                f: v(7),
                omega: v(10),
                torque: v(13),
            });
        }
        while let Some((cs, _)) = cit.peek() {
            if *cs < step {
                cit.next();
            } else {
                break;
            }
        }
        if let Some((cs, crow)) = cit.peek() {
            if *cs == step && !crow.is_empty() {
                let r = &crow[0];
                if crow.len() > 1 || r.len() != 3 + n_hist {
                    return Err(Error::Parse {
                        path: cpath.clone(),
                        msg: format!(
                            "step {step}: expected one contact with {} columns",
                            3 + n_hist
                        ),
                    });
                }
                // pair/gran/local ids: (id_i, id_j, periodic); wall/gran/local: (mesh, tri, atom).
                let sign = if !is_wall && r[0] == 2.0 && r[1] == 1.0 {
                    -1.0
                } else {
                    1.0
                };
                let h = &r[3..];
                fr.touching = true;
                fr.history.shear = [sign * h[0], sign * h[1], sign * h[2]];
                if n_hist == 6 {
                    fr.history.r_torque = [sign * h[3], sign * h[4], sign * h[5]];
                }
            }
        }
        frames.push(fr);
    }
    Ok(frames)
}

/// A parse error of a LIGGGHTS output file.
pub fn parse_err(path: &Path, msg: impl Into<String>) -> Error {
    Error::Parse {
        path: path.to_path_buf(),
        msg: msg.into(),
    }
}

/// Rows of a LIGGGHTS dump after its `ITEM: ATOMS` / `ITEM: ENTRIES` header, checking the
/// step, the row count and that every row has `ncol` numbers.
pub fn dump_rows(path: &Path, step: u64, ncol: usize) -> Result<Vec<Vec<f64>>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut lines = text.lines();
    let mut count: Option<usize> = None;
    let mut got_step = None;
    while let Some(l) = lines.next() {
        if l.starts_with("ITEM: TIMESTEP") {
            got_step = lines.next().and_then(|s| s.trim().parse::<u64>().ok());
        } else if l.starts_with("ITEM: NUMBER OF") {
            count = lines.next().and_then(|s| s.trim().parse::<usize>().ok());
        } else if l.starts_with("ITEM: ATOMS") || l.starts_with("ITEM: ENTRIES") {
            let cols = l.split_whitespace().count() - 2;
            if cols != ncol {
                return Err(parse_err(
                    path,
                    format!("{cols} columns, expected {ncol} (a history layout from another rolling model?)"),
                ));
            }
            break;
        }
    }
    if got_step != Some(step) {
        return Err(parse_err(
            path,
            format!("timestep {got_step:?}, expected {step}"),
        ));
    }
    let count = count.ok_or_else(|| parse_err(path, "no NUMBER OF ATOMS/ENTRIES"))?;
    let mut rows = Vec::with_capacity(count);
    for (k, l) in lines.enumerate() {
        let v: Vec<f64> = l
            .split_whitespace()
            .map(|t| t.parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|e| parse_err(path, format!("row {}: {e}", k + 1)))?;
        if v.len() != ncol {
            return Err(parse_err(
                path,
                format!("row {} has {} values, expected {ncol}", k + 1, v.len()),
            ));
        }
        rows.push(v);
    }
    if rows.len() != count {
        return Err(parse_err(
            path,
            format!("{} rows, header says {count}", rows.len()),
        ));
    }
    Ok(rows)
}

/// The atom rows of a dump sorted by id (`dump_modify sort id`): [`dump_rows`], then exactly
/// `atoms` rows whose first column is the id 1, 2, ... (a lost atom or a reordered dump is an
/// error naming the file).
pub fn dump_atoms(path: &Path, step: u64, ncol: usize, atoms: usize) -> Result<Vec<Vec<f64>>> {
    let rows = dump_rows(path, step, ncol)?;
    if rows.len() != atoms {
        return Err(parse_err(
            path,
            format!("{} atoms, the case has {atoms} (atoms lost?)", rows.len()),
        ));
    }
    if let Some(k) = (0..rows.len()).find(|&k| rows[k][0] as usize != k + 1) {
        return Err(parse_err(
            path,
            format!(
                "row {} holds atom id {}, expected {}",
                k + 1,
                rows[k][0],
                k + 1
            ),
        ));
    }
    Ok(rows)
}

/// Thermo rows of a LIGGGHTS log: (step, values) for every row with `ncol` values after the
/// step, keeping the first row of each step (a new `run` repeats the last step, with the
/// mesh force accumulated twice during setup).
pub fn read_thermo(log: &Path, ncol: usize) -> Result<Vec<(u64, Vec<f64>)>> {
    let text = read_to_string(log)?;
    Ok(parse_thermo(&text, ncol))
}

/// See [`read_thermo`].
pub fn parse_thermo(text: &str, ncol: usize) -> Vec<(u64, Vec<f64>)> {
    let mut rows: Vec<(u64, Vec<f64>)> = Vec::new();
    let mut in_table = false;
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with("Step ") {
            in_table = true;
            continue;
        }
        if !in_table {
            continue;
        }
        let mut it = t.split_whitespace();
        let Some(step) = it.next().and_then(|s| s.parse::<u64>().ok()) else {
            in_table = false;
            continue;
        };
        let vals: Vec<f64> = it.filter_map(|s| s.parse().ok()).collect();
        if vals.len() != ncol {
            in_table = false;
            continue;
        }
        if rows.last().is_some_and(|(s, _)| *s >= step) {
            continue;
        }
        rows.push((step, vals));
    }
    rows
}

/// The last thermo step written so far (for progress), if any.
pub fn last_thermo_step(log: &Path, ncol: usize) -> Option<u64> {
    let text = std::fs::read_to_string(log).ok()?;
    parse_thermo(&text, ncol).last().map(|r| r.0)
}

/// Wall time of the last `run` in a LIGGGHTS log: `Loop time of T on P procs for N steps`.
pub fn last_loop_time(log: &Path) -> Result<(f64, u64)> {
    let text = read_to_string(log)?;
    text.lines()
        .rev()
        .find_map(|l| {
            let rest = l.strip_prefix("Loop time of ")?;
            let mut it = rest.split_whitespace();
            let t: f64 = it.next()?.parse().ok()?;
            let steps: u64 = rest
                .split(" for ")
                .nth(1)?
                .split_whitespace()
                .next()?
                .parse()
                .ok()?;
            Some((t, steps))
        })
        .ok_or_else(|| Error::Parse {
            path: log.to_path_buf(),
            msg: "no `Loop time of` line".into(),
        })
}

/// Neighbour list builds of the last `run` in a LIGGGHTS log: the `Neighbor list builds = N`
/// line of its statistics (after its `Loop time of` line); None when that run printed none.
pub fn last_neighbor_builds(log: &Path) -> Result<Option<u64>> {
    Ok(parse_last_neighbor_builds(&read_to_string(log)?))
}

fn parse_last_neighbor_builds(text: &str) -> Option<u64> {
    let (_, last_run) = text.rsplit_once("Loop time of ")?;
    last_run
        .lines()
        .find_map(|l| l.strip_prefix("Neighbor list builds = "))?
        .trim()
        .parse()
        .ok()
}

/// Kills every descendant of process `pid` (a wrapper script's LIGGGHTS, the ranks under
/// `mpirun`), deepest first, so a timeout leaves nothing running. The process itself is left
/// to the caller. The tree is read again until no descendant is left (a dying wrapper may
/// have started one more).
pub fn kill_tree(pid: u32) {
    use sysinfo::{Pid, ProcessRefreshKind, ProcessesToUpdate, Signal, System};
    let Ok(mut sys) = System::new() else {
        return; // no process table to read: only the direct child is killed
    };
    for _ in 0..20 {
        sys.refresh_processes_specifics(
            ProcessesToUpdate::All,
            true,
            ProcessRefreshKind::nothing(),
        );
        let root = Pid::from_u32(pid);
        let mut tree = vec![root];
        let mut k = 0;
        while k < tree.len() {
            let parent = tree[k];
            tree.extend(
                sys.processes()
                    .iter()
                    .filter(|(_, p)| p.parent() == Some(parent))
                    .map(|(id, _)| *id),
            );
            k += 1;
        }
        if tree.len() == 1 {
            return;
        }
        for id in tree[1..].iter().rev() {
            if let Some(p) = sys.process(*id) {
                p.kill_with(Signal::Kill);
            }
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbour_builds_are_those_of_the_last_run() {
        let log = "Loop time of 0.1 on 1 procs for 1 steps\nNeighbor list builds = 0\n\
                   run 2500\nLoop time of 2.4 on 1 procs for 2500 steps\n\nTotal # of \
                   neighbors = 12089\nNeighbor list builds = 10\nDangerous builds = 0\n";
        assert_eq!(parse_last_neighbor_builds(log), Some(10));
        let unfinished = "Loop time of 0.1 on 1 procs for 1 steps\nNeighbor list builds = 3\n\
                          Loop time of 2.4 on 1 procs for 2500 steps\n";
        assert_eq!(parse_last_neighbor_builds(unfinished), None);
        assert_eq!(parse_last_neighbor_builds("no run here"), None);
    }

    #[test]
    fn thermo_keeps_first_row_of_each_step() {
        let log =
            "Step a b\n 0 1 2\n 100 3 4\nLoop time of 1\nStep a b\n 100 6 8\n 200 5 6\nLoop time\n";
        let r = parse_thermo(log, 2);
        assert_eq!(
            r,
            vec![
                (0, vec![1.0, 2.0]),
                (100, vec![3.0, 4.0]),
                (200, vec![5.0, 6.0])
            ]
        );
    }
}
