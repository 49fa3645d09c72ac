//! Feature detection: LSCM paper §3.1, Algorithm 1 ("features growing").
//!
//! Purpose: find curves of high curvature, where chart borders will not show (shading already
//! varies sharply there), so that chart growing (`grow.rs`) makes charts meet on them.
//!
//! Algorithm, as in the paper:
//! 1. Sharpness of an edge = the angle between the normals of its two faces ("second order
//!    difference", [`TriangleMesh::dihedral_angle_rad`]). Boundary edges and edges next to a
//!    zero-area face have no sharpness (0 here): they never start or carry a feature.
//! 2. The threshold τ keeps a fraction of the edges: τ is the sharpness of the
//!    `⌈feature_fraction · n⌉`-th sharpest of the `n` edges that have one. With τ = 0 (a flat mesh,
//!    or a flat part whose creases are fewer than that fraction) Algorithm 1 keeps no curve;
//!    the hard-edge pass still runs.
//! 3. Every edge with sharpness ≥ τ, sharpest first (ties by edge id), not yet tagged, starts a
//!    curve grown in both directions: from the curve's end, a depth-first search finds the string
//!    `S` of at most `max_string_length` edges with the largest total sharpness, then the curve
//!    advances by the first edge after the end, while `sharpness(S) ≥ max_string_length · τ`.
//!    Curves with more than `min_feature_length` edges are kept: their edges become features and
//!    every other edge touching one of their vertices is tagged as a feature *neighbour*, which no
//!    later string may use (this is what stops a high-curvature zone from producing a bundle of
//!    parallel features).
//!
//! Interpretation choices (the paper leaves them open), each for a stated reason:
//! - "No halfedge of S goes backward relative to h′": every edge of `S`, as a vector, has a
//!   non-negative dot product with the curve's current end edge `h′`, and `S` never revisits a
//!   vertex of the curve or of itself. This lets a curve turn by up to 90° within one look-ahead
//!   (a cube corner) while never doubling back.
//! - The stopping test is `≥` (with a relative slack of 1e-9) rather than the paper's `>`: on CAD
//!   meshes every feature edge has exactly the same sharpness, τ is that value, and a strict test
//!   would reject every feature.
//! - The edge a string is searched from is appended only when the string passes the test (the
//!   paper appends first and tests after, leaving one weak edge at each end).
//! - A curve whose end is one edge away from its other end, along an edge with sharpness ≥ τ,
//!   is closed by that edge (closed feature loops such as the rim of a cylinder).
//! - Junctions: a string may end by *docking* on a vertex of an already kept curve (through an
//!   edge that is tagged as a feature neighbour, which it could not use otherwise); such a string
//!   must be sharp on average over its own length (`sharpness(S) ≥ |S| · τ`), and a curve that
//!   docks at both ends, or closes into a loop, is kept whatever its length. Without this, the
//!   neighbour tags of the first curve through a corner of a cube forbid the third edge at that
//!   corner, and T- and Y-junctions of features (common on CAD and scanned models) are lost;
//!   `min_feature_length` is a filter against isolated noise, and an anchored curve is not isolated.
//! - Strings walk the outgoing half-edges of a vertex; the one boundary edge a boundary vertex has
//!   no outgoing half-edge for is not walked. It has no sharpness, so no string would gain from it.
//!
//! Addition to the paper, **hard edges** ([`Lscm2002Options::hard_edge_angle_rad`], default
//! 60°): after Algorithm 1, on every connected component where it kept no curve, every edge at
//! least that sharp becomes a feature edge by itself when it lies on a connected set (sharing
//! vertices) of at least [`MIN_HARD_CHAIN_EDGES`] such edges. Algorithm 1's look-ahead needs
//! `max_string_length` sharp edges in a row and its filter `min_feature_length` of them, which a
//! low-poly crease rarely has (a 12-triangle cube has no feature by Algorithm 1, and was cut by
//! the diameter rule into two star-shaped charts); the chain rule drops isolated sharp edges.
//! Only on components without curves, measured (one run, release, charts after validation):
//! applied everywhere at 60°, bunny went from 28 to 31 charts, armadillo 74 to 80 and
//! MixedLightingExample 106 to 176 (creases of a few edges fenced small regions that the
//! paper's merging had joined); as a fallback those are unchanged and every cube of the corpus
//! gets its 6 sides.
//! Hard edges are kept in [`Features::hard_edges`], not in `curves` (they are not walked curves).
//!
//! Units: sharpness in radians, in `[0, π]`; lengths are counts of edges.
//!
//! Cost: `O(E log E)` for the threshold sort, plus per curve step a depth-first search over at most
//! `d^L` strings (`d` ≈ 3 forward edges per vertex, `L = max_string_length`).
//!
//! Parallelism (same curves at any thread count): candidates are taken in order, but with more
//! than one rayon thread a window of them is expanded at once against the tags at the window's
//! start, and a speculative curve is used only when no curve accepted in between changed a tag
//! it read (else it is grown again); most candidates are rejected (on armadillo 214 of 4759
//! curves are kept), so most speculations stand.
//!
//! References: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least Squares Conformal Maps for
//! Automatic Texture Atlas Generation", SIGGRAPH 2002, §3.1 and Algorithm 1; the sharpness
//! criterion is from Hubeli & Gross 2001 (the paper's reference \[11\]).
use rayon::prelude::*;

