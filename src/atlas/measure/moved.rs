//! An [`OrientationCheck`] brought up to date after a few UV vertices moved, so that the report
//! need not compute the geometry and connectivity of every face again ([`measure_atlas_reusing`]
//! with a check).
//!
//! Purpose: the UV guard's sliver repair moves a handful of UV vertices after the guard's check
//! (70 of 1M faces' corners on a 1M-triangle scan); recomputing the check costs a full
//! connectivity pass (a third of a second there). A move that keeps every corner key's partition
//! changes only the `A2` of the faces at the moved corners, the charts' orientations and the
//! numbering of the corner ids within the moved corners' position ids: charts, UV boundaries and
//! seams are functions of the partition alone.
//!
//! Invariant: the result is what [`orientation_check`] gives on the moved UVs, field for field
//! (`measure_atlas_reusing` asserts it in debug builds); when a move joins a corner to another
//! key or splits a key, no update is attempted (`None`).
//!
//! [`measure_atlas_reusing`]: super::measure_atlas_reusing
//! [`orientation_check`]: super::orientation_check
use super::charts::fold32;
use super::geometry::uv_area;
use super::{chart_orientation_of, OrientationCheck};

impl OrientationCheck {
    /// The check of `corner_uvs`, which differ from the UVs this check was computed on at the
    /// corners of `faces` only (any order, repeats allowed); `face_page` as given to the check.
    /// `None` when the moved corners' keys are no longer partitioned as before (a moved corner
    /// landed on another key of its position, or the corners of one key went apart): the caller
    /// computes the check again. Cost: O(faces) for the bookkeeping, plus a sort of the corners
    /// that share a position with a moved corner.
    pub(crate) fn after_uv_moves(
        mut self,
        corner_uvs: &[[[f32; 2]; 3]],
        face_page: &[u32],
        faces: &[u32],
    ) -> Option<Self> {
        let nf = corner_uvs.len();
        if self.signed_uv_area.len() != nf || face_page.len() != nf {
            return None;
        }
        for &f in faces {
            let (a2, degenerate) = uv_area(corner_uvs.get(f as usize)?);
            self.signed_uv_area[f as usize] = a2;
            self.uv_degenerate[f as usize] = degenerate;
        }
        // Every corner at a position of a moved corner, keyed as the connectivity keys it.
        let pid = &self.rest.corner_pid;
        let num_pids = pid.iter().map(|&p| p as usize + 1).max().unwrap_or(0);
        let mut hit = vec![false; num_pids];
        for &f in faces {
            for k in 0..3 {
                hit[pid[3 * f as usize + k] as usize] = true;
            }
        }
        let mut keyed: Vec<([u32; 4], u32, u32)> = (0..3 * nf)
            .filter(|&c| hit[pid[c] as usize])
            .map(|c| {
                let uv = corner_uvs[c / 3][c % 3];
                let key = [pid[c], face_page[c / 3], fold32(uv[0]), fold32(uv[1])];
                (key, self.corner_id[c], c as u32)
            })
            .collect();
        keyed.sort_unstable();
        // The partition is unchanged when keys and ids correspond one to one.
        let mut key_ids: Vec<([u32; 4], u32)> = keyed.iter().map(|&(k, id, _)| (k, id)).collect();
        key_ids.dedup();
        let mut keys: Vec<[u32; 4]> = key_ids.iter().map(|&(k, _)| k).collect();
        keys.dedup();
        let mut ids: Vec<u32> = key_ids.iter().map(|&(_, id)| id).collect();
        ids.sort_unstable();
        ids.dedup();
        if keys.len() != key_ids.len() || ids.len() != key_ids.len() {
            return None;
        }
        // Ids are numbered by position id, then by (page, u, v): each position id keeps its
        // range (it has as many keys as before), numbered again in its keys' order.
        let mut i = 0;
        while i < key_ids.len() {
            let p = key_ids[i].0[0];
            let mut j = i;
            while j < key_ids.len() && key_ids[j].0[0] == p {
                j += 1;
            }
            let first = key_ids[i..j].iter().map(|&(_, id)| id).min()?;
            for (n, entry) in key_ids[i..j].iter_mut().enumerate() {
                entry.1 = first + n as u32;
            }
            i = j;
        }
        let mut n = 0;
        for &(key, _, c) in &keyed {
            while key_ids[n].0 != key {
                n += 1;
            }
            self.corner_id[c as usize] = key_ids[n].1;
        }
        let (_, positive) = chart_orientation_of(
            &self.signed_uv_area,
            &self.uv_degenerate,
            &self.chart_of_face,
            self.rest.num_charts,
        );
        self.chart_positive = positive;
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::super::{orientation_check, same_check};
    use crate::mesh::{MeshInput, TriangleMesh};
    use proptest::prelude::*;

    /// A grid of `n × n` quads (two triangles each) in the plane z = 0; the columns left of
    /// `cut` are one chart, the rest another (their UVs 0.5 apart in u), so the vertices on the
    /// cut have two UV keys.
    fn grid(n: u32, cut: u32) -> (TriangleMesh, Vec<[[f32; 2]; 3]>) {
        let mut pos = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                pos.push([f64::from(i), f64::from(j), 0.0]);
            }
        }
        let (mut tris, mut uvs) = (Vec::new(), Vec::new());
        let s = 0.4 / n as f32;
        for j in 0..n {
            for i in 0..n {
                let v = |a: u32, b: u32| (a + b * (n + 1), [a as f32 * s, b as f32 * s]);
                let u0 = if i < cut { 0.0 } else { 0.5 };
                for t in [
                    [v(i, j), v(i + 1, j), v(i + 1, j + 1)],
                    [v(i, j), v(i + 1, j + 1), v(i, j + 1)],
                ] {
                    tris.push(t.map(|(id, _)| id));
                    uvs.push(t.map(|(_, uv)| [u0 + uv[0], uv[1]]));
                }
            }
        }
        let input = MeshInput::single_group(pos, tris);
        (TriangleMesh::build(&input).expect("a grid").mesh, uvs)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// Moving whole UV vertices (every corner of a key), onto fresh points, onto another
        /// key's point or past it, or moving part of a key: the updated check is the fresh one,
        /// or `None` only when the keys' partition changed.
        #[test]
        fn the_updated_check_is_the_fresh_one(
            n in 1u32..5,
            cut in 0u32..5,
            moves in proptest::collection::vec(
                (any::<proptest::sample::Index>(), -0.3f32..0.3, -0.3f32..0.3, 0u8..4),
                1..4,
            ),
        ) {
            let (mesh, mut uvs) = grid(n, cut.min(n));
            let pages = vec![0; uvs.len()];
            let before = orientation_check(&mesh, &uvs, &pages);
            let ncorners = before.corner_id.len();
            let mut faces = Vec::new();
            for (pick, du, dv, kind) in moves {
                let c = pick.index(ncorners);
                let id = before.corner_id[c];
                let group: Vec<usize> =
                    (0..ncorners).filter(|&k| before.corner_id[k] == id).collect();
                let old = uvs[c / 3][c % 3];
                let to = match kind {
                    // Onto the point of another corner (at the same position or not).
                    0 => {
                        let o = pick.index(ncorners * 7 + 3) % ncorners;
                        uvs[o / 3][o % 3]
                    }
                    _ => [old[0] + du, old[1] + dv],
                };
                let moved: &[usize] = if kind == 1 { &group[..1] } else { &group };
                for &k in moved {
                    uvs[k / 3][k % 3] = to;
                    faces.push((k / 3) as u32);
                }
            }
            let fresh = orientation_check(&mesh, &uvs, &pages);
            let same_partition = {
                // Two corners share an id before and after, or in neither.
                let c = &before.corner_id;
                let d = &fresh.corner_id;
                (0..ncorners).all(|a| (0..ncorners).all(|b| (c[a] == c[b]) == (d[a] == d[b])))
            };
            match before.after_uv_moves(&uvs, &pages, &faces) {
                Some(updated) => prop_assert!(same_check(&updated, &fresh)),
                None => prop_assert!(!same_partition),
            }
        }
    }

    /// A vertex on the cut between two charts has two keys at one position; moving the left
    /// chart's key past the right one's in u renumbers the two ids, which the update does.
    #[test]
    fn a_key_moved_past_another_at_its_position_is_numbered_again() {
        let (mesh, mut uvs) = grid(2, 1);
        let pages = vec![0; uvs.len()];
        let before = orientation_check(&mesh, &uvs, &pages);
        // Vertex (1, 1) of the grid: corners of the left chart at u = 0.2.
        let at = |uv: [f32; 2]| uv == [0.2, 0.2];
        let mut faces = Vec::new();
        for (f, face) in uvs.iter_mut().enumerate() {
            for uv in face.iter_mut().filter(|uv| at(**uv)) {
                *uv = [0.95, 0.21];
                faces.push(f as u32);
            }
        }
        assert!(!faces.is_empty());
        let fresh = orientation_check(&mesh, &uvs, &pages);
        assert_ne!(
            before.corner_id, fresh.corner_id,
            "the ids are numbered again"
        );
        let updated = before
            .after_uv_moves(&uvs, &pages, &faces)
            .expect("same partition");
        assert!(same_check(&updated, &fresh));
    }

    /// A key moved onto another key at its position joins them: no update.
    #[test]
    fn a_key_moved_onto_another_at_its_position_is_refused() {
        let (mesh, mut uvs) = grid(2, 1);
        let pages = vec![0; uvs.len()];
        let before = orientation_check(&mesh, &uvs, &pages);
        let mut faces = Vec::new();
        for (f, face) in uvs.iter_mut().enumerate() {
            for uv in face.iter_mut().filter(|uv| **uv == [0.2, 0.2]) {
                *uv = [0.7, 0.2];
                faces.push(f as u32);
            }
        }
        assert!(before.after_uv_moves(&uvs, &pages, &faces).is_none());
    }
}
