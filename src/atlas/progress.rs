//! Progress reporting and cooperative cancellation of [`super::generate`].
//!
//! Purpose: the one path by which the pure pipeline tells its caller how far it is and learns
//! that it should stop. The core never logs; the shell (CLI progress bar, job worker) turns these
//! calls into a bar, job state, tracing spans or metrics, and measures stage durations itself.
//!
//! Contract: for every stage that runs, [`Progress::stage_started`] is called once, then
//! [`Progress::advance`] zero or more times with `done <= total` (`total` may grow within a stage
//! when work is discovered, e.g. validation splitting charts), then [`Progress::stage_finished`].
//! Returning `ControlFlow::Break(())` from `advance` cancels: the pipeline stops at that
//! checkpoint and returns [`super::AtlasError::Cancelled`] (no `stage_finished` for that stage).
use std::ops::ControlFlow;

/// The stages of [`super::generate`], in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Stage {
    /// Feature detection and chart growing (`segment_charts`).
    Segment,
    /// Flattening every chart and splitting the invalid ones (`parameterize_charts`).
    Parameterize,
    /// Placing the charts on pages (`pack_charts`).
    Pack,
    /// The quality report (`measure_atlas`).
    Measure,
}

impl Stage {
    /// Every stage, in pipeline order.
    pub const ALL: [Stage; 4] = [
        Stage::Segment,
        Stage::Parameterize,
        Stage::Pack,
        Stage::Measure,
    ];

    /// Stable lower-case name (used on the wire and in progress bars).
    pub fn name(self) -> &'static str {
        match self {
            Stage::Segment => "segment",
            Stage::Parameterize => "parameterize",
            Stage::Pack => "pack",
            Stage::Measure => "measure",
        }
    }
}

/// Receives progress from the pipeline (module doc for the call order).
pub trait Progress {
    /// `stage` begins.
    fn stage_started(&mut self, stage: Stage) {
        let _ = stage;
    }
    /// `done` of `total` units of `stage` are done. `Break` cancels the run.
    fn advance(&mut self, stage: Stage, done: usize, total: usize) -> ControlFlow<()> {
        let _ = (stage, done, total);
        ControlFlow::Continue(())
    }
    /// `stage` ended successfully.
    fn stage_finished(&mut self, stage: Stage) {
        let _ = stage;
    }
}

/// Ignores progress and never cancels.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Progress for NoProgress {}
