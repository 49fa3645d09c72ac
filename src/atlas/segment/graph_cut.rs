//! Graph-cut optimisation of chart borders (Iso-charts §5.2, after Katz & Tal 2003).
//!
//! Purpose: chart growing (`grow.rs`) and the disk guarantee leave borders where two growing
//! fronts met: saw-toothed on low-poly meshes, meandering on smooth ones. For each pair of
//! adjacent charts A and B, this module takes a *medial band* of faces on both sides of their
//! shared border, ties the rest of A to the source and the rest of B to the sink, and moves the
//! border to the minimum cut of a face graph whose edge capacity is cheap on sharp edges and
//! short edges: `c(fi, fj) = length(e) · (1 + d_ang / avg(d_ang))⁻¹ · w_feature`, with
//! `d_ang = 1 − cos α` (α the angle between the face normals) and `w_feature` =
//! [`FEATURE_EDGE_WEIGHT`] on detected feature and hard edges, 1 elsewhere. It is the paper's
//! capacity with α = 1 (its angular term) weighted by edge length so that the cut is the
//! shortest border where the surface is smooth; the paper's distortion term needs the
//! Iso-charts embedding, which this segmentation does not have.
//!
//! Invariants: a border moves only when the cut is strictly cheaper than the current border and
//! both new charts are topological disks ([`super::check_chart_is_disk`]); otherwise the pair
//! keeps its faces. So the stage contract holds, the chart count never changes, and no chart
//! loses its core (the faces outside the band). Deterministic: pairs are visited in ascending
//! (A, B) order of the charts' indices, faces in id order; capacities are quantised to integers
//! before the max-flow (exact arithmetic).
//!
//! Units: edge lengths in model units; capacities dimensionless after quantisation.
//!
//! Cost: per pair, a breadth-first band growth and one max-flow over the band (about 2 ×
//! `band_fraction` of the pair's faces), plus two disk checks when the border moved.
//!
//! References: K. Zhou, J. Snyder, B. Guo, H.-Y. Shum, "Iso-charts: Stretch-driven Mesh
//! Parameterization using Spectral Analysis", SGP 2004, §5.2 (medial region, capacity eq. 2–3);
//! S. Katz, A. Tal, "Hierarchical mesh decomposition using fuzzy clustering and cuts", SIGGRAPH
//! 2003 (the angular capacity).
use crate::mesh::vector::dot;
use crate::mesh::{FaceId, TriangleMesh};
use crate::numerics::{CutSide, FlowGraph};

use super::{disk_check, Features, NotADisk};

/// Capacity factor of a detected feature or hard edge: a border lying on a feature curve costs
/// a tenth of a smooth border of the same length and sharpness, so the cut keeps the curves
/// that segmentation chose as borders.
pub const FEATURE_EDGE_WEIGHT: f64 = 0.1;

/// Capacities are quantised to integers in `[1, CAPACITY_SCALE + 1]` before the max-flow.
const CAPACITY_SCALE: f64 = (1u64 << 20) as f64;

/// The distortion term of the capacity (Iso-charts §5.2, eq. 2, 4–5), for a pair of charts cut
/// from one chart by the stretch-driven segmentation: `c = α·c_ang + (1 − α)·c_distort`, with
/// `c_distort(fi, fj) = d(fi, fj) / avg(d)`, `d(fi, fj) = δ(fi) + δ(fj)` and
/// `δ(f) = |GDD_A(f) − GDD_B(f)|`, the difference of the face's geodesic distance distortion
/// under the two charts' embeddings (`spectral.rs`); both terms are weighted by edge length as
/// the angular one is here. The average runs over the band's edges.
#[derive(Debug, Clone, Copy)]
pub struct Distortion<'a> {
    /// `δ(f)` per face of the mesh (read for the faces of the pair only).
    pub per_face: &'a [f64],
    /// The weight α of the angular term, in `[0, 1]`; the paper's figures use 0.5.
    pub alpha: f64,
}

/// What [`optimize_borders`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BorderStats {
    /// Pairs of adjacent charts examined.
    pub pairs: usize,
    /// Pairs whose border moved.
    pub moved: usize,
}

