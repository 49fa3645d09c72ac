//! Progressive mesh by half-edge collapses, as Ray & Lévy 2003 (hlscm-2003) §4.
//!
//! The paper's Algorithm 2, "Hierarchical triangulated surfaces generation":
//! "while some hcoll can be performed: h ← the less geometrically important halfedge that can
//! be collapsed; add the corresponding hcoll to the operations list; collapse h".
//!
//! A half-edge collapse `u → v` (Kobbelt's `hcoll`) removes vertex `u` and replaces it by `v`
//! in every face; the two (interior) or one (boundary) faces on the edge disappear. Vertices
//! never move, which is what makes the operation list easy to replay.
//!
//! "Validity of hcoll" (§4), each check in `Decimator::best_collapse`:
//! - manifold: the link condition (the common neighbours of `u` and `v` are exactly the
//!   opposite vertices of the faces on the edge);
//! - no flip: every face that survives keeps its normal on the same side (`n_old·n_new > 0`) and
//!   does not become degenerate;
//! - boundary intact: a boundary vertex may only collapse along a boundary edge (so the
//!   boundary stays one simple loop, only coarser), the loop keeps at least 4 vertices before a
//!   boundary collapse, and locked vertices (the LSCM pins) are never removed;
//! - "the angular defect of the vertex to remove has to be smaller than a given threshold
//!   (70 degrees in the examples shown here)": `2π − Σθ` inside, `π − Σθ` on the boundary
//!   (the turning angle, so chart corners are kept).
//!
//! "Halfedge geometric importance" (§4), in `Decimator::best_collapse`: the sum of
//! - the volume difference (the volume swept by the faces of `u` moving to `v`,
//!   `Σ |det(a−u, b−u, v−u)|/6`), as its cube root;
//! - the area difference when the half-edge is on the border (the triangle between the old
//!   boundary `w–u–v` and the new `w–v`), as its square root;
//! - the accumulated loss of quality on merged vertices: each vertex carries the largest loss
//!   merged into it so far (`acc(v) ← max(acc(v), acc(u) + loss)`), our reading of the
//!   "global error management" of the paper's reference \[4\].
//!
//! "Note that to have compatible dimensions, these parameters are normalized (cube root for
//! volume and square root for area)": all three terms are lengths in model units.
//!
//! Replay: every [`Collapse`] records the nearest triangle of the coarser mesh to the removed
//! vertex and its barycentric coordinates, so that the vertex split can give the new vertex
//! "its textures coordinates … using a barycentric interpolation in the nearest triangle"
//! (§4.1). [`ProgressiveMesh::level`] rebuilds the mesh after any prefix of the collapses.
//!
//! Queue: at most one entry per vertex (its cheapest valid half-edge), in a 4-ary heap ordered
//! by (priority, vertex id) with `f64::total_cmp`.
//!
//! Exact dirty tracking. The evaluation of `u` (`Decimator::best_collapse`) reads only the
//! star of `u` (faces, positions, ring, edge face counts, angular defect, `acc(u)`), the stars
//! of its neighbours (link condition) and the global boundary vertex count. A collapse `u → v`
//! changes only the faces around `u` (and `acc(v)`), so the only vertices whose evaluation can
//! change are those whose star changed (the old ring of `u`, plus `v`) and those adjacent to
//! `u` or `v` (their link with a neighbour may change): all of them are `v` and its new ring.
//! Those are marked dirty; every other vertex's cached evaluation stays exact. So a vertex
//! popped clean collapses at once with its cached half-edge (the sequential version re-evaluated
//! every popped vertex), and only a popped dirty vertex is re-evaluated. The boundary count is
//! re-checked when a boundary vertex collapses. The unit tests assert, at every collapse, that
//! the cached half-edge equals a fresh evaluation.
//!
//! Parallel and deterministic: popped dirty vertices wait in a batch of
//! `EVALUATION_BATCH`; the batch is evaluated in parallel (each evaluation reads the current
//! mesh only) and re-queued in batch order, so the collapse list is the same bits at any thread
//! count. Change against the paper's strictly sequential greedy order (Algorithm 2): while a
//! dirty vertex waits in the batch, up to `EVALUATION_BATCH` clean ones may collapse before it
//! although its refreshed priority might have been lower (a negligible change of the finest
//! level's iterations and energy).
//!
//! Cost: `O(n log n)`, bound by cache misses on the random-access star reads. Layout choices cut
//! misses without changing the rules or the collapse list: each vertex's face list sits inline
//! in one 64-byte line (`FaceSlot`, 15 faces, longer lists spill to a pool); inside the chart the
//! candidates of `u` are ranked by swept volume, taking one cube root for the chosen one
//! (`cbrt(vol) + acc(u)` is increasing in the volume; only ties after rounding can order
//! differently); an evaluation batch is evaluated in chunks of `WARM_CHUNK` vertices whose stars
//! are first loaded stage by stage (`Decimator::warm_stars`), so the misses of a stage overlap.
//!
//! Code map: this file (the collapse record, the levels and the replay by vertex splits),
//! `decimate` (the queue, the validity and importance of a collapse, the collapse).

