//! Stretch-driven spectral segmentation (Iso-charts, Zhou et al. 2004, §4–5):
//! [`SegmentMethod::Stretch`](super::SegmentMethod::Stretch).
//!
//! Purpose: cut charts along the shape's global features (head, ears, legs) and keep cutting
//! only where a chart's flattening stretches too much, so that the atlas has few charts *and*
//! low stretch. For each chart, starting from the mesh's connected components:
//! 1. landmark geodesics: `q` landmarks by farthest-point sampling and the graph distances from
//!    each to every vertex (`geodesic.rs`; Dijkstra on the edge graph, building-blocks §1b
//!    step 1);
//! 2. landmark MDS (`numerics::mds`, de Silva & Tenenbaum) of the landmarks, every vertex
//!    placed by distance-based triangulation (§5.2.1);
//! 3. the chart is kept when it is a disk and its L2 stretch is within the bound: the caller's
//!    measure of the chart's flattening ([`ChartStretchFn`]; the pipeline passes its LSCM
//!    flattening), or, without one, the paper's own estimate, the Sander L2 stretch of the
//!    2-D embedding (a flipped triangle is infinite stretch, §4.2);
//! 4. otherwise it is split by surface spectral clustering (§5.1): on a component (the first
//!    split) whose three leading eigenvalues hold less than 90 % of the energy, `n` is the knee
//!    `argmax λ_i / λ_{i+1}` over `3 ≤ i ≤ 10` and the representatives are the extreme
//!    vertices of each of the `n` coordinates, those closer than 10 mean edge lengths to an
//!    earlier one removed; otherwise (and for every later split) it is binary, the extremes of
//!    the first coordinate. Each face joins the representative nearest to the mean of its
//!    corners' geodesic distances (step 6 of §5.1). A part that came out in several pieces keeps
//!    its largest and the others are regrown from the neighbouring parts, so every part is
//!    connected. Parts go back to step 1.
//!
//! With a border band fraction, the border of every split then moves to the minimum cut of a
//! band around it (`graph_cut.rs`, §5.2); for a binary split the capacity weighs the angular
//! term against the parts' embedding distortion (GDD, eq. 2–5, α = [`GDD_ALPHA`]), each part
//! getting its own landmark MDS. The module's caller (`segment_charts`) applies the disk
//! guarantee to every chart.
//!
//! Invariants: every face ends in exactly one chart; every chart returned is connected through
//! glued edges (the disk guarantee runs afterwards). Deterministic: charts of a round are
//! processed in parallel but collected in order, every choice breaks ties by the lowest index,
//! and the MDS runs sequentially; the same mesh and options give the same charts for any rayon
//! thread count (if the stretch measure is deterministic).
//!
//! Units: distances in model units; stretch is a ratio (1 is isometric).
//!
//! Cost: per chart and round, `q` + (at most 20) Dijkstra runs over the chart and one `q × q`
//! eigen-decomposition; the rounds end after [`MAX_ROUNDS`].
//!
//! References: K. Zhou, J. Snyder, B. Guo, H.-Y. Shum, "Iso-charts: Stretch-driven Mesh
//! Parameterization using Spectral Analysis", SGP 2004; V. de Silva, J. B. Tenenbaum, "Sparse
//! multidimensional scaling using landmark points", 2004; P. Sander, J. Snyder, S. Gortler,
//! H. Hoppe, "Texture mapping progressive meshes", SIGGRAPH 2001 (L2 stretch).
use std::collections::VecDeque;

use rayon::prelude::*;

use super::geodesic::{farthest_point_landmarks, farthest_point_landmarks_in, ChartGraph};
use super::graph_cut::{optimize_borders_with, Distortion};
use super::options::StretchSegmentOptions;
use super::{checkpoint, disk_check_connected, split_in_two, SegmentError};
use crate::atlas::progress::StageProgress;
use crate::mesh::{FaceId, TriangleMesh};
use crate::numerics::LandmarkMds;

/// A measure of a chart's L2 stretch (ratio ≥ 1, `f64::INFINITY` for an invalid flattening),
/// given its faces ascending; `None` when it cannot tell (the chart is then kept).
pub type ChartStretchFn<'a> = dyn Fn(&[FaceId]) -> Option<f64> + Sync + 'a;

/// Rounds of splitting at most: charts still above the bound after them are kept as they are
/// (the parameterize stage's own stretch bound still applies).
pub const MAX_ROUNDS: usize = 24;

/// Share of the eigenvalues' energy that the three leading ones must hold for a binary split
/// (§5.1: "the top three eigenvalues constitute 90 % or more").
pub const BINARY_ENERGY: f64 = 0.9;

