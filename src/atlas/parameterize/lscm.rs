//! Least Squares Conformal Maps, exactly as Lévy, Petitjean, Ray, Maillot 2002 §2.
//!
//! The paper's stages, in its words, and where they live here:
//! - §2.3 "each triangle is provided with a local orthonormal basis, where (x1,y1), (x2,y2),
//!   (x3,y3) are the coordinates of its vertices in this basis (i.e., the normal is along the
//!   z-axis). The local bases of two triangles sharing an edge are consistently oriented."
//!   → [`local_frame_coordinates`]: x along the first edge, z along the face normal given by the
//!   winding, so consistently oriented charts give consistently oriented frames.
//! - §2.4 "W1 = (x3 − x2) + i(y3 − y2), W2 = (x1 − x3) + i(y1 − y3), W3 = (x2 − x1) + i(y2 − y1)"
//!   and `d_T` "twice the area of the triangle" → [`triangle_coefficients`].
//! - §2.5 "M = (m_ij) is the sparse n'×n matrix … m_ij = W_{j,T_i}/√d_{T_i}", split into free
//!   and pinned columns, and rewritten with real matrices as `C(x) = ‖A·x − b‖²` with
//!   `A = [[M_f¹, −M_f²], [M_f², M_f¹]]`, `b = −[[M_p¹, −M_p²], [M_p², M_p¹]]·U_p`
//!   → [`LscmSystem`]. We never store `A`: we assemble the normal matrix `AᵀA` (what the paper
//!   solves, §2.6 "x = (AᵀA)⁻¹Aᵀb") directly from `M`, using that for vertices `i, j` of a
//!   triangle the 2×2 block of `AᵀA` acting on `(u_j, v_j)` in row `(u_i, v_i)` is the
//!   complex number `conj(m_i)·m_j` written as the real matrix `[[Re, −Im], [Im, Re]]`.
//!   Unknowns are interleaved `(u_0, v_0, u_1, v_1, …)` over free vertices: a permutation of the
//!   paper's `(U_f¹, U_f²)` that keeps each vertex's two unknowns adjacent (better locality;
//!   the Cholesky ordering is fill-reducing anyway).
//! - §2.6 "we have pinned the two vertices maximizing the length of the shortest path between
//!   them (i.e. the graph diameter)" → [`super::chart::ChartTopology::farthest_boundary_pair`].
//!   The first pin goes to UV (0,0), the second to (L,0) with `L` the shortest-path length
//!   between them, so UVs come out roughly in model units.
//!
//! Energy: [`conformal_energy`] is the paper's `C(U) = Σ_T |Σ_j W_{j,T} U_j|² / d_T` (§2.4, which
//! is twice `Σ_T ∫_T |∂U/∂x + i ∂U/∂y|² dA`), in model units squared when UVs are in model
//! units. It is recomputed from UVs through per-triangle gradients, independently of the solver.
//!
//! Units: positions `_m`, UVs in model units before packing (not yet normalized to \[0,1\]).
//! Invariant: a system is only assembled from a chart that passed
//! [`super::chart::ChartMesh::validate`], so every `d_T > 0`.
use std::ops::ControlFlow;

use crate::numerics::cg::CgStep;
use crate::numerics::{
    solve_cg, CgOptions, CgOutcome, CsrMatrix, HermitianCholesky, SparseCholesky,
};

use super::chart::{exceeds, ChartMesh, ChartTopology};
use super::ParameterizeError;
use crate::mesh::vector::{cross, dot, norm, sub};

/// Coordinates `(x_k, y_k)` of the triangle's vertices in its local orthonormal basis
/// (lscm-2002 §2.3): origin at the first vertex, x along the first edge, normal along z.
/// The triangle must be non-degenerate (validated charts are).
pub fn local_frame_coordinates(p: [[f64; 3]; 3]) -> [[f64; 2]; 3] {
    let e1 = sub(p[1], p[0]);
    let e2 = sub(p[2], p[0]);
    let l1 = norm(e1);
    let x_axis = [e1[0] / l1, e1[1] / l1, e1[2] / l1];
    let n = cross(e1, e2);
    let ln = norm(n);
    let normal = [n[0] / ln, n[1] / ln, n[2] / ln];
    let y_axis = cross(normal, x_axis);
    [[0.0, 0.0], [l1, 0.0], [dot(e2, x_axis), dot(e2, y_axis)]]
}

