//! Where `verify` shows what the library tells ([`crate::run::tell`]): a command's account on
//! stdout, warnings and notes on stderr, progress on stderr (a bar per run on a terminal,
//! one line per 10 % elsewhere). Installed once by `main`.

use crate::run::tell::{self, Event, Sink, Tick};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::collections::HashMap;
use std::io::IsTerminal;
use std::sync::Mutex;

/// The terminal (or the log a command's output goes to).
pub struct Console {
    /// Bars are drawn when stderr is a terminal.
    live: bool,
    multi: MultiProgress,
    bars: Mutex<HashMap<String, ProgressBar>>,
}

impl Console {
    fn new() -> Self {
        Console {
            live: std::io::stderr().is_terminal(),
            multi: MultiProgress::new(),
            bars: Mutex::new(HashMap::new()),
        }
    }

    /// The bar of run `label`, made at its first report.
    fn bar(&self, label: &str, total: u64) -> ProgressBar {
        let mut bars = self.bars.lock().unwrap_or_else(|e| e.into_inner());
        bars.entry(label.to_string())
            .or_insert_with(|| {
                let b = self.multi.add(ProgressBar::with_draw_target(
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
            })
            .clone()
    }
}

impl Sink for Console {
    fn line(&self, text: &str) {
        println!("{text}");
    }

    fn warning(&self, text: &str) {
        eprintln!("warning: {text}");
    }

    fn note(&self, text: &str) {
        eprintln!("note: {text}");
    }

    fn progress(&self, t: &Tick) {
        let label = t.label;
        match (&t.event, self.live) {
            (
                Event::Step {
                    step,
                    total,
                    sim_time,
                    ..
                },
                true,
            ) => {
                let b = self.bar(label, *total);
                b.set_position(*step);
                b.set_message(format!("t = {sim_time:.4e} s"));
            }
            (
                Event::Step {
                    step,
                    total,
                    sim_time,
                    elapsed,
                    eta,
                    decile: Some(d),
                },
                false,
            ) => eprintln!(
                "{label:>10}: {:>3} %  step {step}/{total}  t = {sim_time:.4e} s  elapsed \
                 {elapsed:.0} s  ETA {eta:.0} s",
                d * 10
            ),
            (Event::Step { decile: None, .. }, false) => {}
            (Event::Resumed { step, total, note }, true) => {
                let b = self.bar(label, *total);
                b.set_position(*step);
                b.reset_eta();
                b.println(format!("{label:>10}: {note}"));
            }
            (Event::Resumed { note, .. }, false) => eprintln!("{label:>10}: {note}"),
            (Event::Finished, _) => {
                let bar = self
                    .bars
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .remove(label);
                if let Some(b) = bar {
                    b.finish();
                }
            }
        }
    }

    fn live(&self) -> bool {
        self.live
    }
}

/// Installs the console as the library's sink (once per process).
pub fn install() {
    tell::install(Box::new(Console::new()));
}
