//! Border smoothing: single faces that stick out of a chart across a border go to the chart
//! they stick into.
//!
//! Purpose: where two growing fronts meet (chart growing, the breadth-first halves of a split),
//! the border follows whichever triangle each front reached first. On low-poly meshes that
//! leaves saw teeth: single triangles of one chart held by one edge, with their other two edges
//! on the border. Each tooth is a spike in UV that a texture artist cannot paint on, and its
//! padding costs packing space. A face is moved to the neighbouring chart when that shortens the
//! border's cost (the edge capacity of `graph_cut.rs`, or plain length): greedy local descent of
//! the same energy the graph cut minimises, one face at a time.
//!
//! Which faces move: a face `f` of chart A glued to A by exactly one edge `e_A`, moved to the
//! chart X that shares the most border cost with it, when `cost(f–X edges) > cost(e_A)`. Its
//! other edges may meet X, a third chart, a foreign face or the mesh boundary; only the cost of
//! `e_A` and of the `f–X` edges changes, so every move lowers the total border cost by at least
//! a relative [`MIN_GAIN`], and the descent ends.
//!
//! Invariants: a chart that was a topological disk still is one, and a connected chart stays
//! connected, because a move is made only when (1) `f` is A's only face at its vertex opposite
//! `e_A` (so `f` is an ear of A: removing it keeps one fan per vertex and `χ`), and (2) when `f`
//! meets X along one edge, X has no face at `f`'s vertex opposite that edge (so adding `f`
//! closes no loop); meeting X along two edges, `f` fills the notch between them. No chart
//! becomes empty (A keeps the face across `e_A`), the chart count is unchanged, faces outside
//! the labels and pinned faces never move. Deterministic: the largest gain moves first (ties to
//! the lower face id), a tooth's target is the chart of most shared cost (ties to the lower
//! label).
//!
//! Cost: one visit per candidate plus the three neighbours of each moved face, in a heap; each
//! visit looks at the fans of at most two vertices. At most [`MAX_MOVES_PER_CANDIDATE`] moves
//! per candidate.
use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::mesh::{FaceId, HalfedgeId, TriangleMesh, VertexId};

/// A move must lower the border cost by at least this fraction of the cost it touches (the
/// `f–X` edges plus `e_A`): equal trades (a face between three charts with equal edges) stay,
/// and rounding cannot cycle.
const MIN_GAIN: f64 = 1e-9;

/// A bound on the moves of one call, per candidate face (a safety net: every move lowers the
/// total border cost, so the descent ends on its own long before).
const MAX_MOVES_PER_CANDIDATE: usize = 4;

/// The chart label of each face a smoothing may read or move.
pub(super) trait FaceLabels {
    /// The label of `f`, or `None` for a face outside the charts being smoothed (a foreign
    /// chart's face: a fixed border).
    fn label(&self, f: FaceId) -> Option<u32>;
    /// Gives `f` (which has a label) the label `to`.
    fn set(&mut self, f: FaceId, to: u32);
}

/// Labels in a per-mesh array; `u32::MAX` marks a face outside the charts.
pub(super) struct DenseLabels<'a>(pub &'a mut [u32]);

impl FaceLabels for DenseLabels<'_> {
    fn label(&self, f: FaceId) -> Option<u32> {
        self.0.get(f.index()).copied().filter(|&l| l != u32::MAX)
    }
    fn set(&mut self, f: FaceId, to: u32) {
        self.0[f.index()] = to;
    }
}

/// Labels kept as `u8` at a slot of each face (`slot(f)`: `None` for a face outside the
/// charts), `0` meaning no label: the two sides of a split in `grow_two`.
pub(super) struct SlotLabels<'a, S: Fn(FaceId) -> Option<usize>> {
    pub labels: &'a mut [u8],
    pub slot: S,
}

impl<S: Fn(FaceId) -> Option<usize>> FaceLabels for SlotLabels<'_, S> {
    fn label(&self, f: FaceId) -> Option<u32> {
        (self.slot)(f)
            .map(|k| self.labels[k])
            .filter(|&l| l != 0)
            .map(u32::from)
    }
    fn set(&mut self, f: FaceId, to: u32) {
        if let (Some(k), Ok(to)) = ((self.slot)(f), u8::try_from(to)) {
            self.labels[k] = to;
        }
    }
}