/// The complex coefficients `W_1, W_2, W_3` (as `[re, im]`) of lscm-2002 §2.4 and `d_T`, twice
/// the triangle area.
pub fn triangle_coefficients(p: [[f64; 3]; 3]) -> ([[f64; 2]; 3], f64) {
    let [[x1, y1], [x2, y2], [x3, y3]] = local_frame_coordinates(p);
    let d_t = (x1 * y2 - y1 * x2) + (x2 * y3 - y2 * x3) + (x3 * y1 - y3 * x1);
    (
        [[x3 - x2, y3 - y2], [x1 - x3, y1 - y3], [x2 - x1, y2 - y1]],
        d_t,
    )
}

/// A pinned vertex and its prescribed UV.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pin {
    /// Chart vertex index.
    pub vertex: u32,
    /// Prescribed UV (model units).
    pub uv: [f64; 2],
}

/// Marker in [`LscmSystem`]'s vertex → unknown map for pinned vertices.
const PINNED: u32 = u32::MAX;

/// The normal equations `AᵀA·x = Aᵀb` of lscm-2002 §2.5 for one chart and its pins.
#[derive(Debug, Clone)]
pub struct LscmSystem {
    /// Free-vertex number of each chart vertex, `PINNED` for pins.
    free_index: Vec<u32>,
    /// Chart vertex of each free number.
    free_vertices: Vec<u32>,
    pins: Vec<Pin>,
    /// `AᵀA`, `2f × 2f`, symmetric positive definite (appendix A.1–A.2, when ≥ 2 pins).
    matrix: CsrMatrix,
    /// `Aᵀb`.
    rhs: Vec<f64>,
    /// `‖b‖²`, so that `C(x) = xᵀ(AᵀA)x − 2(Aᵀb)ᵀx + ‖b‖²`.
    b_norm2: f64,
}

impl LscmSystem {
    /// Assembles the system for a validated chart. Needs at least two distinct pins with
    /// distinct UVs (appendix A.1: full rank when `p ≥ 2`).
    ///
    /// Cost: `O(F)` time; memory ≈ 14 stored entries per unknown row (12 bytes each).
    pub fn assemble(
        chart: &ChartMesh,
        topology: &ChartTopology,
        pins: &[Pin],
    ) -> Result<Self, ParameterizeError> {
        let n = chart.positions_m.len();
        if !topology_fits(chart, topology) {
            return Err(foreign_topology());
        }
        let (free_index, free_vertices) = free_numbering(n, pins)?;
        let f = free_vertices.len();
        // Sparsity pattern: row pair of free vertex i couples to the unknowns of i and of its
        // free neighbours.
        let mut row_ptr = Vec::with_capacity(2 * f + 1);
        row_ptr.push(0usize);
        let mut col_idx: Vec<u32> = Vec::new();
        let mut block_cols: Vec<u32> = Vec::new();
        for &v in &free_vertices {
            block_cols.clear();
            block_cols.push(free_index[v as usize]);
            for &w in topology.neighbors_of(v) {
                let k = free_index[w as usize];
                if k != PINNED {
                    block_cols.push(k);
                }
            }
            block_cols.sort_unstable();
            for _row in 0..2 {
                for &k in &block_cols {
                    col_idx.push(2 * k);
                    col_idx.push(2 * k + 1);
                }
                row_ptr.push(col_idx.len());
            }
        }
        let mut values = vec![0.0f64; col_idx.len()];
        let mut rhs = vec![0.0f64; 2 * f];
        let mut b_norm2 = 0.0f64;
        let uv_of_pin = |v: u32| -> [f64; 2] {
            pins.iter()
                .rev()
                .find(|p| p.vertex == v)
                .map(|p| p.uv)
                .unwrap_or([0.0, 0.0])
        };
        for t in &chart.triangles {
            let p = t.map(|i| chart.positions_m[i as usize]);
            let (w, d_t) = triangle_coefficients(p);
            let s = 1.0 / d_t.sqrt();
            let m = w.map(|c| [c[0] * s, c[1] * s]);
            for a in 0..3 {
                let ka = free_index[t[a] as usize];
                for b in 0..3 {
                    let kb = free_index[t[b] as usize];
                    // c = conj(m_a)·m_b
                    let re = m[a][0] * m[b][0] + m[a][1] * m[b][1];
                    let im = m[a][0] * m[b][1] - m[a][1] * m[b][0];
                    match (ka != PINNED, kb != PINNED) {
                        (true, true) => {
                            let r0 = 2 * ka as usize;
                            for (dr, (c_u, c_v)) in [(re, -im), (im, re)].into_iter().enumerate() {
                                let row = r0 + dr;
                                let (lo, hi) = (row_ptr[row], row_ptr[row + 1]);
                                let pos =
                                    col_idx[lo..hi].binary_search(&(2 * kb)).map_err(|_| {
                                        ParameterizeError::Internal {
                                            detail: "LSCM sparsity pattern misses a triangle edge"
                                                .to_string(),
                                        }
                                    })?;
                                values[lo + pos] += c_u;
                                values[lo + pos + 1] += c_v;
                            }
                        }
                        (true, false) => {
                            let uv = uv_of_pin(t[b]);
                            let r0 = 2 * ka as usize;
                            rhs[r0] -= re * uv[0] - im * uv[1];
                            rhs[r0 + 1] -= im * uv[0] + re * uv[1];
                        }
                        (false, false) => {
                            let ua = uv_of_pin(t[a]);
                            let ub = uv_of_pin(t[b]);
                            b_norm2 += ua[0] * (re * ub[0] - im * ub[1])
                                + ua[1] * (im * ub[0] + re * ub[1]);
                        }
                        (false, true) => {}
                    }
                }
            }
        }
        let matrix = CsrMatrix::from_csr_parts(2 * f, 2 * f, row_ptr, col_idx, values)
            .map_err(ParameterizeError::Sparse)?;
        Ok(Self {
            free_index,
            free_vertices,
            pins: pins.to_vec(),
            matrix,
            rhs,
            b_norm2,
        })
    }

