//! Building a [`TriangleMesh`] from a [`MeshInput`]: validate, weld, glue, repair.
//!
//! Purpose: the only way to obtain a `TriangleMesh`. Fatal problems become a
//! [`MeshBuildError`]; everything else is repaired according to the policy in [`crate::mesh`] and
//! reported as [`MeshDefect`]s.
//!
//! Algorithm (all steps sort- or array-based; O(n log n) worst case even on hostile input, no
//! hash maps, no per-vertex `Vec`s, deterministic whatever the rayon thread count because every
//! sort key is unique):
//! 1. Validate sizes, indices and coordinates of referenced vertices.
//! 2. Weld: sort referenced source vertices by `(hash of (weld group, x, y, z bits), index)`;
//!    each run of equal hashes is confirmed (or, on a collision, split) by the full key, and each
//!    group of equal keys becomes one welded vertex, named by its lowest source index.
//! 3. Degenerate faces: repeated welded vertex, or zero area (`geometry::triangle_is_zero_area`).
//!    The ends of a near-zero-length edge of a zero-area face (relative to that face and to
//!    the faces of area at either end) are joined (union-find in ascending pair order, each
//!    group named by its lowest source index; [`NEAR_WELD_RELATIVE`]), except where a join
//!    would put two corners of a face of area into one group, and the faces classified again.
//!    Faces with a repeated vertex are isolated (their corners become vertices of their own).
//! 4. Group half-edges by undirected welded edge (bucket by lower end, sort each bucket) and glue:
//!    exactly one half-edge each way → glued; otherwise repair (pair greedily or cut) and report.
//! 5. Fans: rotate around each corner's vertex through the glued half-edges (`opposite(prev(h))`).
//!    Each fan is one final vertex, so a welded vertex with several fans is split, one copy per
//!    fan (non-manifold vertex repair). Final vertices are numbered by (lowest source index, lowest
//!    corner), so on clean input with every position used, `VertexId(i)` is source vertex `i`.
//!
//! Measured (`tests/it/mesh_build_bench.rs`, opt-level 3, shared 2-core machine under load): about
//! 0.25 s for a 1M-triangle grid and 0.35 s for the 1M-triangle `beast_sub2_1M` (random vertex
//! order costs cache misses), about 130 bytes per face at peak including the input.
//!
//! Units: positions in model units (`_m`), untouched (no transform, no rescaling).
use rayon::iter::{
    IndexedParallelIterator, IntoParallelIterator, IntoParallelRefIterator, ParallelIterator,
};
use rayon::slice::ParallelSliceMut;

use super::defect::{BadIndex, DegenerateKind, MeshBuildError, MeshDefect, Offenders};
use super::geometry::triangle_is_zero_area;
use super::ids::{FaceId, HalfedgeId, VertexId};
use super::input::MeshInput;
use super::topology::{TriangleMesh, NONE};

/// The largest triangle count: `3 * triangles` half-edge ids must stay below `u32::MAX`, which
/// marks "no opposite".
pub const MAX_TRIANGLES: usize = (u32::MAX / 3 - 1) as usize;

/// A built mesh and the defects that were repaired while building it.
#[derive(Debug, Clone)]
pub struct BuiltMesh {
    /// The welded, repaired, manifold mesh. Face `i` is input triangle `i`.
    pub mesh: TriangleMesh,
    /// Every repaired problem, each naming its elements. Order: degenerate triangles (by face),
    /// edge defects (by lowest face), non-manifold vertices (by source vertex), unreferenced vertices.
    pub defects: Vec<MeshDefect>,
    /// Number of distinct welded vertices (used source vertices after welding by position and
    /// group, and after the joins of near-coincident ends of zero-area faces), before repair
    /// splits and isolated-face copies. `mesh.num_vertices()` is at least this on a mesh without
    /// repeated-vertex faces.
    pub num_welded_vertices: usize,
}

/// An edge of a zero-area face at most this fraction of the face's longest edge, and of the
/// shortest edge of each face of area at either end, joins its two ends, unless that collapses a
/// face of area (the module doc of [`crate::mesh`], "Weld rule").
pub const NEAR_WELD_RELATIVE: f64 = 1e-9;

