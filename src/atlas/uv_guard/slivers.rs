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
//!
//! The apex alone often cannot do it: the height asked for can be a tenth of a spacing, and
//! the apex must also sit within about that height of its place along the base (a shear of
//! `δ / h` otherwise), a target a few hundredths of a spacing cell wide, which the `f32`
//! points around the apex rarely hit. When the face is still above
//! [`BASE_SEARCH_ABOVE_LINF`], one base vertex at a time is moved too ([`BASE_SEARCH_ULPS`]):
//! each move shifts the apex's target against the `f32` grid by a fraction of a spacing, and
//! the apex is tried at the `f32` points nearest that target. The faces at both vertices are
//! measured and checked as for the apex alone.
//!
//! Every move is a fix of rounding, worth less than a chart: [`restore_slivers`] returns its
//! moves ([`SliverMoves`]), and the caller undoes those at a face that then covers a texel
//! centre of another face of its chart or crosses one (the report's sampling and exact test),
//! where `moves_fine`, which looks at orientation only, cannot see it (a needle's apex moved
//! across the next face of its chart).
use super::{f32_spacing, moves_fine, oriented, UvVertices};
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

/// The base search (module doc) tries each base vertex at every `f32` point within this many
/// spacings on each axis, with the apex at the 3 × 3 `f32` points nearest its target. Trade-off:
/// a wider square gives more targets (each hit with a chance of about 6 (h/spacing)², h the
/// height asked for), at 2 (2·8 + 1)² · 9 shapes per sliver searched.
const BASE_SEARCH_ULPS: i32 = 8;

/// The base search runs on thin faces whose L∞ is above this after the apex search: the
/// default bound of a chart's L∞ (`--max-linf`), past which a sliver would be the atlas's worst
/// face. Trade-off: below it the search costs (a build of the fold raster when it moves
/// anything: bunny's pack stage +15% for its L∞ 2.417 → 2.397) more than it gains.
const BASE_SEARCH_ABOVE_LINF: f64 = 3.0;

/// At most this many slivers get the base search per atlas: a bound on its cost (each costs
/// about half a millisecond) on meshes made of slivers.
const BASE_SEARCHES_MAX: usize = 1024;

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

/// Moves the apex of every thin face with a high L∞, then the base search on those still high
/// (module doc); returns the moves, for the caller to undo those at a fold. `check` is
/// `measure::orientation_check` of `corner_uvs` as they are on entry (the guard's last);
/// `size = [W, H]` texels of a page.
pub(in crate::atlas) fn restore_slivers(
    mesh: &TriangleMesh,
    check: &OrientationCheck,
    corner_uvs: &mut [[[f32; 2]; 3]],
    size: [u32; 2],
) -> SliverMoves {
    let nf = corner_uvs.len();
    let used = |f: usize| !check.uv_degenerate[f] && !check.degenerate_3d[f];
    let (mut a2_sum, mut a3_sum) = (0.0f64, 0.0f64);
    for f in (0..nf).filter(|&f| used(f)) {
        a2_sum += check.signed_uv_area[f].abs();
        a3_sum += mesh.face_area_m2(FaceId(f as u32));
    }
    let k = a2_sum / a3_sum;
    let mut moves = SliverMoves::default();
    if !(k.is_finite() && k > 0.0) {
        return moves;
    }
    let texel = 1.0 / f64::from(size[0].max(size[1]).max(1));
    let mut vertices: Option<UvVertices> = None;
    // The thin faces still above BASE_SEARCH_ABOVE_LINF after their apex search, with their
    // apex.
    let mut still: Vec<(usize, usize)> = Vec::new();
    for f in (0..nf).filter(|&f| used(f) && !check.flipped(f)) {
        let Some(apex) = thin_apex(mesh, check, corner_uvs, f, k, texel) else {
            continue;
        };
        let group = vertices
            .get_or_insert_with(|| UvVertices::of(check))
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
            moves.apply(corner_uvs, [(group, p)], false);
        }
        if face_linf(mesh, f, &corner_uvs[f], k) > BASE_SEARCH_ABOVE_LINF {
            still.push((f, apex));
        }
    }
    if let Some(vertices) = &vertices {
        restore_by_base(mesh, check, corner_uvs, vertices, (&still, k), &mut moves);
    }
    moves
}