    /// Free-vertex number of each chart vertex (`u32::MAX` for pinned vertices); free vertex
    /// `k` owns unknowns `2k` (u) and `2k + 1` (v).
    pub fn free_index_map(&self) -> &[u32] {
        &self.free_index
    }

    /// Number of real unknowns, `2(n − p)`.
    pub fn unknowns(&self) -> usize {
        self.rhs.len()
    }

    /// The assembled normal matrix `AᵀA`.
    pub fn matrix(&self) -> &CsrMatrix {
        &self.matrix
    }

    /// The right-hand side `Aᵀb`.
    pub fn rhs(&self) -> &[f64] {
        &self.rhs
    }

    /// `C(x) = ‖A·x − b‖²`, evaluated from the normal equations as
    /// `xᵀ(AᵀA)x − 2(Aᵀb)ᵀx + ‖b‖²`. This is the solver's own energy; it loses absolute
    /// precision ~1e-16·‖b‖² to cancellation, so near-zero energies read as tiny numbers.
    pub fn energy(&self, x: &[f64]) -> Result<f64, ParameterizeError> {
        let ax = self.matrix.mul_vec(x).map_err(ParameterizeError::Sparse)?;
        let xax = crate::numerics::sparse::dot(x, &ax);
        let bx = crate::numerics::sparse::dot(&self.rhs, x);
        Ok(xax - 2.0 * bx + self.b_norm2)
    }

    /// `C(x)` from an iterate and its residual `r = Aᵀb − AᵀA·x` (as CG maintains it):
    /// `C = ‖b‖² − (Aᵀb)ᵀx − rᵀx`. Two dot products, no matrix product; exact when `r` is the
    /// true residual, which CG's recursive residual tracks to rounding.
    pub fn energy_from_residual(&self, x: &[f64], residual: &[f64]) -> f64 {
        self.b_norm2
            - crate::numerics::sparse::dot(&self.rhs, x)
            - crate::numerics::sparse::dot(residual, x)
    }

    /// Solves the normal equations with the sparse Cholesky factorization.
    pub fn solve_direct(&self) -> Result<Vec<f64>, ParameterizeError> {
        let factor = SparseCholesky::factor(&self.matrix).map_err(ParameterizeError::Direct)?;
        factor.solve(&self.rhs).map_err(ParameterizeError::Direct)
    }

