//! Flattening one chart ([`flatten_chart`]): LSCM (Lévy et al. 2002 §2) by a sparse direct solve,
//! or hierarchical LSCM (Ray & Lévy 2003) for huge charts.
//!
//! Guarantees: every returned map has finite UVs, one per chart vertex; flips are never hidden
//! ([`ChartMap::flipped_faces`] lists every face whose UV image has non-positive signed area, so
//! the stage can split the chart); deterministic whatever the rayon thread count (fixed
//! reduction trees in `numerics`, sequential faer, a progressive mesh whose parallel evaluation
//! batches do not change its bits).
//!
//! Units: positions and UVs in model units (the second pin sits at the pins' path length from
//! the first), not normalized.

use super::{
    conformal_energy, flipped_faces, hlscm, lscm, ChartMesh, ChartTopology, HlscmOptions,
    HlscmReport, LscmSystem, ParameterizeError,
};
use crate::atlas::progress::StageProgress;
use crate::numerics::CgOptions;

/// Which solver flattens a chart.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ParameterizeMethod {
    /// Direct below [`FlattenOptions::auto_hierarchical_min_vertices`], hierarchical above.
    #[default]
    Auto,
    /// Sparse Cholesky on the normal equations in complex Hermitian form (exact up to rounding;
    /// `lscm::solve_direct_complex`).
    Direct,
    /// HLSCM: cascadic multigrid over a progressive mesh (hlscm-2003).
    Hierarchical,
    /// Single-level Jacobi-preconditioned CG from zero (slow at scale; for reference).
    ConjugateGradient,
}

/// Options of [`flatten_chart`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlattenOptions {
    /// Solver choice. Default [`ParameterizeMethod::Auto`].
    pub method: ParameterizeMethod,
    /// With `Auto`, charts with at least this many vertices use HLSCM. Default 1_048_576
    /// (2^20). Trade-off: the direct solve (complex Hermitian Cholesky) was faster at every
    /// size measured (up to 1M vertices) at a similar peak memory; HLSCM, whose memory grows
    /// linearly while the Cholesky fill grows superlinearly, is kept for larger charts.
    pub auto_hierarchical_min_vertices: usize,
    /// HLSCM tuning.
    pub hlscm: HlscmOptions,
    /// CG settings for [`ParameterizeMethod::ConjugateGradient`]. Default: relative residual
    /// 1e-10, at most 100_000 iterations.
    pub cg: CgOptions,
}

impl Default for FlattenOptions {
    fn default() -> Self {
        Self {
            method: ParameterizeMethod::Auto,
            auto_hierarchical_min_vertices: 1 << 20,
            hlscm: HlscmOptions::default(),
            cg: CgOptions {
                tolerance: 1e-10,
                max_iterations: 100_000,
            },
        }
    }
}

/// A chart's map and its local → global vertex map (from [`chart_mesh`](super::chart_mesh)).
pub type LocatedMap = (ChartMap, Vec<crate::mesh::VertexId>);

/// The flattened chart.
#[derive(Debug, Clone, PartialEq)]
pub struct ChartMap {
    /// UV per chart vertex, model units, not yet normalized or packed.
    pub uv: Vec<[f64; 2]>,
    /// `C(U)` of lscm-2002 §2.4 recomputed from `uv` by [`conformal_energy`].
    pub conformal_energy: f64,
    /// Faces whose UV image has non-positive signed area. Empty means the map is valid.
    pub flipped_faces: Vec<u32>,
    /// The solver that produced the map (never `Auto`).
    pub method_used: ParameterizeMethod,
    /// CG iterations (0 for the direct solve; finest-level iterations for HLSCM).
    pub iterations: usize,
    /// The two pinned vertices (lscm-2002 §2.6).
    pub pins: [u32; 2],
    /// HLSCM details when it was used.
    pub hlscm: Option<HlscmReport>,
}

impl ChartMap {
    /// True when no face is flipped (the guarantee the next stage needs).
    pub fn is_valid(&self) -> bool {
        self.flipped_faces.is_empty()
    }
}

/// Flattens one chart. See the module doc for the guarantees.
///
/// `progress` receives `(done, cap)` CG iterations on the iterative paths (the direct solve has
/// no checkpoint); `Break` cancels with [`ParameterizeError::Cancelled`]. Pass
/// [`StageProgress::ignored`] for no reporting.
///
/// Errors: any defect of the chart (see [`ChartMesh::validate`]) or a solver failure.
pub fn flatten_chart(
    chart: &ChartMesh,
    options: &FlattenOptions,
    progress: &mut StageProgress<'_>,
) -> Result<ChartMap, ParameterizeError> {
    flatten_chart_with_topology(chart, options, progress).map(|(map, _)| map)
}

/// [`flatten_chart`], also returning the chart's connectivity (computed once, by
/// [`ChartMesh::validate`]), for the stage, which reads the boundary loop.
pub(super) fn flatten_chart_with_topology(
    chart: &ChartMesh,
    options: &FlattenOptions,
    progress: &mut StageProgress<'_>,
) -> Result<(ChartMap, ChartTopology), ParameterizeError> {
    let topology = chart.validate()?;
    let map = flatten_validated(chart, &topology, options, progress)?;
    Ok((map, topology))
}

/// The map of a chart that passed [`ChartMesh::validate`] (which gave `topology`).
fn flatten_validated(
    chart: &ChartMesh,
    topology: &ChartTopology,
    options: &FlattenOptions,
    progress: &mut StageProgress<'_>,
) -> Result<ChartMap, ParameterizeError> {
    let pins = lscm::diameter_pins(chart, topology);
    let method = match options.method {
        ParameterizeMethod::Auto => {
            if chart.positions_m.len() >= options.auto_hierarchical_min_vertices {
                ParameterizeMethod::Hierarchical
            } else {
                ParameterizeMethod::Direct
            }
        }
        m => m,
    };
    let (uv, iterations, report) = match method {
        ParameterizeMethod::Direct | ParameterizeMethod::Auto => {
            let uv = lscm::solve_direct_complex(chart, topology, &pins)?;
            (uv, 0, None)
        }
        ParameterizeMethod::ConjugateGradient => {
            let system = LscmSystem::assemble(chart, topology, &pins)?;
            let mut x = vec![0.0; system.unknowns()];
            let mut cancelled = false;
            let total = options.cg.max_iterations;
            let outcome = system.solve_cg(&mut x, &options.cg, &mut |step| {
                let flow = progress.advance(step.iteration, total);
                cancelled = flow.is_break();
                flow
            })?;
            if cancelled {
                return Err(ParameterizeError::Cancelled);
            }
            (system.uv_from_solution(&x), outcome.iterations, None)
        }
        ParameterizeMethod::Hierarchical => {
            let (uv, report) =
                hlscm::solve_hlscm(chart, topology, &pins, &options.hlscm, progress)?;
            (uv, report.finest_iterations, Some(report))
        }
    };
    if !uv.iter().all(|p| p[0].is_finite() && p[1].is_finite()) {
        return Err(ParameterizeError::NonFiniteResult);
    }

    Ok(ChartMap {
        conformal_energy: conformal_energy(chart, &uv),
        flipped_faces: flipped_faces(chart, &uv),
        uv,
        method_used: method,
        iterations,
        pins: [pins[0].vertex, pins[1].vertex],
        hlscm: report,
    })
}
