//! The flip promise's last line of defence: the final `f32` corner UVs have no flipped face and
//! no face that is degenerate in UV but not in 3-D (or the other way round).
//!
//! # Purpose
//! Every stage before this one works in `f64` and validates its own maps, yet the written UVs
//! can still break the promise, for three measured reasons (issue 22, corpus `hard/`):
//! - a zero-area face (collinear corners) whose corners are all mapped by its non-degenerate
//!   neighbours keeps their UVs, which need not be collinear: its UV triangle has area, either
//!   orientation, and can cover its neighbours' texels (alien: 1 flip, 45 overlapping texels);
//! - a zero-area face whose lone vertex was put on its UV segment (parameterize/degenerate.rs)
//!   is collinear in `f64` but not after rounding to `f32`: a UV area of ~1e-8 of its edge²,
//!   of either sign (alien, craft_speederD: 4 flips);
//! - a 3-D sliver (height ~1e-8 of its length) whose `f64` map is valid but whose UV height is
//!   below the `f32` spacing: rounding flips it (cakeBirthday: 1 flip).
//!
//! [`guard_uvs`] checks the UVs with the report's own rules (`measure::orientation_check`, the
//! definitions of the report and the evaluator) and repairs, in this order:
//! 1. **collapse:** a 3-D-degenerate face with three distinct UV corners (a UV area, or a
//!    segment that a raster's fixed-point rounding can give area) gets two equal corners (the
//!    corner off its longest 3-D edge takes the UV of the nearer end of that edge): `A2` is
//!    exactly 0 at any rounding, only that face changes, and its long edge stays shared with
//!    its neighbour;
//! 2. **nudge:** for a flipped or UV-degenerate face with 3-D area, one of its UV vertices (all
//!    the corners with its key: glTF mesh, position, page, UV) moves along the normal of the
//!    opposite UV edge, towards its chart's orientation, by 1, 2, 4, … up to
//!    [`NUDGE_MAX_ULPS`] `f32` spacings; the first move after which every face at that vertex is
//!    non-degenerate and oriented as its chart is kept. A move of at most 256 spacings is below
//!    1/60 texel at 4096 px, far inside the padding, so it cannot reach another chart. A face
//!    whose UV corners all coincide (a triangle smaller than the `f32` spacing) first has one
//!    corner moved off the others (along ±u or ±v, the other faces at it staying fine);
//! 3. what is left is returned, for `generate` to split each such face off into a chart of its
//!    own and pack again (a single-face chart is never flipped: its orientation is its own);
//!    so are, after step 4, the faces that [`folds`] finds covering a texel centre of another
//!    face of their chart by the report's own sampling (a sliver thinner than the raster's
//!    rounding), or else crossing another face of their chart by the report's exact test:
//!    alone, a face keeps the padding from every other chart. When faults are still found after
//!    the caller's split rounds, its last split also takes apart every face thinner than that
//!    rounding could flip ([`raster_slivers`]): on a chart made of such slivers, each packing
//!    flips others, one at a time never ends;
//! 4. slivers whose UV height the rounding set far from their 3-D height get their apex moved
//!    back (`slivers.rs`, [`restore_slivers`]), and where that is not enough one base vertex
//!    with it: the one step that moves a corner of a face that is not flipped or degenerate,
//!    by at most 16 spacings, at the vertices of faces thinner than 1/16 texel; [`folds`]
//!    undoes every such move at a face that then overlaps another, before it splits anything.
//!
//! # Invariants
//! Pure and deterministic: faces and vertices are visited in index order; no hashing. Steps 1–3
//! never move a corner of a face that is not at fault (flipped, degenerate in only one of UV and
//! 3-D, or 3-D-degenerate with three distinct UV corners) or at a nudged vertex, so a valid
//! atlas without slivers comes out bit-identical.
//!
//! # Units
//! UVs in normalized page coordinates (`f32`, as written to the file); `A2` in page units².
//!
//! # References
//! Sander, Snyder, Gortler, Hoppe 2001, "Texture mapping progressive meshes" §4 (vertex moves
//! that keep every face of the one-ring oriented); the evaluator's definitions
//! (`measure/mod.rs`, "Degenerate", "Charts", "Flips").
use super::measure::{exact_overlaps, orientation_check, ExactOverlaps, OrientationCheck};
use crate::mesh::{FaceId, TriangleMesh};

mod slivers;
pub(super) use slivers::{restore_slivers, SliverMoves};

/// The largest nudge, in `f32` spacings at the vertex (2⁸: see the module doc).
pub(super) const NUDGE_MAX_ULPS: u32 = 256;

/// What [`guard_uvs`] did.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(super) struct GuardOutcome {
    /// 3-D-degenerate faces whose UV triangle was collapsed to a segment.
    pub collapsed_faces: usize,
    /// UV vertices moved by a nudge.
    pub nudged_vertices: usize,
    /// Faces still at fault (ascending): flipped, or UV-degenerate with 3-D area.
    pub unrepaired: Vec<FaceId>,
}