    /// Relaxes `x` with Jacobi-preconditioned CG (see [`crate::numerics::cg`] for the stopping
    /// rule). `x` is the warm start.
    pub fn solve_cg(
        &self,
        x: &mut [f64],
        options: &CgOptions,
        monitor: &mut dyn FnMut(&CgStep<'_>) -> ControlFlow<()>,
    ) -> Result<CgOutcome, ParameterizeError> {
        solve_cg(&self.matrix, &self.rhs, x, options, monitor).map_err(ParameterizeError::Sparse)
    }

    /// Per-vertex UVs from a solution vector: free vertices from `x`, pins from their UVs.
    pub fn uv_from_solution(&self, x: &[f64]) -> Vec<[f64; 2]> {
        let mut uv = vec![[0.0; 2]; self.free_index.len()];
        for (k, &v) in self.free_vertices.iter().enumerate() {
            if let (Some(slot), Some(&u), Some(&w)) =
                (uv.get_mut(v as usize), x.get(2 * k), x.get(2 * k + 1))
            {
                *slot = [u, w];
            }
        }
        for pin in &self.pins {
            if let Some(slot) = uv.get_mut(pin.vertex as usize) {
                *slot = pin.uv;
            }
        }
        uv
    }

    /// The solution vector holding the given per-vertex UVs (pins are ignored).
    pub fn solution_from_uv(&self, uv: &[[f64; 2]]) -> Vec<f64> {
        let mut x = vec![0.0; self.rhs.len()];
        for (k, &v) in self.free_vertices.iter().enumerate() {
            if let Some(p) = uv.get(v as usize) {
                x[2 * k] = p[0];
                x[2 * k + 1] = p[1];
            }
        }
        x
    }
}

/// The free-vertex numbering of a chart with `n` vertices and these pins: free number (or
/// `PINNED`) per vertex, ascending with the vertex index, and the vertex of each free number.
/// Checks the pins: in range, finite, at least two distinct vertices with distinct UVs
/// (appendix A.1: full rank when `p ≥ 2`).
fn free_numbering(n: usize, pins: &[Pin]) -> Result<(Vec<u32>, Vec<u32>), ParameterizeError> {
    let mut free_index = vec![0u32; n];
    for pin in pins {
        match free_index.get_mut(pin.vertex as usize) {
            Some(slot) => *slot = PINNED,
            None => {
                return Err(ParameterizeError::BadPins {
                    detail: format!("pin vertex {} is not in the chart", pin.vertex),
                })
            }
        }
        if !pin.uv.iter().all(|c| c.is_finite()) {
            return Err(ParameterizeError::BadPins {
                detail: format!("pin vertex {} has a non-finite UV", pin.vertex),
            });
        }
    }
    let distinct_pins = free_index.iter().filter(|&&f| f == PINNED).count();
    let spread = pins
        .iter()
        .any(|p| pins.iter().any(|q| p.uv != q.uv && p.vertex != q.vertex));
    if distinct_pins < 2 || !spread {
        return Err(ParameterizeError::BadPins {
            detail: "LSCM needs at least two distinct pinned vertices with distinct UVs"
                .to_string(),
        });
    }
    let mut free_vertices = Vec::with_capacity(n);
    for (v, slot) in free_index.iter_mut().enumerate() {
        if *slot != PINNED {
            *slot = free_vertices.len() as u32;
            free_vertices.push(v as u32);
        }
    }
    Ok((free_index, free_vertices))
}

/// The LSCM map of a validated chart by one sparse direct solve of the normal equations in
/// complex form (lscm-2002 §2.5: `C(U) = U*·𝒞·U` with the Hermitian `𝒞 = M*M`): the free
/// unknowns `U_f` solve `𝒞_ff·U_f = −𝒞_fp·U_p`. This is the system [`LscmSystem`] assembles in
/// real form (each complex entry `c` of `𝒞` is its 2×2 block `[[Re c, −Im c], [Im c, Re c]]`),
/// so the map is the same up to rounding, but the factorization orders half the unknowns with
/// a quarter of the entries and stores half the values (see
/// [`crate::numerics::HermitianCholesky`]); only the upper triangle is assembled.
///
/// Any number `p ≥ 2` of pins is allowed (the minimizer is then unique, appendix A.1); with
/// more than two, the map is the least squares conformal extension of the pinned UVs to the
/// free vertices (chart validation pins a chart's shared vertices to a neighbour's map when it
/// tries to merge them). Returns one UV per chart vertex (pins at their UVs). Errors: bad pins,
/// a foreign topology, a failed factorization. Cost: `O(F)` assembly plus the factorization.
pub fn solve_direct_complex(
    chart: &ChartMesh,
    topology: &ChartTopology,
    pins: &[Pin],
) -> Result<Vec<[f64; 2]>, ParameterizeError> {
    let n = chart.positions_m.len();
    if !topology_fits(chart, topology) {
        return Err(foreign_topology());
    }
    let (free_index, free_vertices) = free_numbering(n, pins)?;
    let f = free_vertices.len();
    // Column k (free vertex v): its free neighbours below it, then itself. Neighbours are
    // ascending and the free numbering follows the vertex order, so rows come out ascending.
    let mut col_ptr: Vec<u32> = Vec::with_capacity(f + 1);
    col_ptr.push(0);
    let mut row_idx: Vec<u32> = Vec::with_capacity(f + topology.neighbors.len() / 2 + 1);
    for (k, &v) in free_vertices.iter().enumerate() {
        for &w in topology.neighbors_of(v) {
            if w >= v {
                break;
            }
            let kw = free_index[w as usize];
            if kw != PINNED {
                row_idx.push(kw);
            }
        }
        row_idx.push(k as u32);
        col_ptr.push(row_idx.len() as u32);
    }
    let mut values = vec![[0.0f64; 2]; row_idx.len()];
    let mut rhs = vec![[0.0f64; 2]; f];
    // The UV of each pinned vertex (the last pin wins, as in `LscmSystem::assemble`).
    let mut pin_uv = vec![[0.0f64; 2]; n];
    for pin in pins {
        pin_uv[pin.vertex as usize] = pin.uv;
    }
    let uv_of_pin = |v: u32| pin_uv[v as usize];
    for t in &chart.triangles {
        let p = t.map(|i| chart.positions_m[i as usize]);
        let (w, d_t) = triangle_coefficients(p);
        let s = 1.0 / d_t.sqrt();
        let m = w.map(|c| [c[0] * s, c[1] * s]);
        let k = t.map(|i| free_index[i as usize]);
        for a in 0..3 {
            if k[a] == PINNED {
                continue;
            }
            for b in 0..3 {
                // c = conj(m_a)·m_b, the entry (a, b) of 𝒞.
                let re = m[a][0] * m[b][0] + m[a][1] * m[b][1];
                let im = m[a][0] * m[b][1] - m[a][1] * m[b][0];
                if k[b] == PINNED {
                    let z = uv_of_pin(t[b]);
                    let r = &mut rhs[k[a] as usize];
                    r[0] -= re * z[0] - im * z[1];
                    r[1] -= im * z[0] + re * z[1];
                } else if k[a] <= k[b] {
                    let col = k[b] as usize;
                    let (lo, hi) = (col_ptr[col] as usize, col_ptr[col + 1] as usize);
                    let pos = row_idx[lo..hi]
                        .iter()
                        .position(|&r| r == k[a])
                        .ok_or_else(|| ParameterizeError::Internal {
                            detail: "LSCM sparsity pattern misses a triangle edge".to_string(),
                        })?;
                    values[lo + pos][0] += re;
                    values[lo + pos][1] += im;
                }
            }
        }
    }
    let x = if f == 0 {
        Vec::new()
    } else {
        let factor = HermitianCholesky::factor_upper(f, &col_ptr, &row_idx, &values)
            .map_err(ParameterizeError::Direct)?;
        factor.solve(&rhs).map_err(ParameterizeError::Direct)?
    };
    let mut uv = vec![[0.0; 2]; n];
    for (&v, z) in free_vertices.iter().zip(x) {
        uv[v as usize] = z;
    }
    for pin in pins {
        uv[pin.vertex as usize] = pin.uv;
    }
    Ok(uv)
}

/// The topology is a public struct: check it belongs to this chart before indexing.
fn topology_fits(chart: &ChartMesh, topology: &ChartTopology) -> bool {
    let n = chart.positions_m.len();
    topology.neighbor_ptr.len() == n + 1
        && topology.neighbor_ptr.last() == Some(&topology.neighbors.len())
        && topology.neighbor_ptr.windows(2).all(|w| w[0] <= w[1])
        && topology.neighbors.iter().all(|&w| (w as usize) < n)
        && chart
            .triangles
            .iter()
            .all(|t| t.iter().all(|&i| (i as usize) < n))
}

fn foreign_topology() -> ParameterizeError {
    ParameterizeError::Internal {
        detail: "topology does not belong to this chart; use ChartMesh::validate".to_string(),
    }
}

/// The two pins of lscm-2002 §2.6 for a validated chart: the farthest boundary pair (graph
/// diameter), the first at UV (0,0), the second at (L,0) with `L` their path length.
pub fn diameter_pins(chart: &ChartMesh, topology: &ChartTopology) -> [Pin; 2] {
    let (a, b, length_m) = topology.farthest_boundary_pair(&chart.positions_m);
    [
        Pin {
            vertex: a,
            uv: [0.0, 0.0],
        },
        Pin {
            vertex: b,
            uv: [length_m, 0.0],
        },
    ]
}

/// The conformal energy `C(U)` of lscm-2002 §2.4 (with the paper's factor 2), recomputed from
/// the UVs through the per-triangle gradient `∂U/∂x + i ∂U/∂y` in the local frame:
/// `C = Σ_T 2·A_T·|∂U/∂x + i ∂U/∂y|²`. Independent of any solver state.
///
/// Triangles whose index is out of range are skipped (callers pass validated charts).
pub fn conformal_energy(chart: &ChartMesh, uv: &[[f64; 2]]) -> f64 {
    let mut total = 0.0;
    for t in &chart.triangles {
        let (Some(p), Some(q)) = (fetch3(&chart.positions_m, t), fetch3(uv, t)) else {
            continue;
        };
        let [[x1, y1], [x2, y2], [x3, y3]] = local_frame_coordinates(p);
        let d_t = (x2 - x1) * (y3 - y1) - (x3 - x1) * (y2 - y1);
        // Gradient of a linear function with values s_k at the corners (§2.4, first equation).
        let grad = |s: [f64; 3]| {
            [
                ((y2 - y3) * s[0] + (y3 - y1) * s[1] + (y1 - y2) * s[2]) / d_t,
                ((x3 - x2) * s[0] + (x1 - x3) * s[1] + (x2 - x1) * s[2]) / d_t,
            ]
        };
        let gu = grad([q[0][0], q[1][0], q[2][0]]);
        let gv = grad([q[0][1], q[1][1], q[2][1]]);
        // ∂U/∂x + i ∂U/∂y = (u_x − v_y) + i (v_x + u_y)
        let re = gu[0] - gv[1];
        let im = gv[0] + gu[1];
        total += d_t * (re * re + im * im);
    }
    total
}

/// Faces whose UV image has non-positive signed area (flipped or collapsed), in face order.
pub fn flipped_faces(chart: &ChartMesh, uv: &[[f64; 2]]) -> Vec<u32> {
    chart
        .triangles
        .iter()
        .enumerate()
        .filter_map(|(f, t)| {
            let q = fetch3(uv, t)?;
            let area2 = (q[1][0] - q[0][0]) * (q[2][1] - q[0][1])
                - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]);
            (!exceeds(area2, 0.0)).then_some(f as u32)
        })
        .collect()
}

