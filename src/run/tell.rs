//! What the library tells its user while it works: the lines of a run's account (what it
//! does, each result as it arrives), warnings that do not stop it, and progress (steps,
//! simulated time, ETA). The library never writes to the terminal itself: it says what it
//! has to say here, and the command layer decides where that goes by installing a [`Sink`]
//! once at start-up (`verify` prints lines on stdout, warnings on stderr, and draws progress
//! bars on a terminal: `cli::console`). Without a sink (tests, library use) nothing is said.
//! The same shape as the `log` facade, kept apart from it because these lines are the
//! commands' output, not diagnostics (`RUST_LOG` governs those).

use std::sync::OnceLock;

/// One progress report of a run: where it stands and how fast it goes.
#[derive(Clone, Debug)]
pub struct Tick<'a> {
    /// The run's label (`native s1`, a sweep's `run 3/20 native`).
    pub label: &'a str,
    /// What happened.
    pub event: Event<'a>,
}

/// What a [`Tick`] reports.
#[derive(Clone, Debug)]
pub enum Event<'a> {
    /// The run is at `step` of `total` (simulated time `sim_time` s, `elapsed` s since it
    /// started or resumed, `eta` s left); `decile` is `Some(d)` when it just passed `10 d` %
    /// (what a log without a live display shows), `None` for a live display's update.
    Step {
        step: u64,
        total: u64,
        sim_time: f64,
        elapsed: f64,
        eta: f64,
        decile: Option<u64>,
    },
    /// The run continues from `step` (a checkpoint), with a note saying so.
    Resumed {
        step: u64,
        total: u64,
        note: &'a str,
    },
    /// The run ended.
    Finished,
}

/// Where what the library says goes.
pub trait Sink: Send + Sync {
    /// A line of a command's account.
    fn line(&self, text: &str);
    /// Something the user should know that does not stop the run.
    fn warning(&self, text: &str);
    /// A note on what the run does about something it met (a checkpoint it cannot resume).
    fn note(&self, text: &str);
    /// A run's progress.
    fn progress(&self, tick: &Tick);
    /// True when progress is shown live (a bar redrawn at every step) rather than as lines.
    fn live(&self) -> bool {
        false
    }
}

static SINK: OnceLock<Box<dyn Sink>> = OnceLock::new();

/// Installs the sink for the rest of the process; false if one was installed already (the
/// first stays).
pub fn install(sink: Box<dyn Sink>) -> bool {
    SINK.set(sink).is_ok()
}

/// `f` on the installed sink, if any.
fn to_sink(f: impl FnOnce(&dyn Sink)) {
    if let Some(s) = SINK.get() {
        f(s.as_ref());
    }
}

/// Says a line of the command's account.
pub fn line(text: &str) {
    to_sink(|s| s.line(text));
}

/// Says a warning.
pub fn warning(text: &str) {
    to_sink(|s| s.warning(text));
}

/// Says a note.
pub fn note(text: &str) {
    to_sink(|s| s.note(text));
}

/// Reports progress.
pub fn progress(tick: &Tick) {
    to_sink(|s| s.progress(tick));
}

/// True when the installed sink shows progress live.
pub fn live() -> bool {
    SINK.get().is_some_and(|s| s.live())
}

/// `say!(...)`: a line of the command's account, formatted as `format!` does.
macro_rules! say {
    () => {
        $crate::run::tell::line("")
    };
    ($($t:tt)*) => {
        $crate::run::tell::line(&format!($($t)*))
    };
}
pub(crate) use say;