use crate::atlas::progress::StageProgress;
use crate::mesh::{HalfedgeId, TriangleMesh};

use super::options::Lscm2002Options;
use super::{checkpoint, SegmentError};

/// The detected features of a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Features {
    /// Sharpness of the edge of each half-edge (both halves of a glued edge carry the same value),
    /// radians in `[0, π]`; 0 on the boundary and next to zero-area faces. Indexed by
    /// `HalfedgeId::index()`.
    pub sharpness_rad: Vec<f64>,
    /// The threshold τ, or `None` when no edge has a positive sharpness (a flat mesh).
    pub threshold_rad: Option<f64>,
    /// True on both halves of every edge that belongs to a kept feature curve.
    pub is_feature: Vec<bool>,
    /// The kept curves, each as its edges (the half-edge it was walked along) in curve order.
    pub curves: Vec<Vec<HalfedgeId>>,
    /// Hard edges that were not already on a curve (one half-edge per edge, ascending): see
    /// the module doc and [`Lscm2002Options::hard_edge_angle_rad`].
    pub hard_edges: Vec<HalfedgeId>,
    /// True on both halves of every hard edge (on a curve or not): chart growing treats these
    /// as borders (`grow.rs`).
    pub is_hard: Vec<bool>,
}

impl Features {
    /// True when the edge of `h` is a feature.
    pub fn is_feature_edge(&self, h: HalfedgeId) -> bool {
        self.is_feature.get(h.index()).copied().unwrap_or(false)
    }
    /// True when the edge of `h` is a hard edge (module doc).
    pub fn is_hard_edge(&self, h: HalfedgeId) -> bool {
        self.is_hard.get(h.index()).copied().unwrap_or(false)
    }
    /// Number of feature edges (glued pairs counted once).
    pub fn num_feature_edges(&self) -> usize {
        self.curves.iter().map(Vec::len).sum::<usize>() + self.hard_edges.len()
    }
}

/// Hard edges are features only on a connected set (through shared vertices) of at least this
/// many hard edges: an isolated sharp edge or pair is noise on a scanned mesh, a crease is a
/// chain. 3: a cube corner, and any crease of three edges or more.
pub const MIN_HARD_CHAIN_EDGES: usize = 3;

/// Relative slack of the string test `sharpness(S) ≥ L·τ` (see the module doc).
const STRING_TEST_SLACK: f64 = 1e-9;