/// Moves the border of every pair of adjacent charts to the minimum cut in a band of
/// `band_fraction` of each chart's area on both sides of it (see the module doc). `charts`
/// must be topological disks covering every face once; they still are on return, with the same
/// count. `features` marks edges that stay preferred as borders.
pub fn optimize_borders(
    mesh: &TriangleMesh,
    charts: &mut [Vec<FaceId>],
    features: Option<&Features>,
    band_fraction: f64,
) -> BorderStats {
    optimize_borders_with(mesh, charts, features, band_fraction, None, true)
}

/// [`optimize_borders`] with the distortion term `distortion` in the capacity, and, with
/// `keep_disks` false, for charts that need only be connected (the spectral segmentation's
/// intermediate parts): a border then moves when both charts stay connected. `charts` need not
/// cover the mesh; faces outside them are never touched.
pub fn optimize_borders_with(
    mesh: &TriangleMesh,
    charts: &mut [Vec<FaceId>],
    features: Option<&Features>,
    band_fraction: f64,
    distortion: Option<Distortion<'_>>,
    keep_disks: bool,
) -> BorderStats {
    let nf = mesh.num_faces();
    let mut stats = BorderStats::default();
    if charts.len() < 2 || nf == 0 {
        return stats;
    }
    // Ascending face lists (kept so: new lists are merges of two ascending lists).
    for faces in charts.iter_mut() {
        faces.sort_unstable();
    }
    let mut face_chart = vec![u32::MAX; nf];
    for (c, faces) in charts.iter().enumerate() {
        for f in faces {
            face_chart[f.index()] = c as u32;
        }
    }
    let area_m2: Vec<f64> = mesh.faces().map(|f| mesh.face_area_m2(f)).collect();
    let capacity = edge_capacities(mesh, features);
    let mut chart_area_m2: Vec<f64> = charts
        .iter()
        .map(|faces| faces.iter().map(|f| area_m2[f.index()]).sum())
        .collect();

    // The adjacent pairs, ascending.
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    for h in mesh.halfedges() {
        if let Some(o) = mesh.opposite(h) {
            let (a, b) = (
                face_chart[mesh.face(h).index()],
                face_chart[mesh.face(o).index()],
            );
            if a < b && b != u32::MAX {
                pairs.push((a, b));
            }
        }
    }
    pairs.sort_unstable();
    pairs.dedup();

    // Scratch, indexed by face: the band's node index, or NONE.
    const NONE: u32 = u32::MAX;
    let mut node_of = vec![NONE; nf];
    for (a, b) in pairs {
        stats.pairs += 1;
        let in_pair = |f: FaceId, fc: &[u32]| {
            let c = fc[f.index()];
            c == a || c == b
        };
        // Faces of the pair touching the other chart: ring 0 of the band, found from the
        // smaller chart's side (both faces of each crossing edge).
        let (small, other) = if charts[a as usize].len() <= charts[b as usize].len() {
            (a, b)
        } else {
            (b, a)
        };
        let mut ring: Vec<FaceId> = Vec::new();
        for &f in &charts[small as usize] {
            for g in mesh.face_neighbors(f).iter().flatten() {
                if face_chart[g.index()] == other {
                    ring.push(f);
                    ring.push(*g);
                }
            }
        }
        if ring.is_empty() {
            continue; // no longer adjacent after an earlier pair moved
        }
        ring.sort_unstable();
        ring.dedup();
        let budget = [
            band_fraction * chart_area_m2[a as usize],
            band_fraction * chart_area_m2[b as usize],
        ];
        let side = |f: FaceId, fc: &[u32]| usize::from(fc[f.index()] == b);
        let mut band: Vec<FaceId> = Vec::new();
        let mut band_area = [0.0f64; 2];
        let mut band_faces = [0usize; 2];
        let sizes = [charts[a as usize].len(), charts[b as usize].len()];
        // Breadth-first rings; a side stops growing at its area budget, and always keeps at
        // least one core face (a chart entirely in the band could vanish).
        while !ring.is_empty() {
            let mut next = Vec::new();
            for &f in &ring {
                if node_of[f.index()] != NONE {
                    continue;
                }
                let s = side(f, &face_chart);
                if band_faces[s] + 1 >= sizes[s] || (band_area[s] >= budget[s] && band_faces[s] > 0)
                {
                    continue;
                }
                node_of[f.index()] = band.len() as u32;
                band.push(f);
                band_area[s] += area_m2[f.index()];
                band_faces[s] += 1;
                for g in mesh.face_neighbors(f).iter().flatten() {
                    if node_of[g.index()] == NONE && in_pair(*g, &face_chart) {
                        next.push(*g);
                    }
                }
            }
            next.sort_unstable();
            next.dedup();
            ring = next;
        }
        if band.is_empty() {
            continue;
        }

        // Capacities of the band's edges (to band faces and to the cores), quantised.
        let mut edges: Vec<(u32, Option<u32>, usize, f64)> = Vec::new(); // (node, other node | core side, side of core, cap)
                                                                         // With the distortion term: (length, δ(f) + δ(g)) per entry of `edges`.
        let mut spread: Vec<(f64, f64)> = Vec::new();
        for (i, &f) in band.iter().enumerate() {
            for h in mesh.face_halfedges(f) {
                let Some(o) = mesh.opposite(h) else { continue };
                let g = mesh.face(o);
                if !in_pair(g, &face_chart) {
                    continue;
                }
                let c = capacity[h.index()];
                let j = node_of[g.index()];
                if j == NONE {
                    edges.push((i as u32, None, side(g, &face_chart), c));
                } else if (i as u32) < j {
                    edges.push((i as u32, Some(j), 0, c));
                } else {
                    continue;
                }
                if let Some(d) = distortion {
                    spread.push((
                        mesh.edge_length_m(h),
                        d.per_face[f.index()] + d.per_face[g.index()],
                    ));
                }
            }
        }
        if let Some(d) = distortion {
            let mean = spread.iter().map(|s| s.1).sum::<f64>() / spread.len().max(1) as f64;
            for (e, &(length_m, sum)) in edges.iter_mut().zip(&spread) {
                let c_distort = if mean > 0.0 { sum / mean } else { 0.0 };
                e.3 = d.alpha * e.3 + (1.0 - d.alpha) * c_distort * length_m;
            }
        }
        let max_cap = edges.iter().fold(0.0f64, |m, e| m.max(e.3));
        let quantise = |c: f64| -> i64 {
            if max_cap > 0.0 && c.is_finite() {
                1 + (c / max_cap * CAPACITY_SCALE).round() as i64
            } else {
                1
            }
        };
        let mut graph = FlowGraph::new(band.len());
        // The current border's cost in the same units, to move only on a strict gain.
        let mut current = 0i64;
        let current_side = |n: u32| side(band[n as usize], &face_chart);
        for &(i, j, core_side, c) in &edges {
            let q = quantise(c);
            match j {
                Some(j) => {
                    graph.add_edge(i as usize, j as usize, q, q);
                    if current_side(i) != current_side(j) {
                        current += q;
                    }
                }
                None => {
                    if core_side == 0 {
                        graph.add_terminal(i as usize, q, 0);
                    } else {
                        graph.add_terminal(i as usize, 0, q);
                    }
                    if current_side(i) != core_side {
                        current += q;
                    }
                }
            }
        }
        let cut = graph.max_flow();
        let new_side: Vec<usize> = cut
            .side
            .iter()
            .map(|s| usize::from(*s == CutSide::Sink))
            .collect();
        let changed = band
            .iter()
            .zip(&new_side)
            .any(|(f, &s)| side(*f, &face_chart) != s);
        if changed && cut.flow < current {
            // Both lists ascending: a merge of the two charts' (ascending) face lists.
            let mut new_a: Vec<FaceId> = Vec::with_capacity(sizes[0]);
            let mut new_b: Vec<FaceId> = Vec::with_capacity(sizes[1]);
            let (fa, fb) = (&charts[a as usize], &charts[b as usize]);
            let (mut i, mut j) = (0, 0);
            while i < fa.len() || j < fb.len() {
                let f = if j == fb.len() || (i < fa.len() && fa[i] < fb[j]) {
                    i += 1;
                    fa[i - 1]
                } else {
                    j += 1;
                    fb[j - 1]
                };
                let n = node_of[f.index()];
                let s = if n == NONE {
                    side(f, &face_chart)
                } else {
                    new_side[n as usize]
                };
                if s == 0 {
                    new_a.push(f);
                } else {
                    new_b.push(f);
                }
            }
            // Membership by label (O(1)), not by search in the face lists: the disk checks are
            // most of this module's cost otherwise.
            let label = |f: FaceId| -> u32 {
                let j = node_of[f.index()];
                if j != NONE {
                    if new_side[j as usize] == 0 {
                        a
                    } else {
                        b
                    }
                } else {
                    face_chart[f.index()]
                }
            };
            let fits = |faces: &[FaceId], c: u32| match disk_check(mesh, faces, &|f| label(f) == c)
            {
                Ok(_) => true,
                Err(NotADisk::Disconnected { .. } | NotADisk::Empty) => false,
                Err(_) => !keep_disks,
            };
            if !new_a.is_empty() && !new_b.is_empty() && fits(&new_a, a) && fits(&new_b, b) {
                for f in &new_a {
                    face_chart[f.index()] = a;
                }
                for f in &new_b {
                    face_chart[f.index()] = b;
                }
                chart_area_m2[a as usize] = new_a.iter().map(|f| area_m2[f.index()]).sum();
                chart_area_m2[b as usize] = new_b.iter().map(|f| area_m2[f.index()]).sum();
                charts[a as usize] = new_a;
                charts[b as usize] = new_b;
                stats.moved += 1;
            }
        }
        for f in &band {
            node_of[f.index()] = NONE;
        }
    }
    stats
}

