//! Charts, seams and boundaries recomputed from the output (the evaluator's connectivity).
//!
//! A corner's key is (glTF mesh, 3-D position, page, UV), exact bits with `-0.0 == 0.0`. Two
//! faces are connected when they have a half-edge with the same unordered pair of corner keys;
//! charts are the connected components, numbered by lowest face. The page is part of the key so
//! that a chart never spans pages; with one page this is exactly the evaluator's rule.
//!
//! Seams: a half-edge whose corner-key pair no other half-edge has is a chart-boundary
//! half-edge (when its two ends are distinct positions); it is a *seam* half-edge when another
//! half-edge joins the same two (mesh, position) points, else an open border.
//!
//! Cost: O(faces) — one sort over the vertices (not the corners), counting sorts of the corners
//! into per-vertex buckets, each sorted on its own (a handful of entries), and of the half-edges
//! by their (lower, higher) end ids (two stable counting passes, no comparison sort).
use super::numpy::np_sum;
use crate::mesh::{FaceId, TriangleMesh, VertexId};

/// Connectivity results.
pub(super) struct Connectivity {
    /// Chart of each face, charts numbered by lowest face.
    pub chart_of_face: Vec<u32>,
    /// Number of charts.
    pub num_charts: usize,
    /// Distinct corner keys.
    pub unique_corners: usize,
    /// Distinct cut 3-D edges.
    pub seam_edges: usize,
    /// Their total 3-D length, each once.
    pub seam_length_3d_m: f64,
    /// 3-D length of all chart-boundary half-edges.
    pub boundary_length_3d_m: f64,
    /// 3-D length of the boundary half-edges that are open mesh borders.
    pub open_border_length_3d_m: f64,
    /// Per half-edge `3f + k` (corner `k` to `k + 1` of face `f`): whether no other half-edge
    /// has its unordered corner-key pair, i.e. it lies on its chart's UV boundary (outer or
    /// hole).
    pub uv_boundary: Vec<bool>,
    /// Per corner `3f + k`: its corner key's id (glTF mesh, position, page and UV bits, `-0.0`
    /// as `0.0`), numbered `0..unique_corners`: by position id, then by (page, u, v) within
    /// one position id.
    pub corner_id: Vec<u32>,
    /// Per corner `3f + k`: the id of its (glTF mesh, position) key, numbered in the order of
    /// the keys.
    pub corner_pid: Vec<u32>,
}

/// Bit pattern with `-0.0` folded onto `0.0`, as a signed integer: position ids are then
/// numbered in the evaluator's order (it sorts the `int64` views of the bits), so that sums
/// over seams run in the same order.
fn fold64(x: f64) -> i64 {
    if x == 0.0 {
        0
    } else {
        x.to_bits() as i64
    }
}

pub(super) fn fold32(x: f32) -> u32 {
    if x == 0.0 {
        0
    } else {
        x.to_bits()
    }
}

/// Stable counting sort of `0..keys.len()` by `keys[i] < num_buckets`: returns the bucket
/// offsets (`num_buckets + 1`) and the item order.
fn bucket_order(num_buckets: usize, keys: &[u32]) -> (Vec<u32>, Vec<u32>) {
    bucket_items(num_buckets, keys, 0..keys.len() as u32)
}

/// Stable counting sort of `items` (each of `0..keys.len()` once, in the order given) by
/// `keys[item] < num_buckets`: the bucket offsets (`num_buckets + 1`) and the sorted items.
fn bucket_items(
    num_buckets: usize,
    keys: &[u32],
    items: impl IntoIterator<Item = u32>,
) -> (Vec<u32>, Vec<u32>) {
    let mut offsets = vec![0u32; num_buckets + 1];
    for &k in keys {
        offsets[k as usize + 1] += 1;
    }
    for i in 0..num_buckets {
        offsets[i + 1] += offsets[i];
    }
    let mut next = offsets.clone();
    let mut order = vec![0u32; keys.len()];
    for e in items {
        let k = keys[e as usize] as usize;
        order[next[k] as usize] = e;
        next[k] += 1;
    }
    (offsets, order)
}

/// The half-edges `0..lo.len()` ordered by `(lo, hi, index)` with two stable counting sorts
/// (by `hi`, then by `lo`), and the offsets of each `lo` bucket (`num_buckets + 1`): the order
/// of a bucket sort by `lo` with each bucket sorted by `(hi, index)`, without comparisons.
fn pair_order(num_buckets: usize, lo: &[u32], hi: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let (_, by_hi) = bucket_order(num_buckets, hi);
    bucket_items(num_buckets, lo, by_hi)
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let p = parent[x as usize];
        parent[x as usize] = parent[p as usize];
        x = p;
    }
    x
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    // The smaller root wins, so every root is its component's lowest face.
    if ra < rb {
        parent[rb as usize] = ra;
    } else if rb < ra {
        parent[ra as usize] = rb;
    }
}

