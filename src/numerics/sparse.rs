//! Sparse assembly (triplets → CSR) and the matrix-vector product.
//!
//! Invariants of [`CsrMatrix`]: `row_ptr.len() == nrows + 1`, `row_ptr` is non-decreasing,
//! within each row the column indices are strictly increasing and `< ncols`, and
//! `col_idx.len() == values.len() == row_ptr[nrows]`. Duplicated triplets are summed in the
//! order they were given, so assembly is deterministic.
//!
//! Cost: assembly sorts the triplets (`O(t log t)` for `t` triplets) and allocates
//! `O(t)`; the matrix-vector product is `O(nnz)` and row-parallel (each output entry is written
//! by exactly one task, so the result does not depend on the thread count).
use rayon::prelude::*;

/// One entry `(row, col, value)` of a matrix under assembly. Duplicates are summed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triplet {
    /// Row index, `< nrows`.
    pub row: u32,
    /// Column index, `< ncols`.
    pub col: u32,
    /// Value added at `(row, col)`.
    pub value: f64,
}

/// Errors of sparse assembly.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SparseError {
    /// A triplet addressed a row or column outside the declared shape.
    #[error("triplet ({row}, {col}) is outside a {nrows}x{ncols} matrix; fix the index computation of the caller")]
    IndexOutOfBounds {
        /// Offending row.
        row: u32,
        /// Offending column.
        col: u32,
        /// Declared rows.
        nrows: usize,
        /// Declared columns.
        ncols: usize,
    },
    /// A triplet carried a NaN or infinite value.
    #[error("triplet ({row}, {col}) has a non-finite value; the input geometry is degenerate or overflows")]
    NonFinite {
        /// Offending row.
        row: u32,
        /// Offending column.
        col: u32,
    },
    /// Vector length did not match the matrix shape.
    #[error("vector of length {got} used with a matrix needing {expected}; pass a vector of the right length")]
    DimensionMismatch {
        /// Length required.
        expected: usize,
        /// Length given.
        got: usize,
    },
}

/// A compressed sparse row matrix of `f64`. See the module doc for its invariants.
#[derive(Debug, Clone, PartialEq)]
pub struct CsrMatrix {
    nrows: usize,
    ncols: usize,
    row_ptr: Vec<usize>,
    col_idx: Vec<u32>,
    values: Vec<f64>,
}

/// Rows per parallel task in [`CsrMatrix::mul_vec_into`]; large enough that rayon's per-task
/// overhead is negligible, small enough to balance two cores.
const ROWS_PER_TASK: usize = 4096;

impl CsrMatrix {
    /// Assembles an `nrows × ncols` matrix from triplets, summing duplicates in input order.
    ///
    /// Errors: an index outside the shape or a non-finite value.
    /// Cost: `O(t + nrows)` plus a sort of each row's entries, `O(t log r)` for rows of `r`.
    pub fn from_triplets(
        nrows: usize,
        ncols: usize,
        triplets: &[Triplet],
    ) -> Result<Self, SparseError> {
        for t in triplets {
            if t.row as usize >= nrows || t.col as usize >= ncols {
                return Err(SparseError::IndexOutOfBounds {
                    row: t.row,
                    col: t.col,
                    nrows,
                    ncols,
                });
            }
            if !t.value.is_finite() {
                return Err(SparseError::NonFinite {
                    row: t.row,
                    col: t.col,
                });
            }
        }
        // Stable sort by (row, col): equal keys keep input order, so sums are reproducible. A
        // counting sort by row (stable), then a stable sort of each row's few entries by column.
        let mut start = vec![0usize; nrows + 1];
        for t in triplets {
            start[t.row as usize + 1] += 1;
        }
        for r in 0..nrows {
            start[r + 1] += start[r];
        }
        let mut order: Vec<u32> = vec![0; triplets.len()];
        let mut next = start.clone();
        for (k, t) in triplets.iter().enumerate() {
            order[next[t.row as usize]] = k as u32;
            next[t.row as usize] += 1;
        }
        for r in 0..nrows {
            order[start[r]..start[r + 1]].sort_by_key(|&k| triplets[k as usize].col);
        }
        let mut row_ptr = vec![0usize; nrows + 1];
        let mut col_idx: Vec<u32> = Vec::with_capacity(triplets.len());
        let mut values: Vec<f64> = Vec::with_capacity(triplets.len());
        let mut last: Option<(u32, u32)> = None;
        for &k in &order {
            let t = &triplets[k as usize];
            if last == Some((t.row, t.col)) {
                if let Some(v) = values.last_mut() {
                    *v += t.value;
                }
            } else {
                col_idx.push(t.col);
                values.push(t.value);
                row_ptr[t.row as usize + 1] += 1;
                last = Some((t.row, t.col));
            }
        }
        for r in 0..nrows {
            row_ptr[r + 1] += row_ptr[r];
        }
        Ok(Self {
            nrows,
            ncols,
            row_ptr,
            col_idx,
            values,
        })
    }

