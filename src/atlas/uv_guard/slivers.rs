//! Slivers whose UV height is set by `f32` rounding: their apex is moved back to the height
//! their 3-D shape asks for.
//!
//! A 3-D sliver (cakeBirthday, craft_speederD: heights of ~1e-5 texels under long edges) keeps
//! a valid `f64` map, but written as `f32` its UV apex lands wherever the rounding puts it: a
//! UV height 13 or 22 times too small, which the report's and the evaluator's per-face L∞
//! (max(Γ, 1/γ)) then counts as the atlas's worst stretch. [`restore_slivers`] tries the apex
//! of each such face (UV height below [`THIN_FACE_TEXELS`], L∞ above [`SLIVER_LINF_OK`]) at
//! the `f32` points around it ([`APEX_SEARCH_ULPS`]) and keeps the one where the largest L∞ of
//! the faces at that UV vertex is least, when that is below today's and every one of them stays
//! non-degenerate and oriented as its chart (`moves_fine`). A move of at most 16 spacings is
//! far below a texel, inside the padding. Deterministic: faces in index order, points in a
//! fixed order, strict improvement.
use super::{f32_spacing, moves_fine, UvVertices};
use crate::atlas::measure::{face_metric, OrientationCheck};
use crate::mesh::{FaceId, TriangleMesh};

/// A face whose UV height (over its longest UV edge) is below this many texels has its shape
/// decided by `f32` rounding as much as by its map. Trade-off: larger values look at more faces,
/// whose moves are then more than rounding.
pub(in crate::atlas) const THIN_FACE_TEXELS: f64 = 1.0 / 16.0;

/// Thin faces whose per-face L∞ is at most this are left as they are.
pub(in crate::atlas) const SLIVER_LINF_OK: f64 = 2.0;

/// The apex is tried at every `f32` point within this many spacings of it on each axis
/// ((2·16 + 1)² points). Trade-off: a wider square finds heights closer to the asked one, at a
/// cost paid only on slivers.
const APEX_SEARCH_ULPS: i32 = 16;

/// The report's per-face L∞ (`measure::face_metric`: max(Γ, 1/γ)) of face `f` with UV `uv`,
/// at scale `k` (the atlas's UV area over 3-D area); infinite for a UV-degenerate face.
fn face_linf(mesh: &TriangleMesh, f: usize, uv: &[[f32; 2]; 3], k: f64) -> f64 {
    let w = uv.map(|c| c.map(f64::from));
    let two_a2 =
        (w[1][0] - w[0][0]) * (w[2][1] - w[0][1]) - (w[2][0] - w[0][0]) * (w[1][1] - w[0][1]);
    if two_a2 == 0.0 || !two_a2.is_finite() {
        return f64::INFINITY;
    }
    let m = face_metric(mesh.face_positions(FaceId(f as u32)), uv, two_a2, k);
    if m.small > 0.0 {
        m.big.max(1.0 / m.small)
    } else {
        f64::INFINITY
    }
}

/// Moves the apex of every thin face with a high L∞ (module doc); returns the UV vertices
/// moved. `check` is `measure::orientation_check` of `corner_uvs` as they are on entry (the
/// guard's last); `size = [W, H]` texels of a page.
pub(in crate::atlas) fn restore_slivers(
    mesh: &TriangleMesh,
    check: &OrientationCheck,
    corner_uvs: &mut [[[f32; 2]; 3]],
    face_page: &[u32],
    size: [u32; 2],
) -> usize {
    let nf = corner_uvs.len();
    let used = |f: usize| !check.uv_degenerate[f] && !check.degenerate_3d[f];
    let (mut a2_sum, mut a3_sum) = (0.0f64, 0.0f64);
    for f in (0..nf).filter(|&f| used(f)) {
        a2_sum += check.signed_uv_area[f].abs();
        a3_sum += mesh.face_area_m2(FaceId(f as u32));
    }
    let k = a2_sum / a3_sum;
    if !(k.is_finite() && k > 0.0) {
        return 0;
    }
    let texel = 1.0 / f64::from(size[0].max(size[1]).max(1));
    let mut vertices: Option<UvVertices> = None;
    let mut moved = 0;
    for f in (0..nf).filter(|&f| used(f) && !check.flipped(f)) {
        let Some(apex) = thin_apex(mesh, check, corner_uvs, f, k, texel) else {
            continue;
        };
        let group = vertices
            .get_or_insert_with(|| UvVertices::new(mesh, corner_uvs, face_page))
            .group(3 * f + apex);
        // A 3-D-degenerate face at the vertex was collapsed to a segment by a corner of its
        // own (another key): moving this one would give it area again.
        if group
            .iter()
            .any(|&corner| check.degenerate_3d[corner as usize / 3])
        {
            continue;
        }
        let local_max = |corner_uvs: &[[[f32; 2]; 3]], at: [f32; 2]| -> f64 {
            group
                .iter()
                .map(|&corner| (corner as usize / 3, corner as usize % 3))
                .filter(|&(g, _)| used(g))
                .map(|(g, j)| {
                    let mut t = corner_uvs[g];
                    t[j] = at;
                    face_linf(mesh, g, &t, k)
                })
                .fold(0.0, f64::max)
        };
        let c = corner_uvs[f][apex];
        let before = local_max(corner_uvs, c);
        // The f32 points within APEX_SEARCH_ULPS spacings of the apex on each axis: the height
        // the 3-D shape asks for is often a fraction of a spacing, which a step along one axis
        // cannot make but a step along both can approach (the base is not axis-aligned).
        let (su, sv) = (f32_spacing(c[0]), f32_spacing(c[1]));
        let r = APEX_SEARCH_ULPS;
        let mut best: Option<(f64, [f32; 2])> = None;
        for i in -r..=r {
            for j in -r..=r {
                let p = [
                    (f64::from(c[0]) + f64::from(i) * su) as f32,
                    (f64::from(c[1]) + f64::from(j) * sv) as f32,
                ];
                if p == c || !p.iter().all(|x| x.is_finite()) {
                    continue;
                }
                let value = local_max(corner_uvs, p);
                if value < best.map_or(before, |b| b.0)
                    && moves_fine(check, group, corner_uvs, p, usize::MAX)
                {
                    best = Some((value, p));
                }
            }
        }
        if let Some((_, p)) = best {
            for &corner in group {
                corner_uvs[corner as usize / 3][corner as usize % 3] = p;
            }
            moved += 1;
        }
    }
    moved
}

