//! Chart growing: LSCM paper §3.2, Algorithm 2 ("charts growing").
//!
//! Purpose: partition the faces into charts whose borders lie on the feature curves found by
//! `features.rs`, growing all charts at once from seeds far from any feature.
//!
//! Algorithm:
//! 1. [`distance_to_features`]: a front is propagated from the feature curves and the mesh
//!    borders, giving each face its distance to the nearest one. It runs **over the face graph**
//!    (Dijkstra from face centroid to face centroid across glued edges; a source face starts at
//!    the distance from its centroid to the midpoint of its feature or border edge), because the
//!    paper stores `dist(F)` per facet and grows charts facet by facet, and because centroid
//!    distances, unlike hop counts, do not depend on the tessellation and rarely tie (fewer
//!    spurious plateau maxima). Faces of a component with no feature and no border get `+∞`.
//! 2. Seeds are the local maxima of that distance (a face at least as far as every face sharing a
//!    vertex with it: the edge neighbours alone give many spurious maxima along the ridges of a
//!    discrete distance, measured: 10 seeds instead of 1 on a flat 10×10 grid); a plateau of
//!    equal local maxima gives one seed, its lowest face id.
//! 3. A closed component without features (all distances `+∞`) is seeded from the two ends of a
//!    diameter of its face graph (double sweep, as the paper does after Lazarus & Verroust), and
//!    its priority is minus the distance to those two seeds, so it splits into two caps.
//! 4. All charts grow at once from a max-heap of half-edges keyed by the distance of their face
//!    (priority −distance in the paper's words: the face *farthest* from features first, ties by
//!    half-edge id). A half-edge whose opposite face is free adds that face to its chart; one whose
//!    opposite face is in another chart merges the two charts when they meet within
//!    ε = `merge_epsilon_fraction · maxdist` of both charts' largest distance, i.e. near both
//!    seeds. Charts seeded by the diameter rule never merge (that would undo the split).
//!    Additions at **hard edges** (creases of at least `hard_edge_angle_rad`, `features.rs`), for
//!    coarse and CAD meshes, where a face next to a crease can be as far from it as any face:
//!    half-edges on a hard edge are taken only after every other half-edge (a chart crosses a
//!    crease only where no other chart reaches), charts never merge across a hard edge, a plateau
//!    of maxima never extends across one, and the local-maximum test compares a face only with
//!    the faces on its side of the hard edges at each vertex (one seed per side). Without hard
//!    edges all four rules are the paper's.
//!
//! Departures, stated: the paper's `chart_boundaries` edge set, which lets a chart wrap around a
//! cylinder and meet itself along a cut, is not kept: a chart here is a set of faces glued along
//! every interior edge, so a chart that wraps around is an annulus and the disk guarantee in
//! `mod.rs` splits it. Sock-shaped extremal cylinders are not cut here: a capped cylinder is
//! already a disk, and a seam inside a chart cannot be represented; when its map fails the
//! validation's stretch bound it is split lengthwise over its tip instead (`sock.rs`).
//!
//! Invariants: every face gets exactly one chart; charts never span connected components (growth
//! crosses glued edges only); the result is deterministic (heap ties broken by id, no hash maps).
//!
//! Units: distances in model units (`_m`).
//!
//! References: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least Squares Conformal Maps for
//! Automatic Texture Atlas Generation", SIGGRAPH 2002, §3.2 and Algorithm 2; F. Lazarus and
//! A. Verroust, "Level set diagrams of polyhedral objects", 1999 (diameter seeding).
use std::collections::BinaryHeap;

use rayon::prelude::*;

use crate::atlas::progress::StageProgress;
use crate::mesh::{FaceId, HalfedgeId, TriangleMesh};

use super::features::Features;
use super::options::Lscm2002Options;
use super::{checkpoint, SegmentError};

