//! Chart parameterization: LSCM (Lévy et al. 2002 §2) and hierarchical LSCM (Ray & Lévy 2003).
//!
//! Purpose: flatten one chart (a topological disk, [`ChartMesh`]) into the plane with the least
//! squares conformal map, choosing between a sparse direct solve (small and medium charts) and
//! the cascadic multigrid over a progressive mesh (HLSCM, huge charts).
//!
//! Guarantees to the next stage (issue 3 §5):
//! - every returned map has finite UVs, one per chart vertex;
//! - flips are never hidden: [`ChartMap::flipped_faces`] lists every face whose UV image has
//!   non-positive signed area (empty means valid), so that chart validation can split the chart
//!   (lscm-2002 §3.3);
//! - deterministic: same input, same output bits, whatever the rayon thread count (fixed
//!   reduction trees in `numerics`, sequential faer, a progressive mesh whose parallel
//!   evaluation batches do not change its bits).
//!
//! Units: positions in model units (`_m`); UVs in model units (the second pin sits at the
//! pins' path length from the first), NOT yet normalized to \[0,1\]: packing does that.
//!
//! Code map: [`chart`] (input and validation), [`lscm`] (the LSCM system, §2),
//! [`progressive_mesh`] (half-edge collapses, hlscm-2003 §4), [`hlscm`] (cascadic multigrid,
//! hlscm-2003 §3.3 and §4.1).
pub mod chart;
pub mod defects;
mod degenerate;
pub mod extract;
pub mod flatten;
pub mod hlscm;
pub mod lscm;
mod merge;
pub mod options;
pub mod progressive_mesh;
mod schedule;
pub mod sock;
mod split;
pub mod stage;
pub mod test_meshes;
mod warm_start;

#[cfg(test)]
mod tests;

pub use chart::{ChartMesh, ChartTopology};
pub use defects::{boundary_crossing, vertex_fold, ChartDefect};
pub use extract::chart_mesh;
pub use flatten::{
    parameterize_chart, parameterize_chart_with_monitor, parameterize_chart_with_topology,
    ChartMap, ParameterizeMethod, ParameterizeOptions,
};
pub use hlscm::{HlscmLevel, HlscmOptions, HlscmReport, HlscmSmoother};
pub use lscm::{conformal_energy, flipped_faces, LscmSystem, Pin};
pub use options::{ValidateOptions, LATE_MERGE_MAX_FACES, MERGE_CAP_FLOOR_FACES};
pub use stage::{validate_charts, validate_charts_with_monitor, LocatedMap, ValidatedCharts};

use crate::numerics::{CholeskyError, SparseError};

/// Errors of the parameterization stage. Every variant says what is wrong and how to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParameterizeError {
    /// The chart has no triangle.
    #[error("chart has no triangles; do not send empty charts to parameterization")]
    EmptyChart,
    /// More vertices than the solvers index (`u32`, two unknowns per vertex).
    #[error("chart has {vertices} vertices, more than the 2^31 supported; split the chart")]
    TooLarge {
        /// Vertex count.
        vertices: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {index} but the chart has {vertices} vertices; fix the chart extraction")]
    IndexOutOfRange {
        /// Triangle index.
        triangle: u32,
        /// Offending index.
        index: u32,
        /// Vertex count.
        vertices: usize,
    },
    /// A triangle uses the same vertex twice.
    #[error("triangle {triangle} uses a vertex twice; remove degenerate triangles before parameterization")]
    RepeatedVertex {
        /// Triangle index.
        triangle: u32,
    },
    /// A position is NaN or infinite.
    #[error("vertex {vertex} has a non-finite position; repair the mesh")]
    NonFinitePosition {
        /// Vertex index.
        vertex: u32,
    },
    /// A triangle has (numerically) zero area.
    #[error("triangle {triangle} has zero area (relative to its longest edge); remove or repair slivers before parameterization")]
    DegenerateTriangle {
        /// Triangle index.
        triangle: u32,
    },
    /// A vertex is used by no triangle (it would make the LSCM system singular).
    #[error("vertex {vertex} is used by no triangle; compact the chart's vertices")]
    UnreferencedVertex {
        /// Vertex index.
        vertex: u32,
    },
    /// A directed edge appears twice: more than two faces on an edge, or inconsistent winding.
    #[error("edge {a}->{b} is used twice in the same direction (non-manifold edge or inconsistent orientation); split or re-orient the chart")]
    NonManifoldEdge {
        /// Edge start.
        a: u32,
        /// Edge end.
        b: u32,
    },
    /// A vertex has more than one fan of faces (bow-tie).
    #[error(
        "vertex {vertex} is non-manifold (its faces form several fans); split the chart there"
    )]
    NonManifoldVertex {
        /// Vertex index.
        vertex: u32,
    },
    /// The chart is not connected.
    #[error("chart is not connected ({reached} of {vertices} vertices reachable); send each component as its own chart")]
    Disconnected {
        /// Vertices reachable from vertex 0.
        reached: usize,
        /// Vertex count.
        vertices: usize,
    },
    /// The chart is not a topological disk.
    #[error("chart is not a disk ({boundary_loops} boundary loops, Euler characteristic {euler_characteristic}, a disk has 1 and 1); cut it into disks first")]
    NotADisk {
        /// Number of boundary loops.
        boundary_loops: usize,
        /// `V − E + F`.
        euler_characteristic: i64,
    },
    /// Pins are unusable.
    #[error("invalid pins: {detail}")]
    BadPins {
        /// What is wrong.
        detail: String,
    },
    /// Sparse assembly or product failed (a bug: the chart was validated).
    #[error("sparse assembly failed: {0}")]
    Sparse(SparseError),
    /// The direct solver failed.
    #[error("direct solve failed: {0}")]
    Direct(CholeskyError),
    /// The solver produced non-finite UVs.
    #[error("the solver produced non-finite UVs; the chart is too badly conditioned, split it")]
    NonFiniteResult,
    /// The caller's monitor asked to stop.
    #[error("parameterization was cancelled")]
    Cancelled,
    /// An internal invariant broke (a bug, reported rather than panicking).
    #[error("internal error in parameterization: {detail}; please report it with the input")]
    Internal {
        /// What broke.
        detail: String,
    },
}