/// The moves of [`restore_slivers`], in the order made, each kept or undone.
#[derive(Debug, Default)]
pub(in crate::atlas) struct SliverMoves {
    moves: Vec<SliverMove>,
}

/// One move: the faces at its vertices (ascending), each moved corner's position before,
/// whether it is a base move (two vertices) and whether it has been undone.
#[derive(Debug)]
struct SliverMove {
    faces: Vec<u32>,
    before: Vec<(usize, [f32; 2])>,
    base: bool,
    undone: bool,
}

impl SliverMoves {
    /// Moves every corner of each group to its position and records the move.
    fn apply<'a>(
        &mut self,
        corner_uvs: &mut [[[f32; 2]; 3]],
        groups: impl IntoIterator<Item = (&'a [u32], [f32; 2])>,
        base: bool,
    ) {
        let (mut faces, mut before) = (Vec::new(), Vec::new());
        for (group, at) in groups {
            for &c in group {
                let (g, j) = (c as usize / 3, c as usize % 3);
                before.push((c as usize, corner_uvs[g][j]));
                corner_uvs[g][j] = at;
                faces.push(g as u32);
            }
        }
        faces.sort_unstable();
        faces.dedup();
        self.moves.push(SliverMove {
            faces,
            before,
            base,
            undone: false,
        });
    }

    /// The faces at every move's vertices, kept or undone (ascending, each once): outside
    /// them, no corner's UV differs from what it was before the sliver repair.
    pub(in crate::atlas) fn faces(&self) -> Vec<u32> {
        let mut faces: Vec<u32> = self.moves.iter().flat_map(|m| m.faces.clone()).collect();
        faces.sort_unstable();
        faces.dedup();
        faces
    }

    /// UV vertices moved by the moves kept (one per apex move, two per base move).
    pub(in crate::atlas) fn vertices_moved(&self) -> usize {
        self.moves
            .iter()
            .filter(|m| !m.undone)
            .map(|m| if m.base { 2 } else { 1 })
            .sum()
    }

    /// Undoes every kept move with a face in `faces` (ascending), and every later kept move
    /// that shares a face with an undone one (its checks saw the undone positions), latest
    /// first, so that each corner gets back the position it had before; returns how many.
    pub(in crate::atlas) fn undo_at(
        &mut self,
        faces: &[u32],
        corner_uvs: &mut [[[f32; 2]; 3]],
    ) -> usize {
        self.undo_where(
            |m| m.faces.iter().any(|f| faces.binary_search(f).is_ok()),
            corner_uvs,
        )
    }

    fn undo_where(
        &mut self,
        hit: impl Fn(&SliverMove) -> bool,
        corner_uvs: &mut [[[f32; 2]; 3]],
    ) -> usize {
        let mut undone_faces: Vec<u32> = Vec::new();
        let mut undo = Vec::new();
        for (i, m) in self.moves.iter().enumerate() {
            if m.undone {
                continue;
            }
            if hit(m)
                || m.faces
                    .iter()
                    .any(|f| undone_faces.binary_search(f).is_ok())
            {
                undone_faces.extend(&m.faces);
                undone_faces.sort_unstable();
                undone_faces.dedup();
                undo.push(i);
            }
        }
        for &i in undo.iter().rev() {
            let m = &mut self.moves[i];
            for &(c, at) in m.before.iter().rev() {
                corner_uvs[c / 3][c % 3] = at;
            }
            m.undone = true;
        }
        undo.len()
    }
}

/// The second pass of [`restore_slivers`]: the base search ([`search_base`]) on each thin face
/// `still` above [`BASE_SEARCH_ABOVE_LINF`] after the first (with its apex corner;
/// ascending), at most [`BASE_SEARCHES_MAX`]; `vertices` are the UV vertices of `corner_uvs`.
/// Each move kept is recorded in `moves`.
fn restore_by_base(
    mesh: &TriangleMesh,
    check: &OrientationCheck,
    corner_uvs: &mut [[[f32; 2]; 3]],
    vertices: &UvVertices,
    (still, k): (&[(usize, usize)], f64),
    moves: &mut SliverMoves,
) {
    for &(f, apex) in still.iter().take(BASE_SEARCHES_MAX) {
        // An earlier move here may have changed it.
        if face_linf(mesh, f, &corner_uvs[f], k) <= BASE_SEARCH_ABOVE_LINF {
            continue;
        }
        let Some((base_corner, base_at, apex_at)) =
            search_base(mesh, check, vertices, corner_uvs, (f, apex), k)
        else {
            continue;
        };
        let groups = [
            (vertices.group(base_corner), base_at),
            (vertices.group(3 * f + apex), apex_at),
        ];
        moves.apply(corner_uvs, groups, true);
    }
}