/// Repairs `corner_uvs` in place (module doc) and returns what it did and what is left, with
/// the orientation check of `corner_uvs` as it leaves them (for the next step to reuse).
/// `face_page[f]` is the page of face `f`; both have one entry per face of `mesh`.
pub(super) fn guard_uvs(
    mesh: &TriangleMesh,
    corner_uvs: &mut [[[f32; 2]; 3]],
    face_page: &[u32],
) -> (GuardOutcome, OrientationCheck) {
    let mut out = GuardOutcome::default();
    let check = orientation_check(mesh, corner_uvs, face_page);
    let open = |f: usize| check.degenerate_3d[f] && !two_equal(&corner_uvs[f]);
    if !(0..corner_uvs.len()).any(|f| check.fault(f) || open(f)) {
        return (out, check);
    }
    // 1. Collapse 3-D-degenerate faces with three distinct UV corners (changes no other face).
    let shared = if (0..corner_uvs.len()).any(open) {
        SharedEdges::of(&check)
    } else {
        SharedEdges::default()
    };
    out.collapsed_faces += collapse_all(mesh, &check.degenerate_3d, &shared, corner_uvs);
    // 2. Nudge the faces with 3-D area at fault (charts recomputed after the collapses, which
    //    can cut a chart).
    let check = orientation_check(mesh, corner_uvs, face_page);
    let faulty: Vec<usize> = (0..corner_uvs.len())
        .filter(|&f| check.fault(f) && !check.degenerate_3d[f])
        .collect();
    if !faulty.is_empty() {
        let vertices = UvVertices::of(&check);
        for &f in &faulty {
            if face_ok(&check, corner_uvs, f) {
                continue; // repaired by an earlier nudge at a shared vertex
            }
            if (0..3).any(|k| nudge(&check, &vertices, corner_uvs, f, k)) {
                out.nudged_vertices += 1;
                continue;
            }
            // A face whose UV corners coincide (a triangle smaller than the `f32` spacing)
            // has no opposite edge to move away from: separate one corner first.
            for k in 0..3 {
                if separate(&check, &vertices, corner_uvs, f, k)
                    && (0..3).any(|j| nudge(&check, &vertices, corner_uvs, f, j))
                {
                    out.nudged_vertices += 2;
                    break;
                }
            }
        }
    }
    // A nudge moves the ends of a collapsed face's long edge but not its third corner, which
    // has a key of its own: collapse again (a no-op where nothing moved).
    collapse_all(mesh, &check.degenerate_3d, &shared, corner_uvs);
    // 3. What is left, by the report's rules.
    let check = orientation_check(mesh, corner_uvs, face_page);
    out.unrepaired = (0..corner_uvs.len())
        .filter(|&f| check.fault(f))
        .map(|f| FaceId(f as u32))
        .collect();
    (out, check)
}

/// Collapses every face marked in `degenerate_3d` whose three UV corners are distinct; returns
/// how many. Such a face with UV area breaks the flip rules; one whose corners are collinear
/// (its lone vertex put on its UV segment) does not, but a raster's fixed-point rounding can
/// give it area, and two such faces on one segment (a zero-area face and its duplicate) then
/// cover a common texel centre.
fn collapse_all(
    mesh: &TriangleMesh,
    degenerate_3d: &[bool],
    shared: &SharedEdges,
    corner_uvs: &mut [[[f32; 2]; 3]],
) -> usize {
    let mut n = 0;
    for (f, uv) in corner_uvs.iter_mut().enumerate() {
        if degenerate_3d[f] && !two_equal(uv) {
            collapse(mesh, f, shared, uv);
            n += 1;
        }
    }
    n
}

/// Two of the three UV corners are equal (bit for bit, `-0.0 == 0.0`).
fn two_equal(uv: &[[f32; 2]; 3]) -> bool {
    uv[0] == uv[1] || uv[1] == uv[2] || uv[2] == uv[0]
}

/// Two equal corners for the 3-D-degenerate face `f`: it keeps one edge, the longest (in 3-D)
/// of those another face shares in the output (so that the face stays in its chart), or else
/// its longest edge; the third corner takes the UV of the nearer (in 3-D) end of that edge.
/// `A2` is then exactly 0.
fn collapse(mesh: &TriangleMesh, f: usize, shared: &SharedEdges, uv: &mut [[f32; 2]; 3]) {
    let p = mesh.face_positions(FaceId(f as u32));
    let d2 = |a: usize, b: usize| -> f64 { (0..3).map(|i| (p[a][i] - p[b][i]).powi(2)).sum() };
    // Edge k joins corners k and k+1; the corner off it is k+2. Ties to the lowest k.
    let rank = |k: usize| (shared.is_shared(f, k), d2(k, (k + 1) % 3));
    let k = (0..3)
        .max_by(|&a, &b| {
            let (ra, rb) = (rank(a), rank(b));
            ra.0.cmp(&rb.0).then(ra.1.total_cmp(&rb.1)).then(b.cmp(&a))
        })
        .unwrap_or(0);
    let (a, b, c) = (k, (k + 1) % 3, (k + 2) % 3);
    uv[c] = if d2(c, a) <= d2(c, b) { uv[a] } else { uv[b] };
}

/// Which half-edges of the output share their (unordered) pair of UV vertices with another
/// half-edge: the edges inside a chart.
#[derive(Default)]
struct SharedEdges {
    /// Per half-edge `3f + k`: shared.
    shared: Vec<bool>,
}

