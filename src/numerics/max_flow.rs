//! Maximum flow / minimum s-t cut by the Boykov–Kolmogorov algorithm.
//!
//! Purpose: the minimum cut behind graph-cut chart-boundary optimisation (Iso-charts §5.2,
//! after Katz & Tal 2003): nodes are faces of a band around a chart border, arcs carry the
//! capacity of cutting between two faces, and the two charts' cores are tied to the source and
//! the sink by terminal capacities. Knows nothing of meshes.
//!
//! Algorithm (Boykov & Kolmogorov 2004, §3): two search trees, S grown from the source and T
//! from the sink, over residual arcs. *Growth*: active nodes take free neighbours into their
//! tree until an arc joins S to T. *Augmentation*: the path source → … → sink through that arc
//! carries its bottleneck; saturated tree arcs turn their children into orphans. *Adoption*:
//! each orphan looks for a new parent of its tree whose own chain reaches the terminal, else
//! it becomes free and its children become orphans. The flow is maximal when no active node
//! is left; the minimum cut separates the nodes of S from all others.
//!
//! Invariants: capacities are non-negative integers, so every augmentation carries at least 1
//! and the algorithm ends (after at most "total source capacity" augmentations; in practice far
//! fewer). Deterministic: nodes and arcs are visited in insertion order, with a FIFO of active
//! nodes and a FIFO of orphans; no hashing.
//!
//! Units: capacities are dimensionless integers chosen by the caller (quantise real weights
//! first, e.g. to `round(w / w_max · 2^20)`).
//!
//! Cost: O(V + E) memory; time is not polynomially bounded in theory (as for any augmenting-
//! path method without shortest paths) but near-linear on the sparse, nearly planar graphs of
//! mesh bands it is used on.
//!
//! References: Y. Boykov, V. Kolmogorov, "An Experimental Comparison of Min-Cut/Max-Flow
//! Algorithms for Energy Minimization in Vision", IEEE TPAMI 26(9), 2004, §3; K. Zhou, J. Snyder,
//! B. Guo, H.-Y. Shum, "Iso-charts", SGP 2004, §5.2.
use std::collections::VecDeque;

/// Which side of the minimum cut a node is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CutSide {
    /// Reachable from the source in the final residual graph.
    Source,
    /// Every other node.
    Sink,
}

/// A flow network with integer capacities (see the module doc).
#[derive(Debug, Clone, Default)]
pub struct FlowGraph {
    /// Arc `a` goes from `head[a ^ 1]` to `head[a]`; arcs come in sister pairs `(2i, 2i + 1)`.
    head: Vec<u32>,
    /// Residual capacity of each arc.
    cap: Vec<i64>,
    /// Arcs leaving each node, in insertion order.
    out: Vec<Vec<u32>>,
    /// Residual terminal capacity: `> 0` from the source to the node, `< 0` from the node to the
    /// sink (the other direction of each pair is pushed at insertion, `baseline`).
    terminal: Vec<i64>,
    /// Flow already forced by terminal pairs (`min(source, sink)` of each node).
    baseline: i64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Tree {
    Free,
    Source,
    Sink,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Parent {
    None,
    /// The node hangs directly on its tree's terminal.
    Terminal,
    /// The arc from the node to its parent.
    Arc(u32),
    /// Lost its parent in an augmentation; waiting for adoption.
    Orphan,
}

/// The result of [`FlowGraph::max_flow`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MinCut {
    /// The maximum flow, equal to the capacity of the minimum cut.
    pub flow: i64,
    /// Each node's side of the minimum cut.
    pub side: Vec<CutSide>,
}

impl FlowGraph {
    /// A graph of `num_nodes` nodes and no arcs.
    pub fn new(num_nodes: usize) -> Self {
        Self {
            out: vec![Vec::new(); num_nodes],
            terminal: vec![0; num_nodes],
            ..Self::default()
        }
    }

    /// Number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.out.len()
    }

