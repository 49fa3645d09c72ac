//! Per-face geometry of the measured atlas: 3-D and signed UV areas, degeneracy, edge lengths.
//!
//! Formulas and operation order are fixed (see the module doc of [`super`] for the definitions),
//! so that threshold decisions (degeneracy) come out the same bit for bit on the same `f64`
//! inputs as in an independent implementation of the same definitions.
//! Units: `_m`, `_m2` in model units, UV areas in page units². Cost: one pass, 50 bytes per face.
use crate::mesh::vector::{cross, norm, sub};
use crate::mesh::{FaceId, TriangleMesh};

/// The evaluator's relative degeneracy tolerance: `|A| <= 1e-12 · (longest edge)²`.
pub(super) const DEGENERATE_RELATIVE: f64 = 1e-12;

/// Per-face quantities, indexed by face.
pub(super) struct FaceGeometry {
    /// A3: 3-D area.
    pub area_3d_m2: Vec<f64>,
    /// A2: signed UV area (counter-clockwise positive, u right, v up in the formula's frame).
    pub signed_uv_area: Vec<f64>,
    /// UV-degenerate (NaN counts as degenerate).
    pub uv_degenerate: Vec<bool>,
    /// 3-D-degenerate.
    pub degenerate_3d: Vec<bool>,
    /// 3-D length of the half-edges corner 0→1, 1→2, 2→0.
    pub edge_len_m: Vec<[f64; 3]>,
}

/// numpy's `maximum`: NaN wins.
fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// The evaluator's `~(x > tol)`: true when `x <= tol` or either is NaN (NaN is degenerate).
fn not_greater(x: f64, tol: f64) -> bool {
    x.partial_cmp(&tol) != Some(std::cmp::Ordering::Greater)
}

/// UV corner as `f64` (exact).
#[inline]
pub(super) fn uv64(c: [f32; 2]) -> [f64; 2] {
    [f64::from(c[0]), f64::from(c[1])]
}

/// A face's `A2` and whether it is UV-degenerate (the UV half of [`face_geometry`]).
pub(super) fn uv_area(uv: &[[f32; 2]; 3]) -> (f64, bool) {
    let [s0, t0] = uv64(uv[0]);
    let [s1, t1] = uv64(uv[1]);
    let [s2, t2] = uv64(uv[2]);
    let (ds1, dt1, ds2, dt2) = (s1 - s0, t1 - t0, s2 - s0, t2 - t0);
    let a2 = 0.5 * (ds1 * dt2 - ds2 * dt1);
    let lmax2 = nan_max(
        nan_max(ds1.hypot(dt1), ds2.hypot(dt2)),
        (s2 - s1).hypot(t2 - t1),
    );
    (
        a2,
        not_greater(a2.abs(), DEGENERATE_RELATIVE * lmax2 * lmax2),
    )
}

/// Computes [`FaceGeometry`] for every face.
pub(super) fn face_geometry(mesh: &TriangleMesh, corner_uvs: &[[[f32; 2]; 3]]) -> FaceGeometry {
    let nf = mesh.num_faces();
    let mut g = FaceGeometry {
        area_3d_m2: Vec::with_capacity(nf),
        signed_uv_area: Vec::with_capacity(nf),
        uv_degenerate: Vec::with_capacity(nf),
        degenerate_3d: Vec::with_capacity(nf),
        edge_len_m: Vec::with_capacity(nf),
    };
    for (f, uv) in corner_uvs.iter().enumerate() {
        let p = mesh.face_positions(FaceId(f as u32));
        let e1 = sub(p[1], p[0]);
        let e2 = sub(p[2], p[0]);
        let e3 = sub(p[2], p[1]);
        let a3 = 0.5 * norm(cross(e1, e2));
        let (l1, l2, l3) = (norm(e1), norm(e2), norm(e3));
        let lmax3 = nan_max(nan_max(l1, l2), l3);
        let (a2, deg2) = uv_area(uv);
        let deg3 = not_greater(a3, DEGENERATE_RELATIVE * lmax3 * lmax3);
        g.area_3d_m2.push(a3);
        g.signed_uv_area.push(a2);
        g.uv_degenerate.push(deg2);
        g.degenerate_3d.push(deg3);
        g.edge_len_m.push([l1, l3, l2]);
    }
    g
}
