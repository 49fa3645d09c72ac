//! Hierarchical LSCM: cascadic multigrid over a progressive mesh (Ray & Lévy 2003,
//! hlscm-2003 §3.3 and §4.1).
//!
//! Why (§3.2): "the system is able to efficiently solve high frequencies, but convergence is
//! slower for low frequencies". The cure (§3.3): "The simplest multigrid algorithm (m1 = 0 and
//! mc = 1) is called cascadic multigrid … The idea is to solve the coarser problem and to use it
//! as initial solution to solve higher frequencies. Each frequency is just visited once." It
//! works for LSCM because the conformal energy "does not depend on the mesh resolution"
//! (lscm-2002 appendix A.4), provided "the geometry does not vary too much between two
//! consecutive levels", which the geometry-aware decimation of [`super::progressive_mesh`]
//! ensures.
//!
//! The stages, in the paper's words (§4.1) and here:
//! 1. "the coarsest mesh is parameterized": direct sparse Cholesky on the coarsest level.
//! 2. "the result is propagated to a finer one … during the vsplit operations … its textures
//!    coordinates are estimated using a barycentric interpolation in the nearest triangle":
//!    [`super::progressive_mesh::ProgressiveMesh::split_to`].
//! 3. "LSCM is launched each time there are 10 times as many vertices as in the previous level":
//!    levels hold `n, n/r, n/r², …` vertices with `r = level_ratio` (default 10) down to
//!    `coarsest_max_vertices`.
//! 4. "The number of iterations needed at each level depends of the quality of the coarse
//!    approximation": intermediate levels get `relax_iterations` CG iterations; the finest level
//!    runs CG until its stopping rule (below).
//!
//! Where we depart from the paper, and why: relaxing with plain Jacobi-CG, as the paper does,
//! does not reach a 1e-4 relative energy of the direct solve in a useful number of iterations. A
//! disk always has an exactly conformal continuous map (Riemann), so the discrete LSCM energy of
//! a smooth chart is pure discretization error and shrinks like h²: a tight relative target on
//! that small number asks for an accurate solve of the low frequencies, exactly what Jacobi-CG
//! does slowly. So each level's CG is preconditioned with the hierarchy itself: the additive
//! multilevel (BPX-style) preconditioner `M_l⁻¹ = D_l⁻¹ + P_l·M_{l−1}⁻¹·P_lᵀ`, where `D_l` is
//! the diagonal, `P_l` the vertex-split interpolation of the progressive mesh (the same
//! barycentric rule the cascade uses, as a sparse matrix truncated to 6 terms per row), and
//! `M_0⁻¹` the coarsest level's Cholesky factor. It is symmetric positive definite, so CG stays
//! valid, and it only changes how fast CG converges, never the minimizer.
//! [`HlscmSmoother::Jacobi`] keeps the paper's plain relaxation for comparison.
//!
//! Stopping rule of the finest level: relative residual `≤ final_tolerance` (1e-9), or the
//! conformal energy decreased by at most `final_energy_tolerance·C` (1e-5) over the last
//! `energy_window` (5) iterations, or `final_max_iterations` (500). Trade-off: a looser energy
//! tolerance saves a few iterations for a visibly larger energy; a third level needs more finest
//! iterations than it saves.
//!
//! The pins (lscm-2002 §2.6) are chosen on the full chart and locked in the progressive mesh,
//! so every level solves the same pinned problem. Units as in [`super`]: UVs in model units.
//! Determinism: progressive mesh identical at any thread count (see its module doc),
//! deterministic CG reductions, sequential faer.
//!
//! Memory traffic of the solve: the multilevel CG multiplies by the normal matrix stored in
//! complex 2×2 blocks (`ComplexBlockMatrix`: one column index and `(Re, Im)` per vertex pair,
//! lscm-2002's `conj(m_i)·m_j`, instead of four indices and four values in the scalar CSR) and
//! by the interpolation as a vertex matrix `P` applied to both UV components
//! (`VertexInterpolation`, half the entries of `P ⊗ I₂`). Both add the same products in the
//! same order as the scalar CSR, so the results are the same bits (unit test). Setup overlaps
//! the decimation with the finest level's assembly, and the coarsest factorization with the
//! interpolation matrices (`rayon::join`; each result computed exactly as alone).
//!
//! The coarsest level ("the coarsest mesh is parameterized", §4.1) is factored in complex
//! Hermitian form ([`HermitianCholesky`], as the direct method of [`super::lscm`]): its 2×2
//! blocks are complex numbers, so the factor has half the unknowns and half the values of the
//! real one. It serves the coarsest solve and the `M_0⁻¹` of every preconditioner application.
//!
//! Level ratio (`level_ratio`, default 10, the paper's): a smaller ratio needs fewer finest
//! iterations but a larger coarsest factor, and was no faster.
use std::ops::ControlFlow;

