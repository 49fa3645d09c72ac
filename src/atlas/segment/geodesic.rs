//! Geodesic distances on a chart for the spectral segmentation (Iso-charts §4.1, §6).
//!
//! Purpose: the landmark MDS needs the distances from a few landmark vertices to every vertex of
//! a chart (`q × N`, never `N × N`). [`ChartGraph`] is the chart's vertex graph (the edges of its
//! faces, weighted by 3-D length) and [`ChartGraph::dijkstra`] the shortest-path distances from a
//! set of sources on it: step 1 of building-blocks.md §1b. Graph distances overestimate the
//! surface geodesic by a bounded factor (paths follow edges); the clustering only compares them.
//! [`farthest_point_landmarks`] picks the landmarks by farthest-point sampling, which spreads
//! them over the chart (UVAtlas picks them by progressive-mesh importance).
//!
//! Invariants: local vertex `i` is the `i`-th smallest mesh vertex id of the chart's faces;
//! distances are finite on a chart connected through its faces' edges (every chart the
//! segmentation handles), `f64::INFINITY` for an unreachable vertex. Deterministic: the heap
//! orders by (distance bits, vertex) — non-negative `f64` bits order like the values — and ties
//! of farthest-point sampling go to the lowest local index.
//!
//! Units: distances in model units (`_m`).
//!
//! Cost: building `O(F log F)`; one Dijkstra `O(E log V)`.
use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::mesh::{FaceId, TriangleMesh, VertexId};

/// The vertex graph of a set of faces (a chart), in local numbering.
#[derive(Debug, Clone)]
pub struct ChartGraph {
    /// Mesh vertex of each local vertex, ascending.
    pub vertices: Vec<VertexId>,
    /// Local corners of each face, in the order of the given faces.
    pub triangles: Vec<[u32; 3]>,
    /// CSR: the neighbours of `v` are `adj[ptr[v]..ptr[v + 1]]`, ascending, with edge lengths.
    ptr: Vec<usize>,
    adj: Vec<(u32, f64)>,
}

impl ChartGraph {
    /// The graph of `faces` (any order, distinct).
    pub fn new(mesh: &TriangleMesh, faces: &[FaceId]) -> Self {
        let mut vertices: Vec<VertexId> =
            faces.iter().flat_map(|&f| mesh.face_vertices(f)).collect();
        vertices.sort_unstable();
        vertices.dedup();
        let local = |v: VertexId| vertices.binary_search(&v).map_or(0, |i| i as u32);
        let triangles: Vec<[u32; 3]> = faces
            .iter()
            .map(|&f| mesh.face_vertices(f).map(local))
            .collect();
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(6 * triangles.len());
        for t in &triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                pairs.push((a, b));
                pairs.push((b, a));
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let n = vertices.len();
        let mut ptr = vec![0usize; n + 1];
        for &(a, _) in &pairs {
            ptr[a as usize + 1] += 1;
        }
        for v in 0..n {
            ptr[v + 1] += ptr[v];
        }
        let adj = pairs
            .iter()
            .map(|&(a, b)| {
                let (p, q) = (
                    mesh.position(vertices[a as usize]),
                    mesh.position(vertices[b as usize]),
                );
                let d =
                    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
                (b, d)
            })
            .collect();
        Self {
            vertices,
            triangles,
            ptr,
            adj,
        }
    }

    /// Number of local vertices.
    pub fn num_vertices(&self) -> usize {
        self.vertices.len()
    }

    /// The mean edge length (each edge once), 0 without edges.
    pub fn mean_edge_length_m(&self) -> f64 {
        if self.adj.is_empty() {
            return 0.0;
        }
        self.adj.iter().map(|e| e.1).sum::<f64>() / self.adj.len() as f64
    }

    /// Shortest-path distances from the nearest of `sources` (local ids) to every vertex.
    pub fn dijkstra(&self, sources: &[u32]) -> Vec<f64> {
        let n = self.num_vertices();
        let mut dist = vec![f64::INFINITY; n];
        let mut heap = BinaryHeap::new();
        for &s in sources {
            if (s as usize) < n {
                dist[s as usize] = 0.0;
                heap.push(Reverse((0u64, s)));
            }
        }
        while let Some(Reverse((bits, v))) = heap.pop() {
            let d = f64::from_bits(bits);
            if d > dist[v as usize] {
                continue;
            }
            for &(w, len) in &self.adj[self.ptr[v as usize]..self.ptr[v as usize + 1]] {
                let nd = d + len;
                if nd < dist[w as usize] {
                    dist[w as usize] = nd;
                    heap.push(Reverse((nd.to_bits(), w)));
                }
            }
        }
        dist
    }
}

/// Up to `q` landmarks by farthest-point sampling, and the distances from each to every vertex
/// (`dist[i][v]`): the first is the vertex farthest from local vertex 0, each next one the vertex
/// farthest from those chosen (ties: lowest index). Stops early when every vertex is chosen or
/// the farthest one is at distance 0.
pub fn farthest_point_landmarks(graph: &ChartGraph, q: usize) -> (Vec<u32>, Vec<Vec<f64>>) {
    farthest_point_landmarks_in(graph, q, None)
}

