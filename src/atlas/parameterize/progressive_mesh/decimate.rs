//! The decimation that builds a progressive mesh ([`build_progressive_mesh`]): the queue of
//! candidate half-edge collapses, the validity and importance of a collapse (hlscm-2003 §4), and
//! the collapse itself (module doc of [`super`]).
use std::f64::consts::PI;

use rayon::prelude::*;

use super::super::chart::{exceeds, ChartMesh};
use super::super::ParameterizeError;
use super::{
    closest_point_barycentric, internal, Collapse, ProgressiveMesh, ProgressiveMeshOptions,
};
use crate::mesh::vector::{cross, dot, norm, sub};

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
pub(super) struct QueueState {
    last_priority: f64,
    locked: bool,
    dirty: bool,
    queued: bool,
}

/// Dirty vertices re-evaluated together (in parallel) once this many reached the top of the
/// queue. Bounds how far the collapse order departs from the strictly sequential greedy one.
pub(super) const EVALUATION_BATCH: usize = 256;

/// Vertices of an evaluation batch whose stars are loaded together before they are evaluated
/// ([`Decimator::warm_stars`]). Their data (about 20 cache lines each) stays in L2.
pub(super) const WARM_CHUNK: usize = 32;

/// A 4-ary max-heap: half the depth of a binary heap, and the 4 children of a node share one
/// 64-byte cache line (16-byte entries), so a pop touches about half as many lines. With up to
/// one entry per vertex (500k at 1M triangles, 8 MB) the queue does not fit in cache and its
/// sift-down was the largest single cost of the decimation loop (measured with `perf`).
/// Pops in the same order as `std::collections::BinaryHeap` (a total order has one maximum).
pub(super) struct QuadHeap<T> {
    items: Vec<T>,
}

impl<T: Ord + Copy> QuadHeap<T> {
    pub(super) fn with_capacity(capacity: usize) -> Self {
        Self {
            items: Vec::with_capacity(capacity),
        }
    }

    pub(super) fn push(&mut self, item: T) {
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

    pub(super) fn peek(&self) -> Option<&T> {
        self.items.first()
    }

    pub(super) fn pop(&mut self) -> Option<T> {
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
pub(super) struct Candidate {
    /// `!(order_key(priority) << 32 | vertex)`: the max-heap pops the smallest pair first.
    key: u128,
}

impl Candidate {
    pub(super) fn new(priority: f64, vertex: u32) -> Self {
        Self {
            key: !((u128::from(order_key(priority)) << 32) | u128::from(vertex)),
        }
    }
    pub(super) fn priority(self) -> f64 {
        order_key_inverse((!self.key >> 32) as u64)
    }
    pub(super) fn vertex(self) -> u32 {
        (!self.key & 0xffff_ffff) as u32
    }
}

/// An unsigned key whose integer order is `f64::total_cmp`'s order (the same bit transform
/// as the standard library's implementation, shifted to unsigned).
pub(super) fn order_key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | (1 << 63)
    }
}

pub(super) fn order_key_inverse(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

/// The cheapest valid collapse of a vertex `u` (the half-edge `u → target`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Best {
    /// Priority of the half-edge (a length, model units).
    priority: f64,
    /// The vertex `u` merges into.
    target: u32,
    /// Whether `u` is on the boundary (then the collapse runs along the boundary).
    boundary: bool,
}

/// A face of the star of `u`, rotated so that `u` comes first: `(u, a, b)`.
pub(super) struct StarFace {
    a: u32,
    b: u32,
    pa: [f64; 3],
    pb: [f64; 3],
    /// `(a − u) × (b − u)`, the face normal before the collapse (twice the area).
    n_old: [f64; 3],
}

/// Reusable buffers of [`Decimator::best_collapse`] (one per thread).
#[derive(Default)]
pub(super) struct Scratch {
    star: Vec<StarFace>,
    /// The 1-ring of `u` with the number of faces on each edge (1 boundary, 2 inside),
    /// unsorted (rings are small: linear search beats sorting).
    ring_u: Vec<(u32, u32)>,
    ring_v: Vec<u32>,
    /// (priority, target, faces on the edge).
    candidates: Vec<(f64, u32, u32)>,
}

pub(super) fn add_counted(ring: &mut Vec<(u32, u32)>, w: u32) {
    match ring.iter_mut().find(|e| e.0 == w) {
        Some(e) => e.1 += 1,
        None => ring.push((w, 1)),
    }
}

/// Faces stored inline per vertex; a longer list spills to [`FaceLists::spill`].
pub(super) const INLINE_FACES: usize = 15;

/// `len` of a [`FaceSlot`] whose list lives in the spill pool at index `faces[0]`.
pub(super) const SPILLED: u32 = u32::MAX;

/// One vertex's face list in one 64-byte cache line (a `Vec<u32>` per vertex costs a
/// dependent miss on its header and one on its heap block). Valence rarely exceeds 15 faces
/// during decimation; the few longer lists move to a pool.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(super) struct FaceSlot {
    len: u32,
    faces: [u32; INLINE_FACES],
}

