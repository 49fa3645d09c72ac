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
//!    `⌈feature_fraction · n⌉`-th sharpest of the `n` edges that have one. A flat mesh (τ = 0) has
//!    no features.
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
//! References: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least Squares Conformal Maps for
//! Automatic Texture Atlas Generation", SIGGRAPH 2002, §3.1 and Algorithm 1; the sharpness
//! criterion is from Hubeli & Gross 2001 (the paper's reference \[11\]).
use rayon::prelude::*;

use crate::mesh::{HalfedgeId, TriangleMesh};

use super::options::Lscm2002Options;

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
pub fn detect_features(mesh: &TriangleMesh, options: &Lscm2002Options) -> Features {
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
        return out;
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
    if tau.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return out;
    }
    out.threshold_rad = Some(tau);
    let mut grower = Grower {
        mesh,
        sharp: &out.sharpness_rad,
        tau,
        max_len: options.max_string_length.max(1),
        is_feature: vec![false; nh],
        is_neighbor: vec![false; nh],
        vertex_feature: vec![false; mesh.num_vertices()],
        vertex_stamp: vec![0; mesh.num_vertices()],
        stamp: 0,
        max_out: mesh
            .vertices()
            .map(|v| {
                mesh.outgoing_halfedges(v)
                    .map(|g| out.sharpness_rad[g.index()])
                    .fold(0.0, f64::max)
            })
            .collect(),
        max_sharp: out.sharpness_rad.iter().copied().fold(0.0, f64::max),
    };
    for &(a, h) in &ranked {
        if a < tau {
            break;
        }
        if grower.is_feature[h.index()] || grower.is_neighbor[h.index()] {
            continue;
        }
        let (curve, anchored) = grower.expand(h);
        if curve.len() > options.min_feature_length || (anchored && curve.len() > 1) {
            grower.accept(&curve);
            out.curves.push(curve);
        }
    }
    out.is_feature = grower.is_feature;
    if let Some(angle) = options.hard_edge_angle_rad {
        add_hard_edges(mesh, &mut out, angle);
    }
    out
}

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

/// State of Algorithm 1 across curves.
struct Grower<'a> {
    mesh: &'a TriangleMesh,
    sharp: &'a [f64],
    tau: f64,
    max_len: usize,
    /// Feature tag per half-edge (both halves set).
    is_feature: Vec<bool>,
    /// Feature-neighbour tag per half-edge (both halves set).
    is_neighbor: Vec<bool>,
    /// True at the vertices of kept curves: a string may end there (docking).
    vertex_feature: Vec<bool>,
    /// `vertex_stamp[v] == stamp` marks the vertices of the curve being grown; a new curve takes a
    /// new stamp, so a rejected curve needs no clean-up.
    vertex_stamp: Vec<u32>,
    stamp: u32,
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

