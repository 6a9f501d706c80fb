//! Where a stage is judged and sampled, the same for both codes and every command: the steady
//! window (the second half of a shear stage) and the velocity-profile sample steps inside it.

use crate::spec::shear::ShearCase;
use serde::{Deserialize, Serialize};

/// Steady window rule: the second half (by steps) of a shear stage.
pub fn steady_window(stage_start: u64, stage_end: u64) -> (u64, u64) {
    (stage_start + (stage_end - stage_start) / 2, stage_end)
}

/// Samples per stage, evenly spaced over its steady window.
pub const SAMPLES_PER_STAGE: u64 = 20;

/// The sample steps of one stage: `first + every k` for k = 0 .. samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SampleWindow {
    pub stage: usize,
    pub first: u64,
    pub every: u64,
    pub samples: u64,
}

impl SampleWindow {
    pub fn steps(&self) -> impl Iterator<Item = u64> + '_ {
        (0..self.samples).map(|k| self.first + k * self.every)
    }

    pub fn last(&self) -> u64 {
        self.first + (self.samples - 1) * self.every
    }
}

/// Where both codes sample: per stage, up to [`SAMPLES_PER_STAGE`] output steps (multiples of
/// `output_every`, where both codes record the top plate's position) evenly spaced over its
/// steady window, the last at or just before the stage's end.
pub fn schedule(case: &ShearCase) -> Vec<SampleWindow> {
    let ends = case.run_ends();
    let out = case.output_every;
    (1..ends.len())
        .filter_map(|k| {
            let (a, b) = steady_window(ends[k - 1], ends[k]);
            let last = b / out * out;
            let span = last.checked_sub(a)?;
            let every = (span / SAMPLES_PER_STAGE / out).max(1) * out;
            let samples = (span.saturating_sub(1) / every + 1).min(SAMPLES_PER_STAGE);
            (last > a).then_some(SampleWindow {
                stage: k - 1,
                first: last - (samples - 1) * every,
                every,
                samples,
            })
        })
        .collect()
}

/// Whether `step` is a sample step of the schedule.
pub fn is_sample(windows: &[SampleWindow], step: u64) -> bool {
    windows
        .iter()
        .any(|w| step >= w.first && step <= w.last() && (step - w.first).is_multiple_of(w.every))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::shear::Preset;
    use crate::spec::RollingModel;

    /// The steady window is the second half of the stage, wherever the stage starts.
    #[test]
    fn steady_window_is_the_second_half_of_the_stage() {
        assert_eq!(steady_window(0, 30), (15, 30));
        assert_eq!(steady_window(100, 300), (200, 300));
    }

    #[test]
    fn schedule_samples_the_steady_window() {
        let c = ShearCase::preset(Preset::Ci, RollingModel::Epsd, 0.0, 0.0, 1).unwrap();
        let ends = c.run_ends();
        let w = schedule(&c);
        assert_eq!(w.len(), c.stages.len());
        let (a, b) = steady_window(ends[0], ends[1]);
        assert!(
            w[0].last() <= b && b - w[0].last() < c.output_every,
            "{w:?}"
        );
        assert!(w[0].first > a, "{w:?}");
        assert!(w[0].steps().all(|s| s.is_multiple_of(c.output_every)));
        assert_eq!(w[0].samples, SAMPLES_PER_STAGE);
        assert_eq!(w[0].steps().filter(|s| is_sample(&w, *s)).count(), 20);
        assert!(!is_sample(&w, w[0].first + 1) && !is_sample(&w, a));
    }
}