/// Detects feature curves with Algorithm 1 of the LSCM paper (see the module doc).
/// Deterministic: edges are visited in a fixed order and ties broken by id.
///
/// `progress`: the sharpness of every edge is the first half, growing the curves from the
/// candidate edges the second, with a checkpoint every `PROGRESS_EVERY_CANDIDATES`
/// candidates; `Break` returns [`SegmentError::Cancelled`].
pub fn detect_features(
    mesh: &TriangleMesh,
    options: &Lscm2002Options,
    progress: &mut StageProgress<'_>,
) -> Result<Features, SegmentError> {
    checkpoint(progress.advance(0, 2))?;
    let nh = mesh.num_halfedges();
    let mut sharpness_rad = vec![0.0; nh];
    // One normal per face, then the angle of `TriangleMesh::dihedral_angle_rad` (same formula,
    // same bits) per edge: each normal is computed once instead of once per edge. Both in
    // parallel (each value depends on its own face or edge only; collected in id order).
    let faces: Vec<crate::mesh::FaceId> = mesh.faces().collect();
    let normals: Vec<Option<[f64; 3]>> = faces.par_iter().map(|&f| mesh.face_normal(f)).collect();
    let dihedral = |h: HalfedgeId, o: HalfedgeId| {
        let n1 = normals[h.face().index()]?;
        let n2 = normals[o.face().index()]?;
        let c = [
            n1[1] * n2[2] - n1[2] * n2[1],
            n1[2] * n2[0] - n1[0] * n2[2],
            n1[0] * n2[1] - n1[1] * n2[0],
        ];
        let d = n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2];
        Some((c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt().atan2(d))
    };
    let edges: Vec<HalfedgeId> = mesh.edges().collect();
    let angles: Vec<Option<(f64, HalfedgeId)>> = edges
        .par_iter()
        .map(|&h| {
            let o = mesh.opposite(h)?;
            let a = dihedral(h, o)?;
            debug_assert_eq!(Some(a), mesh.dihedral_angle_rad(h));
            Some((a, o))
        })
        .collect();
    let mut ranked: Vec<(f64, HalfedgeId)> = Vec::with_capacity(edges.len());
    for (&h, e) in edges.iter().zip(&angles) {
        if let Some((a, o)) = *e {
            sharpness_rad[h.index()] = a;
            sharpness_rad[o.index()] = a;
            ranked.push((a, h));
        }
    }
    let mut out = Features {
        sharpness_rad,
        threshold_rad: None,
        is_feature: vec![false; nh],
        curves: Vec::new(),
        hard_edges: Vec::new(),
        is_hard: vec![false; nh],
    };
    if ranked.is_empty() {
        return Ok(out);
    }
    // Sharpest first, ties by edge id: the processing order of step 3. Only the edges at least
    // as sharp as τ (the k-th) are visited, so only they are sorted: the k first by a selection,
    // then those after them that tie with τ (the same prefix as a full sort's, same order).
    let order =
        |a: &(f64, HalfedgeId), b: &(f64, HalfedgeId)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
    let k =
        ((options.feature_fraction * ranked.len() as f64).ceil() as usize).clamp(1, ranked.len());
    ranked.select_nth_unstable_by(k - 1, order);
    let tau = ranked[k - 1].0;
    let mut end = k;
    for i in k..ranked.len() {
        if ranked[i].0.total_cmp(&tau).is_eq() {
            ranked.swap(end, i);
            end += 1;
        }
    }
    ranked.truncate(end);
    ranked.sort_unstable_by(order);
    // τ ≤ 0 (the sharpest share reaches flat edges: a flat part with a short crease) leaves
    // Algorithm 1 nothing to grow, but the hard-edge pass below still runs.
    if tau.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        checkpoint(progress.advance(2, 2))?;
        if let Some(angle) = options.hard_edge_angle_rad {
            add_hard_edges(mesh, &mut out, angle);
        }
        return Ok(out);
    }
    out.threshold_rad = Some(tau);
    let mut grower = Grower::new(
        mesh,
        &out.sharpness_rad,
        tau,
        options.max_string_length.max(1),
    );
    let keep = |e: &Expansion| {
        e.curve.len() > options.min_feature_length || (e.anchored && e.curve.len() > 1)
    };
    let candidates: Vec<HalfedgeId> = ranked
        .iter()
        .take_while(|&&(a, _)| a >= tau)
        .map(|&(_, h)| h)
        .collect();
    let mut scratch = Scratch::default();
    let threads = rayon::current_num_threads();
    checkpoint(progress.advance(1, 2))?;
    let mut curves_progress = progress.part(1, 1, 2);
    if threads <= 1 {
        for (i, &h) in candidates.iter().enumerate() {
            if i % PROGRESS_EVERY_CANDIDATES == 0 {
                checkpoint(curves_progress.advance(i, candidates.len()))?;
            }
            if !grower.usable(h) {
                continue;
            }
            let e = grower.expand(h, &mut scratch);
            if keep(&e) {
                grower.accept(&e.curve);
                out.curves.push(e.curve);
            }
        }
    } else {
        // Speculation, same result as the loop above: the candidates of a window are expanded
        // in parallel against the state at the window's start; each expansion is then taken in
        // candidate order if no curve accepted since has touched the vertices it read (else
        // it is expanded again against the current state). An expansion is a pure function of
        // that state, so the curves do not depend on the thread count.
        let window = SPECULATION_WINDOW_PER_THREAD * threads;
        let mut reported = 0usize;
        for (k, chunk) in candidates.chunks(window).enumerate() {
            let start = k * window;
            if start >= reported + PROGRESS_EVERY_CANDIDATES || k == 0 {
                checkpoint(curves_progress.advance(start, candidates.len()))?;
                reported = start;
            }
            let base = grower.accepts;
            let todo: Vec<HalfedgeId> = chunk
                .iter()
                .copied()
                .filter(|&h| grower.usable(h))
                .collect();
            let speculated: Vec<Expansion> = todo
                .par_iter()
                .map_init(Scratch::default, |s, &h| grower.expand(h, s))
                .collect();
            for (&h, e) in todo.iter().zip(speculated) {
                if !grower.usable(h) {
                    continue;
                }
                let e = if grower.unchanged_since(&e, base) {
                    e
                } else {
                    grower.expand(h, &mut scratch)
                };
                if keep(&e) {
                    grower.accept(&e.curve);
                    out.curves.push(e.curve);
                }
            }
        }
    }
    checkpoint(curves_progress.advance(candidates.len(), candidates.len()))?;
    out.is_feature = grower.is_feature;
    if let Some(angle) = options.hard_edge_angle_rad {
        add_hard_edges(mesh, &mut out, angle);
    }
    Ok(out)
}