/// Largest `n` of the general spectral clustering (§5.1, "restricts n ≤ 10").
pub const MAX_CLUSTER_DIM: usize = 10;

/// Representatives closer than this many mean edge lengths to an earlier one are dropped (§5.1).
pub const REPRESENTATIVE_SPACING_EDGES: f64 = 10.0;

/// The weight α of the angular term against the distortion term in the border cut of a binary
/// split (§5.2, eq. 2; the paper's Fig. 9c uses 0.5).
pub const GDD_ALPHA: f64 = 0.5;

/// What [`spectral_charts`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SpectralStats {
    /// Charts split by spectral clustering.
    pub splits: usize,
    /// Of those, splits into more than two parts (general clustering).
    pub general_splits: usize,
    /// Rounds run.
    pub rounds: usize,
}

/// What happened to one chart in one round.
enum Outcome {
    /// Kept as it is.
    Keep(Vec<FaceId>),
    /// Split into these parts (each ascending, connected), with whether it was a general split.
    Split(Vec<Vec<FaceId>>, bool),
}

/// The charts of `mesh` by the stretch-driven method (see the module doc); each is connected,
/// with faces ascending, in a deterministic order. `progress` gets one checkpoint per round.
pub fn spectral_charts(
    mesh: &TriangleMesh,
    options: &StretchSegmentOptions,
    band_fraction: Option<f64>,
    stretch: Option<&ChartStretchFn<'_>>,
    progress: &mut StageProgress<'_>,
) -> Result<(Vec<Vec<FaceId>>, SpectralStats), SegmentError> {
    let mut stats = SpectralStats::default();
    let mut pending: Vec<(Vec<FaceId>, u32)> =
        components(mesh).into_iter().map(|c| (c, 0)).collect();
    let mut done: Vec<Vec<FaceId>> = Vec::new();
    while !pending.is_empty() {
        checkpoint(progress.advance(stats.rounds, MAX_ROUNDS))?;
        if stats.rounds == MAX_ROUNDS {
            done.extend(pending.drain(..).map(|(c, _)| c));
            break;
        }
        stats.rounds += 1;
        let outcomes: Vec<(Outcome, u32)> = std::mem::take(&mut pending)
            .into_par_iter()
            .with_max_len(1)
            .map(|(faces, depth)| {
                let outcome = process(mesh, faces, depth, options, band_fraction, stretch);
                (outcome, depth)
            })
            .collect();
        for (outcome, depth) in outcomes {
            match outcome {
                Outcome::Keep(c) => done.push(c),
                Outcome::Split(parts, general) => {
                    stats.splits += 1;
                    stats.general_splits += usize::from(general);
                    pending.extend(parts.into_iter().map(|p| (p, depth + 1)));
                }
            }
        }
    }
    checkpoint(progress.advance(MAX_ROUNDS, MAX_ROUNDS))?;
    Ok((done, stats))
}

/// The glued components of the mesh, each ascending, ordered by lowest face.
fn components(mesh: &TriangleMesh) -> Vec<Vec<FaceId>> {
    let nf = mesh.num_faces();
    let mut comp = vec![u32::MAX; nf];
    let mut out: Vec<Vec<FaceId>> = Vec::new();
    let mut queue = VecDeque::new();
    for f in mesh.faces() {
        if comp[f.index()] != u32::MAX {
            continue;
        }
        let id = out.len() as u32;
        comp[f.index()] = id;
        queue.push_back(f);
        let mut faces = Vec::new();
        while let Some(g) = queue.pop_front() {
            faces.push(g);
            for h in mesh.face_neighbors(g).into_iter().flatten() {
                if comp[h.index()] == u32::MAX {
                    comp[h.index()] = id;
                    queue.push_back(h);
                }
            }
        }
        faces.sort_unstable();
        out.push(faces);
    }
    out
}