    /// Adds an arc pair `u → v` with capacity `cap_uv` and `v → u` with `cap_vu` (an undirected
    /// edge has both equal). Panics on a negative capacity or an out-of-range node (caller bugs).
    pub fn add_edge(&mut self, u: usize, v: usize, cap_uv: i64, cap_vu: i64) {
        assert!(cap_uv >= 0 && cap_vu >= 0, "capacities are non-negative");
        assert!(
            u < self.num_nodes() && v < self.num_nodes(),
            "node out of range"
        );
        let a = self.head.len() as u32;
        self.head.push(v as u32);
        self.cap.push(cap_uv);
        self.head.push(u as u32);
        self.cap.push(cap_vu);
        self.out[u].push(a);
        self.out[v].push(a + 1);
    }

    /// Adds terminal capacities: `source` from the source to `v`, `sink` from `v` to the sink.
    /// May be called several times per node (capacities add up).
    pub fn add_terminal(&mut self, v: usize, source: i64, sink: i64) {
        assert!(source >= 0 && sink >= 0, "capacities are non-negative");
        // What is left of earlier calls (one direction only), plus the new capacities; the
        // part both directions share is flow forced through `v` (source → v → sink).
        let r = self.terminal[v];
        let s = r.max(0) + source;
        let t = (-r).max(0) + sink;
        self.baseline += s.min(t);
        self.terminal[v] = s - t;
    }

    /// Runs the algorithm; returns the maximum flow and the minimum cut. Consumes the residual
    /// capacities (call once).
    pub fn max_flow(mut self) -> MinCut {
        let n = self.num_nodes();
        let mut tree = vec![Tree::Free; n];
        let mut parent = vec![Parent::None; n];
        let mut active: VecDeque<u32> = VecDeque::new();
        let mut orphans: VecDeque<u32> = VecDeque::new();
        let mut flow = self.baseline;

        for v in 0..n {
            if self.terminal[v] > 0 {
                tree[v] = Tree::Source;
                parent[v] = Parent::Terminal;
                active.push_back(v as u32);
            } else if self.terminal[v] < 0 {
                tree[v] = Tree::Sink;
                parent[v] = Parent::Terminal;
                active.push_back(v as u32);
            }
        }

        loop {
            // Growth: find an arc from S to T with residual capacity.
            let mut meeting: Option<u32> = None;
            while let Some(&p) = active.front() {
                let p = p as usize;
                let t = tree[p];
                if t == Tree::Free {
                    active.pop_front();
                    continue;
                }
                for &a in &self.out[p] {
                    let q = self.head[a as usize] as usize;
                    // The residual arc in the tree's direction: p → q for S, q → p for T.
                    let arc_in_flow_direction = if t == Tree::Source { a } else { a ^ 1 };
                    if self.cap[arc_in_flow_direction as usize] <= 0 {
                        continue;
                    }
                    if tree[q] == Tree::Free {
                        tree[q] = t;
                        parent[q] = Parent::Arc(a ^ 1);
                        active.push_back(q as u32);
                    } else if tree[q] != t {
                        meeting = Some(arc_in_flow_direction);
                        break;
                    }
                }
                if meeting.is_some() {
                    break;
                }
                active.pop_front();
            }
            let Some(m) = meeting else { break };

            // Augmentation along source → … → tail(m) → head(m) → … → sink.
            let s_end = self.head[(m ^ 1) as usize] as usize;
            let t_end = self.head[m as usize] as usize;
            let mut bottleneck = self.cap[m as usize];
            let mut v = s_end;
            while let Parent::Arc(a) = parent[v] {
                bottleneck = bottleneck.min(self.cap[(a ^ 1) as usize]);
                v = self.head[a as usize] as usize;
            }
            bottleneck = bottleneck.min(self.terminal[v]);
            let mut v = t_end;
            while let Parent::Arc(a) = parent[v] {
                bottleneck = bottleneck.min(self.cap[a as usize]);
                v = self.head[a as usize] as usize;
            }
            bottleneck = bottleneck.min(-self.terminal[v]);
            debug_assert!(bottleneck > 0);

            self.cap[m as usize] -= bottleneck;
            self.cap[(m ^ 1) as usize] += bottleneck;
            let mut v = s_end;
            while let Parent::Arc(a) = parent[v] {
                self.cap[(a ^ 1) as usize] -= bottleneck;
                self.cap[a as usize] += bottleneck;
                if self.cap[(a ^ 1) as usize] == 0 {
                    parent[v] = Parent::Orphan;
                    orphans.push_back(v as u32);
                }
                v = self.head[a as usize] as usize;
            }
            self.terminal[v] -= bottleneck;
            if self.terminal[v] == 0 {
                parent[v] = Parent::Orphan;
                orphans.push_back(v as u32);
            }
            let mut v = t_end;
            while let Parent::Arc(a) = parent[v] {
                self.cap[a as usize] -= bottleneck;
                self.cap[(a ^ 1) as usize] += bottleneck;
                if self.cap[a as usize] == 0 {
                    parent[v] = Parent::Orphan;
                    orphans.push_back(v as u32);
                }
                v = self.head[a as usize] as usize;
            }
            self.terminal[v] += bottleneck;
            if self.terminal[v] == 0 {
                parent[v] = Parent::Orphan;
                orphans.push_back(v as u32);
            }
            flow += bottleneck;

            // Adoption.
            while let Some(o) = orphans.pop_front() {
                let o = o as usize;
                let t = tree[o];
                let mut adopted = false;
                for &a in &self.out[o] {
                    let q = self.head[a as usize] as usize;
                    if tree[q] != t {
                        continue;
                    }
                    // The tree arc o → q (stored as the parent arc) must carry flow in the
                    // tree's direction: q → o for S (arc a ^ 1), o → q for T (arc a).
                    if self.toward_child(t, a) > 0 && rooted(&parent, &self.head, q) {
                        parent[o] = Parent::Arc(a);
                        adopted = true;
                        break;
                    }
                }
                if adopted {
                    continue;
                }
                for &a in &self.out[o] {
                    let q = self.head[a as usize] as usize;
                    if tree[q] != t {
                        continue;
                    }
                    if self.toward_child(t, a) > 0 {
                        active.push_back(q as u32);
                    }
                    if parent[q] == Parent::Arc(a ^ 1) {
                        parent[q] = Parent::Orphan;
                        orphans.push_back(q as u32);
                    }
                }
                tree[o] = Tree::Free;
                parent[o] = Parent::None;
            }
        }

        let side = tree
            .iter()
            .map(|&t| {
                if t == Tree::Source {
                    CutSide::Source
                } else {
                    CutSide::Sink
                }
            })
            .collect();
        MinCut { flow, side }
    }
}