use crate::atlas::progress::StageProgress;

use rayon::prelude::*;

use crate::numerics::{
    solve_pcg, CgOptions, CholeskyError, CsrMatrix, HermitianCholesky, Jacobi, LinearOperator,
    Preconditioner, SparseError,
};

use super::chart::{ChartMesh, ChartTopology};
use super::lscm::{LscmSystem, Pin};
use super::progressive_mesh::{
    build_progressive_mesh, LevelMesh, ProgressiveMesh, ProgressiveMeshOptions,
};
use super::ParameterizeError;

/// HLSCM tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HlscmOptions {
    /// Vertex-count ratio between consecutive levels. Default 10 (hlscm-2003 §4.1).
    pub level_ratio: f64,
    /// The coarsest level has at most this many vertices (fewer if the ratio lands below) and is
    /// solved directly. Default 60_000.
    pub coarsest_max_vertices: usize,
    /// CG iterations on each intermediate level. Default 5.
    pub relax_iterations: usize,
    /// Finest-level stopping rule, part 1: relative residual `‖Aᵀb − AᵀA·x‖/‖Aᵀb‖`.
    /// Default 1e-9.
    pub final_tolerance: f64,
    /// Finest-level stopping rule, part 2 (whichever comes first): stop when the conformal
    /// energy decreased by at most `final_energy_tolerance · C(x)` over the last
    /// `energy_window` iterations. CG decreases `C` monotonically, so this detects that the
    /// remaining error no longer moves the energy. Default 1e-5.
    pub final_energy_tolerance: f64,
    /// Window (iterations) of the energy rule. Default 5.
    pub energy_window: usize,
    /// Finest-level iteration cap. Default 500.
    pub final_max_iterations: usize,
    /// Largest angular defect of a removable vertex, radians. Default 70° (hlscm-2003 §4).
    pub max_angular_defect_rad: f64,
    /// Relaxation preconditioner. Default [`HlscmSmoother::Multilevel`].
    pub smoother: HlscmSmoother,
}

/// How CG is preconditioned when relaxing a level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HlscmSmoother {
    /// Plain Jacobi-CG, the paper's relaxation (§4.1). Measured too slow to reach 1e-4 relative
    /// energy on near-developable height fields (see the module doc).
    Jacobi,
    /// CG preconditioned by the additive multilevel (BPX-style) preconditioner built from the
    /// same hierarchy: `M⁻¹ = D_l⁻¹ + P_l·M_{l−1}⁻¹·P_lᵀ`, with the coarsest level's Cholesky
    /// factor as `M_0⁻¹` and the vertex-split interpolation as `P_l`.
    Multilevel,
}

impl Default for HlscmOptions {
    fn default() -> Self {
        Self {
            level_ratio: 10.0,
            coarsest_max_vertices: 60_000,
            relax_iterations: 5,
            final_tolerance: 1e-9,
            final_energy_tolerance: 1e-5,
            energy_window: 5,
            final_max_iterations: 500,
            max_angular_defect_rad: 70f64.to_radians(),
            smoother: HlscmSmoother::Multilevel,
        }
    }
}

/// What happened on one level, coarsest first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HlscmLevel {
    /// Vertices of the level.
    pub vertices: usize,
    /// CG iterations run (0 on the directly solved coarsest level).
    pub iterations: usize,
    /// Relative residual after the level's solve.
    pub relative_residual: f64,
}

/// Summary of an HLSCM solve.
#[derive(Debug, Clone, PartialEq)]
pub struct HlscmReport {
    /// Levels, coarsest first; the last one is the full chart.
    pub levels: Vec<HlscmLevel>,
    /// Collapses in the progressive mesh.
    pub collapses: usize,
    /// CG iterations on the finest level.
    pub finest_iterations: usize,
    /// Whether the finest level met its stopping rule (residual or energy) before the cap.
    pub converged: bool,
}

/// One level of the hierarchy.
#[derive(Debug)]
struct Level {
    /// Collapses applied to reach this level.
    applied: usize,
    mesh: LevelMesh,
    system: LscmSystem,
    jacobi: Jacobi,
    /// The level's normal matrix in complex 2×2 blocks (the multilevel CG's mat-vec).
    blocks: ComplexBlockMatrix,
    /// Interpolation of free vertices from the next coarser level and its transpose (None on
    /// the coarsest).
    prolongation: Option<(VertexInterpolation, VertexInterpolation)>,
}

