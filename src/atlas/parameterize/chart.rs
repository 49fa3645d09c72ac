//! The input of the parameterization stage: one chart as a chart-local indexed triangle list,
//! and its validation.
//!
//! Purpose: LSCM (Lévy et al. 2002 §2) is defined for "a chart homeomorphic to a disc". This
//! module checks exactly what the solvers rely on and returns a typed error otherwise, so that
//! no input can make them panic or divide by zero:
//! - every index is in range, every triangle has three distinct vertices, every position is
//!   finite and every vertex is used;
//! - no triangle is degenerate (`d_T`, twice its area, appears as `1/√d_T` in the LSCM matrix);
//! - every edge has at most two faces and the two faces of an interior edge traverse it in
//!   opposite directions (consistent orientation: lscm-2002 §2.3 requires "the local bases of
//!   two triangles sharing an edge are consistently oriented");
//! - every vertex has a single fan of faces (manifold vertex);
//! - the mesh is connected and has exactly one boundary loop and Euler characteristic 1 (a disk).
//!
//! Units: positions in model units (`_m`). Invariant of [`ChartTopology`]: it was computed from
//! a chart that passed all checks above, so its indices are in range.
use std::collections::BinaryHeap;

use super::ParameterizeError;
use crate::mesh::vector::{cross, dot, norm, sub};

/// One chart: a connected, manifold, consistently oriented topological disk.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChartMesh {
    /// Vertex positions in model units. Every vertex must be used by a triangle.
    pub positions_m: Vec<[f64; 3]>,
    /// Triangles as indices into `positions_m`; counter-clockwise seen from the front side, the
    /// UV map preserves this orientation.
    pub triangles: Vec<[u32; 3]>,
}

/// Connectivity of a validated chart, computed once and shared by the solvers.
#[derive(Debug, Clone, PartialEq)]
pub struct ChartTopology {
    /// Vertex adjacency in CSR form: neighbours of `v` are
    /// `neighbors[neighbor_ptr[v]..neighbor_ptr[v+1]]`, sorted ascending.
    pub neighbor_ptr: Vec<usize>,
    /// See `neighbor_ptr`.
    pub neighbors: Vec<u32>,
    /// The boundary loop, in the order of the boundary half-edges (interior on the left).
    pub boundary_loop: Vec<u32>,
}

/// Relative threshold under which a triangle counts as degenerate: `2·area ≤ EPS·(longest edge)²`.
/// At this aspect ratio (~1e-12) the `1/√d_T` weights would dominate the system by 6 orders of
/// magnitude and the normal equations (condition number squared) would lose all precision.
const DEGENERATE_RELATIVE_AREA: f64 = 1e-12;

/// `a > b`, and false when either is NaN: the negation `!exceeds(a, b)` is the NaN-safe
/// "not strictly greater" test every geometric guard here needs.
pub(crate) fn exceeds(a: f64, b: f64) -> bool {
    a > b
}