/// Result of [`grow_charts`]: a dense chart index per face, charts numbered by lowest face id.
#[derive(Debug, Clone, PartialEq)]
pub struct GrownCharts {
    /// Chart index of each face (indexed by `FaceId::index()`), in `0..num_charts`.
    pub face_chart: Vec<u32>,
    /// Number of charts.
    pub num_charts: usize,
    /// Number of seeds (charts before merging).
    pub num_seeds: usize,
    /// Number of merges performed (`num_seeds − num_charts`).
    pub num_merges: usize,
    /// `maxdist`: the largest finite distance to features, model units (0 when none).
    pub max_distance_m: f64,
}

fn centroid(mesh: &TriangleMesh, f: FaceId) -> [f64; 3] {
    let p = mesh.face_positions(f);
    [0, 1, 2].map(|k| (p[0][k] + p[1][k] + p[2][k]) / 3.0)
}

fn dist3(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// A heap entry ordered by key (largest first, in `f64::total_cmp` order), then by lowest id,
/// packed into one integer whose order is that order: the key's bits made monotone in the high
/// 64 bits, `!id` in the low 32 (one integer comparison per heap step instead of a float
/// comparison and a tie test; the same pops in the same order).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct MaxEntry(u128);

impl MaxEntry {
    fn new(key: f64, id: u32) -> Self {
        let b = key.to_bits();
        // Negative values (sign bit set) in reverse, all below the non-negative ones: the
        // order of `f64::total_cmp` on unsigned integers.
        let monotone = if b >> 63 == 1 { !b } else { b | (1 << 63) };
        MaxEntry(((monotone as u128) << 32) | (!id) as u128)
    }
    fn key(self) -> f64 {
        let monotone = (self.0 >> 32) as u64;
        f64::from_bits(if monotone >> 63 == 1 {
            monotone & !(1 << 63)
        } else {
            !monotone
        })
    }
    fn id(self) -> u32 {
        !(self.0 as u32)
    }
}

/// A growth heap entry: half-edges not on a hard edge (`open`) first, then [`MaxEntry`]
/// order (bit 96 is `open`). A chart crosses a hard edge only once no chart can grow without
/// crossing one, so on a coarse mesh (a 12-triangle cube, where every face touches a feature)
/// each region between features is filled by its own seed first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct GrowEntry(u128);

impl GrowEntry {
    fn new(open: bool, entry: MaxEntry) -> Self {
        GrowEntry(((open as u128) << 96) | entry.0)
    }
    fn open(self) -> bool {
        self.0 >> 96 != 0
    }
    fn entry(self) -> MaxEntry {
        MaxEntry(self.0 & ((1u128 << 96) - 1))
    }
}

/// Multi-source Dijkstra over the face graph from `sources` (face, initial distance), with
/// centroid-to-centroid edge lengths. Unreached faces stay at `+∞`.
fn face_dijkstra(mesh: &TriangleMesh, sources: &[(FaceId, f64)]) -> Vec<f64> {
    let centroids: Vec<[f64; 3]> = mesh.faces().map(|f| centroid(mesh, f)).collect();
    face_dijkstra_with(mesh, &centroids, sources)
}

/// [`face_dijkstra`] with the face centroids computed once by the caller (same result).
fn face_dijkstra_with(
    mesh: &TriangleMesh,
    centroids: &[[f64; 3]],
    sources: &[(FaceId, f64)],
) -> Vec<f64> {
    let mut dist = vec![f64::INFINITY; mesh.num_faces()];
    let mut heap = BinaryHeap::new();
    for &(f, d) in sources {
        if d < dist[f.index()] {
            dist[f.index()] = d;
            heap.push(MaxEntry::new(-d, f.0));
        }
    }
    while let Some(e) = heap.pop() {
        let f = FaceId(e.id());
        let d = -e.key();
        if d > dist[f.index()] {
            continue;
        }
        let c = centroids[f.index()];
        for g in mesh.face_neighbors(f).into_iter().flatten() {
            let nd = d + dist3(c, centroids[g.index()]);
            if nd < dist[g.index()] {
                dist[g.index()] = nd;
                heap.push(MaxEntry::new(-nd, g.0));
            }
        }
    }
    dist
}

/// Distance from each face to the nearest feature edge or mesh border, over the face graph (see
/// the module doc), in model units; `+∞` for faces of a component without features and borders.
pub fn distance_to_features(mesh: &TriangleMesh, features: &Features) -> Vec<f64> {
    // Centroids and sources in parallel (each value depends on its own face; collected in id
    // order), then the sequential Dijkstra.
    let faces: Vec<FaceId> = mesh.faces().collect();
    let centroids: Vec<[f64; 3]> = faces.par_iter().map(|&f| centroid(mesh, f)).collect();
    let sources: Vec<(FaceId, f64)> = faces
        .par_iter()
        .filter_map(|&f| {
            let c = centroids[f.index()];
            let mut best = f64::INFINITY;
            for h in mesh.face_halfedges(f) {
                if mesh.is_boundary_halfedge(h) || features.is_feature_edge(h) {
                    let a = mesh.position(mesh.from_vertex(h));
                    let b = mesh.position(mesh.to_vertex(h));
                    let mid = [0, 1, 2].map(|k| 0.5 * (a[k] + b[k]));
                    best = best.min(dist3(c, mid));
                }
            }
            best.is_finite().then_some((f, best))
        })
        .collect();
    face_dijkstra_with(mesh, &centroids, &sources)
}

/// The two ends of a (double-sweep) diameter of the face graph of the component holding `start`.
fn diameter_ends(mesh: &TriangleMesh, start: FaceId) -> (FaceId, FaceId) {
    let farthest = |from: FaceId| {
        let d = face_dijkstra(mesh, &[(from, 0.0)]);
        let mut best = from;
        for (i, &x) in d.iter().enumerate() {
            // Strictly greater: lowest id among ties.
            if x.is_finite() && x > d[best.index()] {
                best = FaceId(i as u32);
            }
        }
        best
    };
    let a = farthest(start);
    (a, farthest(a))
}

/// Union-find over chart ids, tracking each root's largest distance and mergeability.
struct Charts {
    parent: Vec<u32>,
    max_key: Vec<f64>,
    mergeable: Vec<bool>,
}

impl Charts {
    fn find(&mut self, mut c: u32) -> u32 {
        while self.parent[c as usize] != c {
            let p = self.parent[c as usize];
            self.parent[c as usize] = self.parent[p as usize];
            c = p;
        }
        c
    }
    fn add(&mut self, key: f64, mergeable: bool) -> u32 {
        let id = self.parent.len() as u32;
        self.parent.push(id);
        self.max_key.push(key);
        self.mergeable.push(mergeable);
        id
    }
}

/// Algorithm 2 of the LSCM paper with the seeding rules of §3.2 (see the module doc).
/// Cost: two Dijkstra passes (distance, and the diameter sweeps per featureless closed
/// component) and one heap pass over the half-edges, `O(F log F)`.
///
/// `progress`: the distances are the first quarter, the seeds the second, growing the rest,
/// with a checkpoint every `PROGRESS_EVERY_FACES` faces grown; `Break` returns
/// [`SegmentError::Cancelled`].
pub fn grow_charts(
    mesh: &TriangleMesh,
    features: &Features,
    options: &Lscm2002Options,
    progress: &mut StageProgress<'_>,
) -> Result<GrownCharts, SegmentError> {
    let nf = mesh.num_faces();
    checkpoint(progress.advance(0, 4))?;
    let mut key = distance_to_features(mesh, features);
    checkpoint(progress.advance(1, 4))?;
    let max_distance_m = key
        .iter()
        .copied()
        .filter(|d| d.is_finite())
        .fold(0.0f64, f64::max);
    let epsilon = options.merge_epsilon_fraction * max_distance_m;

    const FREE: u32 = u32::MAX;
    let mut chart = vec![FREE; nf];
    let mut charts = Charts {
        parent: Vec::new(),
        max_key: Vec::new(),
        mergeable: Vec::new(),
    };
    let mut seeds: Vec<FaceId> = Vec::new();

    // Closed featureless components: diameter seeds, priority −distance to the seeds.
    let comps = mesh.components();
    let mut diameter_seeded = vec![false; nf];
    for info in &comps.components {
        if key[info.first_face.index()].is_finite() {
            continue;
        }
        let (a, b) = diameter_ends(mesh, info.first_face);
        let mut srcs = vec![(a, 0.0)];
        if b != a {
            srcs.push((b, 0.0));
        }
        let d = face_dijkstra(mesh, &srcs);
        for (f, x) in d.iter().enumerate() {
            if x.is_finite() && comps.face_component.as_slice()[f] == info.id {
                key[f] = -x;
                diameter_seeded[f] = true;
            }
        }
        for &(s, _) in &srcs {
            let c = charts.add(0.0, false);
            chart[s.index()] = c;
            seeds.push(s);
        }
    }

    // Local maxima of the distance over the vertex one-ring of faces, one seed per plateau
    // (lowest face id).
    let mut visited = vec![false; nf];
    // The faces compared are those of each vertex's fan on `f`'s side of any hard edge (the
    // whole fan when the vertex has none): a face is not out-ranked by a larger face across a
    // crease (a box whose sides differ in size still gets one seed per side).
    let is_local_max = |f: FaceId, key: &[f64]| {
        let k = key[f.index()];
        mesh.face_halfedges(f).into_iter().all(|g0| {
            // `g0` leaves vertex `from(g0)`; rotate across `prev` (one way), then across `g`
            // itself (the other way), stopping at a hard edge or the border.
            let mut g = g0;
            for _ in 0..mesh.num_halfedges() {
                let e = g.prev();
                if features.is_hard_edge(e) {
                    break;
                }
                let Some(o) = mesh.opposite(e) else { break };
                g = o;
                if g == g0 {
                    return true;
                }
                if key[g.face().index()] > k {
                    return false;
                }
            }
            let mut g = g0;
            for _ in 0..mesh.num_halfedges() {
                if features.is_hard_edge(g) {
                    break;
                }
                let Some(o) = mesh.opposite(g) else { break };
                g = o.next();
                if g == g0 {
                    break;
                }
                if key[g.face().index()] > k {
                    return false;
                }
            }
            true
        })
    };
    for f in mesh.faces() {
        if visited[f.index()]
            || diameter_seeded[f.index()]
            || chart[f.index()] != FREE
            || !is_local_max(f, &key)
        {
            continue;
        }
        let k = key[f.index()];
        let mut stack = vec![f];
        visited[f.index()] = true;
        while let Some(g) = stack.pop() {
            // A plateau never extends across a feature edge: the regions on its two sides are
            // separate charts (on a coarse cube every face is equally far from the edges).
            for h in mesh.face_halfedges(g) {
                if features.is_hard_edge(h) {
                    continue;
                }
                let Some(n) = mesh.opposite(h).map(|o| o.face()) else {
                    continue;
                };
                if !visited[n.index()] && key[n.index()] == k && is_local_max(n, &key) {
                    visited[n.index()] = true;
                    stack.push(n);
                }
            }
        }
        let c = charts.add(k, true);
        chart[f.index()] = c;
        seeds.push(f);
    }

    // Growing: the heap holds half-edges keyed by the distance of their face; half-edges on a
    // feature edge come after all others (`GrowEntry::open`).
    let mut heap: BinaryHeap<GrowEntry> = BinaryHeap::new();
    let push_face = |f: FaceId, heap: &mut BinaryHeap<GrowEntry>, chart: &[u32]| {
        for h in mesh.face_halfedges(f) {
            if let Some(o) = mesh.opposite(h) {
                if chart[o.face().index()] != chart[f.index()] {
                    heap.push(GrowEntry::new(
                        !features.is_hard_edge(h),
                        MaxEntry::new(key[f.index()], h.0),
                    ));
                }
            }
        }
    };
    for &s in &seeds {
        push_face(s, &mut heap, &chart);
    }
    checkpoint(progress.advance(2, 4))?;
    let mut growing = progress.part(2, 2, 4);
    let mut grown = seeds.len();
    let mut num_merges = 0usize;
    while let Some(top) = heap.pop() {
        let open = top.open();
        let h = HalfedgeId(top.entry().id());
        let Some(o) = mesh.opposite(h) else { continue };
        let f = h.face();
        let g = o.face();
        let cf = charts.find(chart[f.index()]);
        if chart[g.index()] == FREE {
            grown += 1;
            if grown % PROGRESS_EVERY_FACES == 0 {
                checkpoint(growing.advance(grown, nf))?;
            }
            chart[g.index()] = cf;
            let m = &mut charts.max_key[cf as usize];
            *m = m.max(key[g.index()]);
            push_face(g, &mut heap, &chart);
            continue;
        }
        let cg = charts.find(chart[g.index()]);
        // Charts that meet on a hard edge never merge: that is where a border belongs.
        if !open || cf == cg || !charts.mergeable[cf as usize] || !charts.mergeable[cg as usize] {
            continue;
        }
        let kf = key[f.index()];
        if charts.max_key[cf as usize] - kf < epsilon && charts.max_key[cg as usize] - kf < epsilon
        {
            let (lo, hi) = (cf.min(cg), cf.max(cg));
            charts.parent[hi as usize] = lo;
            charts.max_key[lo as usize] =
                charts.max_key[lo as usize].max(charts.max_key[hi as usize]);
            num_merges += 1;
        }
    }

    // Dense numbering by lowest face id. Growth covers every component (each has a seed); a face
    // left free would be a bug, and gets a chart of its own rather than a panic.
    let mut dense: Vec<u32> = vec![FREE; charts.parent.len()];
    let mut face_chart = vec![0u32; nf];
    let mut next = 0u32;
    for f in 0..nf {
        let c = if chart[f] == FREE {
            let c = next;
            next += 1;
            c
        } else {
            let r = charts.find(chart[f]) as usize;
            if dense[r] == FREE {
                dense[r] = next;
                next += 1;
            }
            dense[r]
        };
        face_chart[f] = c;
    }
    Ok(GrownCharts {
        face_chart,
        num_charts: next as usize,
        num_seeds: seeds.len(),
        num_merges,
        max_distance_m,
    })
}

/// Faces grown between two progress checkpoints of [`grow_charts`].
const PROGRESS_EVERY_FACES: usize = 4096;

#[cfg(test)]
mod tests {
    use super::{GrowEntry, MaxEntry};

    /// The packed order is `f64::total_cmp` on the key, then the lower id first, then (for
    /// growth entries) open before hard; and the key and id come back bit for bit.
    #[test]
    fn packed_heap_entries_keep_the_float_order_and_round_trip() {
        let keys = [
            f64::NEG_INFINITY,
            -1e300,
            -2.5,
            -f64::MIN_POSITIVE,
            -5e-324,
            -0.0,
            0.0,
            5e-324,
            f64::MIN_POSITIVE,
            1.0,
            1.0 + f64::EPSILON,
            3.75,
            1e300,
            f64::INFINITY,
        ];
        let ids = [0u32, 1, 7, u32::MAX - 1];
        let mut all = Vec::new();
        for &k in &keys {
            for &i in &ids {
                let e = MaxEntry::new(k, i);
                assert_eq!(e.key().to_bits(), k.to_bits());
                assert_eq!(e.id(), i);
                all.push((k, i, e));
            }
        }
        for &(k1, i1, e1) in &all {
            for &(k2, i2, e2) in &all {
                let expected = k1.total_cmp(&k2).then(i2.cmp(&i1));
                assert_eq!(e1.cmp(&e2), expected, "{k1} #{i1} vs {k2} #{i2}");
                for (o1, o2) in [(false, true), (true, false), (true, true)] {
                    let g1 = GrowEntry::new(o1, e1);
                    let g2 = GrowEntry::new(o2, e2);
                    assert_eq!(g1.open(), o1);
                    assert_eq!(g1.entry(), e1);
                    let expected = if o1 == o2 { expected } else { o1.cmp(&o2) };
                    assert_eq!(g1.cmp(&g2), expected);
                }
            }
        }
    }
}