impl SharedEdges {
    /// The shared half-edges of the UVs `check` was computed on: those not on a chart's UV
    /// boundary (the report's connectivity, with the same UV vertex keys).
    fn of(check: &OrientationCheck) -> Self {
        Self {
            shared: check.uv_boundary.iter().map(|&b| !b).collect(),
        }
    }

    fn is_shared(&self, f: usize, k: usize) -> bool {
        self.shared.get(3 * f + k).copied().unwrap_or(false)
    }
}

/// The corners of the output grouped by key (glTF mesh, 3-D position, page, UV bits with
/// `-0.0 == 0.0`): a nudge moves a whole group, so the output's connectivity is unchanged.
struct UvVertices {
    /// Group of corner `3f + k`.
    group_of_corner: Vec<u32>,
    /// Corners of each group: `corners[start[g]..start[g + 1]]`, ascending.
    start: Vec<u32>,
    corners: Vec<u32>,
}

impl UvVertices {
    /// The UV vertices of the UVs `check` was computed on: its corner ids (the report's
    /// connectivity numbers the same keys), grouped by a counting sort. Cost: O(corners).
    fn of(check: &OrientationCheck) -> Self {
        let group_of_corner = check.corner_id.clone();
        let groups = group_of_corner
            .iter()
            .map(|&g| g as usize + 1)
            .max()
            .unwrap_or(0);
        let mut start = vec![0u32; groups + 1];
        for &g in &group_of_corner {
            start[g as usize + 1] += 1;
        }
        for g in 0..groups {
            start[g + 1] += start[g];
        }
        let mut next = start.clone();
        let mut corners = vec![0u32; group_of_corner.len()];
        // Corners in ascending order, so each group's come out ascending.
        for (c, &g) in group_of_corner.iter().enumerate() {
            corners[next[g as usize] as usize] = c as u32;
            next[g as usize] += 1;
        }
        Self {
            group_of_corner,
            start,
            corners,
        }
    }

    fn group(&self, corner: usize) -> &[u32] {
        let g = self.group_of_corner[corner] as usize;
        &self.corners[self.start[g] as usize..self.start[g + 1] as usize]
    }
}

/// `A2` and the report's UV-degeneracy of one UV triangle, with the formulas of
/// `measure/geometry.rs` (same operation order, so the same decisions).
fn signed_area(uv: &[[f32; 2]; 3]) -> (f64, bool) {
    let w = uv.map(|c| c.map(f64::from));
    let (ds1, dt1) = (w[1][0] - w[0][0], w[1][1] - w[0][1]);
    let (ds2, dt2) = (w[2][0] - w[0][0], w[2][1] - w[0][1]);
    let a2 = 0.5 * (ds1 * dt2 - ds2 * dt1);
    let l = ds1
        .hypot(dt1)
        .max(ds2.hypot(dt2))
        .max((w[2][0] - w[1][0]).hypot(w[2][1] - w[1][1]));
    let tol = 1e-12 * l * l;
    let degenerate = a2.abs().partial_cmp(&tol) != Some(std::cmp::Ordering::Greater);
    (a2, degenerate)
}

/// Face `f` (with 3-D area) is non-degenerate in UV and oriented as its chart was.
fn face_ok(check: &OrientationCheck, corner_uvs: &[[[f32; 2]; 3]], f: usize) -> bool {
    oriented(check, f, &corner_uvs[f])
}

/// The UV triangle `uv` of face `f` is non-degenerate and oriented as `f`'s chart.
fn oriented(check: &OrientationCheck, f: usize, uv: &[[f32; 2]; 3]) -> bool {
    let (a2, degenerate) = signed_area(uv);
    !degenerate && (a2 > 0.0) == check.chart_positive[check.chart_of_face[f] as usize]
}

/// Moves the UV vertex `group` (now at `c`) along `dir` by 1, 2, 4, … [`NUDGE_MAX_ULPS`] `f32`
/// spacings and keeps the first finite move that `allowed` accepts and after which every face
/// at the vertex but `except` is fine ([`moves_fine`]); returns whether one was kept.
fn first_fine_move(
    check: &OrientationCheck,
    group: &[u32],
    corner_uvs: &mut [[[f32; 2]; 3]],
    (c, dir): ([f32; 2], [f64; 2]),
    except: usize,
    allowed: impl Fn([f32; 2]) -> bool,
) -> bool {
    let mut steps = 1u32;
    while steps <= NUDGE_MAX_ULPS {
        let moved = step(c, dir, steps);
        steps *= 2;
        if moved == c || !moved.iter().all(|x| x.is_finite()) || !allowed(moved) {
            continue;
        }
        if moves_fine(check, group, corner_uvs, moved, except) {
            for &corner in group {
                corner_uvs[corner as usize / 3][corner as usize % 3] = moved;
            }
            return true;
        }
    }
    false
}

/// Moves the UV vertex at corner `k` of face `f` off the UV of the face's other corners, by
/// 1, 2, 4, … [`NUDGE_MAX_ULPS`] `f32` spacings along +u, −u, +v or −v (the first move after
/// which every other face at that vertex is still fine); returns whether one was made.
fn separate(
    check: &OrientationCheck,
    vertices: &UvVertices,
    corner_uvs: &mut [[[f32; 2]; 3]],
    f: usize,
    k: usize,
) -> bool {
    let c = corner_uvs[f][k];
    let group = vertices.group(3 * f + k);
    let uv = corner_uvs[f];
    let off_the_others = |moved: [f32; 2]| moved != uv[(k + 1) % 3] && moved != uv[(k + 2) % 3];
    [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]
        .into_iter()
        .any(|dir| first_fine_move(check, group, corner_uvs, (c, dir), f, off_the_others))
}