impl ChartMesh {
    /// Checks every precondition listed in the module doc and returns the chart's connectivity.
    ///
    /// Cost: `O(F log F)` (sorting the directed edges) and `O(F)` memory.
    pub fn validate(&self) -> Result<ChartTopology, ParameterizeError> {
        let n = self.positions_m.len();
        if self.triangles.is_empty() {
            return Err(ParameterizeError::EmptyChart);
        }
        if n > u32::MAX as usize / 2 {
            return Err(ParameterizeError::TooLarge { vertices: n });
        }
        for (v, p) in self.positions_m.iter().enumerate() {
            if !p.iter().all(|c| c.is_finite()) {
                return Err(ParameterizeError::NonFinitePosition { vertex: v as u32 });
            }
        }
        let mut used = vec![false; n];
        for (f, t) in self.triangles.iter().enumerate() {
            for &i in t {
                if i as usize >= n {
                    return Err(ParameterizeError::IndexOutOfRange {
                        triangle: f as u32,
                        index: i,
                        vertices: n,
                    });
                }
                used[i as usize] = true;
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err(ParameterizeError::RepeatedVertex { triangle: f as u32 });
            }
            let [a, b, c] = t.map(|i| self.positions_m[i as usize]);
            let (e0, e1, e2) = (sub(b, a), sub(c, a), sub(c, b));
            let longest2 = dot(e0, e0).max(dot(e1, e1)).max(dot(e2, e2));
            let twice_area = norm(cross(e0, e1));
            if !exceeds(twice_area, DEGENERATE_RELATIVE_AREA * longest2) {
                return Err(ParameterizeError::DegenerateTriangle { triangle: f as u32 });
            }
        }
        if let Some(v) = used.iter().position(|u| !u) {
            return Err(ParameterizeError::UnreferencedVertex { vertex: v as u32 });
        }
        // Half-edges bucketed by source vertex (counting sort, O(F)): half-edge a→b of face
        // (a, b, c) stores `to = b` and `third = c`. Vertex degrees are small, so lookups inside
        // a bucket are linear scans.
        let mut out_ptr = vec![0usize; n + 1];
        for t in &self.triangles {
            for &i in t {
                out_ptr[i as usize + 1] += 1;
            }
        }
        for v in 0..n {
            out_ptr[v + 1] += out_ptr[v];
        }
        let mut fill = out_ptr.clone();
        let mut out_to = vec![0u32; out_ptr[n]];
        let mut out_third = vec![0u32; out_ptr[n]];
        for t in &self.triangles {
            for k in 0..3 {
                let a = t[k] as usize;
                out_to[fill[a]] = t[(k + 1) % 3];
                out_third[fill[a]] = t[(k + 2) % 3];
                fill[a] += 1;
            }
        }
        let bucket = |v: u32| out_ptr[v as usize]..out_ptr[v as usize + 1];
        let has = |a: u32, b: u32| out_to[bucket(a)].contains(&b);
        // A directed edge used twice means two faces traverse an edge in the same direction
        // (inconsistent orientation) or more than two faces share it.
        for a in 0..n as u32 {
            let tos = &out_to[bucket(a)];
            for (i, &b) in tos.iter().enumerate() {
                if tos[..i].contains(&b) {
                    return Err(ParameterizeError::NonManifoldEdge { a, b });
                }
            }
        }
        // Boundary half-edges: (a, b) whose twin (b, a) does not exist.
        let mut boundary_next: Vec<Option<u32>> = vec![None; n];
        let mut boundary_prev: Vec<Option<u32>> = vec![None; n];
        let mut boundary_edges = 0usize;
        for a in 0..n as u32 {
            for &b in &out_to[bucket(a)] {
                if !has(b, a) {
                    if boundary_next[a as usize].is_some() {
                        // Two boundary edges leave `a`: two fans touch at `a` (a bow-tie).
                        return Err(ParameterizeError::NonManifoldVertex { vertex: a });
                    }
                    boundary_next[a as usize] = Some(b);
                    boundary_prev[b as usize] = Some(a);
                    boundary_edges += 1;
                }
            }
        }
        // Undirected edge count: interior edges appear twice among the directed ones.
        let edges = (out_to.len() + boundary_edges) / 2;
        // Adjacency (CSR): the targets of outgoing half-edges, plus the source of the incoming
        // boundary half-edge (whose twin does not exist), sorted per vertex.
        let mut neighbor_ptr = Vec::with_capacity(n + 1);
        neighbor_ptr.push(0usize);
        let mut neighbors: Vec<u32> = Vec::with_capacity(out_to.len() + boundary_edges);
        for v in 0..n {
            let start = neighbors.len();
            neighbors.extend_from_slice(&out_to[bucket(v as u32)]);
            if let Some(p) = boundary_prev[v] {
                neighbors.push(p);
            }
            neighbors[start..].sort_unstable();
            neighbor_ptr.push(neighbors.len());
        }
        // Manifold vertices: around each vertex, faces form a single fan. Walk the fan via
        // "next face around v" and compare its size with the number of incident faces.
        let opposite = |a: u32, b: u32| -> Option<u32> {
            let r = bucket(a);
            out_to[r.clone()]
                .iter()
                .position(|&x| x == b)
                .map(|k| out_third[r.start + k])
        };
        for v in 0..n as u32 {
            let incident = out_ptr[v as usize + 1] - out_ptr[v as usize];
            // Start from the boundary edge leaving v if any (so the walk covers the whole open
            // fan), else from any neighbour.
            let start = match boundary_next[v as usize] {
                Some(w) => w,
                None => out_to[out_ptr[v as usize]],
            };
            let mut w = start;
            let mut count = 0usize;
            // Face (v, w, x): rotate to the next face around v, which contains (v, x).
            while let Some(x) = opposite(v, w) {
                count += 1;
                w = x;
                if w == start || count > incident {
                    break;
                }
            }
            if count != incident {
                return Err(ParameterizeError::NonManifoldVertex { vertex: v });
            }
        }
        // Connectivity over vertices (every vertex is used, so this is face connectivity too).
        let mut seen = vec![false; n];
        let mut stack = vec![0u32];
        seen[0] = true;
        let mut reached = 1usize;
        while let Some(v) = stack.pop() {
            for &w in &neighbors[neighbor_ptr[v as usize]..neighbor_ptr[v as usize + 1]] {
                if !seen[w as usize] {
                    seen[w as usize] = true;
                    reached += 1;
                    stack.push(w);
                }
            }
        }
        if reached != n {
            return Err(ParameterizeError::Disconnected {
                reached,
                vertices: n,
            });
        }
        // Boundary loops.
        let mut loops = 0usize;
        let mut on_loop = vec![false; n];
        let mut boundary_loop = Vec::new();
        for s in 0..n {
            if boundary_next[s].is_none() || on_loop[s] {
                continue;
            }
            loops += 1;
            let mut v = s as u32;
            let mut this_loop = Vec::new();
            while !on_loop[v as usize] {
                on_loop[v as usize] = true;
                this_loop.push(v);
                match boundary_next[v as usize] {
                    Some(w) => v = w,
                    None => break,
                }
            }
            if loops == 1 {
                boundary_loop = this_loop;
            }
        }
        let euler = n as i64 - edges as i64 + self.triangles.len() as i64;
        if loops != 1 || euler != 1 {
            return Err(ParameterizeError::NotADisk {
                boundary_loops: loops,
                euler_characteristic: euler,
            });
        }
        Ok(ChartTopology {
            neighbor_ptr,
            neighbors,
            boundary_loop,
        })
    }
}