/// Candidate edges between two progress checkpoints of [`detect_features`].
const PROGRESS_EVERY_CANDIDATES: usize = 1024;

/// Adds the hard edges (sharpness ≥ `angle_rad`, on a connected set of at least
/// [`MIN_HARD_CHAIN_EDGES`] of them) to `features` (module doc). Deterministic: edges in id order,
/// components by union-find over vertex ids.
fn add_hard_edges(mesh: &TriangleMesh, features: &mut Features, angle_rad: f64) {
    // Only on components where Algorithm 1 kept no curve (module doc).
    let comps = mesh.components();
    let comp_of = |h: HalfedgeId| comps.face_component.as_slice()[h.face().index()].0 as usize;
    let mut has_curve = vec![false; comps.len()];
    for c in &features.curves {
        if let Some(&h) = c.first() {
            has_curve[comp_of(h)] = true;
        }
    }
    let hard: Vec<HalfedgeId> = mesh
        .edges()
        .filter(|&h| {
            mesh.opposite(h).is_some()
                && features.sharpness_rad[h.index()] >= angle_rad
                && !has_curve[comp_of(h)]
        })
        .collect();
    if hard.len() < MIN_HARD_CHAIN_EDGES {
        return;
    }
    // Union-find over the vertices of hard edges (indexed by vertex id).
    let mut parent: Vec<u32> = (0..mesh.num_vertices() as u32).collect();
    fn find(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            let p = parent[parent[v as usize] as usize];
            parent[v as usize] = p;
            v = p;
        }
        v
    }
    for &h in &hard {
        let a = find(&mut parent, mesh.from_vertex(h).0);
        let b = find(&mut parent, mesh.to_vertex(h).0);
        if a != b {
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    let mut count = vec![0u32; mesh.num_vertices()];
    for &h in &hard {
        count[find(&mut parent, mesh.from_vertex(h).0) as usize] += 1;
    }
    for &h in &hard {
        let r = find(&mut parent, mesh.from_vertex(h).0);
        if (count[r as usize] as usize) < MIN_HARD_CHAIN_EDGES {
            continue;
        }
        features.is_hard[h.index()] = true;
        if let Some(o) = mesh.opposite(h) {
            features.is_hard[o.index()] = true;
        }
        if features.is_feature[h.index()] {
            continue;
        }
        features.is_feature[h.index()] = true;
        if let Some(o) = mesh.opposite(h) {
            features.is_feature[o.index()] = true;
        }
        features.hard_edges.push(h);
    }
}

/// Candidates expanded in parallel per window and per rayon thread (speculation in
/// [`detect_features`]): small enough that few speculations are spoilt by a curve accepted
/// earlier in the window, large enough to amortise the parallel dispatch.
const SPECULATION_WINDOW_PER_THREAD: usize = 32;

/// Vertices per parallel task when [`Grower::new`] fills the rotation table.
const RING_BLOCK_VERTICES: usize = 8192;

/// An outgoing half-edge of a vertex in [`Grower::ring`]: its id, the vertex it points to, its
/// sharpness (radians) and the position of its far end (model units), side by side for the
/// depth-first search (one contiguous read per search node).
#[derive(Clone, Copy)]
struct Out {
    sharp: f64,
    to_m: [f64; 3],
    g: u32,
    w: u32,
}

/// State of Algorithm 1 across curves.
struct Grower<'a> {
    mesh: &'a TriangleMesh,
    sharp: &'a [f64],
    tau: f64,
    max_len: usize,
    /// The outgoing half-edges of every vertex in rotation order (the order of
    /// `TriangleMesh::outgoing_halfedges`), vertex `v`'s at `ring[ring_start[v]..ring_start[v + 1]]`:
    /// one contiguous read per search node instead of a walk through `opposite` and
    /// `corner_vertex`.
    ring: Vec<Out>,
    ring_start: Vec<u32>,
    /// Feature tag per half-edge (both halves set).
    is_feature: Vec<bool>,
    /// Feature-neighbour tag per half-edge (both halves set).
    is_neighbor: Vec<bool>,
    /// True at the vertices of kept curves: a string may end there (docking).
    vertex_feature: Vec<bool>,
    /// Curves accepted so far.
    accepts: u32,
    /// Per vertex, the number of the last accepted curve (1-based, 0 for none) that changed a
    /// tag an expansion scanning this vertex's rotation reads: those with a vertex of the curve
    /// on a face around this vertex. See [`Grower::unchanged_since`].
    changed_at: Vec<u32>,
    /// Per vertex, the largest sharpness of its outgoing half-edges (radians): with
    /// `max_sharp`, the upper bound that prunes `dfs`.
    max_out: Vec<f64>,
    /// The largest sharpness of any half-edge (radians).
    max_sharp: f64,
}

