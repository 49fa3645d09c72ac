//! Progress reporting and cooperative cancellation of [`super::generate`].
//!
//! Purpose: the one path by which the pure pipeline tells its caller how far it is and learns
//! that it should stop. The core never logs; the shell (CLI progress bar, job worker) turns these
//! calls into a bar, job state, tracing spans or metrics, and measures stage durations itself.
//!
//! Contract: for every stage that runs, [`Progress::stage_started`] is called once, then
//! [`Progress::advance`] zero or more times with `done <= total` (`total` may change within a
//! stage when work is discovered, e.g. the parameterize stage splitting and merging charts), then
//! [`Progress::stage_finished`]. Returning `ControlFlow::Break(())` from `advance` cancels: the
//! pipeline stops at that checkpoint and returns [`super::AtlasError::Cancelled`] (no
//! `stage_finished` for that stage).
//!
//! One mechanism from the top to the inner loops: each stage's code receives a
//! [`StageProgress`] (a [`Progress`] seen from one stage, or [`StageProgress::ignored`]), and
//! hands parts of it ([`StageProgress::part`]) to the functions it calls. Reporting never changes
//! a result; parallel code reports only from its sequential parts.
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

/// One stage's checkpoints: the stage's code, down to its inner loops, reports through this
/// how much of its work is done and learns whether to stop. [`super::generate`] makes one per
/// stage from its [`Progress`]; a caller with no interest passes [`StageProgress::ignored`].
///
/// Contract: `advance` never changes a result; parallel code calls it only from its sequential
/// parts, so the calls, like the results, do not depend on the thread count.
pub struct StageProgress<'a> {
    stage: Stage,
    sink: Option<&'a mut dyn Progress>,
    /// Set when this reports one part of the stage's work ([`StageProgress::part`]).
    part: Option<Part>,
}

/// Units `offset .. offset + span` of a stage total of `whole`.
#[derive(Debug, Clone, Copy)]
struct Part {
    offset: usize,
    span: usize,
    whole: usize,
}

impl<'a> StageProgress<'a> {
    /// Reports `stage`'s progress to `progress`.
    pub fn new(stage: Stage, progress: &'a mut dyn Progress) -> Self {
        Self {
            stage,
            sink: Some(progress),
            part: None,
        }
    }

    /// Reports nothing and never cancels.
    pub fn ignored(stage: Stage) -> Self {
        Self {
            stage,
            sink: None,
            part: None,
        }
    }

    /// The stage reported on.
    pub fn stage(&self) -> Stage {
        self.stage
    }

    /// `(done, total)` in the caller's units as the stage's `(done, total)`: itself, or within
    /// a part, `offset + done · span / total` of `whole`. `done` is capped at `total`.
    fn map(&self, done: usize, total: usize) -> (usize, usize) {
        let done = done.min(total);
        match self.part {
            None => (done, total),
            Some(p) => {
                let scaled = if total == 0 {
                    p.span
                } else {
                    (done as u128 * p.span as u128 / total as u128) as usize
                };
                (p.offset + scaled, p.whole)
            }
        }
    }

    /// `done` of `total` units are done (in this view's units); `Break` means stop: the stage
    /// returns its `Cancelled` error.
    pub fn advance(&mut self, done: usize, total: usize) -> ControlFlow<()> {
        let (done, total) = self.map(done, total);
        match self.sink.as_deref_mut() {
            Some(sink) => sink.advance(self.stage, done, total),
            None => ControlFlow::Continue(()),
        }
    }

    /// A view for one part of the work: units `offset .. offset + span` of `total` (in this
    /// view's units). The part counts in its own units: its `advance(done, n)` is reported as
    /// `offset + done · span / n` here, so the stage's reports stay monotone across parts.
    pub fn part(&mut self, offset: usize, span: usize, total: usize) -> StageProgress<'_> {
        let end = offset.saturating_add(span).min(total);
        let (start, whole) = self.map(offset.min(end), total);
        let (stop, _) = self.map(end, total);
        let sink: Option<&mut dyn Progress> = match &mut self.sink {
            Some(sink) => Some(&mut **sink),
            None => None,
        };
        StageProgress {
            stage: self.stage,
            sink,
            part: Some(Part {
                offset: start,
                span: stop - start,
                whole,
            }),
        }
    }
}

/// A [`Progress`] from a closure called with `(stage, done, total)` at every checkpoint.
pub struct ProgressFn<F>(pub F);

impl<F: FnMut(Stage, usize, usize) -> ControlFlow<()>> Progress for ProgressFn<F> {
    fn advance(&mut self, stage: Stage, done: usize, total: usize) -> ControlFlow<()> {
        (self.0)(stage, done, total)
    }
}
