//! Progress of long runs: steps, simulated time and ETA. An indicatif bar on a terminal;
//! elsewhere (CI, logs) one line per 10 % so that the output stays readable.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Progress of one run of `total` steps of `dt` seconds.
pub struct Progress {
    label: String,
    total: u64,
    dt: f64,
    bar: Option<ProgressBar>,
    last_decile: AtomicU64,
    start: Instant,
    /// The step the run (re)started from: the rate and ETA count only steps run since.
    base: AtomicU64,
}

impl Progress {
    /// A bar added to `multi` (terminal) or a line printer.
    pub fn new(multi: &MultiProgress, label: &str, total: u64, dt: f64) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let b = multi.add(ProgressBar::with_draw_target(
                Some(total),
                ProgressDrawTarget::stderr(),
            ));
            b.set_style(
                ProgressStyle::with_template(
                    "{prefix:>10} [{bar:30}] {pos}/{len} steps  {msg}  ETA {eta}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            b.set_prefix(label.to_string());
            b
        });
        Progress {
            label: label.to_string(),
            total,
            dt,
            bar,
            last_decile: AtomicU64::new(0),
            start: Instant::now(),
            base: AtomicU64::new(0),
        }
    }

    /// Lines only (one per 10 %, never a bar), for runs that go beside others (a sweep's).
    pub fn lines(label: &str, total: u64, dt: f64) -> Self {
        Progress {
            label: label.to_string(),
            total,
            dt,
            bar: None,
            last_decile: AtomicU64::new(0),
            start: Instant::now(),
            base: AtomicU64::new(0),
        }
    }

    /// A progress that reports nothing (tests, library use).
    pub fn hidden() -> Self {
        Progress {
            label: String::new(),
            total: 0,
            dt: 0.0,
            bar: None,
            last_decile: AtomicU64::new(u64::MAX),
            start: Instant::now(),
            base: AtomicU64::new(0),
        }
    }

    /// The run continues from `step` (a checkpoint): says `note`, and counts rate and ETA
    /// from here.
    pub fn resume_at(&self, step: u64, note: &str) {
        self.base.store(step, Ordering::Relaxed);
        match &self.bar {
            Some(b) => {
                b.set_position(step);
                b.reset_eta();
                b.println(format!("{:>10}: {note}", self.label));
            }
            None if self.total > 0 => {
                self.last_decile
                    .store(step * 10 / self.total, Ordering::Relaxed);
                eprintln!("{:>10}: {note}", self.label);
            }
            None => {}
        }
    }

    pub fn set(&self, step: u64) {
        let sim = step as f64 * self.dt;
        match &self.bar {
            Some(b) => {
                b.set_position(step);
                b.set_message(format!("t = {sim:.4e} s"));
            }
            None => {
                if self.total == 0 {
                    return;
                }
                let decile = step * 10 / self.total;
                let prev = self.last_decile.load(Ordering::Relaxed);
                if prev != u64::MAX
                    && decile > prev
                    && self
                        .last_decile
                        .compare_exchange(prev, decile, Ordering::Relaxed, Ordering::Relaxed)
                        .is_ok()
                {
                    let el = self.start.elapsed().as_secs_f64();
                    let done = step
                        .saturating_sub(self.base.load(Ordering::Relaxed))
                        .max(1);
                    let eta = el / done as f64 * (self.total - step.min(self.total)) as f64;
                    eprintln!(
                        "{:>10}: {:>3} %  step {step}/{}  t = {sim:.4e} s  elapsed {el:.0} s  ETA {eta:.0} s",
                        self.label,
                        decile * 10,
                        self.total
                    );
                }
            }
        }
    }

    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish();
        }
    }
}
