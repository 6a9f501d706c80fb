//! Progress of long runs: steps, simulated time, rate and ETA, counted here and shown by the
//! command layer through [`super::tell`]: a live bar on a terminal, elsewhere (CI, logs,
//! runs that go beside others) one line per 10 % so that the output stays readable.

use super::tell::{self, Event, Tick};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// How a [`Progress`] reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shown {
    /// Every step, when the sink shows progress live; else every 10 %.
    Live,
    /// Every 10 % only.
    Lines,
    /// Never.
    Hidden,
}

/// Progress of one run of `total` steps of `dt` seconds.
pub struct Progress {
    label: String,
    total: u64,
    dt: f64,
    shown: Shown,
    last_decile: AtomicU64,
    start: Instant,
    /// The step the run (re)started from: the rate and ETA count only steps run since.
    base: AtomicU64,
}

impl Progress {
    fn with(label: &str, total: u64, dt: f64, shown: Shown) -> Self {
        Progress {
            label: label.to_string(),
            total,
            dt,
            shown,
            last_decile: AtomicU64::new(0),
            start: Instant::now(),
            base: AtomicU64::new(0),
        }
    }

    /// A live display if the sink has one (a terminal), else one line per 10 %.
    pub fn new(label: &str, total: u64, dt: f64) -> Self {
        let shown = if tell::live() {
            Shown::Live
        } else {
            Shown::Lines
        };
        Self::with(label, total, dt, shown)
    }

    /// Lines only (one per 10 %, never live), for runs that go beside others (a sweep's).
    pub fn lines(label: &str, total: u64, dt: f64) -> Self {
        Self::with(label, total, dt, Shown::Lines)
    }

    /// A progress that reports nothing (tests, runs inside others).
    pub fn hidden() -> Self {
        Self::with("", 0, 0.0, Shown::Hidden)
    }

    fn say(&self, event: Event) {
        tell::progress(&Tick {
            label: &self.label,
            event,
        });
    }

    /// The run continues from `step` (a checkpoint): says `note`, and counts rate and ETA
    /// from here.
    pub fn resume_at(&self, step: u64, note: &str) {
        self.base.store(step, Ordering::Relaxed);
        if self.shown == Shown::Hidden || self.total == 0 {
            return;
        }
        self.last_decile
            .store(step * 10 / self.total, Ordering::Relaxed);
        self.say(Event::Resumed {
            step,
            total: self.total,
            note,
        });
    }

    /// The run is at `step`.
    pub fn set(&self, step: u64) {
        if self.shown == Shown::Hidden || self.total == 0 {
            return;
        }
        let decile = step * 10 / self.total;
        let prev = self.last_decile.load(Ordering::Relaxed);
        let passed = decile > prev
            && self
                .last_decile
                .compare_exchange(prev, decile, Ordering::Relaxed, Ordering::Relaxed)
                .is_ok();
        if !passed && self.shown != Shown::Live {
            return;
        }
        let elapsed = self.start.elapsed().as_secs_f64();
        let done = step
            .saturating_sub(self.base.load(Ordering::Relaxed))
            .max(1);
        let eta = elapsed / done as f64 * (self.total - step.min(self.total)) as f64;
        self.say(Event::Step {
            step,
            total: self.total,
            sim_time: step as f64 * self.dt,
            elapsed,
            eta,
            decile: passed.then_some(decile),
        });
    }

    /// The run ended.
    pub fn finish(&self) {
        if self.shown != Shown::Hidden {
            self.say(Event::Finished);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hidden_progress_counts_nothing_and_lines_pass_each_decile_once() {
        let h = Progress::hidden();
        h.set(5);
        assert_eq!(h.last_decile.load(Ordering::Relaxed), 0);
        let p = Progress::lines("x", 100, 1e-6);
        p.set(9);
        assert_eq!(p.last_decile.load(Ordering::Relaxed), 0);
        p.set(25);
        assert_eq!(p.last_decile.load(Ordering::Relaxed), 2);
        p.resume_at(70, "resumed");
        assert_eq!(p.last_decile.load(Ordering::Relaxed), 7);
        p.set(71);
        assert_eq!(p.last_decile.load(Ordering::Relaxed), 7);
    }
}
