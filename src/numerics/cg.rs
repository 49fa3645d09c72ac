//! Jacobi-preconditioned conjugate gradients for symmetric positive definite systems.
//!
//! Stopping rule (stated, and the only one): stop at the first iteration `k` where
//! `‖b − A·x_k‖₂ ≤ tolerance · ‖b‖₂` (the *recursively updated* residual is tested, as usual for
//! CG), or after `max_iterations` iterations, or when the monitor returns
//! [`ControlFlow::Break`]. If `b = 0` the answer is `x = 0` with zero iterations.
//!
//! Invariants: deterministic whatever the rayon thread count (the matrix-vector product writes
//! each entry from one task; dot products use a fixed reduction tree, see [`super::sparse::dot`]).
//!
//! Reference: Shewchuk 1994, "An Introduction to the Conjugate Gradient Method Without the
//! Agonizing Pain", Appendix B3 (preconditioned CG). Known limit (measured, see
//! `atlas::parameterize`): on 2-pin LSCM systems the condition number grows like the square of
//! the mesh resolution, so plain CG stalls on the low frequencies; use it as a smoother
//! (HLSCM) or on small systems.
use std::ops::ControlFlow;

use rayon::prelude::*;

use super::sparse::{dot, CsrMatrix, SparseError};

/// Options of [`solve_cg`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CgOptions {
    /// Stop when `‖r‖₂ ≤ tolerance·‖b‖₂`. Unitless, must be ≥ 0 (0 runs to `max_iterations`).
    pub tolerance: f64,
    /// Hard cap on iterations (each costs one matrix-vector product and three dot products).
    pub max_iterations: usize,
}

impl Default for CgOptions {
    /// `tolerance = 1e-8`, `max_iterations = 10_000`.
    fn default() -> Self {
        Self {
            tolerance: 1e-8,
            max_iterations: 10_000,
        }
    }
}

/// What one CG iteration shows to the monitor.
#[derive(Debug)]
pub struct CgStep<'a> {
    /// Iterations done so far (1 after the first update).
    pub iteration: usize,
    /// `‖r‖₂ / ‖b‖₂` after this iteration.
    pub relative_residual: f64,
    /// The current iterate.
    pub x: &'a [f64],
    /// The current (recursively updated) residual `b − A·x`.
    pub residual: &'a [f64],
}

/// How a CG run ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CgOutcome {
    /// Iterations performed.
    pub iterations: usize,
    /// Final `‖r‖₂ / ‖b‖₂` (0 if `b = 0`).
    pub relative_residual: f64,
    /// Whether the tolerance was reached (false: capped or stopped by the monitor).
    pub converged: bool,
}

/// A symmetric positive definite approximation `M⁻¹` of `A⁻¹`, applied as `z = M⁻¹·r`.
/// Implementations must be deterministic (same bits whatever the thread count).
pub trait Preconditioner: Sync {
    /// Writes `M⁻¹·r` into `z` (same length as `r`).
    fn apply(&self, r: &[f64], z: &mut [f64]);
}

/// The Jacobi preconditioner `M = diag(A)`. Non-positive diagonal entries are treated as 1
/// (the matrix is then not SPD and the result is whatever CG gives).
#[derive(Debug, Clone, PartialEq)]
pub struct Jacobi {
    inv_diag: Vec<f64>,
}

impl Jacobi {
    /// Builds `diag(A)⁻¹`.
    pub fn new(a: &CsrMatrix) -> Self {
        Self {
            inv_diag: a
                .diagonal()
                .into_iter()
                .map(|d| {
                    if d > 0.0 && d.is_finite() {
                        1.0 / d
                    } else {
                        1.0
                    }
                })
                .collect(),
        }
    }

    /// `diag(A)⁻¹` as a vector.
    pub fn inverse_diagonal(&self) -> &[f64] {
        &self.inv_diag
    }
}

impl Preconditioner for Jacobi {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        z.par_iter_mut()
            .zip(r.par_iter().zip(&self.inv_diag))
            .for_each(|(zi, (ri, di))| *zi = ri * di);
    }
}

