//! Sparse linear algebra. Knows nothing of meshes.
//!
//! Purpose: the numerical kernels the atlas stages need, kept free of any
//! geometry so that they can be tested against dense references:
//! - [`sparse`]: triplet assembly into a compressed sparse row matrix ([`CsrMatrix`]), with
//!   duplicates summed in a fixed order, and a row-parallel matrix-vector product.
//! - [`cg`]: preconditioned conjugate gradients (Jacobi, or any [`Preconditioner`], e.g. the
//!   HLSCM multilevel one) with a stated stopping rule
//!   (relative residual `‖b − A·x‖₂ ≤ tol·‖b‖₂`, or an iteration cap).
//! - [`sparse_cholesky`]: a sparse direct solve through faer's supernodal Cholesky with an AMD
//!   fill-reducing ordering. With [`mds`] the only modules that name faer, so that faer's
//!   generic code is monomorphized once (faer is ~30% of a debug build).
//! - [`mds`]: landmark multidimensional scaling (a dense symmetric eigen-decomposition), the
//!   spectral analysis of the stretch-driven segmentation.
//!
//! Invariants: every routine is deterministic: the same input gives the same output bits
//! whatever the rayon thread count. Parallel reductions (dot products) are computed over fixed
//! chunks whose partial sums are added in index order, never in completion order.
//!
//! Units: none (pure linear algebra).
//!
//! References: Shewchuk, "An Introduction to the Conjugate Gradient Method Without the Agonizing
//! Pain" (1994), §B3 (preconditioned CG); faer 0.24 `sparse::linalg::cholesky`.
pub mod cg;
pub mod max_flow;
pub mod mds;
pub mod sparse;
pub mod sparse_cholesky;

pub use cg::{
    solve_cg, solve_pcg, CgOptions, CgOutcome, CgStep, Jacobi, LinearOperator, Preconditioner,
};
pub use max_flow::{CutSide, FlowGraph, MinCut};
pub use mds::{LandmarkMds, MdsError};
pub use sparse::{CsrMatrix, SparseError, Triplet};
pub use sparse_cholesky::{CholeskyError, HermitianCholesky, SparseCholesky};