/// The progressive mesh, its levels, their LSCM systems and the coarsest factorization: all
/// the setup of HLSCM ("PM construction" in hlscm-2003 Table 1), reusable across solves.
#[derive(Debug)]
pub struct HlscmHierarchy {
    pm: ProgressiveMesh,
    /// Coarsest first.
    levels: Vec<Level>,
    /// The coarsest normal matrix factored in complex Hermitian form (half the unknowns and
    /// half the values of the real factor, see [`HermitianCholesky`]).
    coarsest_factor: HermitianCholesky,
}

/// Builds the hierarchy for a validated chart and its pins (the pins are locked in the
/// progressive mesh so every level has them).
pub fn build_hierarchy(
    chart: &ChartMesh,
    topology: &ChartTopology,
    pins: &[Pin],
    options: &HlscmOptions,
) -> Result<HlscmHierarchy, ParameterizeError> {
    let n = chart.positions_m.len();
    let ratio = if options.level_ratio > 1.0 {
        options.level_ratio
    } else {
        10.0
    };
    // Vertex targets n, n/r, n/r², … down to the coarsest size.
    let coarsest = options.coarsest_max_vertices.max(3);
    let mut targets = vec![n];
    while let Some(&last) = targets.last() {
        if last <= coarsest {
            break;
        }
        targets.push(((last as f64 / ratio).ceil() as usize).max(3));
    }
    let locked: Vec<u32> = pins.iter().map(|p| p.vertex).collect();
    // The decimation (mostly sequential) and the finest level's assembly (it is the chart
    // itself, no collapse applied) are independent: run them side by side. Each result is
    // computed exactly as it would be alone, so the bits do not depend on the thread count.
    let (pm, finest) = rayon::join(
        || {
            if targets.len() > 1 {
                let pm_options = ProgressiveMeshOptions {
                    max_angular_defect_rad: options.max_angular_defect_rad,
                    min_vertices: targets.last().copied().unwrap_or(n),
                };
                build_progressive_mesh(chart, &locked, &pm_options)
            } else {
                Ok(ProgressiveMesh {
                    vertex_count: n,
                    collapses: Vec::new(),
                })
            }
        },
        || -> Result<(LevelMesh, LscmSystem, Jacobi, ComplexBlockMatrix), ParameterizeError> {
            // `ProgressiveMesh::level(chart, 0)`: every vertex and triangle, in chart order.
            let mesh = LevelMesh {
                chart: chart.clone(),
                chart_vertex: (0..n as u32).collect(),
                level_vertex: (0..n as u32).collect(),
            };
            let system = LscmSystem::assemble(&mesh.chart, topology, &map_pins(pins, &mesh))?;
            let jacobi = Jacobi::new(system.matrix());
            // The block form too: the finest level's is the largest, and here it is off the
            // decimation's critical path.
            let blocks = ComplexBlockMatrix::from_normal_matrix(system.matrix())?;
            Ok((mesh, system, jacobi, blocks))
        },
    );
    let pm = pm?;
    let mut finest = Some(finest?);
    // Collapses applied at each level, coarsest first, deduplicated (decimation may stall).
    let mut applied: Vec<usize> = targets
        .iter()
        .map(|&t| (n - t.min(n)).min(pm.collapses.len()))
        .collect();
    applied.dedup();
    applied.reverse();
    let mut levels: Vec<Level> = Vec::with_capacity(applied.len());
    for &m in &applied {
        let (mesh, system, jacobi, blocks) = match (m, finest.take()) {
            (0, Some(finest)) => finest,
            (_, keep) => {
                finest = keep;
                let mesh = pm.level(chart, m)?;
                let level_topology =
                    mesh.chart
                        .validate()
                        .map_err(|e| ParameterizeError::Internal {
                            detail: format!(
                                "progressive mesh level with {m} collapses is not a disk: {e}"
                            ),
                        })?;
                let system =
                    LscmSystem::assemble(&mesh.chart, &level_topology, &map_pins(pins, &mesh))?;
                let jacobi = Jacobi::new(system.matrix());
                let blocks = ComplexBlockMatrix::from_normal_matrix(system.matrix())?;
                (mesh, system, jacobi, blocks)
            }
        };
        levels.push(Level {
            applied: m,
            jacobi,
            blocks,
            mesh,
            system,
            prolongation: None,
        });
    }
    if levels.is_empty() {
        return Err(ParameterizeError::Internal {
            detail: "HLSCM hierarchy has no level".to_string(),
        });
    }
    // The coarsest factorization and the interpolation matrices read the levels only:
    // independent, so computed side by side (each exactly as it would be alone).
    let (coarsest_factor, prolongations) = rayon::join(
        || {
            levels[0]
                .blocks
                .factor_hermitian()
                .map_err(ParameterizeError::Direct)
        },
        || {
            (1..levels.len())
                .map(|i| {
                    let p = prolongation_matrix(
                        &pm,
                        &levels[i - 1],
                        &levels[i].mesh,
                        &levels[i].system,
                        levels[i].applied,
                    )?;
                    let pt = p.transpose();
                    Ok((p, pt))
                })
                .collect::<Result<Vec<_>, ParameterizeError>>()
        },
    );
    let coarsest_factor = coarsest_factor?;
    for (level, p) in levels.iter_mut().skip(1).zip(prolongations?) {
        level.prolongation = Some(p);
    }
    Ok(HlscmHierarchy {
        pm,
        levels,
        coarsest_factor,
    })
}

