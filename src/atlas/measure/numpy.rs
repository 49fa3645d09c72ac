//! numpy's numerics, reproduced operation for operation so that our figures agree with the
//! independent evaluator (a numpy program) to the last bits where the inputs are the same:
//! numpy's pairwise summation, its `einsum` dot-product order, its linear-interpolation
//! percentile and the evaluator's inverted-CDF weighted percentile.
//!
//! Why: most figures would agree to ~1e-15 with any accurate summation, but a few decisions
//! hinge on rounding — the sign of a chart's signed UV area when a closed surface is projected
//! flat (front and back cancel), Γ/γ of nearly degenerate faces (cancellation in
//! `(a + c) - root`) — and those agree only when the arithmetic is the same.
//!
//! Reference: numpy `numpy/_core/src/umath/loops_utils.h.src` (`pairwise_sum`, blocks of 128,
//! 8 accumulators), `numpy/lib/_function_base_impl.py` (`_quantile`, `_lerp`).
use super::finite;

/// numpy's `np.sum` of a contiguous `float64` array (pairwise summation, checked bit for bit
/// against numpy 2.x on random arrays of 5 to 300k elements).
pub(super) fn np_sum(a: &[f64]) -> f64 {
    let n = a.len();
    if n < 8 {
        a.iter().fold(0.0, |r, &x| r + x)
    } else if n <= 128 {
        let mut r = [0.0f64; 8];
        r.copy_from_slice(&a[..8]);
        let mut i = 8;
        while i < n - n % 8 {
            for (j, rj) in r.iter_mut().enumerate() {
                *rj += a[i + j];
            }
            i += 8;
        }
        let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for &x in &a[i..] {
            res += x;
        }
        res
    } else {
        let mut n2 = n / 2;
        n2 -= n2 % 8;
        np_sum(&a[..n2]) + np_sum(&a[n2..])
    }
}

/// `x.mean()`.
pub(super) fn np_mean(x: &[f64]) -> Option<f64> {
    (!x.is_empty())
        .then(|| np_sum(x) / x.len() as f64)
        .and_then(finite)
}

/// The evaluator's `_mean(x, w)`: `(x * w).sum() / w.sum()`, `None` when `w.sum() <= 0`.
pub(super) fn np_mean_weighted(x: &[f64], w: &[f64]) -> Option<f64> {
    if x.is_empty() {
        return None;
    }
    let xw: Vec<f64> = x.iter().zip(w).map(|(&a, &b)| a * b).collect();
    let sw = np_sum(w);
    (sw > 0.0).then(|| np_sum(&xw) / sw).and_then(finite)
}

/// A 3-vector dot product in the order numpy's `einsum("ij,ij->i")` evaluates it on an
/// `(n, 3)` array, `(x0·y0 + x2·y2) + x1·y1` (checked bit for bit on 200k random vectors).
pub(super) fn dot3_einsum(x: [f64; 3], y: [f64; 3]) -> f64 {
    (x[0] * y[0] + x[2] * y[2]) + x[1] * y[1]
}

/// numpy `percentile(x, q)` with the default linear method; `sorted` ascending.
pub(super) fn percentile_linear(sorted: &[f64], q: f64) -> Option<f64> {
    let n = sorted.len();
    if n == 0 {
        return None;
    }
    let quantile = q / 100.0;
    // numpy's `_compute_virtual_index` with alpha = beta = 1: `n·q + (1 + q·(-1)) - 1`
    // (`1 + q·(-1)` is exactly `1 - q`).
    let virtual_index = n as f64 * quantile + (1.0 - quantile) - 1.0;
    let below = virtual_index.floor().clamp(0.0, (n - 1) as f64);
    let gamma = virtual_index - below;
    let i = below as usize;
    let (a, b) = (sorted[i], sorted[(i + 1).min(n - 1)]);
    // numpy's `_lerp`: exact at both ends.
    let diff = b - a;
    let x = if gamma >= 0.5 {
        b - diff * (1.0 - gamma)
    } else {
        a + diff * gamma
    };
    finite(x)
}

/// The evaluator's weighted percentile: inverted CDF over `order` (indices of `x` stably
/// sorted ascending), weights `w`: the first element whose sequential cumulative weight
/// reaches `q/100 · Σw`.
pub(super) fn percentile_weighted(x: &[f64], w: &[f64], order: &[u32], q: f64) -> Option<f64> {
    if order.is_empty() {
        return None;
    }
    let total = order.iter().fold(0.0, |s, &i| s + w[i as usize]);
    if total <= 0.0 || total.is_nan() {
        return None;
    }
    let target = q / 100.0 * total;
    let mut cum = 0.0;
    let mut k = order.len() - 1;
    for (j, &i) in order.iter().enumerate() {
        cum += w[i as usize];
        if cum >= target {
            k = j;
            break;
        }
    }
    finite(x[order[k] as usize])
}

/// Indices of `x` stably sorted ascending (numpy `argsort(kind="stable")`), in the order of
/// `f64::total_cmp` with the index as tie-break: the same permutation as a stable sort.
///
/// Least-significant-digit radix sort on the `total_cmp` key (8-bit digits, a digit shared by
/// every key is skipped): `O(n)` passes instead of a comparison sort, and the same permutation
/// (each pass is stable and the items start in index order). Short inputs use a comparison
/// sort of (value, index) pairs.
pub(super) fn stable_order(x: &[f64]) -> Vec<u32> {
    if x.len() < 256 {
        let mut keyed: Vec<(f64, u32)> = x.iter().zip(0u32..).map(|(&v, i)| (v, i)).collect();
        keyed.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        return keyed.into_iter().map(|(_, i)| i).collect();
    }
    let mut items: Vec<(u64, u32)> = x
        .iter()
        .zip(0u32..)
        .map(|(&v, i)| (total_key(v), i))
        .collect();
    let mut counts = vec![[0u32; 256]; 8];
    for &(k, _) in &items {
        for (d, c) in counts.iter_mut().enumerate() {
            c[((k >> (8 * d)) & 0xff) as usize] += 1;
        }
    }
    let mut spare: Vec<(u64, u32)> = vec![(0, 0); items.len()];
    for (d, c) in counts.iter().enumerate() {
        if c.iter().any(|&n| n as usize == items.len()) {
            continue;
        }
        let mut next = [0u32; 256];
        let mut acc = 0u32;
        for (slot, &n) in next.iter_mut().zip(c) {
            *slot = acc;
            acc += n;
        }
        for &item in &items {
            let b = ((item.0 >> (8 * d)) & 0xff) as usize;
            spare[next[b] as usize] = item;
            next[b] += 1;
        }
        std::mem::swap(&mut items, &mut spare);
    }
    items.into_iter().map(|(_, i)| i).collect()
}

/// An unsigned key whose order is `f64::total_cmp`'s (the transform `total_cmp` applies to the
/// bits, with the sign bit flipped to order `i64` values as `u64`).
fn total_key(v: f64) -> u64 {
    let mut b = v.to_bits() as i64;
    b ^= (((b >> 63) as u64) >> 1) as i64;
    (b as u64) ^ (1 << 63)
}