/// One chart (connected, faces ascending) at split depth `depth`: keep or split.
fn process(
    mesh: &TriangleMesh,
    faces: Vec<FaceId>,
    depth: u32,
    options: &StretchSegmentOptions,
    band_fraction: Option<f64>,
    stretch: Option<&ChartStretchFn<'_>>,
) -> Outcome {
    if faces.len() < 2 {
        return Outcome::Keep(faces);
    }
    let inside = |f: FaceId| faces.binary_search(&f).is_ok();
    let disk = disk_check_connected(mesh, &faces, &inside).is_ok();
    let small = faces.len() < options.min_split_faces;
    if small && disk {
        return Outcome::Keep(faces);
    }
    if disk {
        if let Some(measure) = stretch {
            match measure(&faces) {
                Some(s) if s > options.max_stretch => {}
                _ => return Outcome::Keep(faces),
            }
        }
    }
    let graph = ChartGraph::new(mesh, &faces);
    let (landmarks, dists) = farthest_point_landmarks(&graph, options.landmarks);
    let embedding = Embedding::new(&graph, &landmarks, &dists, depth);
    if disk && stretch.is_none() {
        let within = embedding
            .as_ref()
            .map(|e| e.l2_stretch(mesh, &graph))
            .is_some_and(|s| s <= options.max_stretch);
        if within {
            return Outcome::Keep(faces);
        }
    }
    if small {
        // A small non-disk: the disk guarantee splits it.
        return Outcome::Keep(faces);
    }
    let parts = embedding
        .and_then(|e| e.cluster(mesh, &faces, &graph, depth))
        .filter(|(parts, _)| parts.len() >= 2);
    match parts {
        Some((mut parts, general)) => {
            if let Some(band) = band_fraction {
                // §5.2: the border moves to the band's minimum cut; a binary split weighs the
                // angular term against the embedding distortion (GDD) of the two parts.
                let delta = if parts.len() == 2 {
                    gdd_difference(mesh, &faces, &graph, &parts, options.landmarks)
                } else {
                    None
                };
                let distortion = delta.as_deref().map(|per_face| Distortion {
                    per_face,
                    alpha: GDD_ALPHA,
                });
                optimize_borders_with(mesh, &mut parts, None, band, distortion, false);
            }
            Outcome::Split(parts, general)
        }
        None => {
            let (a, b) = split_in_two(mesh, &faces, &inside);
            if a.is_empty() || b.is_empty() {
                Outcome::Keep(faces)
            } else {
                Outcome::Split(vec![a, b], false)
            }
        }
    }
}

/// A chart's landmark MDS and the embedding of all its vertices.
struct Embedding {
    mds: LandmarkMds,
    /// `coords[v]`: the first [`LandmarkMds::dim`] coordinates of local vertex `v`.
    coords: Vec<Vec<f64>>,
}

impl Embedding {
    /// The landmark MDS from the landmarks' distances, with up to [`MAX_CLUSTER_DIM`] dimensions
    /// on a component (depth 0) and 4 on later charts (UVAtlas' caps); `None` without at least
    /// two positive eigenvalues.
    fn new(graph: &ChartGraph, landmarks: &[u32], dists: &[Vec<f64>], depth: u32) -> Option<Self> {
        let q = landmarks.len();
        if q < 3 || dists.iter().any(|d| d.iter().any(|x| !x.is_finite())) {
            return None;
        }
        let sq: Vec<f64> = (0..q * q)
            .map(|k| dists[k / q][landmarks[k % q] as usize].powi(2))
            .collect();
        let max_dim = if depth == 0 { MAX_CLUSTER_DIM } else { 4 };
        let mds = LandmarkMds::new(&sq, q, max_dim.max(2)).ok()?;
        if mds.dim() < 2 {
            return None;
        }
        let mut to = vec![0.0; q];
        let coords = (0..graph.num_vertices())
            .map(|v| {
                for (t, d) in to.iter_mut().zip(dists) {
                    *t = d[v] * d[v];
                }
                mds.embed(&to, mds.dim())
            })
            .collect();
        Some(Self { mds, coords })
    }