fn fetch3<T: Copy>(values: &[T], t: &[u32; 3]) -> Option<[T; 3]> {
    Some([
        *values.get(t[0] as usize)?,
        *values.get(t[1] as usize)?,
        *values.get(t[2] as usize)?,
    ])
}

#[cfg(test)]
mod tests {
    use super::super::test_meshes::{
        cotan_conformal_energy as cotan_energy, grid, hemisphere, noisy_height_field, open_cylinder,
    };
    use super::*;

    fn solve(chart: &ChartMesh) -> (LscmSystem, Vec<[f64; 2]>, f64) {
        let topo = chart.validate().expect("disk");
        let pins = diameter_pins(chart, &topo);
        let sys = LscmSystem::assemble(chart, &topo, &pins).expect("assemble");
        let x = sys.solve_direct().expect("solve");
        let e = sys.energy(&x).expect("energy");
        (sys.clone(), sys.uv_from_solution(&x), e)
    }

    #[test]
    fn planar_patch_is_reproduced_up_to_a_similarity() {
        // A planar patch, rotated and tilted in 3-D, with a non-uniform grid spacing.
        let chart = grid(7, 5, |x, y| {
            let (x, y) = (x + 0.1 * (y * 1.3).sin(), y * 0.8 + 0.05 * x * x);
            let (c, s) = (0.6f64, 0.8f64);
            [c * x, s * x + 0.3 * y, 0.9 * y]
        });
        let (_, uv, e) = solve(&chart);
        // Distances are preserved up to one global scale: compare all edge length ratios.
        let mut ratio = None;
        for t in &chart.triangles {
            for k in 0..3 {
                let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                let l3 = norm(sub(chart.positions_m[a], chart.positions_m[b]));
                let l2 = ((uv[a][0] - uv[b][0]).powi(2) + (uv[a][1] - uv[b][1]).powi(2)).sqrt();
                let r = l2 / l3;
                let r0 = *ratio.get_or_insert(r);
                assert!((r - r0).abs() < 1e-9 * r0, "ratio {r} vs {r0}");
            }
        }
        let scale2: f64 = uv.iter().map(|p| p[0] * p[0] + p[1] * p[1]).sum();
        assert!(e.abs() < 1e-12 * scale2, "energy {e}");
        assert!(conformal_energy(&chart, &uv) < 1e-12 * scale2);
        assert!(flipped_faces(&chart, &uv).is_empty());
    }

