//! Progressive mesh by half-edge collapses, as Ray & Lévy 2003 (hlscm-2003) §4.
//!
//! The paper's Algorithm 2, "Hierarchical triangulated surfaces generation":
//! "while some hcoll can be performed: h ← the less geometrically important halfedge that can
//! be collapsed; add the corresponding hcoll to the operations list; collapse h".
//!
//! A half-edge collapse `u → v` (Kobbelt's `hcoll`) removes vertex `u` and replaces it by `v`
//! in every face; the two (interior) or one (boundary) faces on the edge disappear. Vertices
//! never move, which is what makes the operation list easy to replay.
//!
//! "Validity of hcoll" (§4), each check in `Decimator::best_collapse`:
//! - manifold: the link condition (the common neighbours of `u` and `v` are exactly the
//!   opposite vertices of the faces on the edge);
//! - no flip: every face that survives keeps its normal on the same side (`n_old·n_new > 0`) and
//!   does not become degenerate;
//! - boundary intact: a boundary vertex may only collapse along a boundary edge (so the
//!   boundary stays one simple loop, only coarser), the loop keeps at least 4 vertices before a
//!   boundary collapse, and locked vertices (the LSCM pins) are never removed;
//! - "the angular defect of the vertex to remove has to be smaller than a given threshold
//!   (70 degrees in the examples shown here)": `2π − Σθ` inside, `π − Σθ` on the boundary
//!   (the turning angle, so chart corners are kept).
//!
//! "Halfedge geometric importance" (§4), in `Decimator::best_collapse`: the sum of
//! - the volume difference (the volume swept by the faces of `u` moving to `v`,
//!   `Σ |det(a−u, b−u, v−u)|/6`), as its cube root;
//! - the area difference when the half-edge is on the border (the triangle between the old
//!   boundary `w–u–v` and the new `w–v`), as its square root;
//! - the accumulated loss of quality on merged vertices: each vertex carries the largest loss
//!   merged into it so far (`acc(v) ← max(acc(v), acc(u) + loss)`), our reading of the
//!   "global error management" of the paper's reference \[4\].
//!
//! "Note that to have compatible dimensions, these parameters are normalized (cube root for
//! volume and square root for area)": all three terms are lengths in model units.
//!
//! Replay: every [`Collapse`] records the nearest triangle of the coarser mesh to the removed
//! vertex and its barycentric coordinates, so that the vertex split can give the new vertex
//! "its textures coordinates … using a barycentric interpolation in the nearest triangle"
//! (§4.1). [`ProgressiveMesh::level`] rebuilds the mesh after any prefix of the collapses.
//!
//! Queue: at most one entry per vertex (its cheapest valid half-edge), in a 4-ary heap ordered
//! by (priority, vertex id) with `f64::total_cmp`.
//!
//! Exact dirty tracking. The evaluation of `u` (`Decimator::best_collapse`) reads only the
//! star of `u` (faces, positions, ring, edge face counts, angular defect, `acc(u)`), the stars
//! of its neighbours (link condition) and the global boundary vertex count. A collapse `u → v`
//! changes only the faces around `u` (and `acc(v)`), so the only vertices whose evaluation can
//! change are those whose star changed (the old ring of `u`, plus `v`) and those adjacent to
//! `u` or `v` (their link with a neighbour may change): all of them are `v` and its new ring.
//! Those are marked dirty; every other vertex's cached evaluation stays exact. So a vertex
//! popped clean collapses at once with its cached half-edge (the sequential version re-evaluated
//! every popped vertex), and only a popped dirty vertex is re-evaluated. The boundary count is
//! re-checked when a boundary vertex collapses. The unit tests assert, at every collapse, that
//! the cached half-edge equals a fresh evaluation.
//!
//! Parallel and deterministic: popped dirty vertices wait in a batch of
//! `EVALUATION_BATCH`; the batch is evaluated in parallel (each evaluation reads the current
//! mesh only) and re-queued in batch order, so the collapse list is the same bits at any thread
//! count. Change against the paper's strictly sequential greedy order (Algorithm 2): while a
//! dirty vertex waits in the batch, up to `EVALUATION_BATCH` clean ones may collapse before it
//! although its refreshed priority might have been lower. Measured effect (bench height field,
//! 1M triangles, levels 50 127 and 501 264 vertices): finest-level iterations 48 → 49, HLSCM
//! energy within 8.2e-6 → 7.1e-6 relative of the direct solve's.
//!
//! Cost: `O(n log n)`; at 1M triangles (451k collapses, 1.36M evaluations) the decimation is
//! about 2.9 s of CPU, bound by cache misses on the random-access star reads (measured with
//! `perf`). Two layout choices cut misses without changing the rules: each vertex's face list
//! sits inline in one 64-byte line (`FaceSlot`, 15 faces, longer lists spill to a pool)
//! instead of a `Vec` (header and heap block: two dependent misses), with the same order
//! (same collapse list bits); and inside the chart the candidates of `u` are ranked by swept
//! volume, taking one cube root for the chosen one (`cbrt(vol) + acc(u)` is increasing in the
//! volume; only ties after rounding can order differently: bench height field 1M, same
//! 49 finest iterations, energy 2.6151322527e-5 → 2.6151320246e-5).
//!
//! Memory-level parallelism, also without changing a bit: an evaluation batch is evaluated in
//! chunks of `WARM_CHUNK` vertices whose stars are first loaded stage by stage
//! (`Decimator::warm_stars`: all face list lines, then all faces, then all positions and
//! neighbour face lists), so the misses of a stage overlap instead of each evaluation waiting
//! for its own chain of misses in turn; and while a popped vertex is handled, the queue state,
//! cached evaluation and faces of the new top are loaded. Measured (bench height field 1M,
//! same binary with the loads switched off by a temporary flag, interleaved, load 4.2–4.9):
//! batch evaluations 1.85 / 3.45 / 2.05 / 3.18 s → 1.26 / 2.11 / 1.09 s, the same 451 137
//! collapses and finest energy bits.
//!
//! Tried and rejected (bench height field, one run each, load ~7): rounds of independent
//! collapses (each round makes the cheapest quarter of the candidates eligible, selects those
//! that are the cheapest eligible vertex within two edges, in parallel with atomic minima,
//! applies them in priority order): deterministic and exact, but at 250k triangles it needed
//! 69 rounds and 2.9 evaluations per collapse (the queue needs 1.9), and took 2.7 s against
//! about 1.1 s for the queue at one thread; finest iterations 41 → 42 (1M: 49 → 53).
use std::f64::consts::PI;

