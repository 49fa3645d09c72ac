//! The progress bridge: the pipeline's [`Progress`] calls → a shared snapshot the heartbeat
//! task flushes to the store, and the job's cancel flag → `Break`.
//!
//! The pipeline thread never touches the store: each call is a mutex update (no allocation),
//! so a pipeline that calls `advance` a million times costs nothing extra; the heartbeat decides
//! how often the store sees it.
//!
//! Fraction: each of the four stages counts for a quarter; within a stage, `done / total`.
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use crate::atlas::{Progress, Stage};

/// The latest progress of one job.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Snapshot {
    /// The stage running now.
    pub stage: Option<Stage>,
    /// Fraction of the job done, in \[0, 1\].
    pub fraction: f64,
    /// Bumped on every change, so the heartbeat knows whether to write.
    pub version: u64,
}

/// Shared between the pipeline thread (writer) and the heartbeat task (reader).
pub(crate) type SharedSnapshot = Arc<Mutex<Snapshot>>;

/// The [`Progress`] given to the processor.
pub(crate) struct Bridge {
    /// Set to stop the job at its next checkpoint.
    pub cancel: Arc<AtomicBool>,
    /// Where progress goes.
    pub snapshot: SharedSnapshot,
}

fn stage_index(stage: Stage) -> f64 {
    Stage::ALL.iter().position(|s| *s == stage).unwrap_or(0) as f64
}

impl Bridge {
    fn set(&self, stage: Stage, within: f64) {
        let fraction = ((stage_index(stage) + within.clamp(0.0, 1.0)) / 4.0).clamp(0.0, 1.0);
        let mut s = self.snapshot.lock().unwrap_or_else(|p| p.into_inner());
        // Never go backwards (a stage's `total` may grow).
        if s.stage != Some(stage) || fraction > s.fraction {
            s.stage = Some(stage);
            s.fraction = fraction.max(s.fraction);
            s.version += 1;
        }
    }
}

impl Progress for Bridge {
    fn stage_started(&mut self, stage: Stage) {
        self.set(stage, 0.0);
    }

    fn advance(&mut self, stage: Stage, done: usize, total: usize) -> ControlFlow<()> {
        if self.cancel.load(Ordering::Relaxed) {
            return ControlFlow::Break(());
        }
        let within = if total == 0 {
            0.0
        } else {
            done as f64 / total as f64
        };
        self.set(stage, within);
        ControlFlow::Continue(())
    }

    fn stage_finished(&mut self, stage: Stage) {
        self.set(stage, 1.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fraction_spans_the_stages_and_cancel_breaks() {
        let mut b = Bridge {
            cancel: Arc::new(AtomicBool::new(false)),
            snapshot: SharedSnapshot::default(),
        };
        b.stage_started(Stage::Segment);
        assert_eq!(b.advance(Stage::Segment, 1, 2), ControlFlow::Continue(()));
        assert_eq!(b.snapshot.lock().unwrap().fraction, 0.125);
        b.stage_finished(Stage::Segment);
        b.stage_started(Stage::Pack);
        let _ = b.advance(Stage::Pack, 1, 4);
        let s = *b.snapshot.lock().unwrap();
        assert_eq!((s.stage, s.fraction), (Some(Stage::Pack), 0.5625));
        // A growing total does not move the fraction back.
        let _ = b.advance(Stage::Pack, 1, 100);
        assert_eq!(b.snapshot.lock().unwrap().fraction, 0.5625);
        b.cancel.store(true, Ordering::Relaxed);
        assert_eq!(b.advance(Stage::Pack, 2, 4), ControlFlow::Break(()));
    }
}
