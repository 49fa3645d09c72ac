//! Small vector helpers on `[f64; 3]` (model space) and `[f64; 2]` (UV space), written out once.
//!
//! Each function evaluates its formula in exactly the order written in its doc, left to right,
//! with no fused multiply-add: callers rely on the bits (the atlas output is compared byte for
//! byte), so a change of operation order here is a change of output.
//!
//! Units: whatever the inputs are in (lengths stay lengths, cross products are areas × 2).

/// `a - b`, per component.
#[inline]
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a·b = a0·b0 + a1·b1 + a2·b2`, summed left to right.
#[inline]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a × b = [a1·b2 - a2·b1, a2·b0 - a0·b2, a0·b1 - a1·b0]` (right-handed).
#[inline]
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Euclidean length `sqrt(a·a)` (with [`dot`]; no overflow protection: callers that need it
/// rescale first).
#[inline]
pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// `a - b`, per component.
#[inline]
pub fn sub2(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// The 2-D cross product (perp-dot) `a0·b1 - a1·b0`: twice the signed area of the triangle
/// `(0, a, b)`, positive when `b` is counter-clockwise from `a` (x right, y up).
#[inline]
pub fn cross2(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Twice the signed area of the triangle `(o, a, b)`: `cross2(a - o, b - o)`, positive when it
/// turns counter-clockwise (x right, y up). Not exact (see `robust::orient2d` for that).
#[inline]
pub fn orient2(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    cross2(sub2(a, o), sub2(b, o))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn products_of_the_unit_vectors() {
        let [x, y, z] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(cross(x, y), z);
        assert_eq!(cross(y, z), x);
        assert_eq!(cross(z, x), y);
        assert_eq!(cross(y, x), [0.0, 0.0, -1.0]);
        assert_eq!(dot(x, y), 0.0);
        assert_eq!(dot(x, x), 1.0);
        assert_eq!(cross2([1.0, 0.0], [0.0, 1.0]), 1.0);
        assert_eq!(cross2([0.0, 1.0], [1.0, 0.0]), -1.0);
    }

    #[test]
    fn values_on_a_worked_example() {
        let (a, b) = ([1.0, 2.0, 3.0], [4.0, -5.0, 6.0]);
        assert_eq!(sub(a, b), [-3.0, 7.0, -3.0]);
        assert_eq!(dot(a, b), 12.0);
        // (2·6 - 3·(-5), 3·4 - 1·6, 1·(-5) - 2·4)
        assert_eq!(cross(a, b), [27.0, 6.0, -13.0]);
        assert_eq!(norm([3.0, 4.0, 12.0]), 13.0);
        assert_eq!(sub2([1.0, 2.0], [4.0, -5.0]), [-3.0, 7.0]);
        // The triangle (1,1), (4,1), (1,3): legs 3 and 2, counter-clockwise.
        assert_eq!(orient2([1.0, 1.0], [4.0, 1.0], [1.0, 3.0]), 6.0);
        assert_eq!(orient2([1.0, 1.0], [1.0, 3.0], [4.0, 1.0]), -6.0);
    }

    #[test]
    fn cross_is_orthogonal_and_its_length_is_the_parallelogram_area() {
        // Deterministic pseudo-random vectors (xorshift), away from cancellation.
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..1000 {
            let a = [next(), next(), next()];
            let b = [next(), next(), next()];
            let c = cross(a, b);
            let scale = norm(a) * norm(b);
            assert!(dot(c, a).abs() <= 1e-14 * scale * norm(a));
            assert!(dot(c, b).abs() <= 1e-14 * scale * norm(b));
            // Lagrange's identity: |a × b|² = |a|²|b|² - (a·b)².
            let lagrange = dot(a, a) * dot(b, b) - dot(a, b) * dot(a, b);
            assert!((dot(c, c) - lagrange).abs() <= 1e-13 * scale * scale);
            // The 2-D product is the z component of the 3-D one.
            assert_eq!(cross2([a[0], a[1]], [b[0], b[1]]), c[2]);
        }
    }

    #[test]
    fn the_operation_order_is_the_documented_one() {
        // 1e16 + 1 - 1e16 loses the 1 when summed left to right; any other order keeps it.
        let a = [1e16, 1.0, -1e16];
        let one = [1.0, 1.0, 1.0];
        assert_eq!(dot(a, one), (1e16 + 1.0) + -1e16);
        assert_eq!(dot(a, one), 0.0);
    }
}