use rayon::prelude::*;

use super::chart::{cross, dot3, exceeds, norm3, sub, ChartMesh};
use super::ParameterizeError;

/// One half-edge collapse, in the order they were applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Collapse {
    /// The vertex removed (`u` of `u → v`), as a chart vertex index.
    pub removed: u32,
    /// The vertex it was merged into (`v`).
    pub kept: u32,
    /// The triangle of the mesh right after this collapse nearest to `removed`'s position
    /// (chart vertex indices, all alive after the collapse).
    pub triangle: [u32; 3],
    /// Barycentric coordinates (non-negative, sum 1) of the point of `triangle` nearest to
    /// `removed`'s position.
    pub barycentric: [f64; 3],
}

/// Options of [`build_progressive_mesh`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProgressiveMeshOptions {
    /// Largest |angular defect| of a removable vertex, radians. Default 70° (hlscm-2003 §4).
    pub max_angular_defect_rad: f64,
    /// Stop when this many vertices remain (the coarsest level needs no more collapses).
    /// Default 3.
    pub min_vertices: usize,
}

impl Default for ProgressiveMeshOptions {
    fn default() -> Self {
        Self {
            max_angular_defect_rad: 70f64.to_radians(),
            min_vertices: 3,
        }
    }
}

/// The collapse list of a chart (the vertex splits replay it backwards).
#[derive(Debug, Clone, PartialEq)]
pub struct ProgressiveMesh {
    /// Vertex count of the full-resolution chart.
    pub vertex_count: usize,
    /// Collapses in application order.
    pub collapses: Vec<Collapse>,
}

/// A mesh of the hierarchy with its own compact vertex numbering.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelMesh {
    /// The level as a chart (positions copied from the full chart).
    pub chart: ChartMesh,
    /// Chart vertex index of each level vertex (increasing).
    pub chart_vertex: Vec<u32>,
    /// Level vertex index of each chart vertex, `u32::MAX` when absent at this level.
    pub level_vertex: Vec<u32>,
}

/// Decimates a validated chart with hlscm-2003 Algorithm 2. `locked` vertices are never removed
/// (HLSCM locks the two pins so that every level has them).
pub fn build_progressive_mesh(
    chart: &ChartMesh,
    locked: &[u32],
    options: &ProgressiveMeshOptions,
) -> Result<ProgressiveMesh, ParameterizeError> {
    let mut d = Decimator::new(chart, locked, options)?;
    let n = chart.positions_m.len();
    let mut warm = 0u64;
    // The first evaluation of every vertex reads the unmodified mesh only: run it in
    // parallel (each result depends on its vertex alone, so the bits do not depend on the
    // thread count), then queue sequentially in vertex order.
    let mut best: Vec<Option<Best>> = {
        let d = &d;
        (0..n as u32)
            .into_par_iter()
            .map_init(Scratch::default, |scratch, u| d.best_collapse(u, scratch))
            .collect()
    };
    // Per vertex, packed in 16 bytes so that marking a ring dirty touches one cache line per
    // vertex instead of four arrays (same values and order as separate arrays):
    // - `last_priority`: a dirty vertex is re-queued with it and re-evaluated only when it
    //   reaches the top of the queue;
    // - `dirty`: the star of u or of a neighbour changed since `best[u]` was computed. A clean
    //   vertex's `best` is exact for the current mesh (see the module doc), so it is collapsed
    //   when popped without re-evaluation;
    // - `queued`: u has its (single) queue entry, or waits in the evaluation batch;
    // - `locked`: a copy of the decimator's lock flag.
    let mut state: Vec<QueueState> = d
        .locked
        .iter()
        .map(|&locked| QueueState {
            last_priority: 0.0,
            locked,
            dirty: false,
            queued: false,
        })
        .collect();
    let mut heap = QuadHeap::with_capacity(n);
    for (u, b) in best.iter().enumerate() {
        if let Some(b) = b {
            state[u].last_priority = b.priority;
            state[u].queued = true;
            heap.push(Candidate::new(b.priority, u as u32));
        }
    }
    let target = options.min_vertices.max(3);
    let mut alive = n;
    let mut collapses = Vec::with_capacity(n.saturating_sub(target));
    let mut batch: Vec<u32> = Vec::with_capacity(EVALUATION_BATCH);
    let mut evaluated: Vec<Option<Best>> = Vec::with_capacity(EVALUATION_BATCH);
    while alive > target {
        let popped = heap.pop();
        if popped.is_none() || batch.len() >= EVALUATION_BATCH {
            if batch.is_empty() {
                break;
            }
            {
                let d = &d;
                evaluated.clear();
                evaluated.resize(batch.len(), None);
                evaluated
                    .par_chunks_mut(WARM_CHUNK)
                    .zip(batch.par_chunks(WARM_CHUNK))
                    .for_each_init(Scratch::default, |scratch, (out, us)| {
                        std::hint::black_box(d.warm_stars(us));
                        for (o, &u) in out.iter_mut().zip(us) {
                            *o = d.best_collapse(u, scratch);
                        }
                    });
            }
            for (&u, b) in batch.iter().zip(evaluated.drain(..)) {
                let ui = u as usize;
                state[ui].dirty = false;
                state[ui].queued = false;
                best[ui] = b;
                if let Some(b) = b {
                    state[ui].last_priority = b.priority;
                    state[ui].queued = true;
                    heap.push(Candidate::new(b.priority, u));
                }
            }
            batch.clear();
            if let Some(c) = popped {
                heap.push(c);
            }
            continue;
        }
        let Some(c) = popped else { break };
        // Start loading what the next pop will likely read (the current top's queue state,
        // cached evaluation and faces) while this one is handled: a read, changes nothing.
        if let Some(next) = heap.peek() {
            let wi = next.vertex() as usize;
            warm ^= state[wi].last_priority.to_bits() ^ best[wi].map_or(0, |b| u64::from(b.target));
            for &f in &d.vertex_faces[wi] {
                warm ^= u64::from(d.faces[f as usize][0]);
            }
        }
        let u = c.vertex();
        let ui = u as usize;
        state[ui].queued = false;
        if !d.alive[ui] {
            continue;
        }
        if state[ui].dirty {
            state[ui].last_priority = c.priority();
            state[ui].queued = true;
            batch.push(u);
            continue;
        }
        let Some(b) = best[ui] else { continue };
        if b.boundary && d.boundary_vertices <= 4 {
            // The loop must keep at least 4 vertices (a global rule, not in the star).
            best[ui] = None;
            continue;
        }
        #[cfg(test)]
        assert_eq!(
            d.best_collapse(u, &mut Scratch::default()),
            Some(b),
            "a clean vertex's cached half-edge must equal a fresh evaluation"
        );
        collapses.push(d.collapse(u, b));
        alive -= 1;
        // The stars of v and of its new ring changed (they are the old ring of u plus v):
        // mark them dirty, and queue those without an entry at their last known priority.
        let vi = b.target as usize;
        for k in 0..d.vertex_faces[vi].len() {
            let f = d.vertex_faces[vi][k] as usize;
            for w in d.faces[f] {
                let wi = w as usize;
                let s = &mut state[wi];
                if s.locked {
                    continue;
                }
                s.dirty = true;
                if !s.queued {
                    s.queued = true;
                    heap.push(Candidate::new(s.last_priority, w));
                }
            }
        }
    }
    std::hint::black_box(warm);
    Ok(ProgressiveMesh {
        vertex_count: n,
        collapses,
    })
}