impl ChartTopology {
    /// Neighbours of vertex `v` (sorted). `v` must be a vertex of the validated chart.
    pub fn neighbors_of(&self, v: u32) -> &[u32] {
        let v = v as usize;
        match (self.neighbor_ptr.get(v), self.neighbor_ptr.get(v + 1)) {
            (Some(&a), Some(&b)) => &self.neighbors[a..b],
            _ => &[],
        }
    }

    /// The two pinned vertices of lscm-2002 §2.6: "the two vertices maximizing the length of
    /// the shortest path between them (i.e. the graph diameter)", restricted to boundary
    /// vertices (pins on the boundary guarantee no flips, §2.6 / appendix A.5).
    ///
    /// The exact boundary diameter needs one shortest-path tree per boundary vertex; we use the
    /// classical double sweep (Dijkstra from a boundary vertex to the farthest boundary vertex
    /// `a`, then from `a` to the farthest boundary vertex `b`), which is exact on convex-like
    /// charts and a 2-approximation in general, in `O(E log V)`. Path lengths are Euclidean edge
    /// lengths (model units). Ties break on the smaller vertex index (deterministic).
    ///
    /// Returns `(a, b, shortest path length a→b in model units)`.
    pub fn farthest_boundary_pair(&self, positions_m: &[[f64; 3]]) -> (u32, u32, f64) {
        // Edge lengths once for both sweeps, aligned with `neighbors` (NaN: an index outside
        // `positions_m`, skipped; the topology is a public struct and may not match).
        let n = self.neighbor_ptr.len().saturating_sub(1);
        let mut length_m = vec![f64::NAN; self.neighbors.len()];
        for v in 0..n {
            let (Some(&lo), Some(&hi)) = (self.neighbor_ptr.get(v), self.neighbor_ptr.get(v + 1))
            else {
                continue;
            };
            let Some(&pv) = positions_m.get(v) else {
                continue;
            };
            let hi = hi.min(self.neighbors.len());
            let lo = lo.min(hi);
            for (len, &w) in length_m[lo..hi].iter_mut().zip(&self.neighbors[lo..hi]) {
                if let Some(&pw) = positions_m.get(w as usize) {
                    *len = norm(sub(pw, pv));
                }
            }
        }
        let mut dist = vec![f64::INFINITY; n];
        let mut heap = BinaryHeap::new();
        let first = self.boundary_loop.first().copied().unwrap_or(0);
        let (a, _) = self.farthest_boundary_from(first, &length_m, &mut dist, &mut heap);
        dist.fill(f64::INFINITY);
        let (b, d) = self.farthest_boundary_from(a, &length_m, &mut dist, &mut heap);
        (a, b, d)
    }