/// The `f32` spacing at `x`: the distance from `|x|` to the next larger `f32`.
fn f32_spacing(x: f32) -> f64 {
    let x = x.abs().max(f32::MIN_POSITIVE);
    f64::from(f32::from_bits(x.to_bits() + 1) - x)
}

/// `c` moved by `steps` `f32` spacings (the larger of its two coordinates') along `dir`.
fn step(c: [f32; 2], dir: [f64; 2], steps: u32) -> [f32; 2] {
    let d = f32_spacing(c[0]).max(f32_spacing(c[1])) * f64::from(steps);
    [
        (f64::from(c[0]) + d * dir[0]) as f32,
        (f64::from(c[1]) + d * dir[1]) as f32,
    ]
}

/// Whether every face at the UV vertex `group` but `except` (3-D-degenerate ones excepted) is
/// non-degenerate and oriented as its chart with the vertex at `moved`.
fn moves_fine(
    check: &OrientationCheck,
    group: &[u32],
    corner_uvs: &[[[f32; 2]; 3]],
    moved: [f32; 2],
    except: usize,
) -> bool {
    group.iter().all(|&corner| {
        let (g, j) = (corner as usize / 3, corner as usize % 3);
        if g == except || check.degenerate_3d[g] {
            return true;
        }
        let mut t = corner_uvs[g];
        t[j] = moved;
        oriented(check, g, &t)
    })
}

/// Tries to repair face `f` by moving its UV vertex at corner `k` (module doc, step 2). Keeps
/// the first move after which every face at that vertex is fine (3-D-degenerate ones excepted:
/// they keep two equal corners or were fine); returns whether one was kept.
fn nudge(
    check: &OrientationCheck,
    vertices: &UvVertices,
    corner_uvs: &mut [[[f32; 2]; 3]],
    f: usize,
    k: usize,
) -> bool {
    let positive = check.chart_positive[check.chart_of_face[f] as usize];
    let uv = corner_uvs[f];
    let (a, b, c) = (uv[(k + 1) % 3], uv[(k + 2) % 3], uv[k]);
    // A2 = ½ (b − a) × (c − a): its gradient in c is ½ (−e_v, e_u) with e = b − a.
    let e = [
        f64::from(b[0]) - f64::from(a[0]),
        f64::from(b[1]) - f64::from(a[1]),
    ];
    let len = e[0].hypot(e[1]);
    if len.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return false;
    }
    let sign = if positive { 1.0 } else { -1.0 };
    let n = [-e[1] / len * sign, e[0] / len * sign];
    let group = vertices.group(3 * f + k);
    first_fine_move(check, group, corner_uvs, (c, n), usize::MAX, |_| true)
}

/// Faces of one chart that overlap, for the caller to split off (step 3), once the sliver
/// moves (step 4) at an overlap are undone. First the pairs that cover a common texel centre by
/// the report's own sampling (the evaluator's fixed-point raster,
/// `measure::sampled_same_chart_pairs`): of each, the face of smaller 3-D area (ties: the higher
/// index). Validated `f64` maps do not overlap, but a 3-D sliver whose UV height is below the
/// raster's rounding (craft_speederD: 1e-5 texels) can cross its neighbour there. When there
/// are none, the pairs whose open UV triangles intersect by the report's exact test
/// (`measure::exact_overlaps`): a few faces that meet every such pair ([`cover_of_pairs`]:
/// each split-off face is one more chart to pack). A chart's border that comes back on itself
/// across a cut-out strip (craft_speederD: two border edges 3e-5 texels apart, a cut-out quad
/// between them in 3-D) is valid in `f64` and crosses itself once rounded to `f32`: one face
/// there crosses two.
///
/// Whenever a pair (of any chart, for the exact test) has a face at a kept sliver move, those
/// moves are undone and the UVs looked at again: a fix of rounding is worth less than a chart.
/// Returns the faces (ascending) and, when the search got that far, the exact overlaps of
/// `corner_uvs` as they leave, for the report to reuse when these UVs are the final ones.
/// `face_chart` is the pipeline's chart of each face; `size = [W, H]` texels.
pub(super) fn folds(
    mesh: &TriangleMesh,
    corner_uvs: &mut [[[f32; 2]; 3]],
    (face_page, num_pages): (&[u32], u32),
    size: [u32; 2],
    face_chart: &[u32],
    slivers: &mut SliverMoves,
) -> (Vec<FaceId>, Option<ExactOverlaps>) {
    loop {
        let sampled = super::measure::sampled_same_chart_pairs(
            corner_uvs, face_page, num_pages, size, face_chart,
        );
        if !sampled.is_empty() {
            if slivers.undo_at(&faces_of(&sampled), corner_uvs) > 0 {
                continue;
            }
            return (smaller_of_pairs(mesh, sampled), None);
        }
        let exact = exact_overlaps(corner_uvs, face_page, num_pages);
        if slivers.undo_at(&exact.faces(), corner_uvs) > 0 {
            continue;
        }
        let faces = cover_of_pairs(mesh, &exact.same_chart(face_chart));
        return (faces, Some(exact));
    }
}