/// Queue bookkeeping of one vertex in [`build_progressive_mesh`].
#[derive(Debug, Clone, Copy)]
struct QueueState {
    last_priority: f64,
    locked: bool,
    dirty: bool,
    queued: bool,
}

/// Dirty vertices re-evaluated together (in parallel) once this many reached the top of the
/// queue. Bounds how far the collapse order departs from the strictly sequential greedy one.
const EVALUATION_BATCH: usize = 256;

/// Vertices of an evaluation batch whose stars are loaded together before they are evaluated
/// ([`Decimator::warm_stars`]). Their data (about 20 cache lines each) stays in L2.
const WARM_CHUNK: usize = 32;

impl ProgressiveMesh {
    /// Vertices alive after the first `applied` collapses.
    pub fn vertices_after(&self, applied: usize) -> usize {
        self.vertex_count - applied.min(self.collapses.len())
    }

    /// The mesh after the first `applied` collapses (0 = the full chart). `chart` must be the
    /// chart this progressive mesh was built from.
    ///
    /// A half-edge collapse only substitutes `u → v` in faces, so the level is the set of
    /// original faces with every vertex mapped through the composed substitutions, minus the
    /// faces that became degenerate. Cost `O(n + F)`.
    pub fn level(&self, chart: &ChartMesh, applied: usize) -> Result<LevelMesh, ParameterizeError> {
        let applied = applied.min(self.collapses.len());
        let n = self.vertex_count;
        if chart.positions_m.len() != n {
            return Err(ParameterizeError::Internal {
                detail: "progressive mesh used with another chart".to_string(),
            });
        }
        let mut rep: Vec<u32> = (0..n as u32).collect();
        // Later collapses first, so that `rep[kept]` is final when `removed` reads it.
        for c in self.collapses[..applied].iter().rev() {
            let target = rep
                .get(c.kept as usize)
                .copied()
                .ok_or_else(|| internal("collapse refers to a missing vertex"))?;
            if let Some(slot) = rep.get_mut(c.removed as usize) {
                *slot = target;
            }
        }
        let mut level_vertex = vec![u32::MAX; n];
        let mut chart_vertex = Vec::with_capacity(n - applied);
        for v in 0..n {
            if rep[v] == v as u32 {
                level_vertex[v] = chart_vertex.len() as u32;
                chart_vertex.push(v as u32);
            }
        }
        let mut triangles = Vec::with_capacity(chart.triangles.len());
        for t in &chart.triangles {
            let m = t.map(|i| rep.get(i as usize).copied().unwrap_or(u32::MAX));
            if m[0] != m[1] && m[1] != m[2] && m[0] != m[2] {
                let l = m.map(|i| level_vertex.get(i as usize).copied().unwrap_or(u32::MAX));
                if l.contains(&u32::MAX) {
                    return Err(internal("level face refers to a removed vertex"));
                }
                triangles.push(l);
            }
        }
        let positions_m = chart_vertex
            .iter()
            .map(|&v| chart.positions_m[v as usize])
            .collect();
        Ok(LevelMesh {
            chart: ChartMesh {
                positions_m,
                triangles,
            },
            chart_vertex,
            level_vertex,
        })
    }

    /// Vertex splits (hlscm-2003 §4.1): going from `coarse_applied` collapses back to
    /// `fine_applied`, give each re-inserted vertex the barycentric UV of its recorded nearest
    /// triangle. `uv` is indexed by chart vertex and must hold the UVs of every vertex alive at
    /// the coarse level; the re-inserted entries are overwritten.
    pub fn split_to(&self, uv: &mut [[f64; 2]], coarse_applied: usize, fine_applied: usize) {
        let hi = coarse_applied.min(self.collapses.len());
        let lo = fine_applied.min(hi);
        for c in self.collapses[lo..hi].iter().rev() {
            let mut p = [0.0, 0.0];
            for k in 0..3 {
                let q = uv
                    .get(c.triangle[k] as usize)
                    .copied()
                    .unwrap_or([0.0, 0.0]);
                p[0] += c.barycentric[k] * q[0];
                p[1] += c.barycentric[k] * q[1];
            }
            if let Some(slot) = uv.get_mut(c.removed as usize) {
                *slot = p;
            }
        }
    }
}