/// The vertex → incident faces lists of the mesh under decimation. Insertion order is kept
/// (pushes append, removals shift), exactly as the `Vec<Vec<u32>>` it replaces, so every
/// evaluation visits faces in the same order and gives the same bits.
pub(super) struct FaceLists {
    slots: Vec<FaceSlot>,
    pub(super) spill: Vec<Vec<u32>>,
}

impl FaceLists {
    pub(super) fn new(n: usize) -> Self {
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

    pub(super) fn push(&mut self, v: usize, f: u32) {
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
    pub(super) fn remove(&mut self, v: usize, f: u32) {
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
    pub(super) fn take_into(&mut self, v: usize, out: &mut Vec<u32>) {
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
pub(super) struct Decimator<'a> {
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
    pub(super) fn new(
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
    pub(super) fn warm_stars(&self, us: &[u32]) -> u64 {
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
    pub(super) fn best_collapse(&self, u: u32, scratch: &mut Scratch) -> Option<Best> {
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
            angle_sum += norm(n_old).atan2(dot(ea, eb));
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
    pub(super) fn collapse_loss(
        &self,
        star: &[StarFace],
        u: u32,
        v: u32,
        other_boundary: Option<u32>,
    ) -> f64 {
        let pu = self.pos[u as usize];
        let pv = self.pos[v as usize];
        let volume = self.swept_volume(star, u, v);
        let mut area = 0.0;
        if let Some(w) = other_boundary {
            // The other boundary neighbour w of u: old border w–u–v becomes w–v.
            let pw = self.pos[w as usize];
            area = 0.5 * norm(cross(sub(pu, pw), sub(pv, pw)));
        }
        volume.cbrt() + area.sqrt()
    }

    /// The volume swept by the faces of the star of `u` that survive `u → v`
    /// (`Σ |det(a−u, b−u, v−u)|/6`).
    pub(super) fn swept_volume(&self, star: &[StarFace], u: u32, v: u32) -> f64 {
        let uv = sub(self.pos[v as usize], self.pos[u as usize]);
        let mut volume = 0.0;
        for s in star {
            if s.a == v || s.b == v {
                continue; // a face on the edge: it disappears
            }
            volume += dot(s.n_old, uv).abs() / 6.0;
        }
        volume
    }

    /// No flip: after `u → v` every surviving face of the star of `u` keeps its normal on the
    /// same side (`n_old·n_new > 0`) and stays well away from degeneracy.
    pub(super) fn surviving_faces_stay_valid(&self, star: &[StarFace], v: u32) -> bool {
        let pv = self.pos[v as usize];
        for s in star {
            if s.a == v || s.b == v {
                continue;
            }
            let (pa, pb) = (s.pa, s.pb);
            let n_new = cross(sub(pa, pv), sub(pb, pv));
            if !exceeds(dot(s.n_old, n_new), 0.0) {
                return false;
            }
            let e = [sub(pa, pv), sub(pb, pv), sub(pb, pa)];
            let longest2 = e.iter().map(|x| dot(*x, *x)).fold(0.0, f64::max);
            // Keep coarse triangles well away from the validator's degeneracy threshold.
            if !exceeds(norm(n_new), 1e-8 * longest2) {
                return false;
            }
        }
        true
    }

    /// Applies the collapse `u → best.target` and returns its record.
    pub(super) fn collapse(&mut self, u: u32, best: Best) -> Collapse {
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