/// Solves `A·x = b` for symmetric positive definite `A`, starting from the given `x` (warm
/// start), with the Jacobi (diagonal) preconditioner. `monitor` is called after every
/// iteration and may stop the solve (cancellation, time limits, energy targets).
///
/// Errors: shape mismatch.
/// Cost per iteration: one `O(nnz)` product and `O(n)` vector work.
pub fn solve_cg(
    a: &CsrMatrix,
    b: &[f64],
    x: &mut [f64],
    options: &CgOptions,
    monitor: &mut dyn FnMut(&CgStep<'_>) -> ControlFlow<()>,
) -> Result<CgOutcome, SparseError> {
    solve_pcg(a, b, x, &Jacobi::new(a), options, monitor)
}

/// A square linear operator `y = A·x` that CG can use: a [`CsrMatrix`], or any other storage of
/// a symmetric positive definite matrix (e.g. HLSCM's 2 × 2 block form). `mul_vec_into` must be
/// deterministic (the same bits at any thread count).
pub trait LinearOperator: Sync {
    /// Rows of `A`.
    fn nrows(&self) -> usize;
    /// Columns of `A` (CG needs `nrows() == ncols()`).
    fn ncols(&self) -> usize;
    /// `y = A·x`; errors on a length mismatch.
    fn mul_vec_into(&self, x: &[f64], y: &mut [f64]) -> Result<(), SparseError>;
}

impl LinearOperator for CsrMatrix {
    fn nrows(&self) -> usize {
        CsrMatrix::nrows(self)
    }
    fn ncols(&self) -> usize {
        CsrMatrix::ncols(self)
    }
    fn mul_vec_into(&self, x: &[f64], y: &mut [f64]) -> Result<(), SparseError> {
        CsrMatrix::mul_vec_into(self, x, y)
    }
}

/// [`solve_cg`] with any symmetric positive definite preconditioner and operator (Shewchuk §B3).
pub fn solve_pcg(
    a: &dyn LinearOperator,
    b: &[f64],
    x: &mut [f64],
    preconditioner: &dyn Preconditioner,
    options: &CgOptions,
    monitor: &mut dyn FnMut(&CgStep<'_>) -> ControlFlow<()>,
) -> Result<CgOutcome, SparseError> {
    let n = a.nrows();
    for len in [a.ncols(), b.len(), x.len()] {
        if len != n {
            return Err(SparseError::DimensionMismatch {
                expected: n,
                got: len,
            });
        }
    }
    let b_norm = dot(b, b).sqrt();
    if b_norm == 0.0 {
        x.iter_mut().for_each(|v| *v = 0.0);
        return Ok(CgOutcome {
            iterations: 0,
            relative_residual: 0.0,
            converged: true,
        });
    }
    let mut r = vec![0.0; n];
    a.mul_vec_into(x, &mut r)?;
    r.par_iter_mut().zip(b).for_each(|(ri, bi)| *ri = bi - *ri);
    let mut z = vec![0.0; n];
    preconditioner.apply(&r, &mut z);
    let mut p = z.clone();
    let mut ap = vec![0.0; n];
    let mut rz = dot(&r, &z);
    let mut rel = dot(&r, &r).sqrt() / b_norm;
    let mut iterations = 0;
    while rel > options.tolerance && iterations < options.max_iterations {
        a.mul_vec_into(&p, &mut ap)?;
        let pap = dot(&p, &ap);
        if pap.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            // Breakdown: A is not positive definite along p (or p = 0). Stop honestly.
            break;
        }
        let alpha = rz / pap;
        x.par_iter_mut()
            .zip(&p)
            .for_each(|(xi, pi)| *xi += alpha * pi);
        r.par_iter_mut()
            .zip(&ap)
            .for_each(|(ri, api)| *ri -= alpha * api);
        preconditioner.apply(&r, &mut z);
        let rz_new = dot(&r, &z);
        let beta = rz_new / rz;
        rz = rz_new;
        p.par_iter_mut()
            .zip(&z)
            .for_each(|(pi, zi)| *pi = zi + beta * *pi);
        iterations += 1;
        rel = dot(&r, &r).sqrt() / b_norm;
        let step = CgStep {
            iteration: iterations,
            relative_residual: rel,
            x,
            residual: &r,
        };
        if monitor(&step).is_break() {
            break;
        }
    }
    Ok(CgOutcome {
        iterations,
        relative_residual: rel,
        converged: rel <= options.tolerance,
    })
}

#[cfg(test)]
mod tests {
    use super::super::sparse::Triplet;
    use super::*;

    /// 1-D Laplacian with Dirichlet ends plus a small shift: SPD, condition ~ n².
    fn laplacian(n: usize) -> CsrMatrix {
        let mut t = Vec::new();
        for i in 0..n {
            t.push(Triplet {
                row: i as u32,
                col: i as u32,
                value: 2.01,
            });
            if i + 1 < n {
                t.push(Triplet {
                    row: i as u32,
                    col: i as u32 + 1,
                    value: -1.0,
                });
                t.push(Triplet {
                    row: i as u32 + 1,
                    col: i as u32,
                    value: -1.0,
                });
            }
        }
        CsrMatrix::from_triplets(n, n, &t).expect("valid")
    }

    #[test]
    fn cg_meets_its_stated_residual_rule() {
        let a = laplacian(200);
        let b: Vec<f64> = (0..200).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
        let mut x = vec![0.0; 200];
        let opts = CgOptions {
            tolerance: 1e-10,
            max_iterations: 1000,
        };
        let out = solve_cg(&a, &b, &mut x, &opts, &mut |_| ControlFlow::Continue(())).expect("ok");
        assert!(out.converged);
        // Recompute the TRUE residual independently of CG's recursive one.
        let ax = a.mul_vec(&x).expect("shape");
        let res: f64 = ax
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q) * (p - q))
            .sum::<f64>()
            .sqrt();
        let bn: f64 = b.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(res <= 1e-9 * bn, "true relative residual {}", res / bn);
    }

    #[test]
    fn cg_respects_cap_and_monitor() {
        let a = laplacian(500);
        let b = vec![1.0; 500];
        let mut x = vec![0.0; 500];
        let opts = CgOptions {
            tolerance: 1e-14,
            max_iterations: 7,
        };
        let out = solve_cg(&a, &b, &mut x, &opts, &mut |_| ControlFlow::Continue(())).expect("ok");
        assert_eq!(out.iterations, 7);
        assert!(!out.converged);
        let mut x = vec![0.0; 500];
        let opts = CgOptions {
            tolerance: 1e-14,
            max_iterations: 100,
        };
        let out = solve_cg(&a, &b, &mut x, &opts, &mut |s| {
            if s.iteration >= 3 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .expect("ok");
        assert_eq!(out.iterations, 3);
    }

    #[test]
    fn cg_zero_rhs_and_bad_shapes() {
        let a = laplacian(4);
        let mut x = vec![1.0; 4];
        let out = solve_cg(&a, &[0.0; 4], &mut x, &CgOptions::default(), &mut |_| {
            ControlFlow::Continue(())
        })
        .expect("ok");
        assert_eq!(x, vec![0.0; 4]);
        assert_eq!(out.iterations, 0);
        let mut x = vec![0.0; 3];
        assert!(
            solve_cg(&a, &[1.0; 4], &mut x, &CgOptions::default(), &mut |_| {
                ControlFlow::Continue(())
            })
            .is_err()
        );
    }
}