fn map_pins(pins: &[Pin], mesh: &LevelMesh) -> Vec<Pin> {
    pins.iter()
        .map(|p| Pin {
            vertex: mesh
                .level_vertex
                .get(p.vertex as usize)
                .copied()
                .unwrap_or(u32::MAX),
            uv: p.uv,
        })
        .collect()
}

/// Most coarse vertices one fine vertex interpolates from in the multilevel preconditioner.
const MAX_INTERPOLATION_TERMS: usize = 6;

/// How many rows ahead [`prolongation_matrix`] starts loading the data a row will read.
const WARM_AHEAD: usize = 8;

/// The vertex-split interpolation as a matrix from the coarse level's free unknowns to the
/// fine level's free unknowns: a coarse vertex keeps its value; a re-inserted vertex gets the
/// barycentric combination of its recorded triangle, expanded recursively down to coarse
/// vertices. Pinned coarse vertices carry no correction, so their columns are dropped.
fn prolongation_matrix(
    pm: &ProgressiveMesh,
    coarse: &Level,
    fine_mesh: &LevelMesh,
    fine_system: &LscmSystem,
    fine_applied: usize,
) -> Result<VertexInterpolation, ParameterizeError> {
    let n = pm.vertex_count;
    let hi = coarse.applied.min(pm.collapses.len());
    let lo = fine_applied.min(hi);
    // Expansion of each chart vertex in coarse vertices, as `(coarse level vertex, weight)`:
    // `arena[span[v].0..span[v].1]` (empty when not expanded yet). Coarse level vertices are
    // numbered in increasing chart vertex order, so rows sort and merge exactly as they would
    // by chart vertex (same sums in the same order), and the final mapping to free unknowns
    // reads a coarse-sized table only. One flat arena instead of a `Vec` per vertex: every
    // row is written once (a vertex is removed once), and half a million small allocations
    // were a measurable part of the hierarchy's setup.
    let mut span: Vec<(usize, usize)> = vec![(0, 0); n];
    let mut arena: Vec<(u32, f64)> =
        Vec::with_capacity(coarse.mesh.chart_vertex.len() + MAX_INTERPOLATION_TERMS * (hi - lo));
    for (lv, &v) in coarse.mesh.chart_vertex.iter().enumerate() {
        span[v as usize] = (arena.len(), arena.len() + 1);
        arena.push((lv as u32, 1.0));
    }
    let mut merged: Vec<(u32, f64)> = Vec::new();
    let mut row: Vec<(u32, f64)> = Vec::new();
    let collapses = &pm.collapses[lo..hi];
    let mut warm = 0u64;
    for (i, c) in collapses.iter().enumerate().rev() {
        // Start loading the rows a few collapses ahead need (a read; changes nothing).
        if let Some(ahead) = i.checked_sub(WARM_AHEAD).map(|j| &collapses[j]) {
            for &t in &ahead.triangle {
                if let Some(&(start, _)) = span.get(t as usize) {
                    warm ^= arena.get(start).map_or(0, |e| e.1.to_bits());
                }
            }
        }
        merged.clear();
        for k in 0..3 {
            let w = c.barycentric[k];
            if w == 0.0 {
                continue;
            }
            if let Some(&(start, end)) = span.get(c.triangle[k] as usize) {
                merged.extend(arena[start..end].iter().map(|&(v, a)| (v, a * w)));
            }
        }
        merged.sort_by_key(|e| e.0);
        row.clear();
        for &(v, a) in &merged {
            match row.last_mut() {
                Some(last) if last.0 == v => last.1 += a,
                _ => row.push((v, a)),
            }
        }
        // Recursive expansion grows along split chains; keep the MAX_INTERPOLATION_TERMS
        // largest weights and renormalize to sum 1 (so constants are still interpolated
        // exactly). This only changes the preconditioner, never the solution it converges to.
        if row.len() > MAX_INTERPOLATION_TERMS {
            row.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            row.truncate(MAX_INTERPOLATION_TERMS);
            let total: f64 = row.iter().map(|e| e.1).sum();
            if total > 0.0 {
                row.iter_mut().for_each(|e| e.1 /= total);
            }
            row.sort_by_key(|e| e.0);
        }
        if let Some(slot) = span.get_mut(c.removed as usize) {
            *slot = (arena.len(), arena.len() + row.len());
            arena.extend_from_slice(&row);
        }
    }
    std::hint::black_box(warm);
    let coarse_free = coarse.system.free_index_map();
    let fine_free = fine_system.free_index_map();
    // Rows of the free fine vertices, in increasing free index = increasing level vertex =
    // increasing chart id; fixed chunks in parallel (each row is computed alone, so the bits
    // do not depend on the thread count), concatenated in order.
    let chunks: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> = fine_mesh
        .chart_vertex
        .par_chunks(VERTICES_PER_TASK)
        .enumerate()
        .map(|(chunk, chart_vs)| {
            let mut lens = Vec::with_capacity(chart_vs.len());
            let mut col: Vec<u32> = Vec::with_capacity(MAX_INTERPOLATION_TERMS * chart_vs.len());
            let mut weight: Vec<f64> = Vec::with_capacity(col.capacity());
            let mut entries: Vec<(u32, f64)> = Vec::new();
            let mut warm = 0u64;
            for (k, &chart_v) in chart_vs.iter().enumerate() {
                if let Some(&ahead) = chart_vs.get(k + WARM_AHEAD) {
                    let (start, _) = span[ahead as usize];
                    warm ^= arena.get(start).map_or(0, |e| e.1.to_bits());
                }
                let level_v = chunk * VERTICES_PER_TASK + k;
                if fine_free.get(level_v).copied().unwrap_or(u32::MAX) == u32::MAX {
                    continue;
                }
                entries.clear();
                let (start, end) = span[chart_v as usize];
                for &(lv, a) in &arena[start..end] {
                    let k = coarse_free.get(lv as usize).copied().unwrap_or(u32::MAX);
                    if k != u32::MAX {
                        entries.push((k, a));
                    }
                }
                entries.sort_by_key(|e| e.0);
                for &(k, a) in &entries {
                    col.push(k);
                    weight.push(a);
                }
                lens.push(entries.len());
            }
            std::hint::black_box(warm);
            (lens, col, weight)
        })
        .collect();
    let rows: usize = chunks.iter().map(|c| c.0.len()).sum();
    let entries: usize = chunks.iter().map(|c| c.1.len()).sum();
    let mut row_ptr = Vec::with_capacity(rows + 1);
    row_ptr.push(0usize);
    let mut col: Vec<u32> = Vec::with_capacity(entries);
    let mut weight: Vec<f64> = Vec::with_capacity(entries);
    for (lens, c, w) in chunks {
        for len in lens {
            let last = row_ptr.last().copied().unwrap_or(0);
            row_ptr.push(last + len);
        }
        col.extend_from_slice(&c);
        weight.extend_from_slice(&w);
    }
    if row_ptr.len() != fine_system.unknowns() / 2 + 1 {
        return Err(internal(
            "interpolation rows do not match the fine free vertices",
        ));
    }
    Ok(VertexInterpolation {
        cols: coarse.system.unknowns() / 2,
        row_ptr,
        col,
        weight,
    })
}