fn internal(detail: &str) -> ParameterizeError {
    ParameterizeError::Internal {
        detail: detail.to_string(),
    }
}

/// A 4-ary max-heap: half the depth of a binary heap, and the 4 children of a node share one
/// 64-byte cache line (16-byte entries), so a pop touches about half as many lines. With up to
/// one entry per vertex (500k at 1M triangles, 8 MB) the queue does not fit in cache and its
/// sift-down was the largest single cost of the decimation loop (measured with `perf`).
/// Pops in the same order as `std::collections::BinaryHeap` (a total order has one maximum).
struct QuadHeap<T> {
    items: Vec<T>,
}

impl<T: Ord + Copy> QuadHeap<T> {
    fn with_capacity(capacity: usize) -> Self {
        Self {
            items: Vec::with_capacity(capacity),
        }
    }

    fn push(&mut self, item: T) {
        let mut i = self.items.len();
        self.items.push(item);
        while i > 0 {
            let parent = (i - 1) / 4;
            if self.items[parent] >= item {
                break;
            }
            self.items[i] = self.items[parent];
            i = parent;
        }
        self.items[i] = item;
    }

    fn peek(&self) -> Option<&T> {
        self.items.first()
    }

    fn pop(&mut self) -> Option<T> {
        let last = self.items.pop()?;
        if self.items.is_empty() {
            return Some(last);
        }
        let top = self.items[0];
        let n = self.items.len();
        let mut i = 0;
        loop {
            let first = 4 * i + 1;
            if first >= n {
                break;
            }
            let end = (first + 4).min(n);
            let mut child = first;
            for c in first + 1..end {
                if self.items[c] > self.items[child] {
                    child = c;
                }
            }
            if self.items[child] <= last {
                break;
            }
            self.items[i] = self.items[child];
            i = child;
        }
        self.items[i] = last;
        Some(top)
    }
}

/// A queue entry: min-heap on (priority, vertex) with `f64::total_cmp` semantics, packed in
/// one integer so that a heap comparison is a single `u128` compare (the heap holds up to one
/// entry per vertex, and its sift-down is a measurable part of the decimation at 1M faces).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct Candidate {
    /// `!(order_key(priority) << 32 | vertex)`: the max-heap pops the smallest pair first.
    key: u128,
}

impl Candidate {
    fn new(priority: f64, vertex: u32) -> Self {
        Self {
            key: !((u128::from(order_key(priority)) << 32) | u128::from(vertex)),
        }
    }
    fn priority(self) -> f64 {
        order_key_inverse((!self.key >> 32) as u64)
    }
    fn vertex(self) -> u32 {
        (!self.key & 0xffff_ffff) as u32
    }
}

/// An unsigned key whose integer order is `f64::total_cmp`'s order (the same bit transform
/// as the standard library's implementation, shifted to unsigned).
fn order_key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | (1 << 63)
    }
}

fn order_key_inverse(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

/// The cheapest valid collapse of a vertex `u` (the half-edge `u → target`).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Best {
    /// Priority of the half-edge (a length, model units).
    priority: f64,
    /// The vertex `u` merges into.
    target: u32,
    /// Whether `u` is on the boundary (then the collapse runs along the boundary).
    boundary: bool,
}

/// A face of the star of `u`, rotated so that `u` comes first: `(u, a, b)`.
struct StarFace {
    a: u32,
    b: u32,
    pa: [f64; 3],
    pb: [f64; 3],
    /// `(a − u) × (b − u)`, the face normal before the collapse (twice the area).
    n_old: [f64; 3],
}

/// Reusable buffers of [`Decimator::best_collapse`] (one per thread).
#[derive(Default)]
struct Scratch {
    star: Vec<StarFace>,
    /// The 1-ring of `u` with the number of faces on each edge (1 boundary, 2 inside),
    /// unsorted (rings are small: linear search beats sorting).
    ring_u: Vec<(u32, u32)>,
    ring_v: Vec<u32>,
    /// (priority, target, faces on the edge).
    candidates: Vec<(f64, u32, u32)>,
}

fn add_counted(ring: &mut Vec<(u32, u32)>, w: u32) {
    match ring.iter_mut().find(|e| e.0 == w) {
        Some(e) => e.1 += 1,
        None => ring.push((w, 1)),
    }
}

/// Faces stored inline per vertex; a longer list spills to [`FaceLists::spill`].
const INLINE_FACES: usize = 15;

/// `len` of a [`FaceSlot`] whose list lives in the spill pool at index `faces[0]`.
const SPILLED: u32 = u32::MAX;

/// One vertex's face list in one 64-byte cache line (a `Vec<u32>` per vertex costs a
/// dependent miss on its header and one on its heap block). Valence rarely exceeds 15 faces
/// during decimation; the few longer lists move to a pool.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct FaceSlot {
    len: u32,
    faces: [u32; INLINE_FACES],
}

/// The vertex → incident faces lists of the mesh under decimation. Insertion order is kept
/// (pushes append, removals shift), exactly as the `Vec<Vec<u32>>` it replaces, so every
/// evaluation visits faces in the same order and gives the same bits.
struct FaceLists {
    slots: Vec<FaceSlot>,
    spill: Vec<Vec<u32>>,
}

impl FaceLists {
    fn new(n: usize) -> Self {
        Self {
            slots: vec![
                FaceSlot {
                    len: 0,
                    faces: [0; INLINE_FACES]
                };
                n
            ],
            spill: Vec::new(),
        }
    }

    fn push(&mut self, v: usize, f: u32) {
        let slot = &mut self.slots[v];
        if slot.len == SPILLED {
            self.spill[slot.faces[0] as usize].push(f);
        } else if (slot.len as usize) < INLINE_FACES {
            slot.faces[slot.len as usize] = f;
            slot.len += 1;
        } else {
            let mut list = slot.faces.to_vec();
            list.push(f);
            slot.faces[0] = self.spill.len() as u32;
            slot.len = SPILLED;
            self.spill.push(list);
        }
    }