/// Both faces of every pair, ascending, once each.
fn faces_of(pairs: &[(u32, u32)]) -> Vec<u32> {
    let mut faces: Vec<u32> = pairs.iter().flat_map(|&(a, b)| [a, b]).collect();
    faces.sort_unstable();
    faces.dedup();
    faces
}

/// Faces that meet every pair of `pairs`, chosen greedily: the face in the most pairs not met
/// yet, ties to the smaller 3-D area, then the higher index; ascending. Deterministic;
/// `O(k log k)` for `k` pairs (a heap of faces by pairs left, stale entries skipped), so a
/// hostile input with millions of crossings costs no more than finding them.
fn cover_of_pairs(mesh: &TriangleMesh, pairs: &[(u32, u32)]) -> Vec<FaceId> {
    use std::collections::{BTreeMap, BinaryHeap};
    // Faces, densely numbered, and the pairs at each.
    let mut index: BTreeMap<u32, usize> = BTreeMap::new();
    for &(a, b) in pairs {
        for f in [a, b] {
            let next = index.len();
            index.entry(f).or_insert(next);
        }
    }
    let mut face = vec![0u32; index.len()];
    for (&f, &i) in &index {
        face[i] = f;
    }
    let mut at: Vec<Vec<usize>> = vec![Vec::new(); face.len()];
    for (k, &(a, b)) in pairs.iter().enumerate() {
        at[index[&a]].push(k);
        at[index[&b]].push(k);
    }
    let mut left: Vec<usize> = at.iter().map(Vec::len).collect();
    let mut met = vec![false; pairs.len()];
    // Greater is picked first: more pairs left, then the smaller area, then the higher index.
    #[derive(PartialEq)]
    struct Entry {
        left: usize,
        area_m2: f64,
        face: u32,
        slot: usize,
    }
    impl Eq for Entry {}
    impl Ord for Entry {
        fn cmp(&self, o: &Self) -> std::cmp::Ordering {
            self.left
                .cmp(&o.left)
                .then(o.area_m2.total_cmp(&self.area_m2))
                .then(self.face.cmp(&o.face))
        }
    }
    impl PartialOrd for Entry {
        fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(o))
        }
    }
    let entry = |slot: usize, left: usize| Entry {
        left,
        area_m2: mesh.face_area_m2(FaceId(face[slot])),
        face: face[slot],
        slot,
    };
    let mut heap: BinaryHeap<Entry> = (0..face.len()).map(|i| entry(i, left[i])).collect();
    let mut chosen: Vec<FaceId> = Vec::new();
    while let Some(e) = heap.pop() {
        if e.left != left[e.slot] || e.left == 0 {
            continue;
        }
        chosen.push(FaceId(e.face));
        for &k in &at[e.slot] {
            if met[k] {
                continue;
            }
            met[k] = true;
            let (a, b) = pairs[k];
            for g in [index[&a], index[&b]] {
                left[g] -= 1;
                if g != e.slot && left[g] > 0 {
                    heap.push(entry(g, left[g]));
                }
            }
        }
    }
    chosen.sort_unstable();
    chosen
}

/// Of each pair, the face of smaller 3-D area (ties: the higher index), ascending.
fn smaller_of_pairs(mesh: &TriangleMesh, pairs: Vec<(u32, u32)>) -> Vec<FaceId> {
    let mut faces: Vec<FaceId> = pairs
        .into_iter()
        .map(|(a, b)| {
            let (fa, fb) = (FaceId(a), FaceId(b));
            if mesh.face_area_m2(fa) < mesh.face_area_m2(fb) {
                fa
            } else {
                fb
            }
        })
        .collect();
    faces.sort_unstable();
    faces.dedup();
    faces
}

/// The parts of a chart that the output's connectivity tears apart (the report's charts: faces
/// joined by a UV edge with the same corner keys, `check.chart_of_face`). A chart flattened as
/// one piece can meet itself, in the file, only through a vertex that the weld joined to a
/// near-coincident copy (`TriangleMesh::corner_position`: a needle's end 2e-15 from a corner),
/// or through a degenerate face that the collapse cut; its parts then lie side by side in UV
/// with no padding between them. Of each torn chart, every part but the one of largest 3-D area
/// (ties: the lowest report chart) is returned, faces ascending, for the caller to split off as
/// a chart of its own. Faces degenerate in 3-D (`check.degenerate_3d`) cover no texel and are
/// left out. `face_chart` is the pipeline's chart of each face. Deterministic: one sort.
pub(super) fn torn_parts(
    mesh: &TriangleMesh,
    check: &OrientationCheck,
    face_chart: &[u32],
) -> Vec<Vec<FaceId>> {
    // The usual case, in one pass: every chart is one report chart.
    let charts = face_chart
        .iter()
        .map(|&c| c as usize + 1)
        .max()
        .unwrap_or(0);
    let mut first = vec![u32::MAX; charts];
    let torn = (0..face_chart.len())
        .filter(|&f| !check.degenerate_3d[f])
        .any(|f| {
            let seen = &mut first[face_chart[f] as usize];
            if *seen == u32::MAX {
                *seen = check.chart_of_face[f];
            }
            *seen != check.chart_of_face[f]
        });
    if !torn {
        return Vec::new();
    }
    let mut items: Vec<(u32, u32, u32)> = (0..face_chart.len())
        .filter(|&f| !check.degenerate_3d[f])
        .map(|f| (face_chart[f], check.chart_of_face[f], f as u32))
        .collect();
    items.sort_unstable();
    let mut out = Vec::new();
    for chart in items.chunk_by(|a, b| a.0 == b.0) {
        let parts: Vec<&[(u32, u32, u32)]> = chart.chunk_by(|a, b| a.1 == b.1).collect();
        if parts.len() < 2 {
            continue;
        }
        let area = |part: &[(u32, u32, u32)]| -> f64 {
            part.iter().map(|x| mesh.face_area_m2(FaceId(x.2))).sum()
        };
        let keep = (0..parts.len())
            .max_by(|&i, &j| area(parts[i]).total_cmp(&area(parts[j])).then(j.cmp(&i)))
            .unwrap_or(0);
        for (i, part) in parts.iter().enumerate() {
            if i != keep {
                out.push(part.iter().map(|x| FaceId(x.2)).collect());
            }
        }
    }
    out
}