impl FlowGraph {
    /// Residual capacity, in tree `t`'s flow direction, of the arc pair of `a` (an arc leaving a
    /// node `o` of `t` towards `q`): `q → o` for the source tree, `o → q` for the sink tree.
    fn toward_child(&self, t: Tree, a: u32) -> i64 {
        if t == Tree::Source {
            self.cap[(a ^ 1) as usize]
        } else {
            self.cap[a as usize]
        }
    }
}

/// Whether `v`'s parent chain reaches its terminal (no orphan on the way). Cost: the chain's
/// length (the distance heuristic of the paper would cache it; bands are shallow).
fn rooted(parent: &[Parent], head: &[u32], mut v: usize) -> bool {
    loop {
        match parent[v] {
            Parent::Terminal => return true,
            Parent::Arc(a) => v = head[a as usize] as usize,
            Parent::Orphan | Parent::None => return false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The capacity of a cut given as the set of source-side nodes, recomputed from the edge
    /// list (independent of the algorithm).
    fn cut_capacity(
        source_side: &[bool],
        edges: &[(usize, usize, i64, i64)],
        terminals: &[(usize, i64, i64)],
    ) -> i64 {
        let mut c = 0;
        for &(u, v, cuv, cvu) in edges {
            if source_side[u] && !source_side[v] {
                c += cuv;
            }
            if source_side[v] && !source_side[u] {
                c += cvu;
            }
        }
        for &(v, s, t) in terminals {
            c += if source_side[v] { t } else { s };
        }
        c
    }

    fn solve(
        n: usize,
        edges: &[(usize, usize, i64, i64)],
        terminals: &[(usize, i64, i64)],
    ) -> MinCut {
        let mut g = FlowGraph::new(n);
        for &(u, v, a, b) in edges {
            g.add_edge(u, v, a, b);
        }
        for &(v, s, t) in terminals {
            g.add_terminal(v, s, t);
        }
        g.max_flow()
    }

    /// A tiny deterministic generator (no dependency on the algorithm's order).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self, bound: u64) -> u64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 33) % bound
        }
    }

    #[test]
    fn max_flow_equals_brute_force_min_cut_on_small_graphs() {
        let mut rng = Lcg(7);
        for case in 0..600 {
            let n = 1 + rng.next(9) as usize;
            let mut edges = Vec::new();
            for _ in 0..rng.next(3 * n as u64 + 1) {
                let u = rng.next(n as u64) as usize;
                let v = rng.next(n as u64) as usize;
                if u != v {
                    edges.push((u, v, rng.next(10) as i64, rng.next(10) as i64));
                }
            }
            let mut terminals = Vec::new();
            for _ in 0..rng.next(2 * n as u64 + 1) {
                let v = rng.next(n as u64) as usize;
                terminals.push((v, rng.next(12) as i64, rng.next(12) as i64));
            }
            let cut = solve(n, &edges, &terminals);
            let mut best = i64::MAX;
            for mask in 0..(1u32 << n) {
                let side: Vec<bool> = (0..n).map(|i| mask >> i & 1 == 1).collect();
                best = best.min(cut_capacity(&side, &edges, &terminals));
            }
            assert_eq!(cut.flow, best, "case {case}: {edges:?} {terminals:?}");
            let side: Vec<bool> = cut.side.iter().map(|&s| s == CutSide::Source).collect();
            assert_eq!(
                cut_capacity(&side, &edges, &terminals),
                best,
                "case {case}: the returned cut is not minimal"
            );
        }
    }

    #[test]
    fn a_chain_is_cut_at_its_weakest_link() {
        // source → 0 → 1 → 2 → 3 → sink, weakest link 1–2.
        let edges = [(0, 1, 5, 5), (1, 2, 2, 2), (2, 3, 7, 7)];
        let cut = solve(4, &edges, &[(0, 100, 0), (3, 0, 100)]);
        assert_eq!(cut.flow, 2);
        assert_eq!(
            cut.side,
            [
                CutSide::Source,
                CutSide::Source,
                CutSide::Sink,
                CutSide::Sink
            ]
        );
    }

    #[test]
    fn a_grid_band_is_cut_along_the_cheap_column() {
        // A 6 × 20 grid, left column tied to the source, right column to the sink; horizontal
        // edges crossing between columns 12 and 13 are cheap, so the cut is that column.
        let (w, h) = (20usize, 6usize);
        let id = |x: usize, y: usize| y * w + x;
        let mut edges = Vec::new();
        for y in 0..h {
            for x in 0..w {
                if x + 1 < w {
                    let c = if x == 12 { 1 } else { 10 };
                    edges.push((id(x, y), id(x + 1, y), c, c));
                }
                if y + 1 < h {
                    edges.push((id(x, y), id(x, y + 1), 10, 10));
                }
            }
        }
        let mut terminals = Vec::new();
        for y in 0..h {
            terminals.push((id(0, y), 1000, 0));
            terminals.push((id(w - 1, y), 0, 1000));
        }
        let cut = solve(w * h, &edges, &terminals);
        assert_eq!(cut.flow, h as i64);
        for y in 0..h {
            for x in 0..w {
                let want = if x <= 12 {
                    CutSide::Source
                } else {
                    CutSide::Sink
                };
                assert_eq!(cut.side[id(x, y)], want, "node ({x}, {y})");
            }
        }
    }
}