/// The best string found so far by the depth-first search.
struct Best {
    /// `sharpness(S) − required · τ`: how far the string clears the test (see `dfs`).
    margin: f64,
    second: Option<HalfedgeId>,
    /// Whether the best string ends by docking on an existing feature.
    docked: bool,
    /// Number of edges in the best string.
    len: usize,
}

/// One curve grown by [`Grower::expand`], not yet accepted.
struct Expansion {
    /// The curve's edges in curve order.
    curve: Vec<HalfedgeId>,
    /// Closed into a loop, or joined to existing features at both ends.
    anchored: bool,
    /// Every vertex whose outgoing half-edges' tags the expansion read (with repeats).
    scanned: Vec<u32>,
}

/// Working memory of one expansion, reused across expansions.
#[derive(Default)]
struct Scratch {
    /// The vertices of the curve being grown.
    curve: VertexSet,
    /// The vertices of the string being searched, after the curve's end.
    path: Vec<u32>,
    /// See [`Expansion::scanned`].
    scanned: Vec<u32>,
}

/// A set of vertex ids (open addressing, linear probing), cleared in time proportional to its
/// size: the vertices of one curve, without a per-mesh array per thread.
#[derive(Default)]
struct VertexSet {
    /// `u32::MAX` for an empty slot; the length is a power of two (or 0).
    slots: Vec<u32>,
    /// Indices of the occupied slots.
    used: Vec<u32>,
}

impl VertexSet {
    const EMPTY: u32 = u32::MAX;

    fn clear(&mut self) {
        for &k in &self.used {
            self.slots[k as usize] = Self::EMPTY;
        }
        self.used.clear();
    }

    fn slot(&self, v: u32) -> usize {
        // Fibonacci hashing; `slots.len()` is a power of two.
        (v.wrapping_mul(0x9E37_79B9) as usize) & (self.slots.len() - 1)
    }

    fn contains(&self, v: u32) -> bool {
        if self.slots.is_empty() {
            return false;
        }
        let mask = self.slots.len() - 1;
        let mut k = self.slot(v);
        loop {
            match self.slots[k] {
                Self::EMPTY => return false,
                x if x == v => return true,
                _ => k = (k + 1) & mask,
            }
        }
    }

    fn insert(&mut self, v: u32) {
        if 2 * (self.used.len() + 1) > self.slots.len() {
            let old: Vec<u32> = self.used.iter().map(|&k| self.slots[k as usize]).collect();
            self.slots = vec![Self::EMPTY; (2 * self.slots.len()).max(64)];
            self.used.clear();
            for x in old {
                self.insert_unchecked(x);
            }
        }
        self.insert_unchecked(v);
    }

