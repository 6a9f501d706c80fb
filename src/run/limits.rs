//! Bounds from the machine a run is on: threads and memory. A request above them is refused
//! before anything is allocated or spawned, with the figure it would need in the message.

use crate::error::{Error, Result};

/// Most native threads per run: 4 per core of this machine (at least 8). More threads than
/// cores only share them; thousands exhaust the process's threads (a panic) or stall.
pub fn max_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get()) * 4
}

/// The one rule for a thread count (`--threads` of every command).
pub fn check_threads(field: &str, n: usize) -> Result<usize> {
    let max = max_threads().max(8);
    if (1..=max).contains(&n) {
        Ok(n)
    } else {
        Err(Error::invalid(
            field,
            n,
            format!("1 ..= {max} (4 x this machine's cores, at least 8)"),
        ))
    }
}

/// Memory of the native solver per particle [bytes], an upper estimate: `verify bench` measured
/// a peak resident set of 840-940 bytes per particle at 250,000 particles and 1,090-1,410 at
/// 2,500 (reference/bench/20261203-epyc*; particle arrays 248, pair histories 213, pair list
/// 161, per-particle pair index 75, plate records 125), the input state and its packing
/// included. 1,500 covers the neighbour list's doubling growth.
pub const NATIVE_BYTES_PER_PARTICLE: u64 = 1_500;

/// Memory of a native run that does not grow with the particles [bytes]: the binary, thread
/// stacks and allocator arenas.
pub const NATIVE_BASE_BYTES: u64 = 256 << 20;

/// Estimated peak memory of one native run of `particles` particles [bytes].
pub fn native_estimate(particles: usize) -> u64 {
    NATIVE_BASE_BYTES.saturating_add((particles as u64).saturating_mul(NATIVE_BYTES_PER_PARTICLE))
}

/// What this process may still use [bytes] and what bounds it: the least of the memory the
/// system has available (Linux's MemAvailable), the free memory of the process's cgroup (what
/// SLURM and systemd limit) and the address space left under `ulimit -v` (RLIMIT_AS). `None`
/// when none of them can be read.
pub fn memory_available() -> Option<(u64, &'static str)> {
    use sysinfo::{MemoryRefreshKind, RefreshKind, System};
    let sys = System::new_with_specifics(
        RefreshKind::nothing().with_memory(MemoryRefreshKind::nothing().with_ram()),
    )
    .ok();
    let mut bounds: Vec<(u64, &'static str)> = Vec::new();
    if let Some(sys) = &sys {
        if sys.available_memory() > 0 {
            bounds.push((
                sys.available_memory(),
                "the memory this machine has available",
            ));
        }
        if let Some(c) = sys.cgroup_limits() {
            bounds.push((c.free_memory, "the free memory of this process's cgroup"));
        }
    }
    if let Some(left) = address_space_left() {
        bounds.push((left, "the address space left under `ulimit -v`"));
    }
    bounds.into_iter().min_by_key(|b| b.0)
}

/// The address space this process may still map under RLIMIT_AS [bytes], `None` when it is
/// unlimited or unreadable.
fn address_space_left() -> Option<u64> {
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes one rlimit into the valid, exclusively borrowed `lim`.
    if unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut lim) } != 0
        || lim.rlim_cur == libc::RLIM_INFINITY
    {
        return None;
    }
    // the process's current virtual size: first field of /proc/self/statm, in pages
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().next()?.parse().ok()?;
    // SAFETY: sysconf reads a constant of the system; no memory is touched.
    let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    let used = pages.saturating_mul(u64::try_from(page).ok()?);
    Some(lim.rlim_cur.saturating_sub(used))
}

/// The one memory rule of a native run: refused when its estimate ([`native_estimate`]) is more
/// than [`memory_available`], naming the field, the estimate and the bound.
pub fn check_memory(field: &str, particles: usize) -> Result<()> {
    let need = native_estimate(particles);
    match memory_available() {
        Some((have, what)) if need > have => Err(Error::invalid(
            field,
            particles,
            format!(
                "at most {} particles here: a native run of {particles} needs about {:.2} GB \
                 ({NATIVE_BYTES_PER_PARTICLE} bytes per particle + {} MB), more than {what} \
                 ({:.2} GB)",
                have.saturating_sub(NATIVE_BASE_BYTES) / NATIVE_BYTES_PER_PARTICLE,
                need as f64 / 1e9,
                NATIVE_BASE_BYTES >> 20,
                have as f64 / 1e9
            ),
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn estimate_grows_with_particles_and_saturates() {
        assert_eq!(native_estimate(0), NATIVE_BASE_BYTES);
        assert_eq!(
            native_estimate(1_000_000) - native_estimate(0),
            1_000_000 * NATIVE_BYTES_PER_PARTICLE
        );
        assert_eq!(native_estimate(usize::MAX), u64::MAX);
    }

    #[test]
    fn this_machine_reports_a_bound() {
        let (have, _) = memory_available().expect("a Linux machine reports MemAvailable");
        assert!(have > 0);
        // the ci box fits on any machine the tests run on
        check_memory("particles", 400).unwrap();
    }
}