/// The capacity of every half-edge (module doc: `length · (1 + d_ang / avg(d_ang))⁻¹ ·
/// w_feature`), indexed by `HalfedgeId::index()`; both halves of a glued edge get the same
/// value, a boundary half-edge its length times the feature weight. The cost of an edge as a
/// border, also for `smooth.rs`. Cost: `O(F)`.
pub(super) fn edge_capacities(mesh: &TriangleMesh, features: Option<&Features>) -> Vec<f64> {
    let normals: Vec<Option<[f64; 3]>> = mesh.faces().map(|f| mesh.face_normal(f)).collect();
    let d_ang = |h: crate::mesh::HalfedgeId| -> f64 {
        let Some(o) = mesh.opposite(h) else {
            return 0.0;
        };
        match (normals[mesh.face(h).index()], normals[mesh.face(o).index()]) {
            (Some(a), Some(b)) => (1.0 - dot(a, b)).max(0.0),
            _ => 0.0,
        }
    };
    // avg(d_ang) over the glued edges (each once), for the paper's normalisation.
    let (mut sum, mut count) = (0.0, 0usize);
    for h in mesh.halfedges() {
        if let Some(o) = mesh.opposite(h) {
            if h < o {
                sum += d_ang(h);
                count += 1;
            }
        }
    }
    let avg_d_ang = if count > 0 && sum > 0.0 {
        sum / count as f64
    } else {
        1.0
    };
    // The capacity of every glued half-edge, once (both halves get the same value).
    mesh.halfedges()
        .map(|h| {
            let feature = features.is_some_and(|fs| fs.is_feature_edge(h) || fs.is_hard_edge(h));
            let w = if feature { FEATURE_EDGE_WEIGHT } else { 1.0 };
            mesh.edge_length_m(h) * w / (1.0 + d_ang(h) / avg_d_ang)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atlas::progress::{Stage, StageProgress};
    use crate::atlas::segment::tests::{assert_contract, build};
    use crate::atlas::segment::{segment_charts, SegmentOptions};
    use crate::mesh::{fixtures, MeshInput};

    const NX: u32 = 24;
    const NY: u32 = 10;

    /// Face `k` (0, 1) of grid square `(i, j)` of [`fixtures::grid`].
    fn square_of(f: FaceId) -> (u32, u32) {
        let s = f.0 / 2;
        (s % NX, s / NX)
    }

    /// Two charts of an `NX × NY` grid split by a saw-tooth border: square `(i, j)` is in chart
    /// 0 when `i < 10 + 3·(j mod 2)`.
    fn saw_tooth(mesh: &TriangleMesh) -> Vec<Vec<FaceId>> {
        let mut charts = vec![Vec::new(), Vec::new()];
        for f in mesh.faces() {
            let (i, j) = square_of(f);
            charts[usize::from(i >= 10 + 3 * (j % 2))].push(f);
        }
        charts
    }

    /// The 3-D length of the border between the two charts, and whether every border edge
    /// satisfies `on(edge's two end positions)`. Recomputed from the face lists.
    fn border(
        mesh: &TriangleMesh,
        charts: &[Vec<FaceId>],
        on: impl Fn([f64; 3], [f64; 3]) -> bool,
    ) -> (f64, bool) {
        let in0: std::collections::BTreeSet<FaceId> = charts[0].iter().copied().collect();
        let (mut length, mut all_on) = (0.0, true);
        for h in mesh.edges() {
            let Some(o) = mesh.opposite(h) else { continue };
            if in0.contains(&mesh.face(h)) != in0.contains(&mesh.face(o)) {
                let (p, q) = (
                    mesh.position(mesh.from_vertex(h)),
                    mesh.position(mesh.to_vertex(h)),
                );
                length +=
                    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
                all_on &= on(p, q);
            }
        }
        (length, all_on)
    }

    fn assert_disks_and_partition(mesh: &TriangleMesh, charts: &[Vec<FaceId>]) {
        let mut seen = vec![0u8; mesh.num_faces()];
        for c in charts {
            check_chart_is_disk(mesh, c).expect("a disk");
            for f in c {
                seen[f.index()] += 1;
            }
        }
        assert!(seen.iter().all(|&n| n == 1), "every face in one chart");
    }

    use crate::atlas::segment::check_chart_is_disk;

    #[test]
    fn a_saw_tooth_border_on_a_plane_becomes_a_straight_line() {
        let mesh = build(&fixtures::grid(NX, NY));
        let mut charts = saw_tooth(&mesh);
        assert_disks_and_partition(&mesh, &charts);
        let (before, _) = border(&mesh, &charts, |_, _| true);
        assert!(
            before > f64::from(NY) + 1.0,
            "the fixture is jagged: {before}"
        );
        let stats = optimize_borders(&mesh, &mut charts, None, 0.3);
        assert_eq!(stats, BorderStats { pairs: 1, moved: 1 });
        assert_disks_and_partition(&mesh, &charts);
        // On a plane the capacity is the edge length, and the shortest border from the bottom
        // to the top of the grid is one vertical line of NY unit edges.
        let (after, vertical) = border(&mesh, &charts, |p, q| p[0] == q[0]);
        assert!(
            (after - f64::from(NY)).abs() < 1e-9,
            "border length {after}"
        );
        assert!(vertical);
        // A straight border is already the minimum: a second pass moves nothing.
        let again = charts.clone();
        assert_eq!(optimize_borders(&mesh, &mut charts, None, 0.3).moved, 0);
        assert_eq!(charts, again);
    }

    #[test]
    fn a_border_near_a_crease_moves_onto_the_crease() {
        // The grid folded by 90° along the line x = 12 (columns right of it stand up in z).
        let mut input: MeshInput = fixtures::grid(NX, NY);
        for p in &mut input.positions_m {
            if p[0] > 12.0 {
                *p = [12.0, p[1], p[0] - 12.0];
            }
        }
        let mesh = build(&input);
        let mut charts = saw_tooth(&mesh);
        let stats = optimize_borders(&mesh, &mut charts, None, 0.3);
        assert_eq!(stats.moved, 1);
        assert_disks_and_partition(&mesh, &charts);
        let (length, on_crease) = border(&mesh, &charts, |p, q| {
            p[0] == 12.0 && q[0] == 12.0 && p[2] == 0.0 && q[2] == 0.0
        });
        assert!(on_crease, "every border edge lies on the crease");
        assert!(
            (length - f64::from(NY)).abs() < 1e-9,
            "border length {length}"
        );
    }

    #[test]
    fn segmentation_with_border_optimisation_keeps_the_contract_and_the_chart_count() {
        let inputs = [
            fixtures::grid(3, 2),
            fixtures::cube_split_faces(),
            fixtures::uv_sphere(8, 12, 1.0),
            fixtures::torus(12, 8, 2.0, 0.5),
            fixtures::cylinder_open(10, 6, 1.0, 1.0),
            fixtures::two_components(),
            fixtures::bowtie(),
            fixtures::fin(),
            fixtures::flipped_face(),
            fixtures::degenerate(),
        ];
        let run = |mesh: &TriangleMesh, band: Option<f64>| {
            let options = SegmentOptions {
                border_band_fraction: band,
                ..SegmentOptions::default()
            };
            segment_charts(mesh, &options, &mut StageProgress::ignored(Stage::Segment))
                .expect("valid options")
        };
        for (i, input) in inputs.iter().enumerate() {
            let mesh = build(input);
            let plain = run(&mesh, None);
            let cut = run(&mesh, Some(0.3));
            assert_contract(&mesh, &cut);
            assert_eq!(cut.num_charts(), plain.num_charts(), "fixture {i}");
            assert_eq!(cut, run(&mesh, Some(0.3)), "fixture {i}: deterministic");
        }
    }
}