fn internal(detail: &str) -> ParameterizeError {
    ParameterizeError::Internal {
        detail: detail.to_string(),
    }
}

/// Free vertices per parallel task of the block mat-vecs (fixed, so the work split and
/// therefore nothing about the result depends on the thread count; each row is one task's).
const VERTICES_PER_TASK: usize = 2048;

/// The LSCM normal matrix `AᵀA` stored per pair of free vertices as the complex number
/// `c = Σ_T conj(m_i)·m_j` (see [`super::lscm`]: the real 2×2 block is `[[Re, −Im], [Im, Re]]`).
/// One column index and two values per block instead of four of each in the scalar CSR: the
/// finest-level mat-vec, the largest memory stream of the solve, reads 2.4× fewer bytes.
///
/// Same bits as [`CsrMatrix::mul_vec_into`] on the scalar matrix: each output row adds the
/// same products in the same (increasing column) order.
#[derive(Debug)]
struct ComplexBlockMatrix {
    /// Block row `i` (free vertex `i`) holds `block_ptr[i]..block_ptr[i + 1]`.
    block_ptr: Vec<usize>,
    /// Free vertex of each block, increasing within a row.
    block_col: Vec<u32>,
    /// `(Re c, Im c)` of each block.
    value: Vec<[f64; 2]>,
}