    #[test]
    fn reported_energy_equals_independent_recomputations() {
        for chart in [
            hemisphere(16, 6),
            noisy_height_field(12, 0.5, 7),
            // A saddle z = xy (negative curvature everywhere).
            grid(9, 7, |x, y| [x, y, 0.15 * (x - 4.5) * (y - 3.5)]),
        ] {
            let (_, uv, e) = solve(&chart);
            let c_grad = conformal_energy(&chart, &uv);
            let c_cot = cotan_energy(&chart, &uv);
            assert!(
                e > 1e-6,
                "non-developable surfaces have positive energy, got {e}"
            );
            assert!((e - c_grad).abs() <= 1e-9 * e, "{e} vs {c_grad}");
            assert!((e - c_cot).abs() <= 1e-9 * e, "{e} vs {c_cot}");
        }
    }

    #[test]
    fn cut_cylinder_is_developable_so_its_energy_vanishes() {
        let chart = open_cylinder(12, 4, true);
        let (_, uv, e) = solve(&chart);
        let scale2: f64 = uv.iter().map(|p| p[0] * p[0] + p[1] * p[1]).sum();
        assert!(e.abs() < 1e-10 * scale2 && conformal_energy(&chart, &uv) < 1e-10 * scale2);
        assert!(flipped_faces(&chart, &uv).is_empty());
    }

