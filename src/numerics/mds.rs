//! Landmark multidimensional scaling (landmark MDS, de Silva & Tenenbaum 2004), the spectral
//! analysis of Iso-charts (Zhou et al. 2004, §4.1 and §5.2.1).
//!
//! Purpose: given the squared distances between `q` landmark points, find coordinates whose
//! Euclidean distances match them as well as an `n`-dimensional embedding can (classical MDS:
//! the top eigenpairs of `B = −½ J Δ J`, `J` the centring matrix), then place any other point
//! from its squared distances to the landmarks alone ("distance-based triangulation",
//! `y_p = −½ L♯ (Δ_p − Δ̄)`, with `L♯` the rows `v_k / √λ_k` and `Δ̄` the mean column of `Δ`).
//! The segmentation's spectral clustering (`atlas::segment::spectral`) reads the eigenvalues and
//! the coordinates.
//!
//! Invariants: eigenvalues are returned in descending order; only positive ones carry a
//! dimension; a landmark placed by [`LandmarkMds::embed`] lands on its own coordinates (up to
//! rounding). Deterministic: the dense eigen-decomposition runs with [`faer::Par::Seq`], so the
//! result does not depend on the rayon thread count.
//!
//! Units: those of the distances (squared distances in, coordinates in the distances' unit).
//!
//! Cost: `O(q³)` for the decomposition (microseconds for `q = 25`), `O(q·n)` per embedded point.
//!
//! References: V. de Silva, J. B. Tenenbaum, "Sparse multidimensional scaling using landmark
//! points", Stanford tech. report 2004 (§2–3); K. Zhou, J. Snyder, B. Guo, H.-Y. Shum,
//! "Iso-charts", SGP 2004, §4.1 (energy of the leading eigenvalues), §5.2.1 (the formula above).
use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::evd::{self_adjoint_evd, self_adjoint_evd_scratch, ComputeEigenvectors};
use faer::{Mat, Par};

/// A landmark MDS of `q` landmarks: eigenvalues, the kept eigenvectors and what placing a point
/// needs.
#[derive(Debug, Clone, PartialEq)]
pub struct LandmarkMds {
    /// All `q` eigenvalues of `B = −½ J Δ J`, descending (trailing ones may be ≤ 0).
    pub eigenvalues: Vec<f64>,
    /// Coordinates of each landmark, `coords[i][k] = √λ_k · v_k(i)`, for the positive eigenvalues
    /// kept (at most `max_dim`).
    pub landmark_coords: Vec<Vec<f64>>,
    /// `pinv[k][i] = v_k(i) / √λ_k`, one row per kept dimension.
    pinv: Vec<Vec<f64>>,
    /// `Δ̄`: the mean squared distance from each landmark to all landmarks.
    mean_sq: Vec<f64>,
}

/// Why an MDS could not be computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum MdsError {
    /// The matrix is not `q × q` or has a non-finite entry.
    #[error(
        "the squared-distance matrix must be q × q and finite (got {len} entries for q = {q})"
    )]
    BadInput {
        /// Landmark count.
        q: usize,
        /// Entries given.
        len: usize,
    },
    /// The eigen-solver did not converge.
    #[error("the symmetric eigen-decomposition did not converge")]
    NoConvergence,
}

impl LandmarkMds {
    /// Classical MDS of the landmarks from their squared distances `sq_dist` (`q × q`,
    /// row-major, symmetric; the mean of `(i, j)` and `(j, i)` is used), keeping at most `max_dim`
    /// positive eigenvalues.
    pub fn new(sq_dist: &[f64], q: usize, max_dim: usize) -> Result<Self, MdsError> {
        if q == 0 || sq_dist.len() != q * q || !sq_dist.iter().all(|d| d.is_finite()) {
            return Err(MdsError::BadInput {
                q,
                len: sq_dist.len(),
            });
        }
        let d = |i: usize, j: usize| 0.5 * (sq_dist[i * q + j] + sq_dist[j * q + i]);
        let mean_sq: Vec<f64> = (0..q)
            .map(|j| (0..q).map(|i| d(i, j)).sum::<f64>() / q as f64)
            .collect();
        let total = mean_sq.iter().sum::<f64>() / q as f64;
        // B = −½ (Δ − row means − column means + total mean).
        let b = Mat::from_fn(q, q, |i, j| {
            -0.5 * (d(i, j) - mean_sq[i] - mean_sq[j] + total)
        });
        let mut u = Mat::<f64>::zeros(q, q);
        let mut s = Diag::<f64>::zeros(q);
        let par = Par::Seq;
        let mut buf = MemBuffer::new(self_adjoint_evd_scratch::<f64>(
            q,
            ComputeEigenvectors::Yes,
            par,
            Default::default(),
        ));
        self_adjoint_evd(
            b.as_ref(),
            s.as_mut(),
            Some(u.as_mut()),
            par,
            MemStack::new(&mut buf),
            Default::default(),
        )
        .map_err(|_| MdsError::NoConvergence)?;
        // faer gives ascending order: the largest are the last columns.
        let eigenvalues: Vec<f64> = (0..q).rev().map(|k| s[k]).collect();
        let scale = eigenvalues
            .first()
            .copied()
            .unwrap_or(0.0)
            .abs()
            .max(1e-300);
        let kept = eigenvalues
            .iter()
            .take(max_dim)
            .take_while(|&&l| l > 1e-12 * scale)
            .count();
        let mut landmark_coords = vec![vec![0.0; kept]; q];
        let mut pinv = vec![vec![0.0; q]; kept];
        for k in 0..kept {
            let col = q - 1 - k;
            let root = eigenvalues[k].sqrt();
            // A fixed sign (largest-magnitude entry positive) so that the coordinates do not
            // depend on the solver's sign choice.
            let mut flip = 1.0;
            let mut best = 0.0f64;
            for i in 0..q {
                let x = u[(i, col)];
                if x.abs() > best.abs() + 1e-12 {
                    best = x;
                }
            }
            if best < 0.0 {
                flip = -1.0;
            }
            for i in 0..q {
                let v = flip * u[(i, col)];
                landmark_coords[i][k] = root * v;
                pinv[k][i] = v / root;
            }
        }
        Ok(Self {
            eigenvalues,
            landmark_coords,
            pinv,
            mean_sq,
        })
    }