use super::chart::ChartMesh;
use super::ParameterizeError;
use crate::mesh::vector::{dot, sub};

mod decimate;

pub use decimate::build_progressive_mesh;

/// One half-edge collapse, in the order they were applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Collapse {
    /// The vertex removed (`u` of `u → v`), as a chart vertex index.
    pub removed: u32,
    /// The vertex it was merged into (`v`).
    pub kept: u32,
    /// The triangle of the mesh right after this collapse nearest to `removed`'s position
    /// (chart vertex indices, all alive after the collapse).
    pub triangle: [u32; 3],
    /// Barycentric coordinates (non-negative, sum 1) of the point of `triangle` nearest to
    /// `removed`'s position.
    pub barycentric: [f64; 3],
}

/// Options of [`build_progressive_mesh`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProgressiveMeshOptions {
    /// Largest |angular defect| of a removable vertex, radians. Default 70° (hlscm-2003 §4).
    pub max_angular_defect_rad: f64,
    /// Stop when this many vertices remain (the coarsest level needs no more collapses).
    /// Default 3.
    pub min_vertices: usize,
}

impl Default for ProgressiveMeshOptions {
    fn default() -> Self {
        Self {
            max_angular_defect_rad: 70f64.to_radians(),
            min_vertices: 3,
        }
    }
}

/// The collapse list of a chart (the vertex splits replay it backwards).
#[derive(Debug, Clone, PartialEq)]
pub struct ProgressiveMesh {
    /// Vertex count of the full-resolution chart.
    pub vertex_count: usize,
    /// Collapses in application order.
    pub collapses: Vec<Collapse>,
}

/// A mesh of the hierarchy with its own compact vertex numbering.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelMesh {
    /// The level as a chart (positions copied from the full chart).
    pub chart: ChartMesh,
    /// Chart vertex index of each level vertex (increasing).
    pub chart_vertex: Vec<u32>,
    /// Level vertex index of each chart vertex, `u32::MAX` when absent at this level.
    pub level_vertex: Vec<u32>,
}

impl ProgressiveMesh {
    /// Vertices alive after the first `applied` collapses.
    pub fn vertices_after(&self, applied: usize) -> usize {
        self.vertex_count - applied.min(self.collapses.len())
    }

    /// The mesh after the first `applied` collapses (0 = the full chart). `chart` must be the
    /// chart this progressive mesh was built from.
    ///
    /// A half-edge collapse only substitutes `u → v` in faces, so the level is the set of
    /// original faces with every vertex mapped through the composed substitutions, minus the
    /// faces that became degenerate. Cost `O(n + F)`.
    pub fn level(&self, chart: &ChartMesh, applied: usize) -> Result<LevelMesh, ParameterizeError> {
        let applied = applied.min(self.collapses.len());
        let n = self.vertex_count;
        if chart.positions_m.len() != n {
            return Err(ParameterizeError::Internal {
                detail: "progressive mesh used with another chart".to_string(),
            });
        }
        let mut rep: Vec<u32> = (0..n as u32).collect();
        // Later collapses first, so that `rep[kept]` is final when `removed` reads it.
        for c in self.collapses[..applied].iter().rev() {
            let target = rep
                .get(c.kept as usize)
                .copied()
                .ok_or_else(|| internal("collapse refers to a missing vertex"))?;
            if let Some(slot) = rep.get_mut(c.removed as usize) {
                *slot = target;
            }
        }
        let mut level_vertex = vec![u32::MAX; n];
        let mut chart_vertex = Vec::with_capacity(n - applied);
        for v in 0..n {
            if rep[v] == v as u32 {
                level_vertex[v] = chart_vertex.len() as u32;
                chart_vertex.push(v as u32);
            }
        }
        let mut triangles = Vec::with_capacity(chart.triangles.len());
        for t in &chart.triangles {
            let m = t.map(|i| rep.get(i as usize).copied().unwrap_or(u32::MAX));
            if m[0] != m[1] && m[1] != m[2] && m[0] != m[2] {
                let l = m.map(|i| level_vertex.get(i as usize).copied().unwrap_or(u32::MAX));
                if l.contains(&u32::MAX) {
                    return Err(internal("level face refers to a removed vertex"));
                }
                triangles.push(l);
            }
        }
        let positions_m = chart_vertex
            .iter()
            .map(|&v| chart.positions_m[v as usize])
            .collect();
        Ok(LevelMesh {
            chart: ChartMesh {
                positions_m,
                triangles,
            },
            chart_vertex,
            level_vertex,
        })
    }

