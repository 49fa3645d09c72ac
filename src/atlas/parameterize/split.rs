//! Where a chart with a defect is split: the two seed faces it is re-grown from, breadth-first
//! at once ([`split_for`]), by defect — the ends of a diameter for a flip or a parameterizer
//! failure, the faces of the two crossing segments for an overlap or a fold, the faces of
//! smallest and largest model area per UV area for the area tests, and the lengthwise seeds of
//! [`super::sock`] for an over-stretched sock-shaped chart. Both parts are connected and
//! non-empty.
use super::ChartDefect;
use crate::atlas::segment::grow_two;
use crate::mesh::{FaceId, TriangleMesh};

/// The two parts a chart with `defect` is split into, and the `splits` index of the cause
/// (`None` for a parameterizer failure, split by diameter); `None` when no split is possible.
pub(super) fn split_for(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    defect: &ChartDefect,
) -> Option<(Vec<FaceId>, Vec<FaceId>, Option<usize>)> {
    // Membership by a per-mesh flag array for big charts (zeroed lazily by the allocator), by
    // binary search in the sorted faces for small ones; the same answers.
    let member: Vec<bool> = if faces.len().saturating_mul(16) >= mesh.num_faces() {
        let mut m = vec![false; mesh.num_faces()];
        for &f in faces {
            m[f.index()] = true;
        }
        m
    } else {
        Vec::new()
    };
    let inside = |f: FaceId| {
        if member.is_empty() {
            faces.binary_search(&f).is_ok()
        } else {
            member[f.index()]
        }
    };
    let diameter = || {
        let a = *crate::atlas::segment::flood(mesh, &faces[..1], &inside, faces)
            .last()
            .unwrap_or(&faces[0]);
        let b = *crate::atlas::segment::flood(mesh, &[a], &inside, faces)
            .last()
            .unwrap_or(&a);
        (a, b)
    };
    let (a, b, cause) = match defect {
        ChartDefect::Flipped { .. } => {
            let (a, b) = diameter();
            (a, b, Some(0))
        }
        ChartDefect::BoundaryOverlap { faces: [a, b] } => (*a, *b, Some(1)),
        ChartDefect::AreaRatio {
            min_face, max_face, ..
        } => (*min_face, *max_face, Some(2)),
        ChartDefect::Stretch {
            min_face, max_face, ..
        } => {
            let (a, b) =
                super::sock::stretch_split_seeds(mesh, faces, &inside, *min_face, *max_face);
            (a, b, Some(2))
        }
        ChartDefect::Unparameterizable(_) => {
            let (a, b) = diameter();
            (a, b, None)
        }
    };
    let (mut pa, mut pb) = grow_two(mesh, faces, &inside, a, b);
    if pb.is_empty() {
        // Both seeds in one face (an overlap within one face's edges): split by diameter.
        let (a, b) = diameter();
        (pa, pb) = grow_two(mesh, faces, &inside, a, b);
    }
    (!pb.is_empty()).then_some((pa, pb, cause))
}
