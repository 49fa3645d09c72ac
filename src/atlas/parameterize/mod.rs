//! The parameterize stage: flatten every chart, split the charts whose map is not usable, merge
//! valid charts back (Lévy et al. 2002 §3.3), so that every chart leaves with a valid map.
//!
//! Entry: [`parameterize_charts`] takes the segmentation (every chart a topological disk) and
//! returns [`ParameterizedCharts`]: the final charts (still satisfying the segmentation contract:
//! every chart a disk, every face in exactly one chart) and one map per chart.
//!
//! Guarantees to the next stage:
//! - every chart has a map with finite UVs, one per chart vertex, in [`chart_mesh`] order;
//! - a valid chart's map has no flipped face, no boundary self-intersection, no vertex fold, and
//!   its stretch (or area ratio) is within [`ParameterizeOptions`]' bounds; a chart that cannot
//!   be made valid (a single face) is listed in `unresolved` with its [`ChartDefect`];
//! - zero-area faces take no part in flattening and map to (near-)degenerate UV triangles;
//! - deterministic: same input, same output bits, whatever the rayon thread count.
//!
//! Units: positions in model units (`_m`); UVs in model units (the second pin sits at the pins'
//! path length from the first), NOT yet normalized to \[0,1\]: packing does that.
//!
//! Code map, in the order the stage runs:
//! - [`stage`]: the loop (rounds of flatten-and-split in parallel, then the merge-back);
//! - [`flatten`]: one chart's map — [`lscm`] (the LSCM system, Lévy et al. 2002 §2) or
//!   [`hlscm`] (cascadic multigrid over a [`progressive_mesh`], Ray & Lévy 2003 §3.3, §4), on a
//!   [`chart`] extracted by [`extract`];
//! - `degenerate`: flattening around zero-area faces, the line map, splitting them off;
//! - [`defects`]: the tests a map must pass (flips, boundary crossings, folds, stretch, area
//!   ratio; §3.3), with their 2-D predicates;
//! - `split`: the two seeds a chart with a defect is re-grown from; [`sock`]: the lengthwise
//!   seeds of a sock-shaped chart (§3.2, Figure 5);
//! - `warm_start`: a split part keeps its parent's map when that map is valid for it;
//! - `merge`: the merge-back of valid charts into a neighbour; `schedule`: the largest-first
//!   parallel map and the speculative flattening of merge tries;
//! - [`asp`]: optionally, after validation, every valid chart's LSCM map relaxed for the ASP
//!   angle/area energy (Degener et al. 2003), kept only when it passes the stage's tests;
//! - [`stretch`]: last, optionally, the stretch optimisation of every valid chart's map (Sander et al. 2001:
//!   L∞ then L2, vertex moves inside the no-flip kernel), which keeps every guarantee below.
//!
//! References: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least Squares Conformal Maps for
//! Automatic Texture Atlas Generation", SIGGRAPH 2002, §2–§3.3; N. Ray, B. Lévy, "Hierarchical
//! Least Squares Conformal Map", Pacific Graphics 2003; P. Sander, J. Snyder, S. Gortler, H.
//! Hoppe, "Texture Mapping Progressive Meshes", SIGGRAPH 2001 (the L2 stretch).
pub mod asp;
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
pub mod stretch;
#[cfg(any(test, feature = "test-support"))]
pub mod test_meshes;
mod warm_start;
pub use warm_start::restricted_map;

#[cfg(test)]
mod tests;

pub use asp::{asp_energy, relax_chart_asp, relax_chart_asp_hierarchical, AspOutcome, AspStats};
pub use chart::{ChartMesh, ChartTopology};
pub use defects::{boundary_crossing, vertex_fold, ChartDefect};
pub use extract::chart_mesh;
pub use flatten::{flatten_chart, ChartMap, FlattenOptions, LocatedMap, ParameterizeMethod};
pub use hlscm::{HlscmLevel, HlscmOptions, HlscmReport, HlscmSmoother};
pub use lscm::{conformal_energy, flipped_faces, LscmSystem, Pin};
pub use options::{
    Parameterization, ParameterizeOptions, ASP_MAX_THETA, LATE_MERGE_MAX_FACES,
    MERGE_CAP_FLOOR_FACES,
};
pub use stage::{parameterize_charts, ParameterizedCharts};
pub use stretch::{optimize_chart_stretch, StretchChart, StretchOptimization, StretchStats};

use crate::numerics::{CholeskyError, SparseError};

/// Errors of the parameterize stage ([`parameterize_charts`]). A chart that cannot be flattened
/// is not one: the stage splits it, or returns it with a map and lists it in `unresolved`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParameterizeChartsError {
    /// An option has a meaningless value.
    #[error("invalid parameterization option `{option}`: {detail}")]
    InvalidOption {
        /// The option's name, e.g. `max_stretch`.
        option: &'static str,
        /// What is wrong and what to use instead.
        detail: String,
    },
    /// The caller's [`crate::atlas::StageProgress`] asked to stop.
    #[error("parameterization was cancelled")]
    Cancelled,
}

/// Errors of flattening one chart ([`flatten_chart`]). Every variant says what is wrong and how
/// to fix it.
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
    /// The caller's [`crate::atlas::StageProgress`] asked to stop.
    #[error("parameterization was cancelled")]
    Cancelled,
    /// An internal invariant broke (a bug, reported rather than panicking).
    #[error("internal error in parameterization: {detail}; please report it with the input")]
    Internal {
        /// What broke.
        detail: String,
    },
}