    /// Vertex splits (hlscm-2003 §4.1): going from `coarse_applied` collapses back to
    /// `fine_applied`, give each re-inserted vertex the barycentric UV of its recorded nearest
    /// triangle. `uv` is indexed by chart vertex and must hold the UVs of every vertex alive at
    /// the coarse level; the re-inserted entries are overwritten.
    pub fn split_to(&self, uv: &mut [[f64; 2]], coarse_applied: usize, fine_applied: usize) {
        let hi = coarse_applied.min(self.collapses.len());
        let lo = fine_applied.min(hi);
        for c in self.collapses[lo..hi].iter().rev() {
            let mut p = [0.0, 0.0];
            for k in 0..3 {
                let q = uv
                    .get(c.triangle[k] as usize)
                    .copied()
                    .unwrap_or([0.0, 0.0]);
                p[0] += c.barycentric[k] * q[0];
                p[1] += c.barycentric[k] * q[1];
            }
            if let Some(slot) = uv.get_mut(c.removed as usize) {
                *slot = p;
            }
        }
    }
}

pub(super) fn internal(detail: &str) -> ParameterizeError {
    ParameterizeError::Internal {
        detail: detail.to_string(),
    }
}

/// Barycentric coordinates of the point of triangle `abc` closest to `p`, and the squared
/// distance (Ericson, Real-Time Collision Detection §5.1.5).
pub fn closest_point_barycentric(
    p: [f64; 3],
    a: [f64; 3],
    b: [f64; 3],
    c: [f64; 3],
) -> ([f64; 3], f64) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    let bary = if d1 <= 0.0 && d2 <= 0.0 {
        [1.0, 0.0, 0.0]
    } else {
        let bp = sub(p, b);
        let d3 = dot(ab, bp);
        let d4 = dot(ac, bp);
        let cp = sub(p, c);
        let d5 = dot(ab, cp);
        let d6 = dot(ac, cp);
        let vc = d1 * d4 - d3 * d2;
        let vb = d5 * d2 - d1 * d6;
        let va = d3 * d6 - d5 * d4;
        if d3 >= 0.0 && d4 <= d3 {
            [0.0, 1.0, 0.0]
        } else if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            let t = d1 / (d1 - d3);
            [1.0 - t, t, 0.0]
        } else if d6 >= 0.0 && d5 <= d6 {
            [0.0, 0.0, 1.0]
        } else if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            let t = d2 / (d2 - d6);
            [1.0 - t, 0.0, t]
        } else if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            [0.0, 1.0 - t, t]
        } else {
            let denom = 1.0 / (va + vb + vc);
            let v = vb * denom;
            let w = vc * denom;
            [1.0 - v - w, v, w]
        }
    };
    let q = [0, 1, 2].map(|k| bary[0] * a[k] + bary[1] * b[k] + bary[2] * c[k]);
    let d = sub(p, q);
    (bary, dot(d, d))
}

#[cfg(test)]
mod tests {
    use super::super::test_meshes::{grid, hemisphere, noisy_height_field};
    use super::decimate::*;
    use super::*;