/// Moves teeth between charts (module doc) until none is left, starting from `candidates` and
/// never moving a face of `pinned`. `cost` is the cost of an edge as a border, per half-edge
/// (both halves of a glued edge equal). `sizes[l]` is the number of faces labelled `l`: a chart
/// gives up no face once it is down to half of its size at the call (rounded up), so a chart
/// that is all teeth (a thin strip, a chart of a few triangles) is not eaten face after face.
/// Returns the number of moves.
pub(super) fn smooth_borders<L: FaceLabels>(
    mesh: &TriangleMesh,
    labels: &mut L,
    cost: &dyn Fn(HalfedgeId) -> f64,
    candidates: &[FaceId],
    pinned: &[FaceId],
    sizes: &mut [usize],
) -> usize {
    let floor: Vec<usize> = sizes.iter().map(|&n| n.div_ceil(2)).collect();
    // Largest gain first (ties to the lower face id), so that a spike goes before the faces
    // beside it that would trade a smaller gain for it. Entries are re-checked when popped.
    let mut heap: BinaryHeap<(u64, Reverse<FaceId>)> = candidates
        .iter()
        .filter(|f| !pinned.contains(f))
        .filter_map(|&f| tooth_move(mesh, labels, cost, f).map(|m| (m.gain.to_bits(), Reverse(f))))
        .collect();
    let max_moves = candidates.len().saturating_mul(MAX_MOVES_PER_CANDIDATE);
    let mut moves = 0usize;
    while let Some((gain_bits, Reverse(f))) = heap.pop() {
        if moves >= max_moves {
            break;
        }
        let Some(m) = tooth_move(mesh, labels, cost, f) else {
            continue;
        };
        if m.gain.to_bits() != gain_bits {
            heap.push((m.gain.to_bits(), Reverse(f)));
            continue;
        }
        let (from, to) = (m.from as usize, m.to as usize);
        if from >= sizes.len() || to >= sizes.len() || sizes[from] <= floor[from] {
            continue;
        }
        sizes[from] -= 1;
        sizes[to] += 1;
        labels.set(f, m.to);
        moves += 1;
        for g in mesh.face_neighbors(f).into_iter().flatten() {
            if pinned.contains(&g) {
                continue;
            }
            if let Some(m) = tooth_move(mesh, labels, cost, g) {
                heap.push((m.gain.to_bits(), Reverse(g)));
            }
        }
    }
    moves
}

/// A tooth's move: from its chart to another, lowering the border cost by `gain` (positive and
/// finite, so its bits order as the value does: the heap key).
struct Move {
    from: u32,
    to: u32,
    gain: f64,
}

/// The move of `f`, if it is a tooth whose move keeps the invariants (module doc).
fn tooth_move<L: FaceLabels>(
    mesh: &TriangleMesh,
    labels: &L,
    cost: &dyn Fn(HalfedgeId) -> f64,
    f: FaceId,
) -> Option<Move> {
    let a = labels.label(f)?;
    let hs = mesh.face_halfedges(f);
    // The label across each edge (None: mesh boundary or a foreign face).
    let across: [Option<u32>; 3] =
        hs.map(|h| mesh.opposite(h).and_then(|o| labels.label(mesh.face(o))));
    let mut k_a = None;
    for (k, l) in across.iter().enumerate() {
        if *l == Some(a) {
            if k_a.is_some() {
                return None; // glued to A by two edges or more: not a tooth
            }
            k_a = Some(k);
        }
    }
    let k_a = k_a?; // glued to A by no edge: A is this face alone
    let cost_a = cost(hs[k_a]);
    // The best other chart: the most border cost shared with `f`, ties to the lower label.
    let mut best: Option<(u32, f64)> = None;
    for l in across.iter().flatten().copied() {
        if l == a {
            continue;
        }
        let shared: f64 = (0..3)
            .filter(|&k| across[k] == Some(l))
            .map(|k| cost(hs[k]))
            .sum();
        let better = match best {
            None => true,
            Some((bl, bc)) => shared > bc || (shared == bc && l < bl),
        };
        if better {
            best = Some((l, shared));
        }
    }
    let (to, cost_to) = best?;
    // A NaN cost (never from finite positions) moves nothing.
    let gain = cost_to - cost_a;
    if gain.partial_cmp(&(MIN_GAIN * (cost_to + cost_a))) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    // (1) f is A's only face at its vertex opposite e_A.
    let apex_a = opposite_vertex(mesh, hs, k_a);
    if has_other_face(mesh, labels, apex_a, f, a) {
        return None;
    }
    // (2) meeting X along one edge: X has no face at f's vertex opposite that edge.
    let ks_to: Vec<usize> = (0..3).filter(|&k| across[k] == Some(to)).collect();
    if ks_to.len() == 1 && has_other_face(mesh, labels, opposite_vertex(mesh, hs, ks_to[0]), f, to)
    {
        return None;
    }
    Some(Move { from: a, to, gain })
}