/// UV height, in texels, below which the last split round of `generate` splits a face off its
/// chart ([`raster_slivers`]). The report's and the evaluator's sampling snaps every corner to
/// `1/256` texel, a move of at most `√2/512` texel, which can flip a face whose UV height is
/// below about `1.4/256` texel and lay it over its neighbours; the margin covers the lower
/// density of the packing after the split (more charts). Trade-off: a higher bound splits off
/// faces that could not flip; a lower one leaves faces that the last packing may flip.
pub(super) const RASTER_SLIVER_TEXELS: f64 = 4.0 / 256.0;

/// The faces that the last split round of `generate` splits off besides the faults: every face
/// with 3-D area (not `check.degenerate_3d`) in a chart of more than one face (`charts`, the
/// pipeline's) whose UV height in `corner_uvs` (twice its area over its longest edge, on pages
/// of `size = [W, H]` texels) is below [`RASTER_SLIVER_TEXELS`], ascending. Splitting faults
/// off one at a time does not converge on charts made of such slivers: each packing rounds the
/// corners anew and the sampling's snapping flips another one over its neighbour (a fan of
/// 1,000 faces 1e-6 thick still had crossings after 12 rounds). Alone, a face cannot cover a
/// texel of its own chart twice, and keeps the padding from the others. Deterministic: the
/// faces sorted.
pub(super) fn raster_slivers(
    check: &OrientationCheck,
    corner_uvs: &[[[f32; 2]; 3]],
    size: [u32; 2],
    charts: &[Vec<FaceId>],
) -> Vec<FaceId> {
    let [w, h] = size.map(f64::from);
    let thin = |f: usize| {
        let p = corner_uvs[f].map(|c| [f64::from(c[0]) * w, f64::from(c[1]) * h]);
        let e = |a: usize, b: usize| (p[b][0] - p[a][0]).hypot(p[b][1] - p[a][1]);
        let longest = e(0, 1).max(e(1, 2)).max(e(2, 0));
        let cross =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
        // A face of no UV extent at all is the faults' business (it is one of them).
        longest > 0.0 && cross.abs() < RASTER_SLIVER_TEXELS * longest
    };
    let mut faces: Vec<FaceId> = charts
        .iter()
        .filter(|faces| faces.len() > 1)
        .flatten()
        .copied()
        .filter(|f| !check.degenerate_3d[f.index()] && thin(f.index()))
        .collect();
    faces.sort_unstable();
    faces
}

