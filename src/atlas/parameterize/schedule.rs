//! Scheduling of the stage's parallel work, without changing its result:
//! [`in_parallel_largest_first`] maps a round's charts in parallel, largest first, results in
//! input order; [`Speculation`] flattens the merge-back's next tries on the rayon pool while its
//! sequential pass runs, and a result is used only under the exact chart versions it was queued
//! for.
use rayon::prelude::*;

use super::LocatedMap;
use crate::mesh::FaceId;

/// `work` mapped by `f` in parallel, results in `work`'s order. The items are handed to the
/// thread pool one at a time, largest chart first (ties by position), so that a big chart
/// does not start last while the other threads idle. The result does not depend on the
/// schedule: each result is a function of its item only.
pub(super) fn in_parallel_largest_first<T: Sync, R: Send>(
    work: &[(Vec<FaceId>, T)],
    f: impl Fn(&(Vec<FaceId>, T)) -> R + Sync,
) -> Vec<R> {
    let mut order: Vec<usize> = (0..work.len()).collect();
    order.sort_by_key(|&i| (std::cmp::Reverse(work[i].0.len()), i));
    let results: Vec<(usize, R)> = order
        .into_par_iter()
        .with_max_len(1)
        .map(|i| (i, f(&work[i])))
        .collect();
    let mut slots: Vec<Option<R>> = (0..work.len()).map(|_| None).collect();
    for (i, r) in results {
        slots[i] = Some(r);
    }
    slots.into_iter().flatten().collect()
}

/// How far ahead of the sequential pass `merge_back` queues merge tries for the pool: this many
/// charts per thread. The result never depends on it (a try is used only under its exact key),
/// only the thrown-away work does: a queued try is stale once either chart merges first.
pub(super) const SPECULATION_CHARTS_PER_THREAD: usize = 2;

/// A merge try of `merge_back`, as in its failed set: (lower chart, its version, higher chart,
/// its version). Versions only grow, so a key never comes back once either chart changed.
pub(super) type MergeKey = (u32, u32, u32, u32);

/// Merge tries flattened ahead of `merge_back`'s sequential pass by the rayon pool.
///
/// The pass queues the tries of the next charts (`queue`, or `decide` when no flattening is
/// needed) and spawns one task per chart that flattens its tries in order (`run_chain`, which
/// stops at the first valid union: the later ones are only needed when it fails). When the pass
/// needs a try, `take` returns its result, flattens it on the spot when no task has started it,
/// or waits for the task that has; a never-queued try is computed by the pass itself. A thread
/// only waits for a try another thread is flattening, and flattening waits for nothing, so this
/// cannot deadlock, with one thread too (then the pass flattens everything itself).
#[derive(Default)]
pub(super) struct Speculation {
    slots: std::sync::Mutex<std::collections::BTreeMap<MergeKey, Slot>>,
    finished: std::sync::Condvar,
}

/// The state of one queued merge try.
pub(super) enum Slot {
    /// Not started: the union's faces (ascending).
    Queued(Vec<FaceId>),
    /// A pool thread is flattening it.
    Running,
    /// The union's map, `None` when it is not a valid chart.
    Done(Option<LocatedMap>),
}

impl Speculation {
    pub(super) fn lock(
        &self,
    ) -> std::sync::MutexGuard<'_, std::collections::BTreeMap<MergeKey, Slot>> {
        // A panic while holding the lock can only come from the map itself; the slots are
        // still consistent (each update is one assignment), so a poisoned lock is used as is.
        self.slots.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub(super) fn has(&self, k: &MergeKey) -> bool {
        self.lock().contains_key(k)
    }

    pub(super) fn queue(&self, k: MergeKey, union: Vec<FaceId>) {
        self.lock().insert(k, Slot::Queued(union));
    }

    pub(super) fn decide(&self, k: MergeKey, result: Option<LocatedMap>) {
        self.lock().insert(k, Slot::Done(result));
    }

    /// Drops every try (the pass is over, or cancelled): tasks not yet started find nothing.
    pub(super) fn clear(&self) {
        self.lock().clear();
    }

    /// Drops the tries of charts `a` and `b` (one just merged into the other).
    pub(super) fn forget_charts(&self, a: usize, b: usize) {
        let (a, b) = (a as u32, b as u32);
        self.lock()
            .retain(|k, _| k.0 != a && k.0 != b && k.2 != a && k.2 != b);
    }

    /// Flattens the queued tries of `chain` in order, until one is valid. Tries taken by the
    /// pass or dropped meanwhile are skipped; a result whose try was dropped while flattening
    /// is discarded.
    pub(super) fn run_chain(
        &self,
        chain: &[MergeKey],
        flatten: &dyn Fn(&[FaceId]) -> Option<LocatedMap>,
    ) {
        for k in chain {
            let union = {
                let mut slots = self.lock();
                match slots.get_mut(k) {
                    Some(slot) if matches!(slot, Slot::Queued(_)) => {
                        match std::mem::replace(slot, Slot::Running) {
                            Slot::Queued(union) => union,
                            _ => continue,
                        }
                    }
                    _ => continue,
                }
            };
            let result = flatten(&union);
            let valid = result.is_some();
            if let Some(slot) = self.lock().get_mut(k) {
                if matches!(slot, Slot::Running) {
                    *slot = Slot::Done(result);
                }
            }
            self.finished.notify_all();
            if valid {
                break;
            }
        }
    }

    /// The result of try `k` (removed from the table), or `None` when it is not queued.
    pub(super) fn take(
        &self,
        k: &MergeKey,
        flatten: &dyn Fn(&[FaceId]) -> Option<LocatedMap>,
    ) -> Option<Option<LocatedMap>> {
        let mut slots = self.lock();
        while matches!(slots.get(k), Some(Slot::Running)) {
            slots = self.finished.wait(slots).unwrap_or_else(|e| e.into_inner());
        }
        match slots.remove(k)? {
            Slot::Done(result) => Some(result),
            Slot::Queued(union) => {
                drop(slots);
                Some(flatten(&union))
            }
            Slot::Running => None,
        }
    }
}