    /// Removes `f` from `v`'s list, keeping the order of the others (`Vec::retain`).
    fn remove(&mut self, v: usize, f: u32) {
        let slot = &mut self.slots[v];
        if slot.len == SPILLED {
            self.spill[slot.faces[0] as usize].retain(|&g| g != f);
            return;
        }
        let len = slot.len as usize;
        let mut kept = 0;
        for k in 0..len {
            let g = slot.faces[k];
            if g != f {
                slot.faces[kept] = g;
                kept += 1;
            }
        }
        slot.len = kept as u32;
    }

    /// Empties `v`'s list, copying it into `out`.
    fn take_into(&mut self, v: usize, out: &mut Vec<u32>) {
        out.clear();
        out.extend_from_slice(&self[v]);
        let slot = &mut self.slots[v];
        if slot.len == SPILLED {
            self.spill[slot.faces[0] as usize] = Vec::new();
        }
        slot.len = 0;
    }
}

impl std::ops::Index<usize> for FaceLists {
    type Output = [u32];
    fn index(&self, v: usize) -> &[u32] {
        let slot = &self.slots[v];
        if slot.len == SPILLED {
            &self.spill[slot.faces[0] as usize]
        } else {
            &slot.faces[..slot.len as usize]
        }
    }
}

/// The mutable mesh under decimation.
struct Decimator<'a> {
    pos: &'a [[f64; 3]],
    faces: Vec<[u32; 3]>,
    vertex_faces: FaceLists,
    /// Scratch of [`Decimator::collapse`].
    faces_u: Vec<u32>,
    alive: Vec<bool>,
    locked: Vec<bool>,
    accumulated_m: Vec<f64>,
    boundary_vertices: usize,
    max_defect_rad: f64,
}

impl<'a> Decimator<'a> {
    fn new(
        chart: &'a ChartMesh,
        locked: &[u32],
        options: &ProgressiveMeshOptions,
    ) -> Result<Self, ParameterizeError> {
        let n = chart.positions_m.len();
        let mut vertex_faces = FaceLists::new(n);
        for (f, t) in chart.triangles.iter().enumerate() {
            for &i in t {
                if i as usize >= n {
                    return Err(internal("face index out of range"));
                }
                vertex_faces.push(i as usize, f as u32);
            }
        }
        let mut lock = vec![false; n];
        for &l in locked {
            if let Some(slot) = lock.get_mut(l as usize) {
                *slot = true;
            }
        }
        let mut d = Self {
            pos: &chart.positions_m,
            faces: chart.triangles.clone(),
            vertex_faces,
            faces_u: Vec::new(),
            alive: vec![true; n],
            locked: lock,
            accumulated_m: vec![0.0; n],
            boundary_vertices: 0,
            max_defect_rad: options.max_angular_defect_rad,
        };
        // A count: the same at any thread count.
        d.boundary_vertices = {
            let d = &d;
            (0..n as u32)
                .into_par_iter()
                .map_init(Vec::new, |ring, u| {
                    ring.clear();
                    for &f in &d.vertex_faces[u as usize] {
                        for &w in &d.faces[f as usize] {
                            if w != u {
                                add_counted(ring, w);
                            }
                        }
                    }
                    ring.len() != d.vertex_faces[u as usize].len()
                })
                .filter(|&boundary| boundary)
                .count()
        };
        Ok(d)
    }

    /// Loads the data [`Decimator::best_collapse`] reads for each vertex of `us` (its face
    /// list line, its faces, their vertices' positions and face list lines), stage by stage
    /// over all of `us`: the loads of one stage are independent, so the memory system
    /// overlaps them, where one evaluation after the other waits for each miss of its chain
    /// (face list → faces → positions) in turn. Returns a value folded from what it read, for
    /// `black_box`. Reads only; changes no result.
    fn warm_stars(&self, us: &[u32]) -> u64 {
        let slots = &self.vertex_faces.slots;
        let mut acc = 0u64;
        for &u in us {
            let ui = u as usize;
            acc ^= u64::from(slots[ui].len) ^ self.accumulated_m[ui].to_bits();
        }
        for &u in us {
            for &f in &self.vertex_faces[u as usize] {
                acc ^= u64::from(self.faces[f as usize][0]);
            }
        }
        for &u in us {
            for &f in &self.vertex_faces[u as usize] {
                for w in self.faces[f as usize] {
                    let wi = w as usize;
                    acc ^= self.pos[wi][0].to_bits() ^ u64::from(slots[wi].len);
                }
            }
        }
        acc
    }