    /// Builds a matrix from CSR arrays, checking every invariant of the module doc. Used when
    /// the caller knows the sparsity pattern in advance (e.g. from mesh adjacency), which
    /// avoids materializing one triplet per contribution.
    pub fn from_csr_parts(
        nrows: usize,
        ncols: usize,
        row_ptr: Vec<usize>,
        col_idx: Vec<u32>,
        values: Vec<f64>,
    ) -> Result<Self, SparseError> {
        let bad = |got: usize, expected: usize| SparseError::DimensionMismatch { expected, got };
        if row_ptr.len() != nrows + 1 {
            return Err(bad(row_ptr.len(), nrows + 1));
        }
        let nnz = row_ptr[nrows];
        if row_ptr[0] != 0 || col_idx.len() != nnz {
            return Err(bad(col_idx.len(), nnz));
        }
        if values.len() != nnz {
            return Err(bad(values.len(), nnz));
        }
        for r in 0..nrows {
            let (a, b) = (row_ptr[r], row_ptr[r + 1]);
            if a > b || b > nnz {
                return Err(bad(b, a));
            }
            for k in a..b {
                let c = col_idx[k];
                if c as usize >= ncols || (k > a && col_idx[k - 1] >= c) {
                    return Err(SparseError::IndexOutOfBounds {
                        row: r as u32,
                        col: c,
                        nrows,
                        ncols,
                    });
                }
                if !values[k].is_finite() {
                    return Err(SparseError::NonFinite {
                        row: r as u32,
                        col: c,
                    });
                }
            }
        }
        Ok(Self {
            nrows,
            ncols,
            row_ptr,
            col_idx,
            values,
        })
    }

    /// Number of rows.
    pub fn nrows(&self) -> usize {
        self.nrows
    }