    fn insert_unchecked(&mut self, v: u32) {
        let mask = self.slots.len() - 1;
        let mut k = self.slot(v);
        loop {
            match self.slots[k] {
                Self::EMPTY => {
                    self.slots[k] = v;
                    self.used.push(k as u32);
                    return;
                }
                x if x == v => return,
                _ => k = (k + 1) & mask,
            }
        }
    }
}

impl<'a> Grower<'a> {
    fn new(mesh: &'a TriangleMesh, sharp: &'a [f64], tau: f64, max_len: usize) -> Self {
        let nv = mesh.num_vertices();
        let nh = mesh.num_halfedges();
        // `ring` grouped by vertex in id order. Vertex `v`'s outgoing half-edges are its
        // corners (one per incident face; its rotation visits them all, since every vertex's
        // faces form one fan, a mesh invariant), so the group sizes are counted from the
        // half-edges first; then blocks of vertices fill their groups in parallel, into
        // disjoint parts of one allocation of the final size (a parallel flat-map collect
        // built and copied per-thread pieces of this 40-byte-per-half-edge table, which cost
        // more in page faults and copies than the pass itself).
        let mut ring_start = vec![0u32; nv + 1];
        for h in mesh.halfedges() {
            ring_start[mesh.from_vertex(h).index() + 1] += 1;
        }
        for v in 0..nv {
            ring_start[v + 1] += ring_start[v];
        }
        let mut ring = vec![
            Out {
                sharp: 0.0,
                to_m: [0.0; 3],
                g: 0,
                w: 0,
            };
            nh
        ];
        {
            let mut blocks = Vec::new();
            let mut rest = &mut ring[..];
            for first in (0..nv).step_by(RING_BLOCK_VERTICES) {
                let end = (first + RING_BLOCK_VERTICES).min(nv);
                let len = (ring_start[end] - ring_start[first]) as usize;
                let (block, after) = std::mem::take(&mut rest).split_at_mut(len);
                rest = after;
                blocks.push((first..end, block));
            }
            blocks.into_par_iter().for_each(|(vertices, block)| {
                let mut slots = block.iter_mut();
                for v in vertices {
                    for g in mesh.outgoing_halfedges(crate::mesh::VertexId(v as u32)) {
                        if let Some(slot) = slots.next() {
                            *slot = Out {
                                sharp: sharp[g.index()],
                                to_m: mesh.position(mesh.to_vertex(g)),
                                g: g.0,
                                w: mesh.to_vertex(g).0,
                            };
                        }
                    }
                }
                debug_assert!(
                    slots.next().is_none(),
                    "a vertex's rotation misses some of its corners"
                );
            });
        }
        let max_out = (0..nv)
            .into_par_iter()
            .map(|v| {
                ring[ring_start[v] as usize..ring_start[v + 1] as usize]
                    .iter()
                    .map(|o| o.sharp)
                    .fold(0.0, f64::max)
            })
            .collect();
        Grower {
            mesh,
            sharp,
            tau,
            max_len,
            ring,
            ring_start,
            is_feature: vec![false; nh],
            is_neighbor: vec![false; nh],
            vertex_feature: vec![false; nv],
            accepts: 0,
            changed_at: vec![0; nv],
            max_out,
            max_sharp: sharp.par_iter().copied().reduce(|| 0.0, f64::max),
        }
    }

    fn out_of(&self, v: u32) -> &[Out] {
        &self.ring[self.ring_start[v as usize] as usize..self.ring_start[v as usize + 1] as usize]
    }