/// [`farthest_point_landmarks`] choosing only among the vertices `allowed` (all when `None`);
/// distances still run over the whole graph. The first landmark is the allowed vertex farthest
/// from the lowest allowed one. No landmark when no vertex is allowed.
pub fn farthest_point_landmarks_in(
    graph: &ChartGraph,
    q: usize,
    allowed: Option<&[bool]>,
) -> (Vec<u32>, Vec<Vec<f64>>) {
    let n = graph.num_vertices();
    let mut landmarks = Vec::new();
    let mut dists: Vec<Vec<f64>> = Vec::new();
    let ok = |v: usize| allowed.is_none_or(|a| a[v]);
    let Some(first) = (0..n).find(|&v| ok(v)) else {
        return (landmarks, dists);
    };
    if q == 0 {
        return (landmarks, dists);
    }
    let argmax = |d: &[f64]| {
        let mut best = first;
        for (v, &x) in d.iter().enumerate() {
            if ok(v) && x.is_finite() && (x > d[best] || !d[best].is_finite()) {
                best = v;
            }
        }
        best as u32
    };
    let start = argmax(&graph.dijkstra(&[first as u32]));
    let mut nearest = vec![f64::INFINITY; n];
    let mut next = start;
    while landmarks.len() < q.min(n) {
        let d = graph.dijkstra(&[next]);
        for (m, &x) in nearest.iter_mut().zip(&d) {
            *m = m.min(x);
        }
        landmarks.push(next);
        dists.push(d);
        next = argmax(&nearest);
        // NaN-safe: stop unless the farthest vertex is strictly away from every landmark.
        if nearest[next as usize].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            break;
        }
    }
    (landmarks, dists)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atlas::segment::tests::build;
    use crate::mesh::fixtures;

    #[test]
    fn dijkstra_on_a_flat_grid_gives_manhattan_like_distances() {
        // fixtures::grid(nx, ny): unit squares, each cut by one diagonal; vertex (i, j) at (i, j).
        let (nx, ny) = (6u32, 4u32);
        let mesh = build(&fixtures::grid(nx, ny));
        let faces: Vec<FaceId> = mesh.faces().collect();
        let g = ChartGraph::new(&mesh, &faces);
        assert_eq!(g.num_vertices(), ((nx + 1) * (ny + 1)) as usize);
        let at = |x: f64, y: f64| {
            g.vertices
                .iter()
                .position(|&v| {
                    let p = mesh.position(v);
                    p[0] == x && p[1] == y
                })
                .unwrap() as u32
        };
        let d = g.dijkstra(&[at(0.0, 0.0)]);
        let diag = std::f64::consts::SQRT_2;
        // Along an axis: exact.
        assert!((d[at(6.0, 0.0) as usize] - 6.0).abs() < 1e-12);
        assert!((d[at(0.0, 4.0) as usize] - 4.0).abs() < 1e-12);
        // Every distance lies between the Euclidean one and the axis-path (L1) one, and is one of
        // the lengths `k·√2 + m` (k diagonals, m unit edges) with k + m ≤ L1.
        for (v, &dv) in d.iter().enumerate() {
            let p = mesh.position(g.vertices[v]);
            let (euclid, l1) = ((p[0] * p[0] + p[1] * p[1]).sqrt(), p[0] + p[1]);
            assert!(dv >= euclid - 1e-12 && dv <= l1 + 1e-12, "{p:?}: {dv}");
            let ok = (0..=l1 as u32).any(|k| {
                let m = dv - f64::from(k) * diag;
                m >= -1e-9 && (m - m.round()).abs() < 1e-9
            });
            assert!(ok, "{p:?}: {dv} is not k·√2 + m");
        }
        // Two sources: the distance to the nearer one.
        let both = g.dijkstra(&[at(0.0, 0.0), at(6.0, 4.0)]);
        let far = g.dijkstra(&[at(6.0, 4.0)]);
        for v in 0..g.num_vertices() {
            assert_eq!(both[v], d[v].min(far[v]));
        }
    }

    #[test]
    fn farthest_point_sampling_starts_at_the_corners_and_is_spread() {
        let mesh = build(&fixtures::grid(10, 10));
        let faces: Vec<FaceId> = mesh.faces().collect();
        let g = ChartGraph::new(&mesh, &faces);
        let (lm, dists) = farthest_point_landmarks(&g, 6);
        assert_eq!(lm.len(), 6);
        assert_eq!(dists.len(), 6);
        let corner = |v: u32| {
            let p = mesh.position(g.vertices[v as usize]);
            (p[0] == 0.0 || p[0] == 10.0) && (p[1] == 0.0 || p[1] == 10.0)
        };
        assert!(corner(lm[0]) && corner(lm[1]), "{lm:?}");
        // Distinct, and each landmark's own distance is 0.
        for (i, &l) in lm.iter().enumerate() {
            assert_eq!(dists[i][l as usize], 0.0);
            assert!(lm[..i].iter().all(|&m| m != l));
        }
        assert_eq!(farthest_point_landmarks(&g, 6), (lm, dists));
    }
}