impl Grower<'_> {
    fn in_curve(&self, v: crate::mesh::VertexId) -> bool {
        self.vertex_stamp[v.index()] == self.stamp
    }

    fn direction(&self, h: HalfedgeId) -> [f64; 3] {
        let a = self.mesh.position(self.mesh.from_vertex(h));
        let b = self.mesh.position(self.mesh.to_vertex(h));
        [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
    }

    /// Grows one curve from `start` in both directions; returns its edges in curve order, and
    /// whether it is anchored (closed into a loop, or joined to existing features at both ends).
    fn expand(&mut self, start: HalfedgeId) -> (Vec<HalfedgeId>, bool) {
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            // Wrapped after 2^32 curves: reset so that stale stamps cannot alias.
            self.vertex_stamp.iter_mut().for_each(|s| *s = u32::MAX);
            self.stamp = 1;
        }
        let stamp = self.stamp;
        let mesh = self.mesh;
        self.vertex_stamp[mesh.from_vertex(start).index()] = stamp;
        self.vertex_stamp[mesh.to_vertex(start).index()] = stamp;
        let mut forward: Vec<HalfedgeId> = vec![start];
        let mut backward: Vec<HalfedgeId> = Vec::new();
        let mut docked_ends = 0usize;
        let Some(reverse) = mesh.opposite(start) else {
            return (forward, false);
        };
        for (dir, first) in [(0usize, start), (1, reverse)] {
            let mut cur = first;
            // Each step stamps a new vertex, so at most `num_vertices` steps.
            for _ in 0..mesh.num_vertices() {
                let other_end = if dir == 0 {
                    mesh.from_vertex(start)
                } else {
                    forward
                        .last()
                        .map_or(mesh.to_vertex(start), |h| mesh.to_vertex(*h))
                };
                if let Some(close) =
                    self.closing_edge(cur, other_end, forward.len() + backward.len())
                {
                    if dir == 0 {
                        forward.push(close);
                    } else {
                        backward.push(close);
                    }
                    return (join(forward, backward, mesh), true);
                }
                let mut best = Best {
                    margin: f64::NEG_INFINITY,
                    second: None,
                    docked: false,
                    len: 0,
                };
                let d0 = self.direction(cur);
                let mut path: Vec<crate::mesh::VertexId> = Vec::with_capacity(self.max_len + 1);
                self.dfs(
                    cur,
                    d0,
                    self.sharp[cur.index()],
                    1,
                    None,
                    &mut path,
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
                self.vertex_stamp[mesh.to_vertex(next).index()] = stamp;
                cur = next;
            }
        }
        (join(forward, backward, mesh), docked_ends == 2)
    }

    /// An edge from the end of `cur` to the curve's other end that closes a loop, if the curve
    /// has at least 2 edges and the closing edge is sharp and usable.
    fn closing_edge(
        &self,
        cur: HalfedgeId,
        other_end: crate::mesh::VertexId,
        len: usize,
    ) -> Option<HalfedgeId> {
        if len < 2 {
            return None;
        }
        self.mesh
            .outgoing_halfedges(self.mesh.to_vertex(cur))
            .find(|&g| {
                self.mesh.to_vertex(g) == other_end
                    && self.sharp[g.index()] >= self.tau
                    && self.usable(g)
            })
    }

    fn usable(&self, g: HalfedgeId) -> bool {
        !self.is_feature[g.index()] && !self.is_neighbor[g.index()]
    }

    /// Depth-first search over strings continuing `last`; `depth` edges are in the string so far
    /// (including `h′`), `sum` is their total sharpness, `second` the string's second edge.
    #[allow(clippy::too_many_arguments)]
    fn dfs(
        &self,
        last: HalfedgeId,
        d0: [f64; 3],
        sum: f64,
        depth: usize,
        second: Option<HalfedgeId>,
        path: &mut Vec<crate::mesh::VertexId>,
        best: &mut Best,
    ) {
        let mut extended = false;
        if depth < self.max_len {
            let v = self.mesh.to_vertex(last);
            for g in self.mesh.outgoing_halfedges(v) {
                let w = self.mesh.to_vertex(g);
                if self.in_curve(w) || path.contains(&w) || self.is_feature[g.index()] {
                    continue;
                }
                let d = self.direction(g);
                if d[0] * d0[0] + d[1] * d0[1] + d[2] * d0[2] < 0.0 {
                    continue;
                }
                if self.vertex_feature[w.index()] {
                    // Docking on an existing feature ends the string; it only has to be as
                    // sharp as τ on average over its own length.
                    let s = sum + self.sharp[g.index()];
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
                let s = sum + self.sharp[g.index()];
                let per_edge = self.tau * (1.0 - STRING_TEST_SLACK);
                let left = self.max_len - (depth + 1);
                let bound = s - (depth + 1) as f64 * per_edge
                    + if left > 0 {
                        (self.max_out[w.index()] - per_edge).max(0.0)
                            + (left - 1) as f64 * (self.max_sharp - per_edge).max(0.0)
                    } else {
                        0.0
                    };
                if bound + 1e-9 * (1.0 + bound.abs()) < best.margin.max(0.0) {
                    continue;
                }
                path.push(w);
                self.dfs(
                    g,
                    d0,
                    sum + self.sharp[g.index()],
                    depth + 1,
                    second.or(Some(g)),
                    path,
                    best,
                );
                path.pop();
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