impl ComplexBlockMatrix {
    /// Reads the scalar CSR assembled by [`LscmSystem::assemble`], checking the block
    /// structure exactly (an error means the assembly changed its layout).
    fn from_normal_matrix(a: &CsrMatrix) -> Result<Self, ParameterizeError> {
        let n = a.nrows();
        if n % 2 != 0 || a.ncols() != n {
            return Err(internal("LSCM normal matrix is not square of even order"));
        }
        let (rp, ci, val) = (a.row_ptr(), a.col_idx(), a.values());
        let mut block_ptr = Vec::with_capacity(n / 2 + 1);
        block_ptr.push(0usize);
        let mut block_col = Vec::with_capacity(a.nnz() / 4);
        let mut value = Vec::with_capacity(a.nnz() / 4);
        let bad = || internal("LSCM normal matrix does not have the complex 2×2 block layout");
        for i in 0..n / 2 {
            let (u0, u1) = (rp[2 * i], rp[2 * i + 1]);
            let (v0, v1) = (rp[2 * i + 1], rp[2 * i + 2]);
            if u1 - u0 != v1 - v0 || (u1 - u0) % 2 != 0 {
                return Err(bad());
            }
            for k in (0..u1 - u0).step_by(2) {
                let c = ci[u0 + k];
                let same_columns = c % 2 == 0
                    && ci[u0 + k + 1] == c + 1
                    && ci[v0 + k] == c
                    && ci[v0 + k + 1] == c + 1;
                let (re, minus_im) = (val[u0 + k], val[u0 + k + 1]);
                let (im, re_v) = (val[v0 + k], val[v0 + k + 1]);
                // `==` on finite values: bitwise equal except the sign of zero, which cannot
                // change a sum that starts at +0 (see the type doc).
                if !same_columns || re.to_bits() != re_v.to_bits() || minus_im != -im {
                    return Err(bad());
                }
                block_col.push(c / 2);
                value.push([re, im]);
            }
            block_ptr.push(block_col.len());
        }
        Ok(Self {
            block_ptr,
            block_col,
            value,
        })
    }

    fn unknowns(&self) -> usize {
        2 * (self.block_ptr.len() - 1)
    }

    /// Factors the matrix as the complex Hermitian matrix whose entry `(i, j)` is block
    /// `(i, j)`'s `Re + i·Im` (the real block `[[Re, −Im], [Im, Re]]` acting on `(u_j, v_j)`
    /// is that complex number times `u_j + i·v_j`). Its upper triangle, column `j`, is
    /// `conj` of block row `j`'s entries with column `≤ j` (Hermitian symmetry), ascending.
    fn factor_hermitian(&self) -> Result<HermitianCholesky, CholeskyError> {
        let n = self.block_ptr.len() - 1;
        let mut col_ptr: Vec<u32> = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let mut row_idx: Vec<u32> = Vec::with_capacity(self.block_col.len() / 2 + n);
        let mut values: Vec<[f64; 2]> = Vec::with_capacity(self.block_col.len() / 2 + n);
        for j in 0..n {
            let (lo, hi) = (self.block_ptr[j], self.block_ptr[j + 1]);
            for (&i, &[re, im]) in self.block_col[lo..hi].iter().zip(&self.value[lo..hi]) {
                if i as usize > j {
                    break;
                }
                row_idx.push(i);
                values.push([re, -im]);
            }
            col_ptr.push(row_idx.len() as u32);
        }
        HermitianCholesky::factor_upper(n, &col_ptr, &row_idx, &values)
    }

    fn mul_vec_into(&self, x: &[f64], y: &mut [f64]) -> Result<(), SparseError> {
        let n = self.unknowns();
        for len in [x.len(), y.len()] {
            if len != n {
                return Err(SparseError::DimensionMismatch {
                    expected: n,
                    got: len,
                });
            }
        }
        y.par_chunks_mut(2 * VERTICES_PER_TASK)
            .enumerate()
            .for_each(|(chunk, ys)| {
                let i0 = chunk * VERTICES_PER_TASK;
                for (k, yi) in ys.chunks_exact_mut(2).enumerate() {
                    let i = i0 + k;
                    let (lo, hi) = (self.block_ptr[i], self.block_ptr[i + 1]);
                    let (mut su, mut sv) = (0.0f64, 0.0f64);
                    for (&j, &[re, im]) in self.block_col[lo..hi].iter().zip(&self.value[lo..hi]) {
                        let j = 2 * j as usize;
                        let (xu, xv) = (x[j], x[j + 1]);
                        su += re * xu;
                        su += -im * xv;
                        sv += im * xu;
                        sv += re * xv;
                    }
                    yi[0] = su;
                    yi[1] = sv;
                }
            });
        Ok(())
    }
}

/// Solves the complex factor's system for a right-hand side in the real interleaved layout
/// `(u_0, v_0, u_1, v_1, …)` of [`LscmSystem`], returning the same layout.
fn solve_interleaved(factor: &HermitianCholesky, b: &[f64]) -> Result<Vec<f64>, CholeskyError> {
    let bc: Vec<[f64; 2]> = b.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    if 2 * bc.len() != b.len() {
        return Err(CholeskyError::DimensionMismatch {
            expected: 2 * bc.len(),
            got: b.len(),
        });
    }
    Ok(factor.solve(&bc)?.into_iter().flatten().collect())
}