    #[test]
    fn every_level_is_a_valid_disk_and_keeps_locked_vertices() {
        for chart in [
            noisy_height_field(20, 0.5, 9),
            hemisphere(24, 10),
            grid(15, 9, |x, y| [x, y, 0.1 * (x * 0.7).sin()]),
        ] {
            chart.validate().expect("input disk");
            let locked = [0u32, (chart.positions_m.len() - 1) as u32];
            let pm = build_progressive_mesh(&chart, &locked, &ProgressiveMeshOptions::default())
                .expect("pm");
            let n = chart.positions_m.len();
            assert!(
                pm.collapses.len() > n / 2,
                "decimated only {} of {n}",
                pm.collapses.len()
            );
            let mut removed = vec![false; n];
            for c in &pm.collapses {
                assert!(!locked.contains(&c.removed));
                assert!(!removed[c.removed as usize], "vertex removed twice");
                removed[c.removed as usize] = true;
                let s: f64 = c.barycentric.iter().sum();
                assert!((s - 1.0).abs() < 1e-12 && c.barycentric.iter().all(|&b| b >= 0.0));
            }
            for applied in [
                0,
                pm.collapses.len() / 3,
                pm.collapses.len() / 2,
                pm.collapses.len(),
            ] {
                let level = pm.level(&chart, applied).expect("level");
                assert_eq!(level.chart.positions_m.len(), pm.vertices_after(applied));
                level
                    .chart
                    .validate()
                    .unwrap_or_else(|e| panic!("level {applied}: {e}"));
                for &l in &locked {
                    assert_ne!(level.level_vertex[l as usize], u32::MAX);
                }
                // Euler: a disk keeps V − E + F = 1, so F = 2V − B − 2 (B boundary vertices).
                let topo = level.chart.validate().expect("disk");
                let b = topo.boundary_loop.len();
                assert_eq!(
                    level.chart.triangles.len(),
                    2 * level.chart.positions_m.len() - b - 2
                );
            }
        }
    }

    #[test]
    fn flat_grid_interior_decimates_and_corners_survive() {
        // The 4 corners have a 90° turning angle (> 70°): they must survive every collapse.
        let chart = grid(12, 12, |x, y| [x, y, 0.0]);
        let pm =
            build_progressive_mesh(&chart, &[], &ProgressiveMeshOptions::default()).expect("pm");
        let corners = [0u32, 12, 13 * 12, 13 * 13 - 1];
        for c in &pm.collapses {
            assert!(!corners.contains(&c.removed));
        }
        let coarse = pm.level(&chart, pm.collapses.len()).expect("level");
        assert!(
            coarse.chart.positions_m.len() <= 8,
            "{}",
            coarse.chart.positions_m.len()
        );
        // Vertex splits on a flat grid: barycentric interpolation of the identity map
        // reproduces each re-inserted vertex's (x, y) exactly (it lies in its triangle).
        let mut uv = vec![[f64::NAN; 2]; chart.positions_m.len()];
        for &v in &coarse.chart_vertex {
            let p = chart.positions_m[v as usize];
            uv[v as usize] = [p[0], p[1]];
        }
        pm.split_to(&mut uv, pm.collapses.len(), 0);
        for (p, q) in chart.positions_m.iter().zip(&uv) {
            assert!(
                (p[0] - q[0]).abs() < 1e-9 && (p[1] - q[1]).abs() < 1e-9,
                "{p:?} {q:?}"
            );
        }
    }

    #[test]
    fn min_vertices_stops_early_and_is_deterministic() {
        let chart = noisy_height_field(16, 0.3, 2);
        let opts = ProgressiveMeshOptions {
            min_vertices: 100,
            ..Default::default()
        };
        let a = build_progressive_mesh(&chart, &[], &opts).expect("pm");
        let b = build_progressive_mesh(&chart, &[], &opts).expect("pm");
        assert_eq!(a, b);
        assert_eq!(a.vertices_after(a.collapses.len()), 100);
    }

    #[test]
    fn queue_key_orders_like_total_cmp_and_round_trips() {
        let xs = [
            f64::NEG_INFINITY,
            -1e300,
            -1.5,
            -f64::MIN_POSITIVE,
            -0.0,
            0.0,
            f64::MIN_POSITIVE,
            1e-300,
            0.25,
            0.25000000000000006,
            7.0,
            f64::INFINITY,
            f64::NAN,
        ];
        for &a in &xs {
            assert_eq!(order_key_inverse(order_key(a)).to_bits(), a.to_bits());
            for &b in &xs {
                assert_eq!(order_key(a).cmp(&order_key(b)), a.total_cmp(&b), "{a} {b}");
                for (va, vb) in [(3u32, 5u32), (5, 3), (u32::MAX, 0)] {
                    let (ca, cb) = (Candidate::new(a, va), Candidate::new(b, vb));
                    assert_eq!(ca.vertex(), va);
                    // The max-heap pops the smaller (priority, vertex) first.
                    let expected = b.total_cmp(&a).then(vb.cmp(&va));
                    assert_eq!(ca.cmp(&cb), expected, "{a} {b} {va} {vb}");
                }
            }
        }
    }