/// `validated` with each group of `groups` (faces ascending, each group within one chart)
/// split off its chart into a chart of its own (cut into disks, `segment::enforce_disks`), the
/// rest of that chart cut into disks too, validated again without merge-back (so the parts
/// stay apart). Step 3 of the module doc, and [`torn_parts`]; the caller packs again.
pub(super) fn split_off(
    mesh: &TriangleMesh,
    validated: &super::parameterize::ParameterizedCharts,
    groups: &[Vec<FaceId>],
    options: &super::AtlasOptions,
) -> Result<super::parameterize::ParameterizedCharts, super::AtlasError> {
    use super::progress::{Stage, StageProgress};
    use super::{parameterize, segment};
    let charts = &validated.segmentation.charts;
    let mut stats = validated.segmentation.stats;
    let mut group_of = vec![u32::MAX; mesh.num_faces()];
    for (g, faces) in groups.iter().enumerate() {
        for f in faces {
            group_of[f.index()] = g as u32;
        }
    }
    let mut proposed: Vec<Vec<FaceId>> = Vec::with_capacity(charts.len() + groups.len());
    for faces in charts {
        if faces.iter().all(|f| group_of[f.index()] == u32::MAX) {
            proposed.push(faces.clone());
            continue;
        }
        // The chart's faces by group (the rest under u32::MAX, last), in face order.
        let mut by_group: Vec<(u32, FaceId)> =
            faces.iter().map(|&f| (group_of[f.index()], f)).collect();
        by_group.sort_unstable();
        for part in by_group.chunk_by(|a, b| a.0 == b.0) {
            let group = part[0].0;
            let part: Vec<FaceId> = part.iter().map(|x| x.1).collect();
            if group != u32::MAX && part.len() == 1 {
                proposed.push(part);
            } else {
                proposed.extend(segment::enforce_disks(mesh, vec![part], &mut stats));
            }
        }
    }
    let seg = segment::finish(mesh, proposed, stats);
    Ok(parameterize::parameterize_charts(
        mesh,
        &seg,
        &parameterize::ParameterizeOptions {
            merge_passes: 0,
            ..options.parameterize
        },
        &mut StageProgress::ignored(Stage::Parameterize),
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atlas::segment::tests::build;
    use crate::mesh::MeshInput;

    #[test]
    fn folds_pick_the_smaller_face_of_a_sampled_fold_and_nothing_elsewhere() {
        // Two faces sharing the edge (4,0)-(0,4): face 0 of area 8, face 1 of area 4.
        let mesh = build(&MeshInput::single_group(
            vec![
                [0.0, 0.0, 0.0],
                [4.0, 0.0, 0.0],
                [0.0, 4.0, 0.0],
                [5.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [1, 3, 2]],
        ));
        assert!(mesh.face_area_m2(FaceId(1)) < mesh.face_area_m2(FaceId(0)));
        let face0 = [[0.1f32, 0.1], [0.5, 0.1], [0.1, 0.5]];
        let split_off = |apex: [f32; 2]| {
            let mut corner_uvs = [face0, [[0.5, 0.1], apex, [0.1, 0.5]]];
            let mut none = SliverMoves::default();
            folds(
                &mesh,
                &mut corner_uvs,
                (&[0, 0], 1),
                [64, 64],
                &[0, 0],
                &mut none,
            )
            .0
        };
        // Face 1 folded back over face 0: it covers face 0's texel centres.
        assert_eq!(split_off([0.2, 0.2]), vec![FaceId(1)]);
        // Unfolded, on the other side of the shared edge: nothing.
        assert!(split_off([0.45, 0.45]).is_empty());
    }

    #[test]
    fn the_cover_takes_the_face_in_most_pairs_first_then_the_smaller() {
        // Eight disjoint triangles, face i of area (i + 1) / 2.
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for i in 0..8u32 {
            let x = 10.0 * f64::from(i);
            positions.extend([
                [x, 0.0, 0.0],
                [x + 1.0, 0.0, 0.0],
                [x, f64::from(i + 1), 0.0],
            ]);
            triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let mesh = build(&MeshInput::single_group(positions, triangles));
        let cover = |pairs: &[(u32, u32)]| -> Vec<u32> {
            cover_of_pairs(&mesh, pairs).iter().map(|f| f.0).collect()
        };
        // A star on face 6 and a lone pair: face 6 meets three pairs; of 1 and 5, the smaller.
        assert_eq!(cover(&[(1, 6), (2, 6), (3, 6), (1, 5)]), vec![1, 6]);
        // A path 0-1-2-3: faces 1 and 2 meet two pairs each; 1 is smaller, then (2, 3) is left,
        // and 2 is the smaller of the two.
        assert_eq!(cover(&[(0, 1), (1, 2), (2, 3)]), vec![1, 2]);
        assert!(cover(&[]).is_empty());
    }

    #[test]
    fn folds_split_off_a_crossing_the_raster_misses_with_the_fewest_faces() {
        // A chart's border coming back on itself by 1e-4 texel: no texel centre is covered
        // twice, but the open triangles intersect.
        let mesh = build(&MeshInput::single_group(
            vec![
                [0.0, 0.0, 0.0],
                [4.0, 0.0, 0.0],
                [0.0, 4.0, 0.0],
                [-1.0, 5.0, 0.0],
                [1.0, 5.0, 0.0],
                [0.0, 6.0, 0.0],
            ],
            vec![[0, 1, 2], [2, 4, 5], [2, 5, 3]],
        ));
        // Face 0's top edge runs along v = 0.5 from u = 0.25 to 0.5; faces 1 and 2 lie above
        // it, but their shared corner sits `eps` below it, inside face 0: both cross it by a
        // band thinner than any texel row.
        let eps = 1e-4 / 64.0;
        let face0 = [[0.1f32, 0.1], [0.5, 0.5], [0.25, 0.5]];
        let crossing = [0.3f32, 0.5 - eps];
        let corner_uvs = [
            face0,
            [crossing, [0.5, 0.6], [0.25, 0.65]],
            [crossing, [0.25, 0.65], [0.15, 0.6]],
        ];
        for t in &corner_uvs {
            let (p, q, r) = (t[0], t[1], t[2]);
            let area = (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]);
            assert!(area > 0.0, "test premise: every face is counter-clockwise");
        }
        let (pages, chart) = (&[0, 0, 0], &[0, 0, 0]);
        let mut uvs = corner_uvs;
        let mut none = SliverMoves::default();
        let (faces, exact) = folds(&mesh, &mut uvs, (pages, 1), [64, 64], chart, &mut none);
        let exact = exact.expect("test premise: the raster sees no fold, so the exact test ran");
        let pairs = exact.same_chart(chart);
        assert_eq!(pairs, vec![(0, 1), (0, 2)]);
        // One face meets both pairs: face 0, not the two smaller ones.
        assert_eq!(faces, vec![FaceId(0)]);
        // In two charts, the crossing is not a fold of a chart: nothing to split off.
        let (faces, _) = folds(&mesh, &mut uvs, (pages, 1), [64, 64], &[0, 1, 1], &mut none);
        assert!(faces.is_empty());
    }

    #[test]
    fn torn_parts_are_the_smaller_parts_of_a_chart_the_output_does_not_join() {
        // Three faces in a row (0–1 share edge 1-2, 1–2 share edge 2-3), all in chart 0.
        let mesh = build(&MeshInput::single_group(
            vec![
                [0.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
                [0.0, 2.0, 0.0],
                [2.0, 2.0, 0.0],
                [3.0, 3.0, 0.0],
            ],
            vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]],
        ));
        let p = |v: [f64; 3]| [(0.1 + 0.1 * v[0]) as f32, (0.1 + 0.1 * v[1]) as f32];
        let mut uvs: Vec<[[f32; 2]; 3]> = (0..3)
            .map(|f| mesh.face_positions(FaceId(f)).map(p))
            .collect();
        let torn = |uvs: &[[[f32; 2]; 3]], face_chart: &[u32]| {
            let check = orientation_check(&mesh, uvs, &[0, 0, 0]);
            torn_parts(&mesh, &check, face_chart)
        };
        assert!(torn(&uvs, &[0, 0, 0]).is_empty(), "one piece");
        // Face 2's copy of vertex 3 one spacing off: in the output, face 2 meets the rest at
        // vertex 2 only. It is the smaller part.
        uvs[2][1][0] = f32::from_bits(uvs[2][1][0].to_bits() + 1);
        assert_eq!(torn(&uvs, &[0, 0, 0]), vec![vec![FaceId(2)]]);
        // Already a chart of its own: nothing torn.
        assert!(torn(&uvs, &[0, 0, 1]).is_empty());
    }

    #[test]
    fn uv_vertices_and_shared_edges_follow_the_output_vertex_keys() {
        // A fan of four faces around vertex 0 with a UV seam between faces 1 and 2, and a
        // fifth face at vertex 0 on another page whose other two vertices are copies of
        // vertices 1 and 2 in a second weld group. Keys are compared by brute force: glTF
        // mesh, position bits, page, UV bits with -0.0 as 0.0.
        let mut input = MeshInput::single_group(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [-1.0, 0.0, 0.0],
                [0.0, -1.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1], [0, 5, 6]],
        );
        input.weld_group = vec![0, 0, 0, 0, 0, 1, 1];
        let mesh = build(&input);
        let corner_uvs: Vec<[[f32; 2]; 3]> = vec![
            [[0.5, 0.5], [0.9, 0.5], [0.5, 0.9]],
            [[0.5, 0.5], [0.5, 0.9], [0.1, 0.5]],
            [[0.0, 0.5], [0.0, 0.1], [0.4, 0.1]],
            [[-0.0, 0.5], [0.4, 0.1], [0.9, 0.5]],
            [[0.5, 0.5], [0.9, 0.5], [0.5, 0.9]],
        ];
        let face_page = [0, 0, 0, 0, 1];
        let check = orientation_check(&mesh, &corner_uvs, &face_page);
        let key = |c: usize| {
            let (f, k) = (c / 3, c % 3);
            let v = mesh.face_vertices(FaceId(f as u32))[k];
            let p = mesh
                .position(v)
                .map(|x| if x == 0.0 { 0 } else { x.to_bits() });
            let uv = corner_uvs[f][k].map(|x| if x == 0.0 { 0 } else { x.to_bits() });
            (mesh.vertex_weld_group(v), p, face_page[f], uv)
        };
        let vertices = UvVertices::of(&check);
        for c in 0..15 {
            let expected: Vec<u32> = (0..15)
                .filter(|&d| key(d) == key(c))
                .map(|d| d as u32)
                .collect();
            assert_eq!(vertices.group(c), expected.as_slice(), "corner {c}");
        }
        // Vertex 0 of faces 2 and 3 (0.0 and -0.0) is one UV vertex; face 4's copy of face
        // 0's is another (its page).
        assert_eq!(vertices.group(6), &[6, 9]);
        assert_eq!(vertices.group(0), &[0, 3]);
        let shared = SharedEdges::of(&check);
        let ends = |h: usize| {
            let (f, k) = (h / 3, h % 3);
            let (a, b) = (key(3 * f + k), key(3 * f + (k + 1) % 3));
            if a <= b {
                (a, b)
            } else {
                (b, a)
            }
        };
        for h in 0..15 {
            let others = (0..15).filter(|&g| g != h && ends(g) == ends(h)).count();
            assert_eq!(shared.is_shared(h / 3, h % 3), others > 0, "half-edge {h}");
        }
        // Inside a chart: faces 0 and 1 (edge 0-2), faces 2 and 3 (edge 0-4, through -0.0).
        // Across the seam (edge 0-3 of faces 1 and 2) and everywhere on face 4: not shared.
        assert!(shared.is_shared(0, 2) && shared.is_shared(1, 0));
        assert!(shared.is_shared(2, 2) && shared.is_shared(3, 0));
        assert!(!shared.is_shared(1, 2) && !shared.is_shared(2, 0));
        assert!((0..3).all(|k| !shared.is_shared(4, k)));
    }
}