    /// Number of columns.
    pub fn ncols(&self) -> usize {
        self.ncols
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// Row pointers (`nrows + 1` entries).
    pub fn row_ptr(&self) -> &[usize] {
        &self.row_ptr
    }

    /// Column index of each stored entry.
    pub fn col_idx(&self) -> &[u32] {
        &self.col_idx
    }

    /// Value of each stored entry.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The stored diagonal (zero where no diagonal entry is stored). Length `min(nrows, ncols)`.
    pub fn diagonal(&self) -> Vec<f64> {
        let n = self.nrows.min(self.ncols);
        let mut d = vec![0.0; n];
        for (r, dr) in d.iter_mut().enumerate() {
            let (a, b) = (self.row_ptr[r], self.row_ptr[r + 1]);
            if let Ok(k) = self.col_idx[a..b].binary_search(&(r as u32)) {
                *dr = self.values[a + k];
            }
        }
        d
    }

    /// `y = A·x`, row-parallel. Errors if `x.len() != ncols` or `y.len() != nrows`.
    pub fn mul_vec_into(&self, x: &[f64], y: &mut [f64]) -> Result<(), SparseError> {
        if x.len() != self.ncols {
            return Err(SparseError::DimensionMismatch {
                expected: self.ncols,
                got: x.len(),
            });
        }
        if y.len() != self.nrows {
            return Err(SparseError::DimensionMismatch {
                expected: self.nrows,
                got: y.len(),
            });
        }
        y.par_chunks_mut(ROWS_PER_TASK)
            .enumerate()
            .for_each(|(chunk, ys)| {
                let r0 = chunk * ROWS_PER_TASK;
                for (k, yr) in ys.iter_mut().enumerate() {
                    let r = r0 + k;
                    let (a, b) = (self.row_ptr[r], self.row_ptr[r + 1]);
                    let mut s = 0.0;
                    for (c, v) in self.col_idx[a..b].iter().zip(&self.values[a..b]) {
                        s += v * x[*c as usize];
                    }
                    *yr = s;
                }
            });
        Ok(())
    }

    /// `A·x` into a new vector. See [`CsrMatrix::mul_vec_into`].
    pub fn mul_vec(&self, x: &[f64]) -> Result<Vec<f64>, SparseError> {
        let mut y = vec![0.0; self.nrows];
        self.mul_vec_into(x, &mut y)?;
        Ok(y)
    }

    /// The transpose, as a new CSR matrix (i.e. this matrix in CSC form). `O(nnz)`.
    pub fn transpose(&self) -> CsrMatrix {
        let mut row_ptr = vec![0usize; self.ncols + 1];
        for &c in &self.col_idx {
            row_ptr[c as usize + 1] += 1;
        }
        for c in 0..self.ncols {
            row_ptr[c + 1] += row_ptr[c];
        }
        let mut next = row_ptr.clone();
        let mut col_idx = vec![0u32; self.nnz()];
        let mut values = vec![0.0; self.nnz()];
        for r in 0..self.nrows {
            for k in self.row_ptr[r]..self.row_ptr[r + 1] {
                let c = self.col_idx[k] as usize;
                let dst = next[c];
                next[c] += 1;
                col_idx[dst] = r as u32;
                values[dst] = self.values[k];
            }
        }
        CsrMatrix {
            nrows: self.ncols,
            ncols: self.nrows,
            row_ptr,
            col_idx,
            values,
        }
    }
}

/// Elements per chunk of a deterministic parallel reduction.
const DOT_CHUNK: usize = 8192;

/// Dot product with a fixed reduction tree: partial sums over fixed chunks, added in chunk
/// order. The result is bit-identical whatever the number of rayon threads.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    let partial: Vec<f64> = a
        .par_chunks(DOT_CHUNK)
        .zip(b.par_chunks(DOT_CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>())
        .collect();
    partial.iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(row: u32, col: u32, value: f64) -> Triplet {
        Triplet { row, col, value }
    }

    #[test]
    fn assembly_sums_duplicates_and_matches_dense_product() {
        let trips = [
            t(0, 0, 1.0),
            t(2, 1, 4.0),
            t(0, 2, 2.0),
            t(0, 0, 0.5),
            t(1, 1, 3.0),
            t(2, 1, -1.0),
        ];
        let a = CsrMatrix::from_triplets(3, 3, &trips).expect("valid");
        let dense = [[1.5, 0.0, 2.0], [0.0, 3.0, 0.0], [0.0, 3.0, 0.0]];
        assert_eq!(a.nnz(), 4);
        let x = [1.0, -2.0, 0.25];
        let y = a.mul_vec(&x).expect("shape");
        for r in 0..3 {
            let expect: f64 = (0..3).map(|c| dense[r][c] * x[c]).sum();
            assert_eq!(y[r], expect);
        }
        assert_eq!(a.diagonal(), vec![1.5, 3.0, 0.0]);
        let at = a.transpose();
        let yt = at.mul_vec(&x).expect("shape");
        for c in 0..3 {
            let expect: f64 = (0..3).map(|r| dense[r][c] * x[r]).sum();
            assert_eq!(yt[c], expect);
        }
    }

    /// Duplicates are summed left to right in input order (so the bits do not depend on how
    /// the assembly sorts), and each row comes out with ascending, distinct columns.
    #[test]
    fn assembly_sums_duplicates_in_input_order() {
        let (n, mut seed) = (7u32, 12345u64);
        let mut next = |m: u64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) % m
        };
        let trips: Vec<Triplet> = (0..600)
            .map(|_| {
                let (r, c) = (next(n as u64) as u32, next(n as u64) as u32);
                // Magnitudes far apart, so that another summation order changes the bits.
                let v = (next(1000) as f64 - 500.0) * 10f64.powi(next(17) as i32 - 8);
                t(r, c, v)
            })
            .collect();
        let a = CsrMatrix::from_triplets(n as usize, n as usize, &trips).expect("valid");
        for r in 0..n as usize {
            let (cols, vals) = (
                &a.col_idx()[a.row_ptr()[r]..a.row_ptr()[r + 1]],
                &a.values()[a.row_ptr()[r]..a.row_ptr()[r + 1]],
            );
            assert!(cols.windows(2).all(|w| w[0] < w[1]), "row {r}: {cols:?}");
            for (&c, &v) in cols.iter().zip(vals) {
                let mut want: Option<f64> = None;
                for x in trips.iter().filter(|x| x.row as usize == r && x.col == c) {
                    want = Some(want.map_or(x.value, |w| w + x.value));
                }
                assert_eq!(v.to_bits(), want.expect("present").to_bits(), "({r}, {c})");
            }
            // Every (row, column) of the input is kept, once: the row's columns are exactly the
            // distinct columns its triplets name.
            let mut named: Vec<u32> = trips
                .iter()
                .filter(|x| x.row as usize == r)
                .map(|x| x.col)
                .collect();
            named.sort_unstable();
            named.dedup();
            assert_eq!(cols, &named[..], "row {r}");
        }
    }

    #[test]
    fn csr_parts_are_checked() {
        let a = CsrMatrix::from_csr_parts(2, 2, vec![0, 1, 3], vec![1, 0, 1], vec![2.0, 3.0, 4.0])
            .expect("valid");
        assert_eq!(a.mul_vec(&[1.0, 10.0]).expect("shape"), vec![20.0, 43.0]);
        // unsorted columns in row 1
        assert!(
            CsrMatrix::from_csr_parts(2, 2, vec![0, 1, 3], vec![1, 1, 0], vec![1.0; 3]).is_err()
        );
        // column out of range
        assert!(CsrMatrix::from_csr_parts(2, 2, vec![0, 1, 2], vec![1, 2], vec![1.0; 2]).is_err());
        // bad row_ptr length
        assert!(CsrMatrix::from_csr_parts(2, 2, vec![0, 1], vec![1], vec![1.0]).is_err());
        // non-finite
        assert!(CsrMatrix::from_csr_parts(1, 1, vec![0, 1], vec![0], vec![f64::INFINITY]).is_err());
    }

    #[test]
    fn assembly_rejects_bad_triplets() {
        assert!(matches!(
            CsrMatrix::from_triplets(2, 2, &[t(2, 0, 1.0)]),
            Err(SparseError::IndexOutOfBounds { .. })
        ));
        assert!(matches!(
            CsrMatrix::from_triplets(2, 2, &[t(0, 0, f64::NAN)]),
            Err(SparseError::NonFinite { .. })
        ));
        let a = CsrMatrix::from_triplets(2, 2, &[t(0, 0, 1.0)]).expect("valid");
        assert!(a.mul_vec(&[1.0]).is_err());
    }

    #[test]
    fn dot_is_independent_of_thread_count() {
        let a: Vec<f64> = (0..100_000u64)
            .map(|i| ((i * 7919) % 1000) as f64 * 1e-3 - 0.3)
            .collect();
        let b: Vec<f64> = (0..100_000u64)
            .map(|i| ((i * 104_729) % 997) as f64 * 1e-2)
            .collect();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool");
        let three = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .expect("pool");
        let d1 = one.install(|| dot(&a, &b));
        let d3 = three.install(|| dot(&a, &b));
        assert_eq!(d1.to_bits(), d3.to_bits());
        let serial: f64 = a.iter().zip(&b).map(|(p, q)| p * q).sum();
        assert!((d1 - serial).abs() <= 1e-9 * serial.abs());
    }
}
