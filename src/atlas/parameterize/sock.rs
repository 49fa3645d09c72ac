//! Sock-shaped charts: LSCM paper §3.2 ("an additional cut is added to sock-shaped extremal
//! cylinders", Figure 5-B).
//!
//! Purpose: a chart that is a cylinder closed at one end (a finger, a toe, a tail, an ear) is a
//! topological disk, but its conformal map squeezes the closed end towards the centre of the
//! disk, and the squeeze grows exponentially with the length of the cylinder (measured on the
//! armadillo: grown sock charts of the hands, feet and tail have Sander L2 stretch 4.6 to 4808,
//! against 1.0–1.1 for the other charts). The paper cuts such a chart from its seed (the tip,
//! where `distance_to_features` is largest) along the steepest descent of that distance, so the
//! chart unrolls.
//!
//! **Departure, stated.** A chart here is a set of faces glued along every interior edge (see
//! `mod.rs`): a cut *inside* a chart (a seam) cannot be represented, since the parameterizer, the
//! validation and the pipeline all map a chart vertex to one UV. So the cut is made as a split:
//! the chart is cut along a curve that runs from the rim over the tip and back to the rim on the
//! other side, i.e. along the steepest-descent path from the tip on both sides, and becomes two
//! half-socks, each of which unrolls like a half-cylinder with a quarter-sphere cap. The curve is
//! the bisector of two rim faces half the rim length apart: the two halves are grown from them
//! breadth-first at once (`grow_two`), so each half is connected and meets the other along the
//! equidistant curve, which passes over the tip.
//!
//! Detection: the paper uses the area / perimeter ratio; here a chart is sock-shaped when it is
//! over-stretched (the validation's stretch bound failed) and its most squeezed face (largest
//! model area per UV area) lies deep inside it: at least half as many face rings from the
//! boundary as the deepest face. Measured on the armadillo, the area / perimeter ratio alone does
//! not separate the socks (a hand with fingers has a long rim and a small ratio, a dome a large
//! ratio and a fine map), the squeeze does: it is where the map fails.
//!
//! Invariants: deterministic (ties by lowest id); the two seeds are distinct faces of the chart
//! when the chart has at least two faces on its boundary; pure.
//!
//! References: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least Squares Conformal Maps for
//! Automatic Texture Atlas Generation", SIGGRAPH 2002, §3.2 and Figure 5.
use std::collections::VecDeque;

use crate::mesh::{FaceId, HalfedgeId, TriangleMesh};

use crate::atlas::segment::sorted_faces;

/// Breadth-first depth of every face of the chart (`faces` ascending, or any order) from its
/// boundary faces (depth 0: a face with an edge that is not glued to a chart face), in the order
/// of the sorted faces. Faces unreachable from the boundary (a closed chart) get `u32::MAX`.
pub(super) fn boundary_depth(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    inside: &dyn Fn(FaceId) -> bool,
) -> Vec<u32> {
    let sorted = sorted_faces(faces);
    let mut depth = vec![u32::MAX; sorted.len()];
    let mut queue = VecDeque::new();
    for (k, &f) in sorted.iter().enumerate() {
        let on_boundary = mesh
            .face_neighbors(f)
            .into_iter()
            .any(|g| g.is_none_or(|g| !inside(g)));
        if on_boundary {
            depth[k] = 0;
            queue.push_back(k);
        }
    }
    while let Some(k) = queue.pop_front() {
        let d = depth[k] + 1;
        for g in mesh.face_neighbors(sorted[k]).into_iter().flatten() {
            if !inside(g) {
                continue;
            }
            if let Ok(j) = sorted.binary_search(&g) {
                if depth[j] == u32::MAX {
                    depth[j] = d;
                    queue.push_back(j);
                }
            }
        }
    }
    depth
}

/// The boundary half-edges of a chart (face inside, opposite absent or outside) in walking order
/// along the loop that holds the lowest one. Empty for a closed chart.
pub(super) fn boundary_loop(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    inside: &dyn Fn(FaceId) -> bool,
) -> Vec<HalfedgeId> {
    let glued_inside = |h: HalfedgeId| mesh.opposite(h).filter(|o| inside(o.face()));
    let mut boundary: Vec<HalfedgeId> = faces
        .iter()
        .flat_map(|&f| mesh.face_halfedges(f))
        .filter(|&h| glued_inside(h).is_none())
        .collect();
    boundary.sort_unstable();
    let Some(&first) = boundary.first() else {
        return Vec::new();
    };
    let mut seen = vec![false; boundary.len()];
    let mut out = Vec::new();
    let mut h = first;
    // Each step visits a new boundary half-edge; bounded by their count.
    for _ in 0..boundary.len() {
        let Ok(k) = boundary.binary_search(&h) else {
            break;
        };
        if seen[k] {
            break;
        }
        seen[k] = true;
        out.push(h);
        // The successor leaves `to(h)`: rotate (g -> next(opposite(g))) while glued inside.
        let mut g = h.next();
        for _ in 0..mesh.num_halfedges() {
            match glued_inside(g) {
                Some(o) => g = o.next(),
                None => break,
            }
        }
        h = g;
    }
    out
}

/// The two seed faces from which an over-stretched chart is split (module doc): for a
/// sock-shaped chart, two rim faces half the rim length apart (the split then runs over the
/// tip); otherwise the paper's faces of smallest and largest model area per UV area,
/// `(min_face, max_face)`. `faces` ascending (or any order), connected.
pub fn stretch_split_seeds(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    inside: &dyn Fn(FaceId) -> bool,
    min_face: FaceId,
    max_face: FaceId,
) -> (FaceId, FaceId) {
    let paper = (min_face, max_face);
    let sorted = sorted_faces(faces);
    let depth = boundary_depth(mesh, &sorted, inside);
    let deepest = depth
        .iter()
        .copied()
        .filter(|&d| d != u32::MAX)
        .max()
        .unwrap_or(0);
    let Ok(k) = sorted.binary_search(&max_face) else {
        return paper;
    };
    let squeezed = depth[k];
    // A tip at least 2 rings deep and at least half as deep as the deepest face.
    if squeezed == u32::MAX || squeezed < 2 || 2 * squeezed < deepest {
        return paper;
    }
    let rim = boundary_loop(mesh, &sorted, inside);
    if rim.len() < 2 {
        return paper;
    }
    let lengths: Vec<f64> = rim.iter().map(|&h| mesh.edge_length_m(h)).collect();
    let total: f64 = lengths.iter().sum();
    // `a`: the face of the loop's first (lowest) edge; `b`: the face of the rim edge that starts
    // half the rim length further along.
    let a = rim[0].face();
    let mut acc = 0.0;
    let mut b = a;
    for (h, l) in rim.iter().zip(&lengths) {
        if acc >= 0.5 * total {
            b = h.face();
            break;
        }
        acc += l;
    }
    if a == b {
        return paper;
    }
    (a, b)
}
