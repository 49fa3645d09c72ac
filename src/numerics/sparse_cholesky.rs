//! Sparse direct solve of a symmetric positive definite system: the one wrapper around faer.
//!
//! Purpose: factor `A = L·Lᵀ` once (supernodal or simplicial, chosen by faer from the flop
//! ratio; fill-reducing AMD ordering) and solve `A·x = b` for any number of right-hand sides.
//!
//! Architecture invariant: this is the ONLY file that names `faer`. faer is generic and heavy
//! (~30% of a debug build); keeping every use here monomorphizes it once.
//!
//! Determinism: the numeric factorization and the solves run with [`faer::Par::Seq`]. faer's
//! rayon path gave the same bits on the 3600-unknown grid system of the test
//! `parallel_factorization_matches_sequential_bits`, but we have not proven it for every
//! input, and sequential execution is deterministic by construction, so production uses it.
//! (The direct solve still parallelizes across charts at the caller.)
//!
//! Units: none. Reference: faer 0.24 `sparse::linalg::cholesky` (symbolic analysis
//! `factorize_symbolic_cholesky`, numeric `factorize_numeric_llt`, `LltRef::solve_in_place_with_conj`).
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use super::sparse::CsrMatrix;

/// Errors of the direct solver.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CholeskyError {
    /// The matrix is not square.
    #[error("matrix is {nrows}x{ncols}, a Cholesky factorization needs a square matrix")]
    NotSquare {
        /// Rows.
        nrows: usize,
        /// Columns.
        ncols: usize,
    },
    /// A pivot was not positive: the matrix is not (numerically) positive definite. For LSCM
    /// this means fewer than two distinct pinned vertices or degenerate triangles.
    #[error("matrix is not positive definite (pivot {index}); check that the system is well posed (e.g. two distinct pinned vertices, no degenerate triangles)")]
    NotPositiveDefinite {
        /// Pivot index in faer's permuted order.
        index: usize,
    },
    /// faer could not allocate or the sizes overflow.
    #[error("sparse Cholesky failed ({detail}); the system is too large for this machine's memory, use the hierarchical solver")]
    Resource {
        /// faer's own message.
        detail: String,
    },
    /// Right-hand side of the wrong length.
    #[error("right-hand side has length {got}, the factored matrix needs {expected}")]
    DimensionMismatch {
        /// Expected length.
        expected: usize,
        /// Given length.
        got: usize,
    },
}

/// A Cholesky factorization `A = L·Lᵀ` of a sparse SPD matrix.
#[derive(Debug)]
pub struct SparseCholesky {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
    n: usize,
}

/// Parallelism used for every faer call (see the module doc for why sequential).
const PAR: Par = Par::Seq;

impl SparseCholesky {
    /// Factors the symmetric matrix `a`. Only the upper triangle (`col ≥ row`) of `a` is read,
    /// so callers may store either the full symmetric matrix or its upper half.
    ///
    /// Cost: AMD ordering + symbolic analysis + numeric factorization; memory is the fill of
    /// `L`, which for 2-D mesh matrices grows like `n log n`.
    pub fn factor(a: &CsrMatrix) -> Result<Self, CholeskyError> {
        Self::factor_with(a, PAR)
    }

    fn factor_with(a: &CsrMatrix, par: Par) -> Result<Self, CholeskyError> {
        let n = a.nrows();
        if a.ncols() != n {
            return Err(CholeskyError::NotSquare {
                nrows: n,
                ncols: a.ncols(),
            });
        }
        // A symmetric matrix in CSR is the same matrix in CSC: row r of the CSR is column r.
        // faer reads the upper side of each column, i.e. the entries with row index ≤ column,
        // which in our CSR row r are the entries with column index ≤ r: the lower-left half
        // of the CSR storage, which by symmetry equals the upper half.
        let col_ptr: Vec<usize> = a.row_ptr().to_vec();
        let row_idx: Vec<usize> = a.col_idx().iter().map(|&c| c as usize).collect();
        let symbolic_view = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(
            symbolic_view,
            Side::Upper,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| CholeskyError::Resource {
            detail: format!("{e:?}"),
        })?;
        let mut values = Vec::new();
        values
            .try_reserve_exact(symbolic.len_val())
            .map_err(|e| CholeskyError::Resource {
                detail: e.to_string(),
            })?;
        values.resize(symbolic.len_val(), 0.0f64);
        let scratch = symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default());
        let mut buffer = MemBuffer::try_new(scratch).map_err(|e| CholeskyError::Resource {
            detail: format!("{e:?}"),
        })?;
        let mat = SparseColMatRef::new(symbolic_view, a.values());
        symbolic
            .factorize_numeric_llt::<f64>(
                &mut values,
                mat,
                Side::Upper,
                Default::default(),
                par,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .map_err(|e| match e {
                faer::linalg::solvers::LltError::NonPositivePivot { index } => {
                    CholeskyError::NotPositiveDefinite { index }
                }
            })?;
        Ok(Self {
            symbolic,
            values,
            n,
        })
    }