/// The apex corner (opposite the longest UV edge) of face `f` when `f` is thin (UV height below
/// [`THIN_FACE_TEXELS`]) and its L∞ at scale `k` is above [`SLIVER_LINF_OK`].
fn thin_apex(
    mesh: &TriangleMesh,
    check: &OrientationCheck,
    corner_uvs: &[[[f32; 2]; 3]],
    f: usize,
    k: f64,
    texel: f64,
) -> Option<usize> {
    let uv = corner_uvs[f];
    let w = uv.map(|c| c.map(f64::from));
    let len = |a: usize, b: usize| (w[b][0] - w[a][0]).hypot(w[b][1] - w[a][1]);
    let apex = (0..3)
        .max_by(|&a, &b| len((a + 1) % 3, (a + 2) % 3).total_cmp(&len((b + 1) % 3, (b + 2) % 3)))
        .unwrap_or(0);
    let base = len((apex + 1) % 3, (apex + 2) % 3);
    let height = 2.0 * check.signed_uv_area[f].abs() / base;
    (base > 0.0 && height < THIN_FACE_TEXELS * texel && face_linf(mesh, f, &uv, k) > SLIVER_LINF_OK)
        .then_some(apex)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atlas::measure::orientation_check;
    use crate::atlas::segment::tests::build;
    use crate::mesh::MeshInput;

    #[test]
    fn a_sliver_whose_rounded_apex_sits_too_high_gets_it_back_near_its_height() {
        // A sliver (height 2e-7 under a 10 m edge) beside a big face, both mapped by one
        // similarity (scale 0.05, turned off the axes), written as f32: the sliver's apex put
        // 3 spacings off its base (its 3-D height asks for a third of one).
        let mesh = build(&MeshInput::single_group(
            vec![
                [0.0, 0.0, 0.0],
                [10.0, 0.0, 0.0],
                [5.0, 2e-7, 0.0],
                [5.0, -5.0, 0.0],
            ],
            vec![[0, 1, 2], [1, 0, 3]],
        ));
        let (c, s) = (0.06f64.cos() * 0.05, 0.06f64.sin() * 0.05);
        let map = |p: [f64; 2]| [0.1 + c * p[0] - s * p[1], 0.3 + s * p[0] + c * p[1]];
        let f32s = |q: [f64; 2]| [q[0] as f32, q[1] as f32];
        let (a, b, d) = (map([0.0, 0.0]), map([10.0, 0.0]), map([5.0, -5.0]));
        let mid = map([5.0, 0.0]);
        let n = [-s / 0.05, c / 0.05];
        let spacing = 2f64.powi(-25); // of f32 in [0.25, 0.5), where the apex lies
        assert!((0.25..0.5).contains(&mid[0]) && (0.25..0.5).contains(&mid[1]));
        let apex = [mid[0] + 3.0 * spacing * n[0], mid[1] + 3.0 * spacing * n[1]];
        let mut uvs = [[f32s(a), f32s(b), f32s(apex)], [f32s(b), f32s(a), f32s(d)]];
        let k = {
            let a2 = |t: &[[f32; 2]; 3]| {
                let w = t.map(|p| p.map(f64::from));
                0.5 * ((w[1][0] - w[0][0]) * (w[2][1] - w[0][1])
                    - (w[2][0] - w[0][0]) * (w[1][1] - w[0][1]))
                    .abs()
            };
            (a2(&uvs[0]) + a2(&uvs[1]))
                / (mesh.face_area_m2(FaceId(0)) + mesh.face_area_m2(FaceId(1)))
        };
        let before = face_linf(&mesh, 0, &uvs[0], k);
        assert!(
            before > 4.0,
            "the setup is a sliver with a high L∞: {before}"
        );
        let check = orientation_check(&mesh, &uvs, &[0, 0]);
        let moved = restore_slivers(&mesh, &check, &mut uvs, &[0, 0], [64, 64]);
        let after = face_linf(&mesh, 0, &uvs[0], k);
        assert_eq!(moved, 1);
        assert!(after < before / 2.0, "L∞ {before} -> {after}");
        // Only the apex moved, and both faces keep the big face's orientation.
        assert_eq!(uvs[0][..2], [f32s(a), f32s(b)]);
        assert_eq!(uvs[1], [f32s(b), f32s(a), f32s(d)]);
        let check = orientation_check(&mesh, &uvs, &[0, 0]);
        assert!(!check.flipped(0) && !check.uv_degenerate[0]);
    }
}