    /// Dimensions kept (positive eigenvalues, at most `max_dim`).
    pub fn dim(&self) -> usize {
        self.pinv.len()
    }

    /// The smallest dimension whose leading eigenvalues hold at least `fraction` of the positive
    /// eigenvalues' sum (Iso-charts §4.1; UVAtlas uses 0.9), at most [`Self::dim`], at least 1
    /// when any dimension is kept.
    pub fn energy_dimension(&self, fraction: f64) -> usize {
        let total: f64 = self.eigenvalues.iter().filter(|&&l| l > 0.0).sum();
        let mut acc = 0.0;
        for (k, &l) in self.eigenvalues.iter().take(self.dim()).enumerate() {
            acc += l;
            if acc >= fraction * total {
                return k + 1;
            }
        }
        self.dim()
    }

    /// Share of the positive eigenvalues' sum held by the first `n` eigenvalues.
    pub fn energy_of(&self, n: usize) -> f64 {
        let total: f64 = self.eigenvalues.iter().filter(|&&l| l > 0.0).sum();
        if total <= 0.0 {
            return 1.0;
        }
        self.eigenvalues
            .iter()
            .take(n)
            .filter(|&&l| l > 0.0)
            .sum::<f64>()
            / total
    }

    /// The first `dim` coordinates (at most [`Self::dim`]) of a point whose squared distances to
    /// the landmarks are `sq_to_landmarks` (length `q`).
    pub fn embed(&self, sq_to_landmarks: &[f64], dim: usize) -> Vec<f64> {
        self.pinv
            .iter()
            .take(dim)
            .map(|row| {
                -0.5 * row
                    .iter()
                    .zip(sq_to_landmarks.iter().zip(&self.mean_sq))
                    .map(|(p, (d, m))| p * (d - m))
                    .sum::<f64>()
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sq(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
    }

    /// Points of a tilted plane in 3-D (a rotation of a 2-D pattern), deterministic.
    fn plane_points(n: usize) -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| {
                let t = i as f64;
                let (u, v) = ((t * 0.618).fract() * 7.0, (t * 0.414).fract() * 3.0);
                // An orthonormal basis of a tilted plane through (1, 2, 3).
                let (e1, e2) = ([0.6, 0.8, 0.0], [-0.48, 0.36, 0.8]);
                [0, 1, 2].map(|c| [1.0, 2.0, 3.0][c] + u * e1[c] + v * e2[c])
            })
            .collect()
    }

    #[test]
    fn mds_of_points_on_a_plane_recovers_the_plane() {
        let q = 20;
        let pts = plane_points(60);
        let (lm, rest) = pts.split_at(q);
        let d2: Vec<f64> = (0..q * q).map(|k| sq(&lm[k / q], &lm[k % q])).collect();
        let mds = LandmarkMds::new(&d2, q, 10).expect("mds");
        // Two significant eigenvalues, the rest ~0.
        let l = &mds.eigenvalues;
        assert!(l[1] > 1e-3 * l[0], "second eigenvalue {}", l[1]);
        assert!(
            l[2..].iter().all(|x| x.abs() < 1e-9 * l[0]),
            "third and later eigenvalues {:?}",
            &l[2..]
        );
        assert_eq!(mds.dim(), 2);
        // The long side (7) holds about 49/58 of the energy: 90 % needs both dimensions.
        assert_eq!(mds.energy_dimension(0.9), 2);
        assert_eq!(mds.energy_dimension(0.5), 1);
        assert!((mds.energy_of(2) - 1.0).abs() < 1e-9);
        // Landmarks land on their own coordinates, and every pairwise distance (landmarks and
        // the other points, placed by triangulation) is preserved.
        let y: Vec<Vec<f64>> = pts
            .iter()
            .map(|p| {
                let d: Vec<f64> = lm.iter().map(|l| sq(p, l)).collect();
                mds.embed(&d, 2)
            })
            .collect();
        for (yi, ci) in y.iter().zip(&mds.landmark_coords) {
            assert!(sq(yi, ci) < 1e-16 * l[0]);
        }
        for i in 0..pts.len() {
            for j in 0..pts.len() {
                let (d3, d2) = (sq(&pts[i], &pts[j]).sqrt(), sq(&y[i], &y[j]).sqrt());
                assert!((d3 - d2).abs() < 1e-7, "pair ({i}, {j}): {d3} vs {d2}");
            }
        }
        assert!(rest.len() > 30);
    }

    #[test]
    fn points_on_a_line_have_one_dimension_and_bad_input_is_refused() {
        let q = 8;
        let d2: Vec<f64> = (0..q * q)
            .map(|k| ((k / q) as f64 - (k % q) as f64).powi(2))
            .collect();
        let mds = LandmarkMds::new(&d2, q, 10).unwrap();
        assert_eq!(mds.dim(), 1);
        assert_eq!(mds.energy_dimension(0.9), 1);
        assert!(matches!(
            LandmarkMds::new(&d2[1..], q, 10),
            Err(MdsError::BadInput { .. })
        ));
        let mut bad = d2.clone();
        bad[3] = f64::NAN;
        assert!(LandmarkMds::new(&bad, q, 10).is_err());
    }
}