    fn direction(&self, h: HalfedgeId) -> [f64; 3] {
        let a = self.mesh.position(self.mesh.from_vertex(h));
        let b = self.mesh.position(self.mesh.to_vertex(h));
        [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
    }

    /// True when no curve accepted after the first `base` ones changed a tag that `e` read:
    /// `e` is then exactly what [`Grower::expand`] would return now. An accepted curve changes
    /// only tags of edges with an endpoint on the curve and of the curve's vertices, and an
    /// expansion reads only tags of the outgoing edges of the vertices it scans and of their
    /// far ends, so a change it could see marks a vertex it scanned (`changed_at`).
    fn unchanged_since(&self, e: &Expansion, base: u32) -> bool {
        e.scanned
            .iter()
            .all(|&v| self.changed_at[v as usize] <= base)
    }

    /// Grows one curve from `start` in both directions (its edges in curve order, and whether
    /// it is anchored: closed into a loop, or joined to existing features at both ends).
    /// Reads the tags only; `s` is working memory.
    fn expand(&self, start: HalfedgeId, s: &mut Scratch) -> Expansion {
        let mesh = self.mesh;
        s.curve.clear();
        s.scanned.clear();
        s.curve.insert(mesh.from_vertex(start).0);
        s.curve.insert(mesh.to_vertex(start).0);
        let mut forward: Vec<HalfedgeId> = vec![start];
        let mut backward: Vec<HalfedgeId> = Vec::new();
        let mut docked_ends = 0usize;
        let Some(reverse) = mesh.opposite(start) else {
            return Expansion {
                curve: forward,
                anchored: false,
                scanned: std::mem::take(&mut s.scanned),
            };
        };
        for (dir, first) in [(0usize, start), (1, reverse)] {
            let mut cur = first;
            // Each step adds a new vertex to the curve, so at most `num_vertices` steps.
            for _ in 0..mesh.num_vertices() {
                let other_end = if dir == 0 {
                    mesh.from_vertex(start)
                } else {
                    forward
                        .last()
                        .map_or(mesh.to_vertex(start), |h| mesh.to_vertex(*h))
                };
                if let Some(close) =
                    self.closing_edge(cur, other_end, forward.len() + backward.len(), s)
                {
                    if dir == 0 {
                        forward.push(close);
                    } else {
                        backward.push(close);
                    }
                    return Expansion {
                        curve: join(forward, backward, mesh),
                        anchored: true,
                        scanned: std::mem::take(&mut s.scanned),
                    };
                }
                let mut best = Best {
                    margin: f64::NEG_INFINITY,
                    second: None,
                    docked: false,
                    len: 0,
                };
                let d0 = self.direction(cur);
                s.path.clear();
                self.dfs(
                    mesh.to_vertex(cur).0,
                    d0,
                    self.sharp[cur.index()],
                    1,
                    None,
                    s,
                    &mut best,
                );
                let Some(next) = best.second else { break };
                if best.margin < 0.0 {
                    break;
                }
                if dir == 0 {
                    forward.push(next);
                } else {
                    backward.push(next);
                }
                if best.docked && best.len == 2 {
                    // `next` reaches an existing feature: this end of the curve is joined.
                    docked_ends += 1;
                    break;
                }
                s.curve.insert(mesh.to_vertex(next).0);
                cur = next;
            }
        }
        Expansion {
            curve: join(forward, backward, mesh),
            anchored: docked_ends == 2,
            scanned: std::mem::take(&mut s.scanned),
        }
    }

    /// An edge from the end of `cur` to the curve's other end that closes a loop, if the curve
    /// has at least 2 edges and the closing edge is sharp and usable.
    fn closing_edge(
        &self,
        cur: HalfedgeId,
        other_end: crate::mesh::VertexId,
        len: usize,
        s: &mut Scratch,
    ) -> Option<HalfedgeId> {
        if len < 2 {
            return None;
        }
        let v = self.mesh.to_vertex(cur).0;
        s.scanned.push(v);
        self.out_of(v)
            .iter()
            .find(|o| o.w == other_end.0 && o.sharp >= self.tau && self.usable(HalfedgeId(o.g)))
            .map(|o| HalfedgeId(o.g))
    }

    fn usable(&self, g: HalfedgeId) -> bool {
        !self.is_feature[g.index()] && !self.is_neighbor[g.index()]
    }

    /// Depth-first search over strings continuing a string that ends at vertex `v`; `depth`
    /// edges are in the string so far (including `h′`), `sum` is their total sharpness,
    /// `second` the string's second edge; `s.path` holds the string's vertices after `h′`.
    #[allow(clippy::too_many_arguments)]
    fn dfs(
        &self,
        v: u32,
        d0: [f64; 3],
        sum: f64,
        depth: usize,
        second: Option<HalfedgeId>,
        s: &mut Scratch,
        best: &mut Best,
    ) {
        let mut extended = false;
        if depth < self.max_len {
            s.scanned.push(v);
            let pv = self.mesh.position(crate::mesh::VertexId(v));
            for &Out {
                sharp,
                to_m: pw,
                g,
                w,
            } in self.out_of(v)
            {
                if s.curve.contains(w) || s.path.contains(&w) || self.is_feature[g as usize] {
                    continue;
                }
                // `direction(g)`: `g` leaves `v`.
                let d = [pw[0] - pv[0], pw[1] - pv[1], pw[2] - pv[2]];
                if d[0] * d0[0] + d[1] * d0[1] + d[2] * d0[2] < 0.0 {
                    continue;
                }
                let g = HalfedgeId(g);
                if self.vertex_feature[w as usize] {
                    // Docking on an existing feature ends the string; it only has to be as
                    // sharp as τ on average over its own length.
                    let s = sum + sharp;
                    let margin = s - (depth + 1) as f64 * self.tau * (1.0 - STRING_TEST_SLACK);
                    if margin > best.margin {
                        *best = Best {
                            margin,
                            second: second.or(Some(g)),
                            docked: true,
                            len: depth + 1,
                        };
                    }
                    continue;
                }
                if !self.usable(g) {
                    continue;
                }
                extended = true;
                // Branch and bound: every string through `g` has a margin of at most `bound`
                // (each further edge adds at most its sharpness minus the per-edge requirement,
                // the first one at most `max_out[w]`, and a string may stop by docking at no
                // cost). `expand` only uses a best margin ≥ 0, and `best` changes only on a
                // strictly greater margin, so pruning below max(best, 0) never changes the
                // result (the 1e-9 slack covers rounding of the sums).
                let total = sum + sharp;
                let per_edge = self.tau * (1.0 - STRING_TEST_SLACK);
                let left = self.max_len - (depth + 1);
                let bound = total - (depth + 1) as f64 * per_edge
                    + if left > 0 {
                        (self.max_out[w as usize] - per_edge).max(0.0)
                            + (left - 1) as f64 * (self.max_sharp - per_edge).max(0.0)
                    } else {
                        0.0
                    };
                if bound + 1e-9 * (1.0 + bound.abs()) < best.margin.max(0.0) {
                    continue;
                }
                s.path.push(w);
                self.dfs(w, d0, total, depth + 1, second.or(Some(g)), s, best);
                s.path.pop();
            }
        }
        // A string ends here when it cannot or may not grow; only strings with a second edge can
        // advance the curve. Strictly greater: the first string found wins ties (rotation order).
        let margin = sum - self.max_len as f64 * self.tau * (1.0 - STRING_TEST_SLACK);
        if !extended && second.is_some() && margin > best.margin {
            *best = Best {
                margin,
                second,
                docked: false,
                len: depth,
            };
        }
    }

    /// Tags a kept curve's edges as features and the other edges at its vertices as neighbours.
    fn accept(&mut self, curve: &[HalfedgeId]) {
        let mesh = self.mesh;
        self.accepts += 1;
        for &h in curve {
            self.vertex_feature[mesh.from_vertex(h).index()] = true;
            self.vertex_feature[mesh.to_vertex(h).index()] = true;
            self.is_feature[h.index()] = true;
            if let Some(o) = mesh.opposite(h) {
                self.is_feature[o.index()] = true;
            }
        }
        for &h in curve {
            for v in [mesh.from_vertex(h), mesh.to_vertex(h)] {
                for g in mesh.outgoing_halfedges(v) {
                    // Every vertex of a face around `v` may read a tag changed here.
                    for u in mesh.face_vertices(g.face()) {
                        self.changed_at[u.index()] = self.accepts;
                    }
                    // `g` leaves v and `prev(g)` enters it: together every edge at v.
                    for e in [g, g.prev()] {
                        if !self.is_feature[e.index()] {
                            self.is_neighbor[e.index()] = true;
                            if let Some(o) = mesh.opposite(e) {
                                self.is_neighbor[o.index()] = true;
                            }
                        }
                    }
                }
            }
        }
    }
}

/// The curve in order: the backward extension reversed (as opposite half-edges where they exist,
/// so that the whole curve runs one way), then the forward part.
fn join(
    forward: Vec<HalfedgeId>,
    backward: Vec<HalfedgeId>,
    mesh: &TriangleMesh,
) -> Vec<HalfedgeId> {
    let mut out: Vec<HalfedgeId> = backward
        .iter()
        .rev()
        .map(|&h| mesh.opposite(h).unwrap_or(h))
        .collect();
    out.extend(forward);
    out
}