    /// Dijkstra from `source` over the edges of `length_m` (aligned with `neighbors`, NaN
    /// skipped) into `dist` (all infinite on entry; `heap` empty on entry and exit): the
    /// farthest boundary vertex and its distance.
    fn farthest_boundary_from(
        &self,
        source: u32,
        length_m: &[f64],
        dist: &mut [f64],
        heap: &mut BinaryHeap<HeapEntry>,
    ) -> (u32, f64) {
        let n = dist.len();
        if (source as usize) < n {
            dist[source as usize] = 0.0;
            heap.push(HeapEntry {
                dist: 0.0,
                vertex: source,
            });
        }
        while let Some(HeapEntry { dist: d, vertex: v }) = heap.pop() {
            if d > dist[v as usize] {
                continue;
            }
            let (lo, hi) = (
                self.neighbor_ptr[v as usize],
                self.neighbor_ptr[v as usize + 1],
            );
            let hi = hi.min(length_m.len()).min(self.neighbors.len());
            let lo = lo.min(hi);
            for (&len, &w) in length_m[lo..hi].iter().zip(&self.neighbors[lo..hi]) {
                if len.is_nan() {
                    continue;
                }
                let nd = d + len;
                let Some(slot) = dist.get_mut(w as usize) else {
                    continue;
                };
                if nd < *slot {
                    *slot = nd;
                    heap.push(HeapEntry {
                        dist: nd,
                        vertex: w,
                    });
                }
            }
        }
        let mut best = (source, 0.0);
        for &v in &self.boundary_loop {
            let d = dist.get(v as usize).copied().unwrap_or(f64::INFINITY);
            if d.is_finite() && (d > best.1 || (d == best.1 && v < best.0)) {
                best = (v, d);
            }
        }
        best
    }
}

/// Min-heap entry for Dijkstra (ordered by distance, then vertex index).
#[derive(Debug, PartialEq)]
struct HeapEntry {
    dist: f64,
    vertex: u32,
}
impl Eq for HeapEntry {}
impl Ord for HeapEntry {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        other
            .dist
            .total_cmp(&self.dist)
            .then_with(|| other.vertex.cmp(&self.vertex))
    }
}
impl PartialOrd for HeapEntry {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_meshes::grid;
    use super::*;