    /// Dimension of the factored matrix.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Number of stored values in `L` (the fill), a proxy for memory (8 bytes each).
    pub fn factor_nnz(&self) -> usize {
        self.values.len()
    }

    /// Solves `A·x = b`, returning `x`.
    pub fn solve(&self, b: &[f64]) -> Result<Vec<f64>, CholeskyError> {
        self.solve_with(b, PAR)
    }

    fn solve_with(&self, b: &[f64], par: Par) -> Result<Vec<f64>, CholeskyError> {
        if b.len() != self.n {
            return Err(CholeskyError::DimensionMismatch {
                expected: self.n,
                got: b.len(),
            });
        }
        let mut x = b.to_vec();
        let scratch = self.symbolic.solve_in_place_scratch::<f64>(1, par);
        let mut buffer = MemBuffer::try_new(scratch).map_err(|e| CholeskyError::Resource {
            detail: format!("{e:?}"),
        })?;
        let llt = LltRef::<'_, usize, f64>::new(&self.symbolic, &self.values);
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut x, self.n, 1),
            par,
            MemStack::new(&mut buffer),
        );
        Ok(x)
    }
}

#[cfg(test)]
mod tests {
    use super::super::sparse::Triplet;
    use super::*;

    /// 2-D grid Laplacian (5-point) plus a diagonal shift: SPD with real fill.
    fn grid(m: usize) -> CsrMatrix {
        let id = |i: usize, j: usize| (i * m + j) as u32;
        let mut t = Vec::new();
        for i in 0..m {
            for j in 0..m {
                t.push(Triplet {
                    row: id(i, j),
                    col: id(i, j),
                    value: 4.05,
                });
                for (di, dj) in [(1usize, 0usize), (0, 1)] {
                    if i + di < m && j + dj < m {
                        t.push(Triplet {
                            row: id(i, j),
                            col: id(i + di, j + dj),
                            value: -1.0,
                        });
                        t.push(Triplet {
                            row: id(i + di, j + dj),
                            col: id(i, j),
                            value: -1.0,
                        });
                    }
                }
            }
        }
        CsrMatrix::from_triplets(m * m, m * m, &t).expect("valid")
    }

    #[test]
    fn solves_grid_system_to_machine_precision() {
        let a = grid(30);
        let x_true: Vec<f64> = (0..900)
            .map(|i| ((i * 13) % 17) as f64 / 7.0 - 1.0)
            .collect();
        let b = a.mul_vec(&x_true).expect("shape");
        let f = SparseCholesky::factor(&a).expect("spd");
        let x = f.solve(&b).expect("shape");
        let err = x
            .iter()
            .zip(&x_true)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-10, "max error {err}");
        assert!(f.factor_nnz() >= a.nnz() / 2);
        assert!(f.solve(&b[1..]).is_err());
    }

    #[test]
    fn rejects_indefinite_and_non_square() {
        let t = [
            Triplet {
                row: 0,
                col: 0,
                value: 1.0,
            },
            Triplet {
                row: 0,
                col: 1,
                value: 2.0,
            },
            Triplet {
                row: 1,
                col: 0,
                value: 2.0,
            },
            Triplet {
                row: 1,
                col: 1,
                value: 1.0,
            },
        ];
        let a = CsrMatrix::from_triplets(2, 2, &t).expect("valid");
        assert!(matches!(
            SparseCholesky::factor(&a),
            Err(CholeskyError::NotPositiveDefinite { .. })
        ));
        let r = CsrMatrix::from_triplets(2, 3, &[]).expect("valid");
        assert!(matches!(
            SparseCholesky::factor(&r),
            Err(CholeskyError::NotSquare { .. })
        ));
    }

    #[test]
    fn parallel_factorization_matches_sequential_bits() {
        let a = grid(60);
        let b: Vec<f64> = (0..3600).map(|i| (i % 7) as f64 - 3.0).collect();
        let seq = SparseCholesky::factor_with(&a, Par::Seq).expect("spd");
        let xs = seq.solve_with(&b, Par::Seq).expect("shape");
        let par = SparseCholesky::factor_with(&a, Par::rayon(2)).expect("spd");
        let xp = par.solve_with(&b, Par::rayon(2)).expect("shape");
        // Sequential is what production uses; this records whether faer's parallel path
        // happens to agree bit for bit (it does on this input with faer 0.24).
        assert!(xs.iter().zip(&xp).all(|(p, q)| p.to_bits() == q.to_bits()));
    }
}