/// The base search of the module doc for the sliver `f` with apex corner `apex`: the move of one
/// base vertex (`BASE_SEARCH_ULPS`) and of the apex (to the 3 × 3 `f32` points nearest the
/// place its 3-D shape asks for over the moved base) after which the largest L∞ of the faces at
/// both vertices is least, when below today's and every one of them (3-D-degenerate ones
/// excepted) stays non-degenerate and oriented as its chart. Returns the base corner moved and
/// the two new positions.
fn search_base(
    mesh: &TriangleMesh,
    check: &OrientationCheck,
    vertices: &UvVertices,
    corner_uvs: &[[[f32; 2]; 3]],
    (f, apex): (usize, usize),
    k: f64,
) -> Option<(usize, [f32; 2], [f32; 2])> {
    let used = |g: usize| !check.uv_degenerate[g] && !check.degenerate_3d[g];
    let q = mesh.face_positions(FaceId(f as u32));
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    // The apex over the base (corners apex+1 → apex+2, the face's own order): its place along
    // the base and its height, as fractions of the base length, on the chart's side.
    let (ia, ib) = ((apex + 1) % 3, (apex + 2) % 3);
    let (e, w) = (sub(q[ib], q[ia]), sub(q[apex], q[ia]));
    let len2 = dot(e, e);
    let cross = [
        e[1] * w[2] - e[2] * w[1],
        e[2] * w[0] - e[0] * w[2],
        e[0] * w[1] - e[1] * w[0],
    ];
    let (along, height) = (dot(e, w) / len2, dot(cross, cross).sqrt() / len2);
    if !(along.is_finite() && height.is_finite() && len2 > 0.0) {
        return None;
    }
    let side = if check.chart_positive[check.chart_of_face[f] as usize] {
        1.0
    } else {
        -1.0
    };
    let target = |a: [f64; 2], b: [f64; 2]| {
        let d = [b[0] - a[0], b[1] - a[1]];
        [
            a[0] + along * d[0] - side * height * d[1],
            a[1] + along * d[1] + side * height * d[0],
        ]
    };
    let apex_group = vertices.group(3 * f + apex);
    let mut best: Option<(f64, usize, [f32; 2], [f32; 2])> = None;
    for base in [ia, ib] {
        let base_group = vertices.group(3 * f + base);
        if base_group
            .iter()
            .chain(apex_group)
            .any(|&c| check.degenerate_3d[c as usize / 3])
        {
            continue;
        }
        // Every corner of a face at either vertex, with which of the two it is (if any).
        let mut faces: Vec<usize> = base_group
            .iter()
            .chain(apex_group)
            .map(|&c| c as usize / 3)
            .collect();
        faces.sort_unstable();
        faces.dedup();
        let is_base = |c: usize| base_group.binary_search(&(c as u32)).is_ok();
        let is_apex = |c: usize| apex_group.binary_search(&(c as u32)).is_ok();
        // The largest L∞ over those faces with the two vertices at `at_base`, `at_apex`, or
        // None when one of them would be degenerate or turned against its chart.
        let shape = |at_base: [f32; 2], at_apex: [f32; 2]| -> Option<f64> {
            let mut worst = 0.0f64;
            for &g in &faces {
                let mut t = corner_uvs[g];
                for (j, corner) in t.iter_mut().enumerate() {
                    if is_base(3 * g + j) {
                        *corner = at_base;
                    } else if is_apex(3 * g + j) {
                        *corner = at_apex;
                    }
                }
                if check.degenerate_3d[g] {
                    continue;
                }
                if !oriented(check, g, &t) {
                    return None;
                }
                if used(g) {
                    worst = worst.max(face_linf(mesh, g, &t, k));
                }
            }
            Some(worst)
        };
        let (b0, c0) = (corner_uvs[f][base], corner_uvs[f][apex]);
        // Below today's largest L∞ of these faces, and below the best found so far.
        let Some(today) = shape(b0, c0) else {
            continue;
        };
        let bar = best.map_or(today, |b| b.0.min(today));
        let (su, sv) = (f32_spacing(b0[0]), f32_spacing(b0[1]));
        let r = BASE_SEARCH_ULPS;
        for i in -r..=r {
            for j in -r..=r {
                if i == 0 && j == 0 {
                    continue;
                }
                let at_base = [
                    (f64::from(b0[0]) + f64::from(i) * su) as f32,
                    (f64::from(b0[1]) + f64::from(j) * sv) as f32,
                ];
                if !at_base.iter().all(|x| x.is_finite()) {
                    continue;
                }
                let mut ends = [corner_uvs[f][ia], corner_uvs[f][ib]].map(|p| p.map(f64::from));
                ends[usize::from(base == ib)] = at_base.map(f64::from);
                let aim = target(ends[0], ends[1]);
                let near = [aim[0] as f32, aim[1] as f32];
                let (au, av) = (f32_spacing(near[0]), f32_spacing(near[1]));
                for di in -1..=1 {
                    for dj in -1..=1 {
                        let at_apex = [
                            (f64::from(near[0]) + f64::from(di) * au) as f32,
                            (f64::from(near[1]) + f64::from(dj) * av) as f32,
                        ];
                        // The sliver alone first: most shapes fail there.
                        let mut t = corner_uvs[f];
                        t[base] = at_base;
                        t[apex] = at_apex;
                        let own = face_linf(mesh, f, &t, k);
                        if own >= best.map_or(bar, |b| b.0) {
                            continue;
                        }
                        if let Some(worst) = shape(at_base, at_apex) {
                            if worst < best.map_or(bar, |b| b.0) {
                                best = Some((worst, 3 * f + base, at_base, at_apex));
                            }
                        }
                    }
                }
            }
        }
    }
    best.map(|(_, corner, at_base, at_apex)| (corner, at_base, at_apex))
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
    use crate::mesh::{MeshInput, TriangleMesh};

    /// A sliver (corners 0, 1, 2: a 10 m edge along x, its apex at `(apex_x, height_m)`) beside
    /// a big face (1, 0, 3), both mapped by one similarity (scale 0.05, turned off the axes) and
    /// written as `f32`, the sliver's apex put `off` spacings (2^-25, of `f32` in [0.25, 0.5),
    /// where it lies) off its base; with the atlas scale `k` (UV area over 3-D area).
    fn sliver_beside_big_face(
        apex_x: f64,
        height_m: f64,
        off: f64,
    ) -> (TriangleMesh, [[[f32; 2]; 3]; 2], f64) {
        let mesh = build(&MeshInput::single_group(
            vec![
                [0.0, 0.0, 0.0],
                [10.0, 0.0, 0.0],
                [apex_x, height_m, 0.0],
                [5.0, -5.0, 0.0],
            ],
            vec![[0, 1, 2], [1, 0, 3]],
        ));
        let (c, s) = (0.06f64.cos() * 0.05, 0.06f64.sin() * 0.05);
        let map = |p: [f64; 2]| [0.1 + c * p[0] - s * p[1], 0.3 + s * p[0] + c * p[1]];
        let f32s = |q: [f64; 2]| [q[0] as f32, q[1] as f32];
        let (a, b, d) = (map([0.0, 0.0]), map([10.0, 0.0]), map([5.0, -5.0]));
        let foot = map([apex_x, 0.0]);
        assert!((0.25..0.5).contains(&foot[0]) && (0.25..0.5).contains(&foot[1]));
        let (n, spacing) = ([-s / 0.05, c / 0.05], 2f64.powi(-25));
        let apex = [
            foot[0] + off * spacing * n[0],
            foot[1] + off * spacing * n[1],
        ];
        let uvs = [[f32s(a), f32s(b), f32s(apex)], [f32s(b), f32s(a), f32s(d)]];
        let a2 = |t: &[[f32; 2]; 3]| {
            let w = t.map(|p| p.map(f64::from));
            0.5 * ((w[1][0] - w[0][0]) * (w[2][1] - w[0][1])
                - (w[2][0] - w[0][0]) * (w[1][1] - w[0][1]))
                .abs()
        };
        let k = (a2(&uvs[0]) + a2(&uvs[1]))
            / (mesh.face_area_m2(FaceId(0)) + mesh.face_area_m2(FaceId(1)));
        (mesh, uvs, k)
    }

    #[test]
    fn a_sliver_whose_rounded_apex_sits_too_high_gets_it_back_near_its_height() {
        // Height 2e-7 under the 10 m edge: its apex 3 spacings off its base, where its 3-D
        // height asks for a third of one.
        let (mesh, start, k) = sliver_beside_big_face(5.0, 2e-7, 3.0);
        let mut uvs = start;
        let before = face_linf(&mesh, 0, &uvs[0], k);
        assert!(
            before > 4.0,
            "the setup is a sliver with a high L∞: {before}"
        );
        let check = orientation_check(&mesh, &uvs, &[0, 0]);
        let moved = restore_slivers(&mesh, &check, &mut uvs, [64, 64]).vertices_moved();
        let after = face_linf(&mesh, 0, &uvs[0], k);
        assert_eq!(moved, 1);
        assert!(after < before / 2.0, "L∞ {before} -> {after}");
        // Only the apex moved, and both faces keep the big face's orientation.
        assert_eq!(uvs[0][..2], start[0][..2]);
        assert_eq!(uvs[1], start[1]);
        let check = orientation_check(&mesh, &uvs, &[0, 0]);
        assert!(!check.flipped(0) && !check.uv_degenerate[0]);
    }

    /// A sliver whose height is a few hundredths of an `f32` spacing: no `f32` point near its
    /// apex has both its height and its place along the base, so a base vertex moves too,
    /// unless the fold check says no.
    #[test]
    fn a_sliver_thinner_than_the_apex_can_reach_moves_a_base_vertex_too() {
        // Height 2e-8 under the 10 m edge: 1e-9 in UV, 1/30 of a spacing; the apex 2 off.
        let (mesh, start, k) = sliver_beside_big_face(3.7, 2e-8, 2.0);
        let before = face_linf(&mesh, 0, &start[0], k);
        let check = orientation_check(&mesh, &start, &[0, 0]);
        // The apex alone (every base move undone) leaves it above the bar.
        let mut apex_only = start;
        restore_slivers(&mesh, &check, &mut apex_only, [64, 64])
            .undo_where(|m| m.base, &mut apex_only);
        let apex_alone = face_linf(&mesh, 0, &apex_only[0], k);
        assert!(
            apex_alone > BASE_SEARCH_ABOVE_LINF,
            "the setup needs the base search: L∞ {before} -> {apex_alone} by the apex alone"
        );
        assert_eq!(
            apex_only[1], start[1],
            "an undone base move leaves the big face"
        );
        // With the base search kept: far lower, a base vertex moved by at most
        // BASE_SEARCH_ULPS spacings, both faces oriented as before.
        let mut uvs = start;
        let mut moves = restore_slivers(&mesh, &check, &mut uvs, [64, 64]);
        let after = face_linf(&mesh, 0, &uvs[0], k);
        assert!(moves.vertices_moved() >= 2);
        assert!(after < apex_alone / 2.0, "L∞ {apex_alone} -> {after}");
        for (p, q) in uvs[0][..2].iter().zip(&start[0][..2]) {
            for axis in 0..2 {
                let ulps = (f64::from(p[axis]) - f64::from(q[axis])).abs() / f32_spacing(q[axis]);
                assert!(ulps <= f64::from(BASE_SEARCH_ULPS) + 0.5, "{ulps} spacings");
            }
        }
        assert_eq!(uvs[1][2], start[1][2], "the big face's own vertex stays");
        let check = orientation_check(&mesh, &uvs, &[0, 0]);
        assert!(!check.flipped(0) && !check.flipped(1));
        assert!(!check.uv_degenerate[0] && !check.uv_degenerate[1]);
        // Undone at a fold of the sliver (in every move): every corner back where it was, bit
        // for bit.
        assert!(moves.undo_at(&[0], &mut uvs) >= 2);
        assert_eq!(uvs, start);
        assert_eq!(moves.vertices_moved(), 0);
    }
}