    #[test]
    fn grid_is_a_disk_with_the_right_boundary() {
        let chart = grid(4, 3, |x, y| [x, y, 0.0]);
        let topo = chart.validate().expect("disk");
        assert_eq!(topo.boundary_loop.len(), 2 * (4 + 3));
        // Interior vertex (1,1) of a 5x4 vertex grid with diagonal split has 6 neighbours.
        assert_eq!(topo.neighbors_of(6).len(), 6);
        let (a, b, d) = topo.farthest_boundary_pair(&chart.positions_m);
        // The farthest pair on a 4x3 grid with one diagonal per quad is a pair of opposite
        // corners; the graph distance along the diagonals is 3·√2 + 1.
        let pa = chart.positions_m[a as usize];
        let pb = chart.positions_m[b as usize];
        assert!((pa[0] - pb[0]).abs() == 4.0 && (pa[1] - pb[1]).abs() == 3.0);
        assert!((d - (3.0 * 2f64.sqrt() + 1.0)).abs() < 1e-12, "{d}");
    }

    #[test]
    fn every_defect_is_reported_with_its_type() {
        let ok = grid(2, 2, |x, y| [x, y, 0.0]);
        assert!(ok.validate().is_ok());
        let empty = ChartMesh::default();
        assert!(matches!(
            empty.validate(),
            Err(ParameterizeError::EmptyChart)
        ));
        let mut m = ok.clone();
        m.triangles[0][1] = 99;
        assert!(matches!(
            m.validate(),
            Err(ParameterizeError::IndexOutOfRange { .. })
        ));
        let mut m = ok.clone();
        m.triangles[0][1] = m.triangles[0][0];
        assert!(matches!(
            m.validate(),
            Err(ParameterizeError::RepeatedVertex { .. })
        ));
        let mut m = ok.clone();
        m.positions_m[0][2] = f64::NAN;
        assert!(matches!(
            m.validate(),
            Err(ParameterizeError::NonFinitePosition { .. })
        ));
        let mut m = ok.clone();
        m.positions_m.push([5.0, 5.0, 5.0]);
        assert!(matches!(
            m.validate(),
            Err(ParameterizeError::UnreferencedVertex { .. })
        ));
        let mut m = ok.clone();
        m.triangles[0].swap(0, 1);
        assert!(matches!(
            m.validate(),
            Err(ParameterizeError::NonManifoldEdge { .. })
        ));
        let degenerate = ChartMesh {
            positions_m: vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            triangles: vec![[0, 1, 2]],
        };
        assert!(matches!(
            degenerate.validate(),
            Err(ParameterizeError::DegenerateTriangle { .. })
        ));
        // Two triangles touching at one vertex: a bow-tie.
        let bowtie = ChartMesh {
            positions_m: vec![
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [-1.0, 0.0, 0.0],
                [0.0, -1.0, 0.0],
            ],
            triangles: vec![[0, 1, 2], [0, 3, 4]],
        };
        assert!(matches!(
            bowtie.validate(),
            Err(ParameterizeError::NonManifoldVertex { .. })
        ));
        // Two separate triangles.
        let two = ChartMesh {
            positions_m: vec![
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [5.0, 0.0, 0.0],
                [6.0, 0.0, 0.0],
                [5.0, 1.0, 0.0],
            ],
            triangles: vec![[0, 1, 2], [3, 4, 5]],
        };
        assert!(matches!(
            two.validate(),
            Err(ParameterizeError::Disconnected { .. })
        ));
        // A closed tetrahedron: no boundary.
        let tet = ChartMesh {
            positions_m: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
        };
        assert!(matches!(
            tet.validate(),
            Err(ParameterizeError::NotADisk {
                boundary_loops: 0,
                ..
            })
        ));
        // An annulus (cylinder without caps): two boundary loops.
        let annulus = super::super::test_meshes::open_cylinder(8, 2, false);
        assert!(matches!(
            annulus.validate(),
            Err(ParameterizeError::NotADisk {
                boundary_loops: 2,
                ..
            })
        ));
    }
}