    /// The cheapest valid collapse `u → v`, or `None`. Reads the stars of `u` and of its
    /// neighbours only (the module doc's exactness argument relies on this), plus the global
    /// boundary vertex count.
    fn best_collapse(&self, u: u32, scratch: &mut Scratch) -> Option<Best> {
        let ui = u as usize;
        if !self.alive[ui] || self.locked[ui] || self.vertex_faces[ui].is_empty() {
            return None;
        }
        let Scratch {
            star,
            ring_u,
            ring_v,
            candidates,
        } = scratch;
        star.clear();
        ring_u.clear();
        let pu = self.pos[ui];
        // One pass over the star: rotated faces, old normals, the ring with edge face counts
        // and the angle sum for the angular defect.
        let mut angle_sum = 0.0;
        for &f in &self.vertex_faces[ui] {
            let t = self.faces[f as usize];
            let k = t.iter().position(|&w| w == u).unwrap_or(0);
            let (a, b) = (t[(k + 1) % 3], t[(k + 2) % 3]);
            let (pa, pb) = (self.pos[a as usize], self.pos[b as usize]);
            let (ea, eb) = (sub(pa, pu), sub(pb, pu));
            let n_old = cross(ea, eb);
            angle_sum += norm3(n_old).atan2(dot3(ea, eb));
            star.push(StarFace {
                a,
                b,
                pa,
                pb,
                n_old,
            });
            add_counted(ring_u, a);
            add_counted(ring_u, b);
        }
        let boundary_u = ring_u.len() != self.vertex_faces[ui].len();
        // The two boundary neighbours (one face on their edge), for the boundary area term.
        let boundary_neighbors: [Option<u32>; 2] = {
            let mut it = ring_u.iter().filter(|e| e.1 == 1).map(|e| e.0);
            [it.next(), it.next()]
        };
        let defect = if boundary_u { PI } else { 2.0 * PI } - angle_sum;
        // Cost every candidate first (cheap: a few dot products), then check validity (no
        // flip, no degeneracy, link condition) in order of cost: it rarely fails, so usually
        // only the cheapest candidate pays for it. The result is the cheapest valid candidate
        // either way.
        candidates.clear();
        if defect.abs() <= self.max_defect_rad && (!boundary_u || self.boundary_vertices > 4) {
            for &(v, on_edge) in ring_u.iter() {
                if boundary_u && on_edge != 1 {
                    continue; // a boundary vertex only slides along the boundary
                }
                let other_boundary = if boundary_u {
                    match boundary_neighbors {
                        [Some(a), Some(b)] => Some(if a == v { b } else { a }),
                        _ => continue,
                    }
                } else {
                    None
                };
                // Inside, the priority `cbrt(volume) + acc(u)` is increasing in the volume
                // alone (acc(u) is common to all candidates): rank by the volume and take the
                // cube root of the chosen one only (the same bits as `collapse_loss`).
                let key = match other_boundary {
                    None => self.swept_volume(star, u, v),
                    Some(_) => {
                        self.collapse_loss(star, u, v, other_boundary) + self.accumulated_m[ui]
                    }
                };
                candidates.push((key, v, on_edge));
            }
        }
        // Cheapest first (ties: smaller vertex), removing each candidate once tried.
        while let Some(k) = (0..candidates.len()).min_by(|&a, &b| {
            let (ca, cb) = (&candidates[a], &candidates[b]);
            ca.0.total_cmp(&cb.0).then(ca.1.cmp(&cb.1))
        }) {
            let (key, v, on_edge) = candidates.swap_remove(k);
            if !self.surviving_faces_stay_valid(star, v) {
                continue;
            }
            // Link condition: the common neighbours of u and v are exactly the opposite
            // vertices of the faces on the edge, otherwise the mesh becomes non-manifold.
            ring_v.clear();
            for &f in &self.vertex_faces[v as usize] {
                for &w in &self.faces[f as usize] {
                    if w != v && !ring_v.contains(&w) {
                        ring_v.push(w);
                    }
                }
            }
            let common = ring_u.iter().filter(|e| ring_v.contains(&e.0)).count();
            if common == on_edge as usize {
                let priority = if boundary_u {
                    key
                } else {
                    (key.cbrt() + 0.0f64.sqrt()) + self.accumulated_m[ui]
                };
                return Some(Best {
                    priority,
                    target: v,
                    boundary: boundary_u,
                });
            }
        }
        None
    }

    /// Geometric loss of `u → v`: the volume and boundary-area terms, as lengths. `star` is
    /// the star of `u`.
    fn collapse_loss(&self, star: &[StarFace], u: u32, v: u32, other_boundary: Option<u32>) -> f64 {
        let pu = self.pos[u as usize];
        let pv = self.pos[v as usize];
        let volume = self.swept_volume(star, u, v);
        let mut area = 0.0;
        if let Some(w) = other_boundary {
            // The other boundary neighbour w of u: old border w–u–v becomes w–v.
            let pw = self.pos[w as usize];
            area = 0.5 * norm3(cross(sub(pu, pw), sub(pv, pw)));
        }
        volume.cbrt() + area.sqrt()
    }

    /// The volume swept by the faces of the star of `u` that survive `u → v`
    /// (`Σ |det(a−u, b−u, v−u)|/6`).
    fn swept_volume(&self, star: &[StarFace], u: u32, v: u32) -> f64 {
        let uv = sub(self.pos[v as usize], self.pos[u as usize]);
        let mut volume = 0.0;
        for s in star {
            if s.a == v || s.b == v {
                continue; // a face on the edge: it disappears
            }
            volume += dot3(s.n_old, uv).abs() / 6.0;
        }
        volume
    }

    /// No flip: after `u → v` every surviving face of the star of `u` keeps its normal on the
    /// same side (`n_old·n_new > 0`) and stays well away from degeneracy.
    fn surviving_faces_stay_valid(&self, star: &[StarFace], v: u32) -> bool {
        let pv = self.pos[v as usize];
        for s in star {
            if s.a == v || s.b == v {
                continue;
            }
            let (pa, pb) = (s.pa, s.pb);
            let n_new = cross(sub(pa, pv), sub(pb, pv));
            if !exceeds(dot3(s.n_old, n_new), 0.0) {
                return false;
            }
            let e = [sub(pa, pv), sub(pb, pv), sub(pb, pa)];
            let longest2 = e.iter().map(|x| dot3(*x, *x)).fold(0.0, f64::max);
            // Keep coarse triangles well away from the validator's degeneracy threshold.
            if !exceeds(norm3(n_new), 1e-8 * longest2) {
                return false;
            }
        }
        true
    }