    #[test]
    fn solution_is_a_minimum_and_has_no_flips() {
        let chart = noisy_height_field(10, 0.8, 3);
        let (sys, uv, e) = solve(&chart);
        let x = sys.solution_from_uv(&uv);
        // Any perturbation of the free unknowns increases the energy.
        for k in [0usize, 5, 17, x.len() - 1] {
            let mut y = x.clone();
            y[k] += 1e-3;
            assert!(sys.energy(&y).expect("energy") > e);
        }
        for chart in [
            grid(9, 4, |x, y| [x, y, 0.0]),
            hemisphere(20, 8),
            open_cylinder(16, 5, true),
            noisy_height_field(15, 1.0, 11),
        ] {
            let (_, uv, _) = solve(&chart);
            assert!(uv.iter().all(|p| p[0].is_finite() && p[1].is_finite()));
            assert!(flipped_faces(&chart, &uv).is_empty());
        }
    }

    #[test]
    fn resolution_independence_appendix_a4() {
        // Split one interior triangle 1-to-3; the old vertices keep their UVs and the new one
        // sits at the barycentric combination (lscm-2002 appendix A.4).
        let coarse = noisy_height_field(6, 0.6, 5);
        let (_, uv0, _) = solve(&coarse);
        let topo = coarse.validate().expect("disk");
        let pins = diameter_pins(&coarse, &topo);
        let mut fine = coarse.clone();
        let target = 25usize; // an interior triangle of the 6x6 grid
        let t = fine.triangles[target];
        let alpha = [0.2, 0.5, 0.3];
        let p = t.map(|i| fine.positions_m[i as usize]);
        let new_p = [0, 1, 2].map(|c| alpha[0] * p[0][c] + alpha[1] * p[1][c] + alpha[2] * p[2][c]);
        let v = fine.positions_m.len() as u32;
        fine.positions_m.push(new_p);
        fine.triangles[target] = [t[0], t[1], v];
        fine.triangles.push([t[1], t[2], v]);
        fine.triangles.push([t[2], t[0], v]);
        let ftopo = fine.validate().expect("disk");
        let sys = LscmSystem::assemble(&fine, &ftopo, &pins).expect("assemble");
        let uv1 = sys.uv_from_solution(&sys.solve_direct().expect("solve"));
        let scale = uv0
            .iter()
            .map(|p| p[0].abs().max(p[1].abs()))
            .fold(0.0, f64::max);
        for (a, b) in uv0.iter().zip(&uv1) {
            assert!((a[0] - b[0]).abs() <= 1e-9 * scale && (a[1] - b[1]).abs() <= 1e-9 * scale);
        }
        let q = t.map(|i| uv0[i as usize]);
        for c in 0..2 {
            let expect = alpha[0] * q[0][c] + alpha[1] * q[1][c] + alpha[2] * q[2][c];
            assert!((uv1[v as usize][c] - expect).abs() <= 1e-9 * scale);
        }
    }