/// The corner `k` whose edge to corner `k + 1` is the shortest of the triangle `p` when that
/// edge is at most [`NEAR_WELD_RELATIVE`] of the longest (ties: the lowest `k`); `None`
/// otherwise, or when the triangle has no length at all (every corner equal).
fn near_coincident_edge(p: &[[f64; 3]; 3]) -> Option<usize> {
    let l = [dist2(p[0], p[1]), dist2(p[1], p[2]), dist2(p[2], p[0])];
    let longest = l[0].max(l[1]).max(l[2]);
    if !(longest > 0.0 && longest.is_finite()) {
        return None;
    }
    let k = (0..3).min_by(|&a, &b| l[a].total_cmp(&l[b]))?;
    (l[k] <= NEAR_WELD_RELATIVE * NEAR_WELD_RELATIVE * longest).then_some(k)
}

/// Squared distance between two points.
fn dist2(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// `-0.0` and `0.0` weld together: compare bits of the coordinate with the sign of zero cleared.
#[inline]
fn weld_bits(x: f64) -> u64 {
    if x == 0.0 {
        0
    } else {
        x.to_bits()
    }
}

impl TriangleMesh {
    /// Validates, welds and repairs a triangle soup. See the module docs of [`crate::mesh`] for
    /// the weld rule and the repair policy.
    ///
    /// Errors (nothing is built): zero triangles, `weld_group` length mismatch, more than
    /// [`MAX_TRIANGLES`] triangles, out-of-range indices, non-finite coordinates on a used vertex.
    ///
    /// Cost: O(n log n) time; about 60 bytes per face kept, about 100 bytes per face temporarily.
    pub fn build(input: &MeshInput) -> Result<BuiltMesh, MeshBuildError> {
        let tris = &input.triangles;
        let pos = &input.positions_m;
        let nf = tris.len();
        let ns = pos.len();
        if nf == 0 {
            return Err(MeshBuildError::NoTriangles);
        }
        if input.weld_group.len() != ns {
            return Err(MeshBuildError::WeldGroupLengthMismatch {
                positions: ns,
                weld_groups: input.weld_group.len(),
            });
        }
        if nf > MAX_TRIANGLES || ns > u32::MAX as usize {
            return Err(MeshBuildError::TooLarge {
                triangles: nf,
                positions: ns,
                max_triangles: MAX_TRIANGLES,
            });
        }

        // 1. Indices in range, used coordinates finite.
        let mut bad_index = Offenders::new();
        for (f, t) in tris.iter().enumerate() {
            for (k, &i) in t.iter().enumerate() {
                if i as usize >= ns {
                    bad_index.push(BadIndex {
                        face: FaceId(f as u32),
                        slot: k as u8,
                        index: i,
                    });
                }
            }
        }
        if !bad_index.is_empty() {
            return Err(MeshBuildError::IndexOutOfRange {
                offenders: bad_index,
                num_positions: ns,
            });
        }
        let mut referenced = vec![false; ns];
        for t in tris {
            for &i in t {
                referenced[i as usize] = true;
            }
        }
        let mut non_finite = Offenders::new();
        let mut unreferenced = Offenders::new();
        for (s, p) in pos.iter().enumerate() {
            if !referenced[s] {
                unreferenced.push(s as u32);
            } else if !p.iter().all(|x| x.is_finite()) {
                non_finite.push(s as u32);
            }
        }
        if !non_finite.is_empty() {
            return Err(MeshBuildError::NonFiniteCoordinate {
                source_vertices: non_finite,
            });
        }

        // 2. Weld. `welded[s]` = lowest source index with the same group and position bits.
        let (welded, num_welded_vertices) = weld(input, &referenced);
        drop(referenced);
        let corner_source: Vec<u32> = tris.iter().flatten().copied().collect();
        let mut wv: Vec<u32> = corner_source.iter().map(|&s| welded[s as usize]).collect();
        drop(welded);
        let mut num_welded_vertices = num_welded_vertices;

        // 3. Degenerate faces (independent per face: parallel map, collected in face order).
        let degeneracy = |wv: &[u32]| -> Vec<Option<DegenerateKind>> {
            (0..nf)
                .into_par_iter()
                .map(|f| {
                    let [a, b, c] = [wv[3 * f], wv[3 * f + 1], wv[3 * f + 2]];
                    if a == b || b == c || a == c {
                        Some(DegenerateKind::RepeatedVertex)
                    } else {
                        let p = tris[f].map(|i| pos[i as usize]);
                        triangle_is_zero_area(&p).then_some(DegenerateKind::ZeroArea)
                    }
                })
                .collect()
        };
        let mut face_degeneracy = degeneracy(&wv);
        // 3b. Near-coincident ends of a zero-area face (the module doc of `crate::mesh`), also
        // near-coincident beside the faces of area at either end: their shortest edge is the
        // local scale (a needle to a far vertex makes a real edge short relative to itself).
        let mut local_edge2 = vec![f64::INFINITY; ns];
        for (f, kind) in face_degeneracy.iter().enumerate() {
            if kind.is_none() {
                let p = tris[f].map(|i| pos[i as usize]);
                let shortest = (0..3)
                    .map(|k| dist2(p[k], p[(k + 1) % 3]))
                    .fold(f64::INFINITY, f64::min);
                for k in 0..3 {
                    let w = wv[3 * f + k] as usize;
                    local_edge2[w] = local_edge2[w].min(shortest);
                }
            }
        }
        let candidates: Vec<(u32, u32)> = face_degeneracy
            .par_iter()
            .enumerate()
            .filter(|(_, k)| **k == Some(DegenerateKind::ZeroArea))
            .filter_map(|(f, _)| {
                let p = tris[f].map(|i| pos[i as usize]);
                let k = near_coincident_edge(&p)?;
                let (a, b) = (tris[f][k], tris[f][(k + 1) % 3]);
                let (wa, wb) = (wv[3 * f + k], wv[3 * f + (k + 1) % 3]);
                let local = local_edge2[wa as usize].min(local_edge2[wb as usize]);
                let near =
                    dist2(p[k], p[(k + 1) % 3]) <= NEAR_WELD_RELATIVE * NEAR_WELD_RELATIVE * local;
                (near && input.weld_group[a as usize] == input.weld_group[b as usize])
                    .then_some((wa, wb))
            })
            .collect();
        // ... unless a face of area would get two corners in one joined group: the join would
        // make it a repeated-vertex face, collapsed, where the file gives it area. (A needle
        // face to one stray far vertex is zero-area relative to its own length, and its short
        // edge may be a real edge of the surface; two such joins, each harmless alone, can
        // chain two corners of a face of area into one group.)
        let joins = allowed_joins(&candidates, &wv, &face_degeneracy);
        let joined = !joins.is_empty();
        if joined {
            for w in wv.iter_mut() {
                *w = joins[*w as usize];
            }
            num_welded_vertices -= joins
                .iter()
                .enumerate()
                .filter(|&(i, &r)| i as u32 != r)
                .count();
            face_degeneracy = degeneracy(&wv);
        }
        let mut defects: Vec<MeshDefect> = face_degeneracy
            .iter()
            .enumerate()
            .filter_map(|(f, kind)| {
                kind.map(|kind| MeshDefect::DegenerateTriangle {
                    face: FaceId(f as u32),
                    kind,
                })
            })
            .collect();
        let isolated = |f: usize| face_degeneracy[f] == Some(DegenerateKind::RepeatedVertex);

        // 4. Glue half-edges by undirected welded edge.
        let nh = 3 * nf;
        let mut opposite = vec![NONE; nh];
        let mut edge_defects = Vec::new();
        {
            // Bucket half-edges by their lower welded end point (counting sort), then sort each
            // bucket by (upper end point, half-edge id): runs of equal upper ends are edges.
            let mut start = vec![0u32; ns + 1];
            for h in 0..nh {
                if !isolated(h / 3) {
                    let (a, b) = (wv[h], wv[next(h)]);
                    start[a.min(b) as usize + 1] += 1;
                }
            }
            for i in 0..ns {
                start[i + 1] += start[i];
            }
            let mut fill = start.clone();
            let mut entries = vec![0u64; start[ns] as usize];
            for h in 0..nh {
                if !isolated(h / 3) {
                    let (a, b) = (wv[h], wv[next(h)]);
                    let lo = a.min(b) as usize;
                    entries[fill[lo] as usize] = (u64::from(a.max(b)) << 32) | h as u64;
                    fill[lo] += 1;
                }
            }
            drop(fill);
            for lo in 0..ns {
                let bucket = &mut entries[start[lo] as usize..start[lo + 1] as usize];
                if bucket.len() > 1 {
                    bucket.sort_unstable();
                }
                for run in bucket.chunk_by(|x, y| x >> 32 == y >> 32) {
                    let hi = (run[0] >> 32) as u32;
                    let h_of = |e: u64| (e & 0xffff_ffff) as u32;
                    match run {
                        [_] => {}
                        [x, y] => {
                            let (hx, hy) = (h_of(*x), h_of(*y));
                            if wv[hx as usize] != wv[hy as usize] {
                                opposite[hx as usize] = hy;
                                opposite[hy as usize] = hx;
                            } else {
                                edge_defects.push(MeshDefect::InconsistentOrientation {
                                    faces: [FaceId(hx / 3), FaceId(hy / 3)],
                                    source_vertices: [lo as u32, hi],
                                });
                            }
                        }
                        _ => {
                            // More than two faces: pair them greedily in face order, the lowest
                            // remaining face with the lowest remaining face running the other
                            // way. With both directions in ascending lists that is simply the
                            // i-th with the i-th (O(k), even for a hostile 1M-face edge). Faces
                            // left without a partner are cut off.
                            let (lo_first, hi_first): (Vec<u32>, Vec<u32>) = (
                                run.iter()
                                    .map(|&e| h_of(e))
                                    .filter(|&h| wv[h as usize] == lo as u32)
                                    .collect(),
                                run.iter()
                                    .map(|&e| h_of(e))
                                    .filter(|&h| wv[h as usize] != lo as u32)
                                    .collect(),
                            );
                            let glued = lo_first
                                .iter()
                                .zip(&hi_first)
                                .map(|(&h0, &h1)| {
                                    opposite[h0 as usize] = h1;
                                    opposite[h1 as usize] = h0;
                                    let (f0, f1) = (FaceId(h0 / 3), FaceId(h1 / 3));
                                    [f0.min(f1), f0.max(f1)]
                                })
                                .collect();
                            edge_defects.push(MeshDefect::NonManifoldEdge {
                                faces: run.iter().map(|&e| FaceId(h_of(e) / 3)).collect(),
                                glued,
                                source_vertices: [lo as u32, hi],
                            });
                        }
                    }
                }
            }
        }
        edge_defects.sort_by_key(|d| d.faces().first().copied());
        defects.append(&mut edge_defects);

        // 5. Fans. Rotating around a vertex with `h -> opposite(prev(h))` walks one fan; each fan
        // becomes one vertex, so a welded vertex with several fans is split. Rotation is
        // injective (prev and opposite are), so every walk ends on the boundary or returns to its
        // start. Corners are visited in ascending order: a fan is found at its lowest corner.
        let mut fan_of = vec![NONE; nh];
        // Per fan: (lowest source index << 32 | lowest corner), the final vertex order key.
        let mut fan_key: Vec<u64> = Vec::new();
        // Per fan: its first outgoing half-edge, the boundary one if the fan is open.
        let mut fan_start: Vec<u32> = Vec::new();
        for c in 0..nh {
            if fan_of[c] != NONE {
                continue;
            }
            let mut start = c;
            loop {
                let o = opposite[start];
                if o == NONE {
                    break;
                }
                let p = next(o as usize);
                if p == c {
                    start = c;
                    break;
                }
                start = p;
            }
            let id = fan_key.len() as u32;
            let mut min_src = u32::MAX;
            let mut h = start;
            loop {
                fan_of[h] = id;
                min_src = min_src.min(corner_source[h]);
                let o = opposite[prev(h)];
                if o == NONE || o as usize == start {
                    break;
                }
                h = o as usize;
            }
            fan_key.push((u64::from(min_src) << 32) | c as u64);
            fan_start.push(start as u32);
        }
        let nfans = fan_key.len();
        let mut order = fan_key;
        order.sort_unstable();
        let mut rank = vec![0u32; nfans];
        let mut positions_m = Vec::with_capacity(nfans);
        let mut vertex_source = Vec::with_capacity(nfans);
        let mut vertex_weld_group = Vec::with_capacity(nfans);
        let mut vertex_halfedge = Vec::with_capacity(nfans);
        for (r, &k) in order.iter().enumerate() {
            let (src, first) = ((k >> 32) as usize, (k & 0xffff_ffff) as usize);
            let fan = fan_of[first] as usize;
            rank[fan] = r as u32;
            // After joins, every vertex sits at its welded group's position (that of its
            // lowest source), isolated corners too, so that equal positions still mean one
            // welded point; each corner keeps its own in `moved_sources`.
            positions_m.push(if joined {
                pos[wv[first] as usize]
            } else {
                pos[src]
            });
            vertex_source.push(src as u32);
            vertex_weld_group.push(input.weld_group[src]);
            vertex_halfedge.push(HalfedgeId(fan_start[fan]));
        }
        drop(fan_start);
        let corner_vertex: Vec<VertexId> =
            fan_of.iter().map(|&f| VertexId(rank[f as usize])).collect();
        drop(fan_of);
        drop(rank);

        // Non-manifold vertices: welded vertices that ended up with more than one fan
        // (corners of isolated degenerate faces are not fans and were reported already).
        let mut fans = vec![0u32; ns];
        for &k in &order {
            let first = (k & 0xffff_ffff) as usize;
            if !isolated(first / 3) {
                fans[wv[first] as usize] += 1;
            }
        }
        let mut split: Vec<(u32, VertexId)> = order
            .iter()
            .enumerate()
            .filter_map(|(id, &k)| {
                let first = (k & 0xffff_ffff) as usize;
                let w = wv[first];
                (!isolated(first / 3) && fans[w as usize] > 1).then_some((w, VertexId(id as u32)))
            })
            .collect();
        drop(fans);
        split.sort_unstable();
        for group in split.chunk_by(|x, y| x.0 == y.0) {
            defects.push(MeshDefect::NonManifoldVertex {
                source_vertex: group[0].0,
                vertices: group.iter().map(|&(_, v)| v).collect(),
            });
        }
        if !unreferenced.is_empty() {
            defects.push(MeshDefect::UnreferencedVertices {
                source_vertices: unreferenced,
            });
        }

        // The sources whose own position is not their vertex's: only after joins.
        let mut moved_sources: Vec<(u32, [f64; 3])> = Vec::new();
        if joined {
            for (c, &s) in corner_source.iter().enumerate() {
                let own = pos[s as usize];
                if own.map(weld_bits) != positions_m[corner_vertex[c].index()].map(weld_bits) {
                    moved_sources.push((s, own));
                }
            }
            moved_sources.sort_unstable_by_key(|e| e.0);
            moved_sources.dedup_by_key(|e| e.0);
        }
        let mesh = TriangleMesh {
            moved_sources,
            positions_m,
            corner_vertex,
            opposite,
            vertex_halfedge,
            vertex_source,
            vertex_weld_group,
            corner_source,
            face_degeneracy,
        };
        debug_assert_eq!(mesh.check_invariants(), Ok(()));
        Ok(BuiltMesh {
            mesh,
            defects,
            num_welded_vertices,
        })
    }
}

/// Index of the next corner in the same face.
#[inline]
fn next(h: usize) -> usize {
    h - h % 3 + (h % 3 + 1) % 3
}

/// Index of the previous corner in the same face.
#[inline]
fn prev(h: usize) -> usize {
    h - h % 3 + (h % 3 + 2) % 3
}

/// The weld key of a source vertex: its group and its coordinate bits (`-0.0` as `0.0`).
type WeldKey = (u32, [u64; 3]);

/// The joins of step 3b: every candidate pair `(a, b)` of welded vertices (ends of a
/// near-coincident edge of a zero-area face) is joined unless that would put two corners of a
/// face of area (`degeneracy` `None`, corners `wv`) into one group, whether the pair itself is an
/// edge of that face or the groups already joined chain them. The pairs are taken in ascending
/// order (deterministic); each group is named by its lowest welded id (the lowest source index,
/// as the weld names them). Returns, for each welded id, the id of its group, or an empty vector
/// when nothing is joined. Cost: only the faces of area with two corners among the candidates'
/// vertices are tracked; a union scans the shorter of its groups' lists and merges it into the
/// longer (each face moves O(log) times), and a pair of groups found to collapse a face is
/// remembered, so its list is scanned again only after one of the groups has grown.
fn allowed_joins(
    candidates: &[(u32, u32)],
    wv: &[u32],
    degeneracy: &[Option<DegenerateKind>],
) -> Vec<u32> {
    if candidates.is_empty() {
        return Vec::new();
    }
    let mut pairs: Vec<(u32, u32)> = candidates
        .iter()
        .filter(|(a, b)| a != b)
        .map(|&(a, b)| (a.min(b), a.max(b)))
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    let mut ends: Vec<u32> = pairs.iter().flat_map(|&(a, b)| [a, b]).collect();
    ends.sort_unstable();
    ends.dedup();
    let slot = |v: u32| ends.binary_search(&v).ok();
    // Per candidate vertex (by slot): the faces of area with two or more corners among the
    // candidates' vertices (only those can collapse), as their corner slots.
    let mut watched: Vec<[Option<usize>; 3]> = Vec::new();
    let mut faces_of: Vec<Vec<u32>> = vec![Vec::new(); ends.len()];
    for (f, kind) in degeneracy.iter().enumerate() {
        if kind.is_some() {
            continue;
        }
        let c = [0, 1, 2].map(|k| slot(wv[3 * f + k]));
        if c.iter().flatten().count() >= 2 {
            let id = watched.len() as u32;
            for &s in c.iter().flatten() {
                faces_of[s].push(id);
            }
            watched.push(c);
        }
    }
    // Union-find over slots; a group's root is its lowest slot (its lowest welded id).
    let mut parent: Vec<usize> = (0..ends.len()).collect();
    fn find(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    let mut any = false;
    // Pairs of groups (by root) found to collapse a face: groups only grow, so such a face keeps
    // a corner in each, and the pair stays refused without another scan.
    let mut refused: std::collections::BTreeSet<(usize, usize)> = Default::default();
    for (a, b) in pairs {
        let (Some(sa), Some(sb)) = (slot(a), slot(b)) else {
            continue;
        };
        let (ra, rb) = (find(&mut parent, sa), find(&mut parent, sb));
        if ra == rb || refused.contains(&(ra.min(rb), ra.max(rb))) {
            continue;
        }
        // A face of area with a corner in each group is in both lists: scan the shorter.
        let (small, large) = if faces_of[ra].len() <= faces_of[rb].len() {
            (ra, rb)
        } else {
            (rb, ra)
        };
        let collapses = faces_of[small].iter().any(|&id| {
            let roots = watched[id as usize].map(|c| c.map(|s| find(&mut parent, s)));
            roots.contains(&Some(small)) && roots.contains(&Some(large))
        });
        if collapses {
            refused.insert((ra.min(rb), ra.max(rb)));
            continue;
        }
        let moved = std::mem::take(&mut faces_of[small]);
        faces_of[large].extend(moved);
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi] = lo;
        if lo != large {
            faces_of.swap(lo, large);
        }
        any = true;
    }
    if !any {
        return Vec::new();
    }
    let n = wv.iter().map(|&w| w as usize + 1).max().unwrap_or(0);
    let mut group: Vec<u32> = (0..n as u32).collect();
    for s in 0..ends.len() {
        let r = find(&mut parent, s);
        group[ends[s] as usize] = ends[r];
    }
    group
}

/// A 64-bit mix of a weld key (splitmix64 finaliser per word). Only a sort key: equal hashes are
/// always confirmed on the full key, so collisions cost time, never correctness.
#[inline]
fn weld_hash(k: &WeldKey) -> u64 {
    let mut h = u64::from(k.0) ^ 0x9e37_79b9_7f4a_7c15;
    for w in k.1 {
        h ^= w;
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^= h >> 31;
    }
    h
}

/// For every source vertex, the lowest source index with the same weld group and position bits
/// (`-0.0 == 0.0`); unreferenced vertices map to themselves and are never used. Also returns the
/// number of welded vertices.
///
/// Sorts 16-byte `(hash, index)` pairs rather than 40-byte full keys (about twice as fast at 1M
/// vertices); each run of equal hashes is then split by the full key.
fn weld(input: &MeshInput, referenced: &[bool]) -> (Vec<u32>, usize) {
    weld_with_hash(input, referenced, weld_hash)
}

/// [`weld`] with the hash as a parameter, so tests can force every key to collide.
fn weld_with_hash(
    input: &MeshInput,
    referenced: &[bool],
    hash: impl Fn(&WeldKey) -> u64 + Sync,
) -> (Vec<u32>, usize) {
    let key_of = |s: u32| -> WeldKey {
        (
            input.weld_group[s as usize],
            input.positions_m[s as usize].map(weld_bits),
        )
    };
    let mut hashed: Vec<(u64, u32)> = (0..input.positions_m.len() as u32)
        .filter(|&s| referenced[s as usize])
        .map(|s| (hash(&key_of(s)), s))
        .collect();
    // Pairs are unique (they end with the source index), so the parallel unstable sort gives the
    // same order whatever the thread count.
    hashed.par_sort_unstable();
    let mut welded: Vec<u32> = (0..input.positions_m.len() as u32).collect();
    let mut count = 0;
    for run in hashed.chunk_by(|x, y| x.0 == y.0) {
        if run.len() == 1 {
            // Most vertices: a unique hash, nothing to compare (and no random position read).
            count += 1;
            continue;
        }
        let first = key_of(run[0].1);
        if run.iter().all(|&(_, s)| key_of(s) == first) {
            // The usual case: one position (the run is in source order, so run[0] is lowest).
            count += 1;
            for &(_, s) in run {
                welded[s as usize] = run[0].1;
            }
        } else {
            // A hash collision: split the run by full key, O(k log k) even for hostile runs.
            let mut full: Vec<(WeldKey, u32)> = run.iter().map(|&(_, s)| (key_of(s), s)).collect();
            full.sort_unstable();
            for sub in full.chunk_by(|x, y| x.0 == y.0) {
                count += 1;
                for &(_, s) in sub {
                    welded[s as usize] = sub[0].1;
                }
            }
        }
    }
    (welded, count)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures;

    #[test]
    fn weld_is_the_same_when_every_hash_collides() {
        let input = fixtures::concat(&[
            fixtures::uv_sphere(6, 8, 1.0),
            fixtures::cube_split_faces(),
            fixtures::degenerate(),
        ]);
        let referenced = vec![true; input.positions_m.len()];
        let normal = weld(&input, &referenced);
        let colliding = weld_with_hash(&input, &referenced, |_| 7);
        assert_eq!(normal, colliding);
        // Independent count: distinct position bit patterns (one group here).
        let distinct: std::collections::HashSet<[u64; 3]> =
            input.positions_m.iter().map(|p| p.map(weld_bits)).collect();
        assert_eq!(normal.1, distinct.len());
        // Sphere 2 + 5·8 and cube 8 share the point (0, 0, 1); the degenerate fixture adds
        // only (1, 0.5, 0) beyond the cube's corners.
        assert_eq!(normal.1, 42 + 8 - 1 + 1);
        assert_ne!(weld_hash(&(0, [1, 2, 3])), weld_hash(&(0, [1, 3, 2])));
    }
}