    /// The paper's stretch estimate: Sander L2 stretch of the map to the first two embedding
    /// coordinates, scaled to UV area = model area; infinite when a triangle is flipped or
    /// degenerate in the embedding (orientation fixed by the total signed area).
    fn l2_stretch(&self, mesh: &TriangleMesh, graph: &ChartGraph) -> f64 {
        let uv = |v: u32| [self.coords[v as usize][0], self.coords[v as usize][1]];
        let signed = |t: &[u32; 3]| {
            let [a, b, c] = t.map(uv);
            0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
        };
        let total: f64 = graph.triangles.iter().map(signed).sum();
        let sign = if total < 0.0 { -1.0 } else { 1.0 };
        let (mut sum3, mut sum2, mut sum_l2) = (0.0f64, 0.0f64, 0.0f64);
        for t in &graph.triangles {
            let area2 = sign * signed(t);
            let q = t.map(|v| mesh.position(graph.vertices[v as usize]));
            let e1 = [0, 1, 2].map(|c| q[1][c] - q[0][c]);
            let e2 = [0, 1, 2].map(|c| q[2][c] - q[0][c]);
            let cr = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            let area3 = 0.5 * (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
            if area3 == 0.0 {
                continue;
            }
            if area2.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return f64::INFINITY;
            }
            let p = t.map(uv);
            let (u, v) = (p.map(|x| x[0]), p.map(|x| x[1] * sign));
            let su = [0, 1, 2].map(|c| {
                (q[0][c] * (v[1] - v[2]) + q[1][c] * (v[2] - v[0]) + q[2][c] * (v[0] - v[1]))
                    / (2.0 * area2)
            });
            let sv = [0, 1, 2].map(|c| {
                (q[0][c] * (u[2] - u[1]) + q[1][c] * (u[0] - u[2]) + q[2][c] * (u[1] - u[0]))
                    / (2.0 * area2)
            });
            let l2sq = 0.5
                * (su.iter().map(|x| x * x).sum::<f64>() + sv.iter().map(|x| x * x).sum::<f64>());
            sum3 += area3;
            sum2 += area2;
            sum_l2 += area3 * l2sq;
        }
        if sum3.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return 1.0;
        }
        (sum_l2 * sum2 / (sum3 * sum3)).sqrt()
    }

    /// Surface spectral clustering (§5.1, module doc step 4): the parts (ascending, connected)
    /// and whether the split was general; `None` when fewer than two representatives remain.
    fn cluster(
        &self,
        mesh: &TriangleMesh,
        faces: &[FaceId],
        graph: &ChartGraph,
        depth: u32,
    ) -> Option<(Vec<Vec<FaceId>>, bool)> {
        let dim = self.mds.dim();
        let general = depth == 0 && self.mds.energy_of(3) < BINARY_ENERGY && dim >= 3;
        let n = if general {
            knee(&self.mds.eigenvalues, dim)
        } else {
            1
        };
        let mut candidates: Vec<u32> = Vec::with_capacity(2 * n);
        for k in 0..n {
            let (mut lo, mut hi) = (0u32, 0u32);
            for (v, y) in self.coords.iter().enumerate() {
                if y[k] < self.coords[lo as usize][k] {
                    lo = v as u32;
                }
                if y[k] > self.coords[hi as usize][k] {
                    hi = v as u32;
                }
            }
            candidates.push(lo);
            candidates.push(hi);
        }
        let spacing = REPRESENTATIVE_SPACING_EDGES * graph.mean_edge_length_m();
        let mut reps: Vec<Vec<f64>> = Vec::new();
        for &c in &candidates {
            // Too close to a kept one (or unreachable: NaN-safe).
            if reps.iter().any(|d| {
                d[c as usize].partial_cmp(&spacing) == Some(std::cmp::Ordering::Less)
                    || d[c as usize].is_nan()
            }) {
                continue;
            }
            reps.push(graph.dijkstra(&[c]));
        }
        if reps.len() < 2 {
            return None;
        }
        // Each face to the nearest representative by the mean of its corners' distances.
        let nf = faces.len();
        let mut label: Vec<u32> = graph
            .triangles
            .iter()
            .map(|t| {
                let mut best = (f64::INFINITY, 0u32);
                for (r, d) in reps.iter().enumerate() {
                    let m = (d[t[0] as usize] + d[t[1] as usize] + d[t[2] as usize]) / 3.0;
                    if m < best.0 {
                        best = (m, r as u32);
                    }
                }
                best.1
            })
            .collect();
        // Local face adjacency through glued edges inside the chart.
        let neighbors: Vec<[u32; 3]> = faces
            .iter()
            .map(|&f| {
                let mut out = [u32::MAX; 3];
                for (k, g) in mesh.face_neighbors(f).into_iter().enumerate() {
                    if let Some(i) = g.and_then(|g| faces.binary_search(&g).ok()) {
                        out[k] = i as u32;
                    }
                }
                out
            })
            .collect();
        // Keep each label's largest piece (ties: the piece with the lowest face); the others
        // are regrown breadth-first from their neighbours.
        const FREE: u32 = u32::MAX;
        let mut piece = vec![u32::MAX; nf];
        let mut best_piece: Vec<(usize, u32)> = vec![(0, u32::MAX); reps.len()];
        let mut queue = VecDeque::new();
        let mut pieces = 0u32;
        for s in 0..nf {
            if piece[s] != u32::MAX {
                continue;
            }
            let (l, id) = (label[s], pieces);
            pieces += 1;
            piece[s] = id;
            queue.push_back(s as u32);
            let mut size = 0usize;
            while let Some(i) = queue.pop_front() {
                size += 1;
                for &j in &neighbors[i as usize] {
                    if j != FREE && piece[j as usize] == u32::MAX && label[j as usize] == l {
                        piece[j as usize] = id;
                        queue.push_back(j);
                    }
                }
            }
            if size > best_piece[l as usize].0 {
                best_piece[l as usize] = (size, id);
            }
        }
        for i in 0..nf {
            if best_piece[label[i] as usize].1 != piece[i] {
                label[i] = FREE;
            }
        }
        queue.extend((0..nf as u32).filter(|&i| label[i as usize] != FREE));
        while let Some(i) = queue.pop_front() {
            for &j in &neighbors[i as usize] {
                if j != FREE && label[j as usize] == FREE {
                    label[j as usize] = label[i as usize];
                    queue.push_back(j);
                }
            }
        }
        let mut parts: Vec<Vec<FaceId>> = vec![Vec::new(); reps.len()];
        for (i, &f) in faces.iter().enumerate() {
            // Every face is reached: the chart is connected.
            let l = if label[i] == FREE { 0 } else { label[i] };
            parts[l as usize].push(f);
        }
        parts.retain(|p| !p.is_empty());
        Some((parts, reps.len() > 2))
    }
}