/// Computes charts, corner count, seams and boundary lengths. `edge_len_m[f][k]` is the 3-D
/// length of half-edge `k → k+1` of face `f`.
pub(super) fn connectivity(
    mesh: &TriangleMesh,
    corner_uvs: &[[[f32; 2]; 3]],
    face_page: &[u32],
    edge_len_m: &[[f64; 3]],
) -> Connectivity {
    let nf = mesh.num_faces();
    // 1. Position ids (glTF mesh + position bits), per mesh vertex: one sort over the vertices.
    //    A corner whose source position differs from its vertex's (`TriangleMesh::corner_position`:
    //    the weld joined near-coincident copies) gets the id of its own position, as in the file:
    //    such corners are keyed as extra entries `nv + j`, `j` their corner index in `moved`.
    let nv = mesh.num_vertices();
    let moved: Vec<u32> = if mesh.has_moved_sources() {
        (0..3 * nf as u32)
            .filter(|&c| {
                let (f, k) = (FaceId(c / 3), (c % 3) as usize);
                mesh.corner_position(f.corner(k)) != mesh.position(mesh.face_vertices(f)[k])
            })
            .collect()
    } else {
        Vec::new()
    };
    let key_of =
        |group: u32, p: [f64; 3], id: u32| (group, [fold64(p[0]), fold64(p[1]), fold64(p[2])], id);
    let mut vkeys: Vec<(u32, [i64; 3], u32)> = (0..nv as u32)
        .map(|v| {
            let vid = VertexId(v);
            key_of(mesh.vertex_weld_group(vid), mesh.position(vid), v)
        })
        .chain(moved.iter().enumerate().map(|(j, &c)| {
            let (f, k) = (FaceId(c / 3), (c % 3) as usize);
            let v = mesh.face_vertices(f)[k];
            key_of(
                mesh.vertex_weld_group(v),
                mesh.corner_position(f.corner(k)),
                (nv + j) as u32,
            )
        }))
        .collect();
    vkeys.sort_unstable();
    let mut pid_of_vertex = vec![0u32; nv + moved.len()];
    let mut num_pids = 0u32;
    for i in 0..vkeys.len() {
        if i > 0 && (vkeys[i].0, vkeys[i].1) != (vkeys[i - 1].0, vkeys[i - 1].1) {
            num_pids += 1;
        }
        pid_of_vertex[vkeys[i].2 as usize] = num_pids;
    }
    let num_pids = if vkeys.is_empty() {
        0
    } else {
        num_pids as usize + 1
    };
    drop(vkeys);

    // 2. Corner ids: bucket corners by position id, then sort each bucket by (page, u, v).
    let mut corner_pid: Vec<u32> = (0..nf)
        .flat_map(|f| {
            mesh.face_vertices(FaceId(f as u32))
                .map(|v| pid_of_vertex[v.index()])
        })
        .collect();
    for (j, &c) in moved.iter().enumerate() {
        corner_pid[c as usize] = pid_of_vertex[nv + j];
    }
    // Half-edge e = 3f + k runs from corner k to corner k+1 of face f; its unordered ends.
    let ends = |ids: &[u32], e: usize| {
        let (f, k) = (e / 3, e % 3);
        let (a, b) = (ids[3 * f + k], ids[3 * f + (k + 1) % 3]);
        (a.min(b), a.max(b))
    };
    // Steps 2–3 (corner ids, UV edges, charts) and the grouping of step 4 (3-D edges by
    // position-id pair) are independent until step 4's last loop: computed concurrently.
    let (
        (num_cids, corner_id, uv_edge_unique, chart_of_face, num_charts),
        (plo, phi, offsets, order),
    ) = rayon::join(
        || {
            let (offsets, mut order) = bucket_order(num_pids, &corner_pid);
            let corner_key = |c: u32| {
                let (f, k) = (c as usize / 3, c as usize % 3);
                let uv = corner_uvs[f][k];
                (face_page[f], fold32(uv[0]), fold32(uv[1]), c)
            };
            let mut corner_id = vec![0u32; 3 * nf];
            let mut num_cids = 0u32;
            for b in 0..num_pids {
                let bucket = &mut order[offsets[b] as usize..offsets[b + 1] as usize];
                bucket.sort_unstable_by_key(|&c| corner_key(c));
                let mut prev = None;
                for &c in bucket.iter() {
                    let (page, u, v, _) = corner_key(c);
                    if prev.is_some() && prev != Some((page, u, v)) {
                        num_cids += 1;
                    }
                    prev = Some((page, u, v));
                    corner_id[c as usize] = num_cids;
                }
                if prev.is_some() {
                    num_cids += 1;
                }
            }
            let num_cids = num_cids as usize;
            drop(order);

            // 3. Group half-edges by unordered corner-id pair (bucket by the lower id, then the higher).
            let (lo, hi): (Vec<u32>, Vec<u32>) = (0..3 * nf).map(|e| ends(&corner_id, e)).unzip();
            let (offsets, order) = pair_order(num_cids, &lo, &hi);
            drop(lo);
            let mut parent: Vec<u32> = (0..nf as u32).collect();
            let mut uv_edge_unique = vec![false; 3 * nf];
            for b in 0..num_cids {
                let bucket = &order[offsets[b] as usize..offsets[b + 1] as usize];
                let mut i = 0;
                while i < bucket.len() {
                    let h = hi[bucket[i] as usize];
                    let mut j = i + 1;
                    while j < bucket.len() && hi[bucket[j] as usize] == h {
                        union(&mut parent, bucket[j - 1] / 3, bucket[j] / 3);
                        j += 1;
                    }
                    if j == i + 1 {
                        uv_edge_unique[bucket[i] as usize] = true;
                    }
                    i = j;
                }
            }
            drop((order, hi));

            // Charts numbered by lowest face (= the root, since the smaller root always wins).
            let mut chart_of_face = vec![0u32; nf];
            let mut chart_of_root = vec![u32::MAX; nf];
            let mut num_charts = 0u32;
            for f in 0..nf as u32 {
                let r = find(&mut parent, f) as usize;
                if chart_of_root[r] == u32::MAX {
                    chart_of_root[r] = num_charts;
                    num_charts += 1;
                }
                chart_of_face[f as usize] = chart_of_root[r];
            }
            drop(parent);
            drop(chart_of_root);
            (
                num_cids,
                corner_id,
                uv_edge_unique,
                chart_of_face,
                num_charts,
            )
        },
        || {
            let (plo, phi): (Vec<u32>, Vec<u32>) =
                (0..3 * nf).map(|e| ends(&corner_pid, e)).unzip();
            let (offsets, order) = pair_order(num_pids, &plo, &phi);
            (plo, phi, offsets, order)
        },
    );

    // 4. 3-D edges: group half-edges by unordered position-id pair.
    let mut seam_edges = 0usize;
    let mut seam_len = Vec::new();
    // Per half-edge: 1 = chart boundary (seam side), 2 = open border, 0 = neither.
    let mut boundary_kind = vec![0u8; 3 * nf];
    let len = |e: u32| edge_len_m[e as usize / 3][e as usize % 3];
    for b in 0..num_pids {
        let bucket = &order[offsets[b] as usize..offsets[b + 1] as usize];
        let mut i = 0;
        while i < bucket.len() {
            let (elo, ehi) = (plo[bucket[i] as usize], phi[bucket[i] as usize]);
            let mut j = i + 1;
            while j < bucket.len() && phi[bucket[j] as usize] == ehi {
                j += 1;
            }
            let run = &bucket[i..j];
            let proper = elo != ehi;
            let shared = run.len() >= 2;
            let mut any_seam = false;
            for &e in run {
                if proper && uv_edge_unique[e as usize] {
                    boundary_kind[e as usize] = if shared { 1 } else { 2 };
                    any_seam |= shared;
                }
            }
            if any_seam {
                seam_edges += 1;
                // Every half-edge of the run joins the same two points: same length bits.
                seam_len.push(len(run[0]));
            }
            i = j;
        }
    }

    // The evaluator sums half-edge lengths slot-major (all slot-0 half-edges, then 1, then 2).
    let slot_major = |keep: &dyn Fn(u8) -> bool| -> Vec<f64> {
        (0..3)
            .flat_map(|k| (0..nf).map(move |f| 3 * f + k))
            .filter(|&e| keep(boundary_kind[e]))
            .map(|e| len(e as u32))
            .collect()
    };
    let boundary = np_sum(&slot_major(&|b| b != 0));
    let open = np_sum(&slot_major(&|b| b == 2));
    Connectivity {
        chart_of_face,
        num_charts: num_charts as usize,
        unique_corners: num_cids,
        seam_edges,
        seam_length_3d_m: np_sum(&seam_len),
        boundary_length_3d_m: boundary,
        open_border_length_3d_m: open,
        uv_boundary: uv_edge_unique,
        corner_id,
        corner_pid,
    }
}