/// The vertex of a face not on its half-edge `hs[k]`.
fn opposite_vertex(mesh: &TriangleMesh, hs: [HalfedgeId; 3], k: usize) -> VertexId {
    mesh.to_vertex(mesh.next(hs[k]))
}

/// True when a face other than `f` at vertex `v` has label `l`.
fn has_other_face<L: FaceLabels>(
    mesh: &TriangleMesh,
    labels: &L,
    v: VertexId,
    f: FaceId,
    l: u32,
) -> bool {
    mesh.outgoing_halfedges(v).any(|h| {
        let g = mesh.face(h);
        g != f && labels.label(g) == Some(l)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atlas::segment::tests::{build, subdivided_cube};
    use crate::atlas::segment::{
        check_chart_is_disk, enforce_disks, graph_cut, grow_two, smooth_charts, smooth_cut,
        SegmentStats,
    };
    use crate::mesh::{fixtures, MeshInput};
    use proptest::prelude::*;

    const NX: u32 = 20;
    const NY: u32 = 9;

    /// Labels of an `NX × NY` grid: squares left of column 10 in chart 0, the rest in chart 1,
    /// and, in every odd row, the upper-left triangle of square (10, j) in chart 0: a tooth
    /// glued to chart 0 by its left edge (length 1), to chart 1 by its top edge and its
    /// diagonal (1 + √2).
    fn toothed_grid() -> (TriangleMesh, Vec<u32>) {
        let mesh = build(&fixtures::grid(NX, NY));
        let labels = mesh
            .faces()
            .map(|f| {
                let (s, upper_left) = (f.0 / 2, f.0 % 2 == 1);
                let (i, j) = (s % NX, s / NX);
                u32::from(!(i < 10 || (i == 10 && upper_left && j % 2 == 1)))
            })
            .collect();
        (mesh, labels)
    }

    /// The total border cost of `labels` (each glued edge between two labels once).
    fn border_cost(mesh: &TriangleMesh, labels: &[u32], cost: &dyn Fn(HalfedgeId) -> f64) -> f64 {
        mesh.edges()
            .filter_map(|h| mesh.opposite(h).map(|o| (h, o)))
            .filter(|&(h, o)| labels[mesh.face(h).index()] != labels[mesh.face(o).index()])
            .map(|(h, _)| cost(h))
            .sum()
    }

    fn charts_of(mesh: &TriangleMesh, labels: &[u32], n: usize) -> Vec<Vec<FaceId>> {
        let mut charts = vec![Vec::new(); n];
        for f in mesh.faces() {
            charts[labels[f.index()] as usize].push(f);
        }
        charts
    }

    fn sizes_of(labels: &[u32], n: usize) -> Vec<usize> {
        let mut sizes = vec![0; n];
        for &l in labels {
            sizes[l as usize] += 1;
        }
        sizes
    }

    #[test]
    fn teeth_on_a_plane_go_to_the_chart_they_stick_into() {
        let (mesh, mut labels) = toothed_grid();
        let length = |h: HalfedgeId| mesh.edge_length_m(h);
        let before = border_cost(&mesh, &labels, &length);
        let teeth = NY as usize / 2;
        assert!((before - (f64::from(NY) + teeth as f64 * std::f64::consts::SQRT_2)).abs() < 1e-9);
        let all: Vec<FaceId> = mesh.faces().collect();
        let mut sizes = sizes_of(&labels, 2);
        let moved = smooth_borders(
            &mesh,
            &mut DenseLabels(&mut labels),
            &length,
            &all,
            &[],
            &mut sizes,
        );
        assert_eq!(moved, teeth);
        assert_eq!(sizes, sizes_of(&labels, 2));
        // The border is the straight line x = 10: NY unit edges.
        assert!((border_cost(&mesh, &labels, &length) - f64::from(NY)).abs() < 1e-9);
        for f in mesh.faces() {
            let i = (f.0 / 2) % NX;
            assert_eq!(labels[f.index()], u32::from(i >= 10), "face {f:?}");
        }
        for c in charts_of(&mesh, &labels, 2) {
            check_chart_is_disk(&mesh, &c).expect("a disk");
        }
    }

    #[test]
    fn a_cut_given_by_sides_loses_its_teeth() {
        // The toothed grid's labels as the far side of a cut (the packing cuts' neck): the
        // parts come back with the straight border x = 10, the near part first, as disks.
        let (mesh, labels) = toothed_grid();
        // In descending order: the parts come back ascending whatever the order given.
        let mut faces: Vec<FaceId> = mesh.faces().collect();
        faces.reverse();
        let far: Vec<bool> = faces.iter().map(|f| labels[f.index()] == 1).collect();
        let (near, far) = smooth_cut(&mesh, &faces, &far);
        assert_eq!(near.len() + far.len(), faces.len());
        assert!(near.windows(2).all(|w| w[0] < w[1]) && far.windows(2).all(|w| w[0] < w[1]));
        for f in &near {
            assert!((f.0 / 2) % NX < 10, "face {f:?}");
        }
        for f in &far {
            assert!((f.0 / 2) % NX >= 10, "face {f:?}");
        }
        for part in [near, far] {
            check_chart_is_disk(&mesh, &part).expect("a disk");
        }
    }

    #[test]
    fn a_tooth_on_cheap_edges_and_a_pinned_tooth_stay() {
        let (mesh, labels) = toothed_grid();
        let all: Vec<FaceId> = mesh.faces().collect();
        let teeth: Vec<FaceId> = mesh
            .faces()
            .filter(|f| labels[f.index()] == 0 && (f.0 / 2) % NX == 10)
            .collect();
        // The teeth's border edges (top and diagonal) are features: a tenth of their length,
        // less than the vertical edge that would become the border.
        let cheap = |h: HalfedgeId| {
            let (p, q) = (
                mesh.position(mesh.from_vertex(h)),
                mesh.position(mesh.to_vertex(h)),
            );
            let of_tooth = teeth.contains(&mesh.face(h))
                || mesh
                    .opposite(h)
                    .is_some_and(|o| teeth.contains(&mesh.face(o)));
            let w = if of_tooth && p[0] != q[0] { 0.1 } else { 1.0 };
            mesh.edge_length_m(h) * w
        };
        let mut kept = labels.clone();
        let mut sizes = sizes_of(&kept, 2);
        assert_eq!(
            smooth_borders(
                &mesh,
                &mut DenseLabels(&mut kept),
                &cheap,
                &all,
                &[],
                &mut sizes
            ),
            0
        );
        assert_eq!(kept, labels);
        let mut pinned = labels.clone();
        let mut sizes = sizes_of(&pinned, 2);
        let length = |h: HalfedgeId| mesh.edge_length_m(h);
        let moved = smooth_borders(
            &mesh,
            &mut DenseLabels(&mut pinned),
            &length,
            &all,
            &teeth[..1],
            &mut sizes,
        );
        assert_eq!(moved, teeth.len() - 1);
        assert_eq!(pinned[teeth[0].index()], 0);
    }

    #[test]
    fn a_chart_of_teeth_keeps_half_of_its_faces() {
        // A strip one square wide (2 NY triangles) in chart 0, between charts 1 and 2, with
        // vertical edges ten times dearer than the others: from its ends, every step of eating
        // it lowers the border cost, and the floor stops it at half.
        let mesh = build(&fixtures::grid(NX, NY));
        let mut labels: Vec<u32> = mesh
            .faces()
            .map(|f| match ((f.0 / 2) % NX).cmp(&10) {
                std::cmp::Ordering::Equal => 0,
                std::cmp::Ordering::Less => 1,
                std::cmp::Ordering::Greater => 2,
            })
            .collect();
        let all: Vec<FaceId> = mesh.faces().collect();
        let mut sizes = sizes_of(&labels, 3);
        let strip = sizes[0];
        smooth_borders(
            &mesh,
            &mut DenseLabels(&mut labels),
            &|h| {
                let (p, q) = (
                    mesh.position(mesh.from_vertex(h)),
                    mesh.position(mesh.to_vertex(h)),
                );
                mesh.edge_length_m(h) * if p[0] == q[0] { 10.0 } else { 1.0 }
            },
            &all,
            &[],
            &mut sizes,
        );
        assert_eq!(sizes, sizes_of(&labels, 3));
        assert!(sizes[0] < strip, "the strip's teeth moved");
        assert!(sizes[0] >= strip.div_ceil(2), "{} of {strip}", sizes[0]);
        for c in charts_of(&mesh, &labels, 3) {
            check_chart_is_disk(&mesh, &c).expect("a disk");
        }
    }

    /// Faces glued to their chart by one edge whose two other edges meet one other chart: the
    /// teeth of the module doc, counted from the face → chart map.
    fn two_edge_teeth(mesh: &TriangleMesh, face_chart: &[u32]) -> usize {
        mesh.faces()
            .filter(|&f| {
                let own = face_chart[f.index()];
                let across: Vec<Option<u32>> = mesh
                    .face_neighbors(f)
                    .into_iter()
                    .map(|g| g.map(|g| face_chart[g.index()]))
                    .collect();
                let glued = across.iter().filter(|&&l| l == Some(own)).count();
                let others: Vec<u32> = across
                    .iter()
                    .flatten()
                    .copied()
                    .filter(|&l| l != own)
                    .collect();
                glued == 1 && others.len() == 2 && others[0] == others[1]
            })
            .count()
    }

    #[test]
    fn segmented_fixtures_have_no_teeth() {
        for input in [
            fixtures::torus(24, 12, 2.0, 0.5),
            fixtures::uv_sphere(12, 24, 1.0),
            subdivided_cube(5),
            fixtures::cylinder_open(24, 12, 1.0, 3.0),
        ] {
            let mesh = build(&input);
            let seg = crate::atlas::segment::tests::segment(&mesh);
            let face_chart: Vec<u32> = seg.face_chart.as_slice().iter().map(|c| c.0).collect();
            assert_eq!(
                two_edge_teeth(&mesh, &face_chart),
                0,
                "{} faces",
                mesh.num_faces()
            );
        }
    }

    /// Jagged charts: breadth-first growth from `seeds` faces, popping the frontier in an order
    /// drawn from `draw`, then the disk guarantee.
    fn jagged_disks(
        mesh: &TriangleMesh,
        seeds: usize,
        mut draw: impl FnMut(usize) -> usize,
    ) -> Vec<Vec<FaceId>> {
        let nf = mesh.num_faces();
        let mut label = vec![u32::MAX; nf];
        let mut frontier = Vec::new();
        for s in 0..seeds.min(nf) {
            let f = draw(nf);
            if label[f] == u32::MAX {
                label[f] = s as u32;
                frontier.push(FaceId(f as u32));
            }
        }
        while !frontier.is_empty() {
            let f = frontier.swap_remove(draw(frontier.len()));
            for g in mesh.face_neighbors(f).into_iter().flatten() {
                if label[g.index()] == u32::MAX {
                    label[g.index()] = label[f.index()];
                    frontier.push(g);
                }
            }
        }
        // Faces no seed reached (another component) form one more proposal, split by the
        // disk guarantee into its components.
        let n = label
            .iter()
            .filter(|&&l| l != u32::MAX)
            .max()
            .map_or(0, |&l| l as usize + 1);
        let mut work = vec![Vec::new(); n + 1];
        for f in mesh.faces() {
            let l = label[f.index()];
            work[if l == u32::MAX { n } else { l as usize }].push(f);
        }
        work.retain(|c| !c.is_empty());
        enforce_disks(mesh, work, &mut SegmentStats::default())
    }

    fn mesh_of(kind: u8) -> MeshInput {
        match kind % 4 {
            0 => fixtures::grid(12, 9),
            1 => fixtures::torus(16, 8, 2.0, 0.5),
            2 => subdivided_cube(4),
            _ => fixtures::uv_sphere(8, 12, 1.0),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// On random jagged disks: every chart is still a disk, the count and the partition
        /// are kept, no chart is below half its size, the border cost never rises, and the
        /// result is the same twice.
        #[test]
        fn smoothing_keeps_disks_and_never_lengthens_a_border(kind in 0u8..4, seeds in 2usize..12, rng in any::<u64>()) {
            let mesh = build(&mesh_of(kind));
            let mut state = rng | 1;
            let draw = |n: usize| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state % n as u64) as usize
            };
            let charts = jagged_disks(&mesh, seeds, draw);
            let label_of = |charts: &[Vec<FaceId>]| {
                let mut l = vec![u32::MAX; mesh.num_faces()];
                for (c, faces) in charts.iter().enumerate() {
                    for f in faces {
                        l[f.index()] = c as u32;
                    }
                }
                l
            };
            let capacity = graph_cut::edge_capacities(&mesh, None);
            let cost = |h: HalfedgeId| capacity[h.index()];
            let before = border_cost(&mesh, &label_of(&charts), &cost);
            let mut smoothed = charts.clone();
            let moved = smooth_charts(&mesh, &mut smoothed, None);
            let mut again = charts.clone();
            prop_assert_eq!(smooth_charts(&mesh, &mut again, None), moved);
            prop_assert_eq!(&again, &smoothed);
            prop_assert_eq!(smoothed.len(), charts.len());
            let labels = label_of(&smoothed);
            prop_assert!(labels.iter().all(|&l| l != u32::MAX));
            for (c, faces) in smoothed.iter().enumerate() {
                prop_assert!(faces.len() >= charts[c].len().div_ceil(2));
                prop_assert!(check_chart_is_disk(&mesh, faces).is_ok(), "chart {} is not a disk", c);
            }
            let after = border_cost(&mesh, &labels, &cost);
            prop_assert!(after <= before + 1e-9 * before);
            if moved > 0 {
                prop_assert!(after < before);
            }
        }

        /// A split's halves, smoothed with their seeds fixed: both connected, non-empty, each
        /// seed in its own half, and together the chart.
        #[test]
        fn split_halves_stay_connected_around_their_seeds(kind in 0u8..4, rng in any::<u64>()) {
            let mesh = build(&mesh_of(kind));
            let faces: Vec<FaceId> = mesh.faces().collect();
            let comps = mesh.components();
            let nf = faces.len() as u64;
            let a = FaceId((rng % nf) as u32);
            let b = FaceId(((rng >> 32) % nf) as u32);
            prop_assume!(a != b && comps.of_face(a) == comps.of_face(b));
            let part: Vec<FaceId> = faces.iter().copied().filter(|&f| comps.of_face(f) == comps.of_face(a)).collect();
            let inside = |f: FaceId| comps.of_face(f) == comps.of_face(a);
            let (ha, hb) = grow_two(&mesh, &part, &inside, a, b);
            prop_assert!(ha.binary_search(&a).is_ok() && hb.binary_search(&b).is_ok());
            prop_assert_eq!(ha.len() + hb.len(), part.len());
            for half in [&ha, &hb] {
                let inside_half = |f: FaceId| half.binary_search(&f).is_ok();
                let reached = crate::atlas::segment::flood(&mesh, &half[..1], &inside_half, half);
                prop_assert_eq!(reached.len(), half.len());
            }
        }
    }
}