/// `δ(f) = |GDD_A(f) − GDD_B(f)|` per face of the mesh (0 outside `faces`), for the two parts
/// `parts` of the chart `faces` (§5.2, eq. 1 and 5): each part gets its own landmark MDS (up to
/// `q` landmarks among its vertices, distances over the whole chart, the dimension by the 90 %
/// energy rule), every vertex of the chart is placed in it (§5.2.1), and its GDD is the root mean
/// square difference between its embedded and geodesic distances to the part's landmarks (the
/// landmark form of eq. 1); a face's GDD is its corners' mean. `None` when a part has fewer than
/// three landmarks or no embedding.
fn gdd_difference(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    graph: &ChartGraph,
    parts: &[Vec<FaceId>],
    q: usize,
) -> Option<Vec<f64>> {
    let nv = graph.num_vertices();
    let mut gdd: Vec<Vec<f64>> = Vec::with_capacity(parts.len());
    for part in parts {
        let mut allowed = vec![false; nv];
        for f in part {
            let i = faces.binary_search(f).ok()?;
            for v in graph.triangles[i] {
                allowed[v as usize] = true;
            }
        }
        let (landmarks, dists) = farthest_point_landmarks_in(graph, q, Some(&allowed));
        let k = landmarks.len();
        if k < 3 || dists.iter().any(|d| d.iter().any(|x| !x.is_finite())) {
            return None;
        }
        let sq: Vec<f64> = (0..k * k)
            .map(|x| dists[x / k][landmarks[x % k] as usize].powi(2))
            .collect();
        let mds = LandmarkMds::new(&sq, k, MAX_CLUSTER_DIM).ok()?;
        let dim = mds.energy_dimension(BINARY_ENERGY);
        if dim == 0 {
            return None;
        }
        let mut to = vec![0.0; k];
        let per_vertex = (0..nv)
            .map(|v| {
                for (t, d) in to.iter_mut().zip(&dists) {
                    *t = d[v] * d[v];
                }
                let y = mds.embed(&to, dim);
                let sum: f64 = (0..k)
                    .map(|j| {
                        let yj = &mds.landmark_coords[j][..dim];
                        let e = y
                            .iter()
                            .zip(yj)
                            .map(|(a, b)| (a - b) * (a - b))
                            .sum::<f64>()
                            .sqrt();
                        (e - dists[j][v]).powi(2)
                    })
                    .sum();
                (sum / k as f64).sqrt()
            })
            .collect::<Vec<f64>>();
        gdd.push(per_vertex);
    }
    let mut delta = vec![0.0; mesh.num_faces()];
    for (i, &f) in faces.iter().enumerate() {
        let t = graph.triangles[i];
        let face = |g: &[f64]| t.iter().map(|&v| g[v as usize]).sum::<f64>() / 3.0;
        delta[f.index()] = (face(&gdd[0]) - face(&gdd[1])).abs();
    }
    Some(delta)
}

/// The knee of §5.1: the `n` in `3..dim` maximising `λ_n / λ_{n+1}` (1-based), or `dim` when
/// there is no `λ_{n+1}` among the kept (positive) eigenvalues.
fn knee(eigenvalues: &[f64], dim: usize) -> usize {
    let mut best = (f64::NEG_INFINITY, dim.min(3));
    for n in 3..dim {
        let ratio = eigenvalues[n - 1] / eigenvalues[n];
        if ratio > best.0 {
            best = (ratio, n);
        }
    }
    best.1
}

#[cfg(test)]
mod tests;
