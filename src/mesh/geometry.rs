//! Geometry on a [`TriangleMesh`]: positions, areas, normals, angles, lengths, dihedral angles.
//!
//! Purpose: the measured quantities that segmentation (LSCM paper §3.1 feature detection uses the
//! angle between the normals of the two faces at an edge), parameterization and the quality report
//! need, computed one way, here.
//!
//! Invariants:
//! - A face is *zero-area* exactly when [`triangle_is_zero_area`] says so; then [`face_normal`]
//!   returns `None` and no dihedral angle is defined across its edges. The build flags the same
//!   faces as [`DegenerateKind::ZeroArea`](super::DegenerateKind::ZeroArea), because it calls the
//!   same predicate.
//! - Every function returns finite values for finite positions (no division by a zero length).
//!
//! Units: positions and lengths in model units (`_m`), areas in `_m2`, angles in radians (`_rad`).
//!
//! References: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least Squares Conformal Maps for
//! Automatic Texture Atlas Generation", SIGGRAPH 2002, §3.1 (sharpness = dihedral angle).
//!
//! [`face_normal`]: TriangleMesh::face_normal
use super::ids::{CornerId, FaceId, HalfedgeId, VertexId};
use super::topology::TriangleMesh;
use super::vector::{cross, dot, norm, sub};

/// A triangle is zero-area when `|e1 × e2| <= ZERO_AREA_RELATIVE_TOLERANCE * (longest edge)²`,
/// i.e. its height is below `1e-12` times its longest edge. That is far above double rounding
/// noise (collinear input points give `|e1 × e2|` of a few ulps) and far below any real sliver.
pub const ZERO_AREA_RELATIVE_TOLERANCE: f64 = 1e-12;

/// An axis-aligned bounding box in model units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Smallest x, y, z.
    pub min_m: [f64; 3],
    /// Largest x, y, z.
    pub max_m: [f64; 3],
}

impl Aabb {
    /// Length of the box diagonal.
    pub fn diagonal_m(&self) -> f64 {
        norm(sub(self.max_m, self.min_m))
    }
}

/// The two edge vectors from corner 0 of the triangle scaled by `1 / m`, where `m` is the largest
/// absolute coordinate, so that differences, squares and cross products neither overflow (even for
/// coordinates near `f64::MAX`) nor underflow (tiny coordinates). Returns `m` too (0 when every
/// corner is at the origin).
#[inline]
fn scaled_edges(p: &[[f64; 3]; 3]) -> ([f64; 3], [f64; 3], f64) {
    let m = p.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    if m == 0.0 || !m.is_finite() {
        return (sub(p[1], p[0]), sub(p[2], p[0]), m);
    }
    // Division rather than multiplication by `1 / m`: `1 / m` overflows for subnormal `m`.
    let q = p.map(|c| c.map(|x| x / m));
    (sub(q[1], q[0]), sub(q[2], q[0]), m)
}

/// True when the triangle `p` has (numerically) zero area; see [`ZERO_AREA_RELATIVE_TOLERANCE`].
pub fn triangle_is_zero_area(p: &[[f64; 3]; 3]) -> bool {
    // Fast path: with every |coordinate| in [1e-60, 1e60] (or exactly 0), differences, squares
    // and cross products can neither overflow nor underflow to 0, so no rescaling is needed.
    let m = p.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    let (e1, e2) = if m > 1e-60 && m < 1e60 {
        (sub(p[1], p[0]), sub(p[2], p[0]))
    } else {
        let (e1, e2, m) = scaled_edges(p);
        if m == 0.0 || !m.is_finite() {
            return true;
        }
        (e1, e2)
    };
    let e3 = sub(e2, e1);
    let longest_sq = dot(e1, e1).max(dot(e2, e2)).max(dot(e3, e3));
    let c = cross(e1, e2);
    // Compare squares: no square root on the 1M-face build path.
    dot(c, c)
        <= ZERO_AREA_RELATIVE_TOLERANCE * ZERO_AREA_RELATIVE_TOLERANCE * longest_sq * longest_sq
}

impl TriangleMesh {
    /// Position of `v` in model units.
    #[inline]
    pub fn position(&self, v: VertexId) -> [f64; 3] {
        self.positions_m[v.index()]
    }
    /// All vertex positions, indexed by `VertexId::index()`.
    #[inline]
    pub fn positions_m(&self) -> &[[f64; 3]] {
        &self.positions_m
    }
    /// The three corner positions of `f`, in corner order.
    #[inline]
    pub fn face_positions(&self, f: FaceId) -> [[f64; 3]; 3] {
        self.face_vertices(f).map(|v| self.position(v))
    }
    /// Area of `f` in square model units (0 for a degenerate face).
    pub fn face_area_m2(&self, f: FaceId) -> f64 {
        let p = self.face_positions(f);
        0.5 * norm(cross(sub(p[1], p[0]), sub(p[2], p[0])))
    }
    /// Unit normal of `f` (right-handed with the corner order), or `None` for a zero-area face.
    pub fn face_normal(&self, f: FaceId) -> Option<[f64; 3]> {
        let p = self.face_positions(f);
        if triangle_is_zero_area(&p) {
            return None;
        }
        let (e1, e2, _) = scaled_edges(&p);
        let n = cross(e1, e2);
        let l = norm(n);
        Some(n.map(|x| x / l))
    }
    /// Interior angle at corner `c`, in `[0, π]`. Zero-length edges give 0 (never NaN).
    pub fn corner_angle_rad(&self, c: CornerId) -> f64 {
        let f = c.face();
        let k = c.slot();
        let p = self.face_positions(f);
        let a = sub(p[(k + 1) % 3], p[k]);
        let b = sub(p[(k + 2) % 3], p[k]);
        // atan2(|a×b|, a·b) is accurate for angles near 0 and π, unlike acos of a normalized dot.
        norm(cross(a, b)).atan2(dot(a, b))
    }
    /// Length of the edge of `h`, in model units.
    pub fn edge_length_m(&self, h: HalfedgeId) -> f64 {
        norm(sub(
            self.position(self.to_vertex(h)),
            self.position(self.from_vertex(h)),
        ))
    }
    /// Angle between the normals of the two faces at the edge of `h`, in `[0, π]` (0 = flat,
    /// π = folded back onto itself): the sharpness of LSCM paper §3.1. `None` on the boundary or
    /// when either face is zero-area.
    pub fn dihedral_angle_rad(&self, h: HalfedgeId) -> Option<f64> {
        let o = self.opposite(h)?;
        let n1 = self.face_normal(h.face())?;
        let n2 = self.face_normal(o.face())?;
        Some(norm(cross(n1, n2)).atan2(dot(n1, n2)))
    }
    /// The bounding box of all vertices.
    pub fn bounding_box(&self) -> Aabb {
        let mut min_m = [f64::INFINITY; 3];
        let mut max_m = [f64::NEG_INFINITY; 3];
        for p in &self.positions_m {
            for k in 0..3 {
                min_m[k] = min_m[k].min(p[k]);
                max_m[k] = max_m[k].max(p[k]);
            }
        }
        Aabb { min_m, max_m }
    }
    /// Total surface area in square model units.
    pub fn surface_area_m2(&self) -> f64 {
        self.faces().map(|f| self.face_area_m2(f)).sum()
    }
}