/// A vertex interpolation (rows: fine free vertices, columns: coarse free vertices), applied
/// to both UV components: the scalar matrix `P` of the block matrix `P ⊗ I₂`. Half the entries
/// of the scalar CSR form, same bits.
#[derive(Debug)]
struct VertexInterpolation {
    cols: usize,
    row_ptr: Vec<usize>,
    col: Vec<u32>,
    weight: Vec<f64>,
}

impl VertexInterpolation {
    fn rows(&self) -> usize {
        self.row_ptr.len() - 1
    }

    /// The transpose, each row's entries in increasing column order (as `CsrMatrix::transpose`).
    fn transpose(&self) -> Self {
        let mut row_ptr = vec![0usize; self.cols + 1];
        for &c in &self.col {
            row_ptr[c as usize + 1] += 1;
        }
        for c in 0..self.cols {
            row_ptr[c + 1] += row_ptr[c];
        }
        let mut next = row_ptr.clone();
        let mut col = vec![0u32; self.col.len()];
        let mut weight = vec![0.0; self.col.len()];
        for r in 0..self.rows() {
            for k in self.row_ptr[r]..self.row_ptr[r + 1] {
                let c = self.col[k] as usize;
                col[next[c]] = r as u32;
                weight[next[c]] = self.weight[k];
                next[c] += 1;
            }
        }
        Self {
            cols: self.rows(),
            row_ptr,
            col,
            weight,
        }
    }

    /// `y = (P ⊗ I₂)·x` (`x`: 2 unknowns per column vertex, `y`: per row vertex).
    fn mul_vec_into(&self, x: &[f64], y: &mut [f64]) -> Result<(), SparseError> {
        if x.len() != 2 * self.cols {
            return Err(SparseError::DimensionMismatch {
                expected: 2 * self.cols,
                got: x.len(),
            });
        }
        if y.len() != 2 * self.rows() {
            return Err(SparseError::DimensionMismatch {
                expected: 2 * self.rows(),
                got: y.len(),
            });
        }
        y.par_chunks_mut(2 * VERTICES_PER_TASK)
            .enumerate()
            .for_each(|(chunk, ys)| {
                let i0 = chunk * VERTICES_PER_TASK;
                for (k, yi) in ys.chunks_exact_mut(2).enumerate() {
                    let i = i0 + k;
                    let (lo, hi) = (self.row_ptr[i], self.row_ptr[i + 1]);
                    let (mut su, mut sv) = (0.0f64, 0.0f64);
                    for (&j, &w) in self.col[lo..hi].iter().zip(&self.weight[lo..hi]) {
                        let j = 2 * j as usize;
                        su += w * x[j];
                        sv += w * x[j + 1];
                    }
                    yi[0] = su;
                    yi[1] = sv;
                }
            });
        Ok(())
    }
}

/// CG runs on the block form directly ([`crate::numerics::solve_pcg`]).
impl LinearOperator for ComplexBlockMatrix {
    fn nrows(&self) -> usize {
        self.unknowns()
    }
    fn ncols(&self) -> usize {
        self.unknowns()
    }
    fn mul_vec_into(&self, x: &[f64], y: &mut [f64]) -> Result<(), SparseError> {
        ComplexBlockMatrix::mul_vec_into(self, x, y)
    }
}

/// The additive multilevel preconditioner for level `top` of the hierarchy.
struct Multilevel<'a> {
    hierarchy: &'a HlscmHierarchy,
    top: usize,
}

impl Multilevel<'_> {
    fn apply_level(&self, level: usize, r: &[f64], z: &mut [f64]) {
        let l = &self.hierarchy.levels[level];
        match (&l.prolongation, level) {
            (Some((p, pt)), _) => {
                let mut rc = vec![0.0; 2 * pt.rows()];
                let mut zc = vec![0.0; 2 * pt.rows()];
                if pt.mul_vec_into(r, &mut rc).is_ok() {
                    self.apply_level(level - 1, &rc, &mut zc);
                }
                if p.mul_vec_into(&zc, z).is_err() {
                    z.iter_mut().for_each(|v| *v = 0.0);
                }
                let inv = l.jacobi.inverse_diagonal();
                for ((zi, ri), di) in z.iter_mut().zip(r).zip(inv) {
                    *zi += ri * di;
                }
            }
            (None, _) => match solve_interleaved(&self.hierarchy.coarsest_factor, r) {
                Ok(x) => z.copy_from_slice(&x),
                Err(_) => l.jacobi.apply(r, z),
            },
        }
    }
}