    /// Applies the collapse `u → best.target` and returns its record.
    fn collapse(&mut self, u: u32, best: Best) -> Collapse {
        let ui = u as usize;
        let v = best.target;
        let mut faces_u = std::mem::take(&mut self.faces_u);
        self.vertex_faces.take_into(ui, &mut faces_u);
        for &f in &faces_u {
            let t = self.faces[f as usize];
            if t.contains(&v) {
                for &w in &t {
                    if w != u {
                        self.vertex_faces.remove(w as usize, f);
                    }
                }
            } else {
                for slot in self.faces[f as usize].iter_mut() {
                    if *slot == u {
                        *slot = v;
                    }
                }
                self.vertex_faces.push(v as usize, f);
            }
        }
        self.faces_u = faces_u;
        self.alive[ui] = false;
        if best.boundary {
            self.boundary_vertices -= 1;
        }
        let vi = v as usize;
        self.accumulated_m[vi] = self.accumulated_m[vi].max(best.priority);
        // Nearest triangle around v (all its faces are alive after the collapse).
        let p = self.pos[ui];
        let mut nearest = ([v, v, v], [1.0, 0.0, 0.0], f64::INFINITY);
        for &f in &self.vertex_faces[vi] {
            let t = self.faces[f as usize];
            let (bary, dist2) = closest_point_barycentric(
                p,
                self.pos[t[0] as usize],
                self.pos[t[1] as usize],
                self.pos[t[2] as usize],
            );
            if dist2 < nearest.2 {
                nearest = (t, bary, dist2);
            }
        }
        Collapse {
            removed: u,
            kept: v,
            triangle: nearest.0,
            barycentric: nearest.1,
        }
    }
}

/// Barycentric coordinates of the point of triangle `abc` closest to `p`, and the squared
/// distance (Ericson, Real-Time Collision Detection §5.1.5).
pub fn closest_point_barycentric(
    p: [f64; 3],
    a: [f64; 3],
    b: [f64; 3],
    c: [f64; 3],
) -> ([f64; 3], f64) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot3(ab, ap);
    let d2 = dot3(ac, ap);
    let bary = if d1 <= 0.0 && d2 <= 0.0 {
        [1.0, 0.0, 0.0]
    } else {
        let bp = sub(p, b);
        let d3 = dot3(ab, bp);
        let d4 = dot3(ac, bp);
        let cp = sub(p, c);
        let d5 = dot3(ab, cp);
        let d6 = dot3(ac, cp);
        let vc = d1 * d4 - d3 * d2;
        let vb = d5 * d2 - d1 * d6;
        let va = d3 * d6 - d5 * d4;
        if d3 >= 0.0 && d4 <= d3 {
            [0.0, 1.0, 0.0]
        } else if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            let t = d1 / (d1 - d3);
            [1.0 - t, t, 0.0]
        } else if d6 >= 0.0 && d5 <= d6 {
            [0.0, 0.0, 1.0]
        } else if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            let t = d2 / (d2 - d6);
            [1.0 - t, 0.0, t]
        } else if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            [0.0, 1.0 - t, t]
        } else {
            let denom = 1.0 / (va + vb + vc);
            let v = vb * denom;
            let w = vc * denom;
            [1.0 - v - w, v, w]
        }
    };
    let q = [0, 1, 2].map(|k| bary[0] * a[k] + bary[1] * b[k] + bary[2] * c[k]);
    let d = sub(p, q);
    (bary, dot3(d, d))
}

#[cfg(test)]
mod tests {
    use super::super::test_meshes::{grid, hemisphere, noisy_height_field};
    use super::*;

    #[test]
    fn every_level_is_a_valid_disk_and_keeps_locked_vertices() {
        for chart in [
            noisy_height_field(20, 0.5, 9),
            hemisphere(24, 10),
            grid(15, 9, |x, y| [x, y, 0.1 * (x * 0.7).sin()]),
        ] {
            chart.validate().expect("input disk");
            let locked = [0u32, (chart.positions_m.len() - 1) as u32];
            let pm = build_progressive_mesh(&chart, &locked, &ProgressiveMeshOptions::default())
                .expect("pm");
            let n = chart.positions_m.len();
            assert!(
                pm.collapses.len() > n / 2,
                "decimated only {} of {n}",
                pm.collapses.len()
            );
            let mut removed = vec![false; n];
            for c in &pm.collapses {
                assert!(!locked.contains(&c.removed));
                assert!(!removed[c.removed as usize], "vertex removed twice");
                removed[c.removed as usize] = true;
                let s: f64 = c.barycentric.iter().sum();
                assert!((s - 1.0).abs() < 1e-12 && c.barycentric.iter().all(|&b| b >= 0.0));
            }
            for applied in [
                0,
                pm.collapses.len() / 3,
                pm.collapses.len() / 2,
                pm.collapses.len(),
            ] {
                let level = pm.level(&chart, applied).expect("level");
                assert_eq!(level.chart.positions_m.len(), pm.vertices_after(applied));
                level
                    .chart
                    .validate()
                    .unwrap_or_else(|e| panic!("level {applied}: {e}"));
                for &l in &locked {
                    assert_ne!(level.level_vertex[l as usize], u32::MAX);
                }
                // Euler: a disk keeps V − E + F = 1, so F = 2V − B − 2 (B boundary vertices).
                let topo = level.chart.validate().expect("disk");
                let b = topo.boundary_loop.len();
                assert_eq!(
                    level.chart.triangles.len(),
                    2 * level.chart.positions_m.len() - b - 2
                );
            }
        }
    }

    #[test]
    fn flat_grid_interior_decimates_and_corners_survive() {
        // The 4 corners have a 90° turning angle (> 70°): they must survive every collapse.
        let chart = grid(12, 12, |x, y| [x, y, 0.0]);
        let pm =
            build_progressive_mesh(&chart, &[], &ProgressiveMeshOptions::default()).expect("pm");
        let corners = [0u32, 12, 13 * 12, 13 * 13 - 1];
        for c in &pm.collapses {
            assert!(!corners.contains(&c.removed));
        }
        let coarse = pm.level(&chart, pm.collapses.len()).expect("level");
        assert!(
            coarse.chart.positions_m.len() <= 8,
            "{}",
            coarse.chart.positions_m.len()
        );
        // Vertex splits on a flat grid: barycentric interpolation of the identity map
        // reproduces each re-inserted vertex's (x, y) exactly (it lies in its triangle).
        let mut uv = vec![[f64::NAN; 2]; chart.positions_m.len()];
        for &v in &coarse.chart_vertex {
            let p = chart.positions_m[v as usize];
            uv[v as usize] = [p[0], p[1]];
        }
        pm.split_to(&mut uv, pm.collapses.len(), 0);
        for (p, q) in chart.positions_m.iter().zip(&uv) {
            assert!(
                (p[0] - q[0]).abs() < 1e-9 && (p[1] - q[1]).abs() < 1e-9,
                "{p:?} {q:?}"
            );
        }
    }