    #[test]
    fn cg_and_direct_agree_on_small_charts() {
        let chart = hemisphere(12, 5);
        let (sys, uv, e) = solve(&chart);
        let mut x = vec![0.0; sys.unknowns()];
        let opts = CgOptions {
            tolerance: 1e-12,
            max_iterations: 20_000,
        };
        let out = sys
            .solve_cg(&mut x, &opts, &mut |_| ControlFlow::Continue(()))
            .expect("cg");
        assert!(out.converged);
        let e_cg = sys.energy(&x).expect("energy");
        let r: Vec<f64> = {
            let ax = sys.matrix().mul_vec(&x).expect("shape");
            sys.rhs().iter().zip(&ax).map(|(b, a)| b - a).collect()
        };
        assert!((sys.energy_from_residual(&x, &r) - e_cg).abs() <= 1e-9 * e_cg);
        assert!((e_cg - e).abs() <= 1e-9 * e);
        let uv_cg = sys.uv_from_solution(&x);
        for (a, b) in uv.iter().zip(&uv_cg) {
            assert!((a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6);
        }
    }

    #[test]
    fn complex_direct_solve_equals_the_real_normal_equations() {
        for chart in [
            hemisphere(16, 6),
            noisy_height_field(14, 0.7, 9),
            open_cylinder(16, 5, true),
            grid(9, 7, |x, y| [x, y, 0.15 * (x - 4.5) * (y - 3.5)]),
        ] {
            let topo = chart.validate().expect("disk");
            let pins = diameter_pins(&chart, &topo);
            let sys = LscmSystem::assemble(&chart, &topo, &pins).expect("assemble");
            let uv_real = sys.uv_from_solution(&sys.solve_direct().expect("solve"));
            let uv = solve_direct_complex(&chart, &topo, &pins).expect("solve");
            let scale = uv_real
                .iter()
                .map(|p| p[0].abs().max(p[1].abs()))
                .fold(0.0, f64::max);
            assert!(scale > 0.0);
            for (a, b) in uv.iter().zip(&uv_real) {
                assert!(
                    (a[0] - b[0]).abs() <= 1e-10 * scale && (a[1] - b[1]).abs() <= 1e-10 * scale,
                    "{a:?} vs {b:?}"
                );
            }
            for pin in &pins {
                assert_eq!(uv[pin.vertex as usize], pin.uv);
            }
            // Same minimum (energies recomputed from the UVs; a developable chart has ~0).
            let (e, e_real) = (
                conformal_energy(&chart, &uv),
                conformal_energy(&chart, &uv_real),
            );
            assert!(
                (e - e_real).abs() <= 1e-9 * e_real + 1e-12 * scale * scale,
                "{e} vs {e_real}"
            );
        }
        // Errors, not panics.
        let small = grid(2, 2, |x, y| [x, y, 0.0]);
        let big = grid(4, 4, |x, y| [x, y, 0.0]);
        let topo = small.validate().expect("disk");
        let pins = diameter_pins(&small, &topo);
        assert!(matches!(
            solve_direct_complex(&big, &topo, &pins),
            Err(ParameterizeError::Internal { .. })
        ));
        assert!(matches!(
            solve_direct_complex(&small, &topo, &pins[..1]),
            Err(ParameterizeError::BadPins { .. })
        ));
    }

    #[test]
    fn foreign_topology_is_an_error_not_a_panic() {
        let small = grid(2, 2, |x, y| [x, y, 0.0]);
        let big = grid(4, 4, |x, y| [x, y, 0.0]);
        let topo = small.validate().expect("disk");
        let pins = [
            Pin {
                vertex: 0,
                uv: [0.0, 0.0],
            },
            Pin {
                vertex: 1,
                uv: [1.0, 0.0],
            },
        ];
        assert!(matches!(
            LscmSystem::assemble(&big, &topo, &pins),
            Err(ParameterizeError::Internal { .. })
        ));
    }

    #[test]
    fn bad_pins_are_typed_errors() {
        let chart = grid(2, 2, |x, y| [x, y, 0.0]);
        let topo = chart.validate().expect("disk");
        let one = [Pin {
            vertex: 0,
            uv: [0.0, 0.0],
        }];
        assert!(matches!(
            LscmSystem::assemble(&chart, &topo, &one),
            Err(ParameterizeError::BadPins { .. })
        ));
        let same = [
            Pin {
                vertex: 0,
                uv: [0.0, 0.0],
            },
            Pin {
                vertex: 1,
                uv: [0.0, 0.0],
            },
        ];
        assert!(LscmSystem::assemble(&chart, &topo, &same).is_err());
        let outside = [
            Pin {
                vertex: 0,
                uv: [0.0, 0.0],
            },
            Pin {
                vertex: 99,
                uv: [1.0, 0.0],
            },
        ];
        assert!(LscmSystem::assemble(&chart, &topo, &outside).is_err());
    }
}