impl Preconditioner for Multilevel<'_> {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        self.apply_level(self.top, r, z);
    }
}

impl HlscmHierarchy {
    /// Vertices per level, coarsest first.
    pub fn level_sizes(&self) -> Vec<usize> {
        self.levels
            .iter()
            .map(|l| l.mesh.chart.positions_m.len())
            .collect()
    }

    /// Cascadic solve (hlscm-2003 §3.3, §4.1). `progress` receives `(finest-level iterations
    /// done, cap)`; `Break` cancels. Returns UVs per chart vertex.
    pub fn solve(
        &self,
        options: &HlscmOptions,
        progress: &mut StageProgress<'_>,
    ) -> Result<(Vec<[f64; 2]>, HlscmReport), ParameterizeError> {
        let n = self.pm.vertex_count;
        let mut uv = vec![[0.0f64; 2]; n];
        let mut reports = Vec::with_capacity(self.levels.len());
        let mut finest_iterations = 0;
        let mut converged = false;
        for (index, level) in self.levels.iter().enumerate() {
            let finest = index + 1 == self.levels.len();
            let (x, iterations, relative_residual) = if index == 0 {
                let x = solve_interleaved(&self.coarsest_factor, level.system.rhs())
                    .map_err(ParameterizeError::Direct)?;
                if finest {
                    converged = true;
                }
                (x, 0, 0.0)
            } else {
                // Vertex splits from the previous level down to this one.
                self.pm
                    .split_to(&mut uv, self.levels[index - 1].applied, level.applied);
                let level_uv: Vec<[f64; 2]> = level
                    .mesh
                    .chart_vertex
                    .iter()
                    .map(|&v| uv[v as usize])
                    .collect();
                let mut x = level.system.solution_from_uv(&level_uv);
                let cg = CgOptions {
                    tolerance: options.final_tolerance,
                    max_iterations: if finest {
                        options.final_max_iterations
                    } else {
                        options.relax_iterations
                    },
                };
                let mut cancelled = false;
                let mut energy_converged = false;
                let window = options.energy_window.max(1);
                let mut history: Vec<f64> = Vec::new();
                let mut watch = |step: &crate::numerics::CgStep<'_>| {
                    if !finest {
                        return ControlFlow::Continue(());
                    }
                    if progress
                        .advance(step.iteration, cg.max_iterations)
                        .is_break()
                    {
                        cancelled = true;
                        return ControlFlow::Break(());
                    }
                    let energy = level.system.energy_from_residual(step.x, step.residual);
                    history.push(energy);
                    if history.len() > window {
                        let before = history[history.len() - 1 - window];
                        if before - energy <= options.final_energy_tolerance * energy.abs() {
                            energy_converged = true;
                            return ControlFlow::Break(());
                        }
                    }
                    ControlFlow::Continue(())
                };
                let outcome = match options.smoother {
                    HlscmSmoother::Jacobi => solve_pcg(
                        level.system.matrix(),
                        level.system.rhs(),
                        &mut x,
                        &level.jacobi,
                        &cg,
                        &mut watch,
                    ),
                    HlscmSmoother::Multilevel => solve_pcg(
                        &level.blocks,
                        level.system.rhs(),
                        &mut x,
                        &Multilevel {
                            hierarchy: self,
                            top: index,
                        },
                        &cg,
                        &mut watch,
                    ),
                }
                .map_err(ParameterizeError::Sparse)?;
                if cancelled {
                    return Err(ParameterizeError::Cancelled);
                }
                if finest {
                    converged = outcome.converged || energy_converged;
                }
                (x, outcome.iterations, outcome.relative_residual)
            };
            let level_uv = level.system.uv_from_solution(&x);
            for (l, &v) in level.mesh.chart_vertex.iter().enumerate() {
                uv[v as usize] = level_uv[l];
            }
            if finest {
                finest_iterations = iterations;
            }
            reports.push(HlscmLevel {
                vertices: level.mesh.chart.positions_m.len(),
                iterations,
                relative_residual,
            });
        }
        Ok((
            uv,
            HlscmReport {
                levels: reports,
                collapses: self.pm.collapses.len(),
                finest_iterations,
                converged,
            },
        ))
    }
}

/// Runs HLSCM on a validated chart with the given pins: [`build_hierarchy`] then
/// [`HlscmHierarchy::solve`].
pub fn solve_hlscm(
    chart: &ChartMesh,
    topology: &ChartTopology,
    pins: &[Pin],
    options: &HlscmOptions,
    progress: &mut StageProgress<'_>,
) -> Result<(Vec<[f64; 2]>, HlscmReport), ParameterizeError> {
    build_hierarchy(chart, topology, pins, options)?.solve(options, progress)
}

#[cfg(test)]
mod tests;