    #[test]
    fn min_vertices_stops_early_and_is_deterministic() {
        let chart = noisy_height_field(16, 0.3, 2);
        let opts = ProgressiveMeshOptions {
            min_vertices: 100,
            ..Default::default()
        };
        let a = build_progressive_mesh(&chart, &[], &opts).expect("pm");
        let b = build_progressive_mesh(&chart, &[], &opts).expect("pm");
        assert_eq!(a, b);
        assert_eq!(a.vertices_after(a.collapses.len()), 100);
    }

    #[test]
    fn queue_key_orders_like_total_cmp_and_round_trips() {
        let xs = [
            f64::NEG_INFINITY,
            -1e300,
            -1.5,
            -f64::MIN_POSITIVE,
            -0.0,
            0.0,
            f64::MIN_POSITIVE,
            1e-300,
            0.25,
            0.25000000000000006,
            7.0,
            f64::INFINITY,
            f64::NAN,
        ];
        for &a in &xs {
            assert_eq!(order_key_inverse(order_key(a)).to_bits(), a.to_bits());
            for &b in &xs {
                assert_eq!(order_key(a).cmp(&order_key(b)), a.total_cmp(&b), "{a} {b}");
                for (va, vb) in [(3u32, 5u32), (5, 3), (u32::MAX, 0)] {
                    let (ca, cb) = (Candidate::new(a, va), Candidate::new(b, vb));
                    assert_eq!(ca.vertex(), va);
                    // The max-heap pops the smaller (priority, vertex) first.
                    let expected = b.total_cmp(&a).then(vb.cmp(&va));
                    assert_eq!(ca.cmp(&cb), expected, "{a} {b} {va} {vb}");
                }
            }
        }
    }

    #[test]
    fn collapse_list_is_bit_identical_at_any_thread_count() {
        // Large enough for full evaluation batches (the parallel part).
        let chart = noisy_height_field(70, 0.4, 5);
        let locked = [0u32, 17];
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool")
                .install(|| {
                    build_progressive_mesh(&chart, &locked, &ProgressiveMeshOptions::default())
                        .expect("pm")
                })
        };
        let one = run(1);
        assert!(one.collapses.len() > chart.positions_m.len() / 2);
        for threads in [2, 3] {
            let other = run(threads);
            assert_eq!(one.collapses.len(), other.collapses.len());
            for (a, b) in one.collapses.iter().zip(&other.collapses) {
                assert_eq!(
                    (a.removed, a.kept, a.triangle),
                    (b.removed, b.kept, b.triangle)
                );
                assert_eq!(
                    a.barycentric.map(f64::to_bits),
                    b.barycentric.map(f64::to_bits)
                );
            }
        }
    }

    #[test]
    fn quad_heap_pops_in_binary_heap_order() {
        let mut seed = 12345u64;
        let mut quad = QuadHeap::with_capacity(0);
        let mut binary = std::collections::BinaryHeap::new();
        for round in 0..2000u32 {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            // Mixed pushes and pops, with repeated priorities (ties broken by vertex).
            if seed >> 62 == 0 {
                assert_eq!(quad.pop(), binary.pop(), "round {round}");
            } else {
                let c = Candidate::new(((seed >> 40) % 64) as f64 * 0.25, round);
                quad.push(c);
                binary.push(c);
            }
        }
        while let Some(c) = binary.pop() {
            assert_eq!(quad.pop(), Some(c));
        }
        assert_eq!(quad.pop(), None);
    }

    #[test]
    fn face_lists_keep_order_through_spills_like_vecs() {
        let mut lists = FaceLists::new(3);
        let mut reference: Vec<Vec<u32>> = vec![Vec::new(); 3];
        let mut seed = 7u64;
        for step in 0..3000u32 {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let v = (seed >> 33) as usize % 3;
            // Grow vertex 1 past the inline capacity; keep the others short.
            let grow = if v == 1 { 6 } else { 2 };
            if (seed >> 40) % 10 < grow || reference[v].is_empty() {
                lists.push(v, step % 40);
                reference[v].push(step % 40);
            } else if (seed >> 50) % if v == 1 { 97 } else { 7 } == 0 {
                let mut out = vec![99];
                lists.take_into(v, &mut out);
                assert_eq!(out, reference[v]);
                reference[v].clear();
            } else {
                let f = reference[v][(seed >> 20) as usize % reference[v].len()];
                lists.remove(v, f);
                reference[v].retain(|&g| g != f);
            }
            for w in 0..3 {
                assert_eq!(&lists[w], reference[w].as_slice(), "step {step} vertex {w}");
            }
        }
        assert!(
            !lists.spill.is_empty(),
            "the test must exercise the spill pool"
        );
    }

    #[test]
    fn closest_point_matches_brute_force() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.5]);
        for p in [
            [0.5, 0.3, 1.0],
            [-1.0, -1.0, 0.0],
            [3.0, 0.1, 0.0],
            [0.0, 2.0, 1.0],
            [1.5, 1.5, 0.0],
        ] {
            let (bary, d2) = closest_point_barycentric(p, a, b, c);
            let mut best = f64::INFINITY;
            for i in 0..=200 {
                for j in 0..=(200 - i) {
                    let (s, t) = (i as f64 / 200.0, j as f64 / 200.0);
                    let q = [0, 1, 2].map(|k| a[k] + s * (b[k] - a[k]) + t * (c[k] - a[k]));
                    best = best.min(dot3(sub(p, q), sub(p, q)));
                }
            }
            assert!(d2 <= best + 1e-12 && d2 >= best - 1e-3, "{d2} vs {best}");
            assert!(bary.iter().all(|&x| x >= -1e-15));
        }
    }
}
