//! The line searches of the vertex moves (`super`'s module doc): golden-section for the L∞
//! phase, a safeguarded parabola for the L2 phase. Pure functions of the objective along the
//! move's line.
use super::exceeds;

/// Trials of the L2 phase's parabolic line search, at most: the first trial and its
/// backtracks, the parabola through the slope, the parabola through three points.
pub(super) const PARABOLA_EVALS: usize = 3 + PARABOLA_BACKTRACKS;
/// Quarterings of the L2 phase's first trial when it does not improve. Trade-off: more reach
/// moves whose gain lies close to the vertex, for evaluations spent on vertices near their optimum.
pub(super) const PARABOLA_BACKTRACKS: usize = 2;
/// Golden-section steps of a line search (the bracket shrinks to 0.618^12 ≈ 0.3 % of the kernel
/// segment).
pub(super) const GOLDEN_STEPS: usize = 12;

/// Golden-section search of `value` on `[0, hi]` ([`GOLDEN_STEPS`] evaluations); returns the best
/// point seen and its value, `(0, phi0)` when none beats `phi0 = value(0)`.
pub(super) fn golden_search(value: &impl Fn(f64) -> f64, hi: f64, phi0: f64) -> (f64, f64) {
    let ratio = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (0.0, hi);
    let mut c = b - ratio * (b - a);
    let mut e = a + ratio * (b - a);
    let (mut fc, mut fe) = (value(c), value(e));
    let (mut best_t, mut best) = (0.0, phi0);
    for (t, fv) in [(c, fc), (e, fe)] {
        if fv < best {
            best = fv;
            best_t = t;
        }
    }
    for _ in 0..GOLDEN_STEPS.saturating_sub(2) {
        if fc <= fe {
            b = e;
            e = c;
            fe = fc;
            c = b - ratio * (b - a);
            fc = value(c);
            if fc < best {
                best = fc;
                best_t = c;
            }
        } else {
            a = c;
            c = e;
            fc = fe;
            e = a + ratio * (b - a);
            fe = value(e);
            if fe < best {
                best = fe;
                best_t = e;
            }
        }
    }
    (best_t, best)
}

/// Line search of a smooth `value` on `[0, hi]` from `phi0 = value(0)` with slope `slope < 0` at
/// 0: a trial at `hi / 4`, then the minimum of the parabola through the slope and the trial,
/// then of the parabola through the three points; a trial that is infeasible (infinite) or not
/// below `phi0` is quartered, at most [`PARABOLA_BACKTRACKS`] times. At most
/// [`PARABOLA_EVALS`] evaluations; returns the best point seen and its value, `(0, phi0)` when
/// none beats `phi0`.
pub(super) fn parabolic_search(
    value: &impl Fn(f64) -> f64,
    hi: f64,
    phi0: f64,
    slope: f64,
) -> (f64, f64) {
    let (mut best_t, mut best) = (0.0, phi0);
    let mut consider = |t: f64, f: f64| {
        if f < best {
            best = f;
            best_t = t;
        }
    };
    let mut t1 = 0.25 * hi;
    let mut f1 = value(t1);
    let mut backtracks = 0;
    while !exceeds(phi0, f1) && backtracks < PARABOLA_BACKTRACKS {
        t1 *= 0.25;
        f1 = value(t1);
        backtracks += 1;
    }
    consider(t1, f1);
    if !f1.is_finite() {
        return (best_t, best);
    }
    // f(t) ≈ phi0 + slope·t + c·t²; through (t1, f1).
    let c = (f1 - phi0 - slope * t1) / (t1 * t1);
    let t2 = if c > 0.0 {
        (-slope / (2.0 * c)).min(hi)
    } else {
        hi
    };
    if !(t2 > 0.0 && t2.is_finite()) || t2 == t1 {
        return (best_t, best);
    }
    let f2 = value(t2);
    consider(t2, f2);
    if !f2.is_finite() {
        return (best_t, best);
    }
    // The parabola through (0, phi0), (t1, f1), (t2, f2).
    let (d1, d2) = ((f1 - phi0) / t1, (f2 - phi0) / t2);
    let c3 = (d2 - d1) / (t2 - t1);
    if c3 > 0.0 {
        let b3 = d1 - c3 * t1;
        let t3 = (-b3 / (2.0 * c3)).min(hi);
        if t3 > 0.0 && t3.is_finite() && t3 != t1 && t3 != t2 {
            let f3 = value(t3);
            consider(t3, f3);
        }
    }
    (best_t, best)
}