    #[test]
    fn collapse_list_is_bit_identical_at_any_thread_count() {
        // Large enough for full evaluation batches (the parallel part).
        let chart = noisy_height_field(70, 0.4, 5);
        let locked = [0u32, 17];
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool")
                .install(|| {
                    build_progressive_mesh(&chart, &locked, &ProgressiveMeshOptions::default())
                        .expect("pm")
                })
        };
        let one = run(1);
        assert!(one.collapses.len() > chart.positions_m.len() / 2);
        for threads in [2, 3] {
            let other = run(threads);
            assert_eq!(one.collapses.len(), other.collapses.len());
            for (a, b) in one.collapses.iter().zip(&other.collapses) {
                assert_eq!(
                    (a.removed, a.kept, a.triangle),
                    (b.removed, b.kept, b.triangle)
                );
                assert_eq!(
                    a.barycentric.map(f64::to_bits),
                    b.barycentric.map(f64::to_bits)
                );
            }
        }
    }

    #[test]
    fn quad_heap_pops_in_binary_heap_order() {
        let mut seed = 12345u64;
        let mut quad = QuadHeap::with_capacity(0);
        let mut binary = std::collections::BinaryHeap::new();
        for round in 0..2000u32 {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            // Mixed pushes and pops, with repeated priorities (ties broken by vertex).
            if seed >> 62 == 0 {
                assert_eq!(quad.pop(), binary.pop(), "round {round}");
            } else {
                let c = Candidate::new(((seed >> 40) % 64) as f64 * 0.25, round);
                quad.push(c);
                binary.push(c);
            }
        }
        while let Some(c) = binary.pop() {
            assert_eq!(quad.pop(), Some(c));
        }
        assert_eq!(quad.pop(), None);
    }

    #[test]
    fn face_lists_keep_order_through_spills_like_vecs() {
        let mut lists = FaceLists::new(3);
        let mut reference: Vec<Vec<u32>> = vec![Vec::new(); 3];
        let mut seed = 7u64;
        for step in 0..3000u32 {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let v = (seed >> 33) as usize % 3;
            // Grow vertex 1 past the inline capacity; keep the others short.
            let grow = if v == 1 { 6 } else { 2 };
            if (seed >> 40) % 10 < grow || reference[v].is_empty() {
                lists.push(v, step % 40);
                reference[v].push(step % 40);
            } else if (seed >> 50) % if v == 1 { 97 } else { 7 } == 0 {
                let mut out = vec![99];
                lists.take_into(v, &mut out);
                assert_eq!(out, reference[v]);
                reference[v].clear();
            } else {
                let f = reference[v][(seed >> 20) as usize % reference[v].len()];
                lists.remove(v, f);
                reference[v].retain(|&g| g != f);
            }
            for w in 0..3 {
                assert_eq!(&lists[w], reference[w].as_slice(), "step {step} vertex {w}");
            }
        }
        assert!(
            !lists.spill.is_empty(),
            "the test must exercise the spill pool"
        );
    }

    #[test]
    fn closest_point_matches_brute_force() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.5]);
        for p in [
            [0.5, 0.3, 1.0],
            [-1.0, -1.0, 0.0],
            [3.0, 0.1, 0.0],
            [0.0, 2.0, 1.0],
            [1.5, 1.5, 0.0],
        ] {
            let (bary, d2) = closest_point_barycentric(p, a, b, c);
            let mut best = f64::INFINITY;
            for i in 0..=200 {
                for j in 0..=(200 - i) {
                    let (s, t) = (i as f64 / 200.0, j as f64 / 200.0);
                    let q = [0, 1, 2].map(|k| a[k] + s * (b[k] - a[k]) + t * (c[k] - a[k]));
                    best = best.min(dot(sub(p, q), sub(p, q)));
                }
            }
            assert!(d2 <= best + 1e-12 && d2 >= best - 1e-3, "{d2} vs {best}");
            assert!(bary.iter().all(|&x| x >= -1e-15));
        }
    }
}
