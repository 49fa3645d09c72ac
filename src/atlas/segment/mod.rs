//! Segmentation: cut a mesh into charts that are topological disks.
//!
//! Purpose: the first stage of the atlas pipeline. [`segment_charts`] partitions the faces of a
//! [`TriangleMesh`] into charts with natural shapes, their borders on high-curvature features
//! where seams do not show (LSCM paper §3), and guarantees that every chart can be flattened.
//!
//! **Architecture invariant (the stage contract).** Every chart returned by [`segment_charts`]
//! is a topological disk: its faces form one component through glued edges, every vertex's
//! faces within the chart form one fan (no pinch), `χ = V − E + F = 1` and it has exactly one
//! boundary loop — counted with the chart's own vertices and edges, where an edge is interior
//! when both its faces are in the chart. [`check_chart_is_disk`] checks exactly this; debug builds
//! assert it on every chart before returning, and the tests call it on every chart of every
//! fixture. Every face is in exactly one chart; charts never span connected components.
//!
//! How the guarantee is kept: the method ([`SegmentMethod::Lscm2002`]: `features.rs` then
//! `grow.rs`; or [`SegmentMethod::Stretch`]: `spectral.rs` on `geodesic.rs` and
//! `numerics::mds`) proposes a partition; each proposed chart is split into its glued components, and
//! each component that is not a disk (a handle, an annulus, a closed part, a pinch) is re-grown as
//! two charts from the two ends of a diameter of its face graph (breadth-first, simultaneously),
//! and the parts are checked again. Each split makes one more chart, so there are at most
//! `F − 1` splits; a single triangle is always a disk, so the process ends with disks. A hard
//! bound on splits (the face count) falls back to one chart per face should it ever be hit.
//!
//! Determinism: no hash maps; every order is by face or half-edge id; the same mesh and options
//! give the same charts.
//!
//! Units: distances in model units (`_m`), angles in radians (`_rad`), counts of edges.
//!
//! Progress: [`segment_charts`] reports through a [`StageProgress`] in four phases of `F`
//! units (features, growing, the disk guarantee, the chart cap), with checkpoints inside each;
//! reporting never changes the charts.
//!
//! Code map: [`options`] (every option, unit, default), [`features`] (§3.1, Algorithm 1),
//! [`grow`] (§3.2, Algorithm 2), [`spectral`] and [`geodesic`] (the stretch-driven method of
//! Iso-charts §4–5), this file (the disk guarantee and the chart-count cap),
//! [`graph_cut`] (opt-in: borders moved to a minimum cut, Iso-charts §5.2, between the disk
//! guarantee and the cap; it keeps every chart a disk and the count unchanged), `smooth.rs`
//! (always, after the graph cut and in every split of `grow_two`: single faces sticking out
//! across a border, the saw teeth where growing fronts met, go to the chart they stick into;
//! disks and the count kept). The
//! next stage, `parameterize`, flattens the charts, splits the invalid ones and merges back
//! (§3.3).
//!
//! References: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least Squares Conformal Maps for
//! Automatic Texture Atlas Generation", SIGGRAPH 2002, §3.
pub mod features;
pub mod geodesic;
pub mod graph_cut;
pub mod grow;
pub mod options;
mod smooth;
pub mod spectral;

#[cfg(test)]
pub(crate) mod tests;

use std::collections::VecDeque;
use std::ops::ControlFlow;

use rayon::prelude::*;

use crate::atlas::progress::StageProgress;
use crate::mesh::{FaceData, FaceId, HalfedgeId, TriangleMesh, VertexId};

pub use features::{detect_features, Features};
pub use grow::{distance_to_features, grow_charts, GrownCharts};
pub use options::{Lscm2002Options, SegmentMethod, SegmentOptions, StretchSegmentOptions};
pub use spectral::ChartStretchFn;

/// A chart of a [`Segmentation`], numbered by its lowest face id. Displayed as `C3`.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Debug)]
pub struct ChartId(pub u32);

impl ChartId {
    /// The id as an index into `Segmentation::charts`.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// Errors of the segmentation stage.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SegmentError {
    /// An option has a meaningless value.
    #[error("invalid segmentation option `{option}`: {detail}")]
    InvalidOption {
        /// The option's path, e.g. `lscm.feature_fraction`.
        option: &'static str,
        /// What is wrong and what to use instead.
        detail: String,
    },
    /// The caller's [`StageProgress`] returned `Break`.
    #[error("segmentation was cancelled")]
    Cancelled,
}

/// Why a set of faces is not a topological disk ([`check_chart_is_disk`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NotADisk {
    /// No faces.
    #[error("the chart has no faces")]
    Empty,
    /// A face id is out of range or listed twice.
    #[error("face {0:?} is out of range or listed twice")]
    BadFace(FaceId),
    /// The faces are not connected through glued edges.
    #[error(
        "the chart is not connected: {reached} of {faces} faces reachable through glued edges"
    )]
    Disconnected {
        /// Faces reached from the first one.
        reached: usize,
        /// Faces in the chart.
        faces: usize,
    },
    /// A vertex's faces within the chart form several fans.
    #[error("vertex {vertex:?} is pinched: its faces in the chart form {fans} fans")]
    Pinched {
        /// The vertex.
        vertex: VertexId,
        /// Number of fans.
        fans: usize,
    },
    /// Wrong Euler characteristic or boundary loop count (handle, annulus, closed surface).
    #[error("χ = {euler_characteristic} with {boundary_loops} boundary loops; a disk has χ = 1 and 1 loop")]
    Topology {
        /// `V − E + F` of the chart.
        euler_characteristic: i64,
        /// Boundary loops of the chart.
        boundary_loops: usize,
    },
}

/// Counts of a chart that passed [`check_chart_is_disk`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DiskInfo {
    /// F.
    pub num_faces: usize,
    /// V.
    pub num_vertices: usize,
    /// E.
    pub num_edges: usize,
    /// Half-edges on the chart's boundary (= boundary edges).
    pub num_boundary_edges: usize,
}

/// Counters of one [`segment_charts`] run (for reports and tests).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SegmentStats {
    /// Feature edges detected (§3.1).
    pub feature_edges: usize,
    /// Feature curves kept.
    pub feature_curves: usize,
    /// Seeds of chart growing (§3.2).
    pub seeds: usize,
    /// Charts after growing and merging, before the disk guarantee.
    pub grown_charts: usize,
    /// Splits made by the disk guarantee (including splitting disconnected charts).
    pub disk_splits: usize,
    /// Merges made to respect [`SegmentOptions::max_charts`].
    pub cap_merges: usize,
    /// Charts split by the stretch-driven method's spectral clustering (`spectral.rs`).
    pub spectral_splits: usize,
    /// Rounds of the stretch-driven method.
    pub spectral_rounds: usize,
    /// Pairs of adjacent charts whose border the graph cut moved (`graph_cut.rs`).
    pub borders_moved: usize,
    /// Faces moved across a border by the smoothing (`smooth.rs`).
    pub border_faces_moved: usize,
    /// `maxdist`, the largest distance to features, model units.
    pub max_distance_m: f64,
}

/// The charts of a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Segmentation {
    /// The chart of each face.
    pub face_chart: FaceData<ChartId>,
    /// The faces of each chart, ascending; charts ordered by lowest face id.
    pub charts: Vec<Vec<FaceId>>,
    /// What happened on the way.
    pub stats: SegmentStats,
}

impl Segmentation {
    /// Number of charts.
    pub fn num_charts(&self) -> usize {
        self.charts.len()
    }
    /// The faces of chart `c` (empty for an id out of range).
    pub fn chart_faces(&self, c: ChartId) -> &[FaceId] {
        self.charts.get(c.index()).map_or(&[], Vec::as_slice)
    }
}

/// Cuts `mesh` into charts, each a topological disk (see the module doc for the contract).
///
/// `progress` is advanced through the phases (features, growing, the disk guarantee, the chart
/// cap), each counted as the mesh's face count, with checkpoints inside each; `Break` returns
/// [`SegmentError::Cancelled`]. Progress does not change the result.
///
/// Errors: [`SegmentError::InvalidOption`]; [`SegmentError::Cancelled`]. Every built mesh can
/// be segmented.
/// Cost: `O(F log F)` for features and growing, plus the disk checks (linear in each chart) and
/// splits (each linear in the chart split).
pub fn segment_charts(
    mesh: &TriangleMesh,
    options: &SegmentOptions,
    progress: &mut StageProgress<'_>,
) -> Result<Segmentation, SegmentError> {
    segment_charts_with(mesh, options, None, progress)
}

/// [`segment_charts`] with the measure of a chart's L2 stretch that [`SegmentMethod::Stretch`]
/// splits by (the pipeline passes its flattening's); `None` uses the method's own estimate from
/// its embedding (`spectral.rs`). Other methods ignore it.
pub fn segment_charts_with(
    mesh: &TriangleMesh,
    options: &SegmentOptions,
    stretch: Option<&ChartStretchFn<'_>>,
    progress: &mut StageProgress<'_>,
) -> Result<Segmentation, SegmentError> {
    options.check()?;
    // Progress units: the faces, once per phase.
    let nf = mesh.num_faces();
    let total = PHASES * nf;
    checkpoint(progress.advance(0, total))?;
    let mut stats = SegmentStats::default();
    let features: Option<Features>;
    let proposed = match options.method {
        SegmentMethod::Lscm2002 => {
            let feats = detect_features(mesh, &options.lscm, &mut progress.part(0, nf, total))?;
            stats.feature_edges = feats.num_feature_edges();
            stats.feature_curves = feats.curves.len();
            let grown = grow_charts(
                mesh,
                &feats,
                &options.lscm,
                &mut progress.part(nf, nf, total),
            )?;
            stats.seeds = grown.num_seeds;
            stats.grown_charts = grown.num_charts;
            stats.max_distance_m = grown.max_distance_m;
            features = Some(feats);
            grown.face_chart
        }
        SegmentMethod::Stretch => {
            let (charts, spectral) = spectral::spectral_charts(
                mesh,
                &options.stretch,
                options.border_band_fraction,
                stretch,
                &mut progress.part(0, 2 * nf, total),
            )?;
            stats.spectral_splits = spectral.splits;
            stats.spectral_rounds = spectral.rounds;
            stats.grown_charts = charts.len();
            features = None;
            let mut face_chart = vec![0u32; nf];
            for (i, c) in charts.iter().enumerate() {
                for f in c {
                    face_chart[f.index()] = i as u32;
                }
            }
            face_chart
        }
    };
    let mut work: Vec<Vec<FaceId>> = Vec::new();
    for f in mesh.faces() {
        let c = proposed[f.index()] as usize;
        if work.len() <= c {
            work.resize(c + 1, Vec::new());
        }
        work[c].push(f);
    }
    // The disk guarantee, in batches of consecutive proposed charts with a checkpoint after
    // each: a chart's disks depend on that chart alone, so the concatenation is the result of
    // one call on all of them.
    let mut disks = progress.part(2 * nf, nf, total);
    let batch_faces = nf.div_ceil(DISK_BATCHES).max(1);
    let mut charts = Vec::new();
    let (mut batch, mut in_batch, mut faces_done) = (Vec::new(), 0usize, 0usize);
    let mut items = work.into_iter().peekable();
    while let Some(item) = items.next() {
        in_batch += item.len();
        batch.push(item);
        if in_batch >= batch_faces || items.peek().is_none() {
            charts.extend(enforce_disks(mesh, std::mem::take(&mut batch), &mut stats));
            faces_done += in_batch;
            in_batch = 0;
            checkpoint(disks.advance(faces_done, nf))?;
        }
    }
    // The stretch-driven method cuts the border of each split as it makes it (with its
    // distortion term), so only the feature method moves borders here.
    if let (Some(band_fraction), SegmentMethod::Lscm2002) =
        (options.border_band_fraction, options.method)
    {
        let moved =
            graph_cut::optimize_borders(mesh, &mut charts, features.as_ref(), band_fraction);
        stats.borders_moved = moved.moved;
    }
    stats.border_faces_moved = smooth_charts(mesh, &mut charts, features.as_ref());
    if let Some(cap) = options.max_charts {
        stats.cap_merges = merge_to_cap(
            mesh,
            &mut charts,
            cap,
            &mut progress.part(3 * nf, nf, total),
        )?;
    }
    checkpoint(progress.advance(total, total))?;
    Ok(finish(mesh, charts, stats))
}

/// Smooths the borders between `charts` (disks covering every face once; they still are, with
/// the same count and order): `smooth.rs` with the graph cut's edge capacities, which make a
/// border on a feature or a sharp edge cheap, so that smoothing keeps it there. Returns the
/// number of faces moved.
fn smooth_charts(
    mesh: &TriangleMesh,
    charts: &mut [Vec<FaceId>],
    features: Option<&Features>,
) -> usize {
    if charts.len() < 2 {
        return 0;
    }
    let mut label = vec![u32::MAX; mesh.num_faces()];
    for (c, faces) in charts.iter().enumerate() {
        for f in faces {
            label[f.index()] = c as u32;
        }
    }
    // Candidates: the faces on a border, in id order.
    let candidates: Vec<FaceId> = mesh
        .faces()
        .filter(|&f| {
            mesh.face_neighbors(f)
                .into_iter()
                .flatten()
                .any(|g| label[g.index()] != label[f.index()])
        })
        .collect();
    if candidates.is_empty() {
        return 0;
    }
    let capacity = graph_cut::edge_capacities(mesh, features);
    let mut sizes: Vec<usize> = charts.iter().map(Vec::len).collect();
    let moved = smooth::smooth_borders(
        mesh,
        &mut smooth::DenseLabels(&mut label),
        &|h| capacity[h.index()],
        &candidates,
        &[],
        &mut sizes,
    );
    if moved > 0 {
        for faces in charts.iter_mut() {
            faces.clear();
        }
        for f in mesh.faces() {
            charts[label[f.index()] as usize].push(f);
        }
    }
    moved
}

/// The phases of [`segment_charts`] for progress: features, growing, the disk guarantee, the
/// chart cap.
const PHASES: usize = 4;

/// Batches of the disk guarantee in [`segment_charts`] (a checkpoint after each).
const DISK_BATCHES: usize = 8;

/// A progress checkpoint's answer as the stage's result: `Break` is [`SegmentError::Cancelled`].
pub(super) fn checkpoint(flow: ControlFlow<()>) -> Result<(), SegmentError> {
    match flow {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(SegmentError::Cancelled),
    }
}

/// Sorts charts by lowest face, builds the face → chart map, asserts the contract in debug.
pub(super) fn finish(
    mesh: &TriangleMesh,
    mut charts: Vec<Vec<FaceId>>,
    stats: SegmentStats,
) -> Segmentation {
    for c in &mut charts {
        c.sort_unstable();
    }
    charts.retain(|c| !c.is_empty());
    charts.sort_unstable_by_key(|c| c[0]);
    let mut face_chart = vec![ChartId(u32::MAX); mesh.num_faces()];
    for (i, c) in charts.iter().enumerate() {
        for f in c {
            face_chart[f.index()] = ChartId(i as u32);
        }
    }
    debug_assert!(
        face_chart.iter().all(|c| c.0 != u32::MAX),
        "a face has no chart"
    );
    debug_assert!(
        charts.iter().all(|c| check_chart_is_disk(mesh, c).is_ok()),
        "segment_charts returned a chart that is not a disk"
    );
    Segmentation {
        face_chart: FaceData::from_vec(face_chart),
        charts,
        stats,
    }
}

/// Checks that `faces` form a topological disk in `mesh` (the invariant of the module doc).
/// `faces` may be in any order. Cost: `O(F log F)` in the chart's size (sort + rotations).
pub fn check_chart_is_disk(mesh: &TriangleMesh, faces: &[FaceId]) -> Result<DiskInfo, NotADisk> {
    let mut sorted = faces.to_vec();
    sorted.sort_unstable();
    for w in sorted.windows(2) {
        if w[0] == w[1] {
            return Err(NotADisk::BadFace(w[0]));
        }
    }
    if let Some(&f) = sorted.iter().find(|f| f.index() >= mesh.num_faces()) {
        return Err(NotADisk::BadFace(f));
    }
    disk_check(mesh, &sorted, &|f| sorted.binary_search(&f).is_ok())
}

/// [`check_chart_is_disk`] with a membership test; `faces` must be distinct and in range.
pub(super) fn disk_check(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    inside: &dyn Fn(FaceId) -> bool,
) -> Result<DiskInfo, NotADisk> {
    let Some(&first) = faces.first() else {
        return Err(NotADisk::Empty);
    };
    // Connected through glued edges.
    let reached = flood(mesh, &[first], inside, faces).len();
    if reached != faces.len() {
        return Err(NotADisk::Disconnected {
            reached,
            faces: faces.len(),
        });
    }
    disk_check_connected(mesh, faces, inside)
}

/// [`disk_check`] for faces already known to be connected through glued edges (non-empty):
/// the fan, Euler characteristic and boundary-loop tests only.
pub(super) fn disk_check_connected(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    inside: &dyn Fn(FaceId) -> bool,
) -> Result<DiskInfo, NotADisk> {
    let glued_inside = |h: HalfedgeId| mesh.opposite(h).filter(|o| inside(o.face()));
    // One fan per vertex: count the outgoing half-edges that start a run of chart faces in the
    // rotation (their predecessor, across `g`'s own edge, is outside or absent).
    // The chart's vertices, ascending. A large chart (at least 1/16 of the mesh) dedups with a
    // flag per mesh vertex and sorts only the distinct ones (about a sixth of the corners).
    let mut vertices: Vec<VertexId>;
    if faces.len().saturating_mul(16) >= mesh.num_faces() {
        let mut seen = vec![false; mesh.num_vertices()];
        vertices = Vec::with_capacity(faces.len());
        for &f in faces {
            for v in mesh.face_vertices(f) {
                if !seen[v.index()] {
                    seen[v.index()] = true;
                    vertices.push(v);
                }
            }
        }
        vertices.sort_unstable();
    } else {
        vertices = faces.iter().flat_map(|&f| mesh.face_vertices(f)).collect();
        vertices.sort_unstable();
        vertices.dedup();
    }
    for &v in &vertices {
        let starts = mesh
            .outgoing_halfedges(v)
            .filter(|&g| inside(g.face()) && glued_inside(g).is_none())
            .count();
        if starts > 1 {
            return Err(NotADisk::Pinched {
                vertex: v,
                fans: starts,
            });
        }
    }
    let mut boundary: Vec<HalfedgeId> = Vec::new();
    let mut interior_halves = 0usize;
    for &f in faces {
        for h in mesh.face_halfedges(f) {
            if glued_inside(h).is_some() {
                interior_halves += 1;
            } else {
                boundary.push(h);
            }
        }
    }
    let num_edges = interior_halves / 2 + boundary.len();
    let chi = vertices.len() as i64 - num_edges as i64 + faces.len() as i64;
    // Boundary loops: the successor of boundary half-edge `h` leaves `to(h)`; rotate backwards
    // (g -> next(opposite(g))) from `next(h)` while the edge is interior to the chart.
    boundary.sort_unstable();
    let mut visited = vec![false; boundary.len()];
    let mut loops = 0usize;
    for i in 0..boundary.len() {
        if visited[i] {
            continue;
        }
        loops += 1;
        let mut j = i;
        // Each step visits a new boundary half-edge; bounded by their count.
        for _ in 0..boundary.len() {
            visited[j] = true;
            let mut g = boundary[j].next();
            for _ in 0..mesh.num_halfedges() {
                match glued_inside(g) {
                    Some(o) => g = o.next(),
                    None => break,
                }
            }
            match boundary.binary_search(&g) {
                Ok(k) if !visited[k] => j = k,
                _ => break,
            }
        }
    }
    if chi != 1 || loops != 1 {
        return Err(NotADisk::Topology {
            euler_characteristic: chi,
            boundary_loops: loops,
        });
    }
    Ok(DiskInfo {
        num_faces: faces.len(),
        num_vertices: vertices.len(),
        num_edges,
        num_boundary_edges: boundary.len(),
    })
}

/// The chart's faces ascending: `faces` itself when already sorted, else a sorted copy.
pub(super) fn sorted_faces(faces: &[FaceId]) -> std::borrow::Cow<'_, [FaceId]> {
    if faces.windows(2).all(|w| w[0] < w[1]) {
        std::borrow::Cow::Borrowed(faces)
    } else {
        let mut v = faces.to_vec();
        v.sort_unstable();
        std::borrow::Cow::Owned(v)
    }
}

/// Faces reachable from `seeds` through glued edges between faces that are `inside`, in
/// breadth-first order. `faces` lists (at least) every face that is `inside` (any order); the
/// visited set is a flag per entry of it, found by binary search (no per-mesh array, no tree),
/// or, for a chart with at least 1/16 of the mesh's faces, a flag per face of the mesh (zeroed
/// lazily by the allocator, so its cost is about the chart's; no search per visit). Both give
/// the same order.
pub(super) fn flood(
    mesh: &TriangleMesh,
    seeds: &[FaceId],
    inside: &dyn Fn(FaceId) -> bool,
    faces: &[FaceId],
) -> Vec<FaceId> {
    if faces.len().saturating_mul(16) >= mesh.num_faces() {
        let mut seen = vec![false; mesh.num_faces()];
        let mut order = Vec::with_capacity(faces.len());
        let mut queue = VecDeque::new();
        for &s in seeds {
            // A seed outside `faces` is not visited (as with the search below); past the
            // seeds, `inside` implies being in `faces` (the contract).
            if s.index() < seen.len() && !seen[s.index()] && faces.contains(&s) {
                seen[s.index()] = true;
                queue.push_back(s);
            }
        }
        while let Some(f) = queue.pop_front() {
            order.push(f);
            for g in mesh.face_neighbors(f).into_iter().flatten() {
                if !seen[g.index()] && inside(g) {
                    seen[g.index()] = true;
                    queue.push_back(g);
                }
            }
        }
        return order;
    }
    let sorted = sorted_faces(faces);
    let mut seen = vec![false; sorted.len()];
    let mut mark = |f: FaceId| match sorted.binary_search(&f) {
        Ok(k) if !seen[k] => {
            seen[k] = true;
            true
        }
        _ => false,
    };
    let mut order = Vec::new();
    let mut queue = VecDeque::new();
    for &s in seeds {
        if mark(s) {
            queue.push_back(s);
        }
    }
    while let Some(f) = queue.pop_front() {
        order.push(f);
        for g in mesh.face_neighbors(f).into_iter().flatten() {
            if inside(g) && mark(g) {
                queue.push_back(g);
            }
        }
    }
    order
}

/// Splits each proposed chart (faces ascending, charts disjoint) into glued components and each non-disk component into two
/// re-grown halves until every chart is a disk (see the module doc).
pub(super) fn enforce_disks(
    mesh: &TriangleMesh,
    work: Vec<Vec<FaceId>>,
    stats: &mut SegmentStats,
) -> Vec<Vec<FaceId>> {
    use std::sync::atomic::{AtomicU32, Ordering::Relaxed};
    let nf = mesh.num_faces();
    // `label[f]` is the work item currently holding `f`: O(1) membership for every check. Faces
    // in no item keep `u32::MAX`. Items are split in parallel, each by its own task (below):
    // a task writes only the labels of its own item's faces, and every label it writes is
    // new (from `next_label`), so the labels another task reads are that task's own or
    // another item's, never equal to its own, whatever the interleaving. Relaxed loads
    // and stores suffice: the value read only ever answers "is this face mine".
    let label: Vec<AtomicU32> = (0..nf).map(|_| AtomicU32::new(u32::MAX)).collect();
    for (i, item) in work.iter().enumerate() {
        for f in item {
            label[f.index()].store(i as u32, Relaxed);
        }
    }
    let next_label = AtomicU32::new(work.len() as u32);
    // Each given item, in parallel, to its disks in the order of a depth-first split (the
    // first part's disks, then the second's), and the number of splits. The result is a
    // function of the item alone (membership is all a task reads of the labels), so `done`
    // is the concatenation in item order whatever the thread count.
    let per_item: Vec<(Vec<Vec<FaceId>>, usize)> = work
        .into_par_iter()
        .enumerate()
        .with_max_len(1)
        .map(|(i, faces)| {
            let mut done = Vec::new();
            let mut splits = 0usize;
            let mut pending = vec![(i as u32, faces)];
            while let Some((id, faces)) = pending.pop() {
                if faces.is_empty() {
                    continue;
                }
                let inside = |f: FaceId| label[f.index()].load(Relaxed) == id;
                let relabel = |part: &[FaceId]| {
                    let l = next_label.fetch_add(1, Relaxed);
                    for &f in part {
                        label[f.index()].store(l, Relaxed);
                    }
                    l
                };
                // Split off glued components first.
                let comp = flood(mesh, &faces[..1], &inside, &faces);
                if comp.len() != faces.len() {
                    splits += 1;
                    let mut in_comp = comp;
                    in_comp.sort_unstable();
                    let rest: Vec<FaceId> = faces
                        .iter()
                        .copied()
                        .filter(|f| in_comp.binary_search(f).is_err())
                        .collect();
                    let (a, b) = (relabel(&in_comp), relabel(&rest));
                    pending.push((b, rest));
                    pending.push((a, in_comp));
                    continue;
                }
                // `comp` covers `faces`: connected, so only the other disk tests remain.
                if disk_check_connected(mesh, &faces, &inside).is_ok() {
                    done.push(faces);
                    continue;
                }
                if splits >= nf {
                    // Unreachable in theory (see the module doc); a triangle is always a disk.
                    done.extend(faces.iter().map(|&f| vec![f]));
                    continue;
                }
                splits += 1;
                let (half_a, half_b) = split_in_two(mesh, &faces, &inside);
                let (a, b) = (relabel(&half_a), relabel(&half_b));
                pending.push((b, half_b));
                pending.push((a, half_a));
            }
            (done, splits)
        })
        .collect();
    let mut done = Vec::new();
    for (disks, splits) in per_item {
        done.extend(disks);
        stats.disk_splits += splits;
    }
    done
}

/// Re-grows a connected chart (at least 2 faces) as two charts from the ends of a diameter of its
/// face graph: breadth-first from both ends at once, one layer at a time, so both halves are
/// connected and non-empty.
pub(super) fn split_in_two(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    inside: &dyn Fn(FaceId) -> bool,
) -> (Vec<FaceId>, Vec<FaceId>) {
    let a = *flood(mesh, &faces[..1], inside, faces)
        .last()
        .unwrap_or(&faces[0]);
    let b = *flood(mesh, &[a], inside, faces).last().unwrap_or(&a);
    grow_two(mesh, faces, inside, a, b)
}

/// Grows two charts from faces `a` and `b` of a connected chart, breadth-first and one layer at a
/// time, then smooths the border where the fronts met (`smooth.rs`: teeth move to the other part,
/// `a` and `b` stay, each part keeps at least half of its faces), so both parts are connected;
/// `a == b` returns the chart whole and an empty part. Faces unreachable from `a` and `b` (only
/// if the chart is disconnected) join part `a`.
pub(super) fn grow_two(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    inside: &dyn Fn(FaceId) -> bool,
    a: FaceId,
    b: FaceId,
) -> (Vec<FaceId>, Vec<FaceId>) {
    if a == b {
        return (faces.to_vec(), Vec::new());
    }
    // Side per face of the chart: 0 unset, 1 `a`, 2 `b`; by binary search in the sorted faces,
    // or, for a chart with at least 1/16 of the mesh's faces, per face of the mesh (as in
    // `flood`; the same sides).
    let sorted = sorted_faces(faces);
    let dense = faces.len().saturating_mul(16) >= mesh.num_faces();
    let mut side = vec![
        0u8;
        if dense {
            mesh.num_faces()
        } else {
            sorted.len()
        }
    ];
    let slot = |f: FaceId| {
        if dense {
            // Past the seeds (checked below), only faces of the chart are `inside` (the
            // contract).
            Some(f.index()).filter(|&k| k < mesh.num_faces())
        } else {
            sorted.binary_search(&f).ok()
        }
    };
    let mut queue = VecDeque::new();
    for (seed, s) in [(a, 1u8), (b, 2u8)] {
        if dense && !faces.contains(&seed) {
            // Not a face of the chart: no side, as with the search.
            continue;
        }
        if let Some(k) = slot(seed) {
            side[k] = s;
            queue.push_back(seed);
        }
    }
    while let Some(f) = queue.pop_front() {
        let s = slot(f).map_or(1, |k| side[k]);
        for g in mesh.face_neighbors(f).into_iter().flatten() {
            if !inside(g) {
                continue;
            }
            if let Some(k) = slot(g) {
                if side[k] == 0 {
                    side[k] = s;
                    queue.push_back(g);
                }
            }
        }
    }
    smooth_halves(mesh, &sorted, dense, &mut side, &[a, b])
}

/// The two parts of `sorted` (a chart's faces, ascending) by `side` (1 or 2 per face: per
/// face of the mesh when `dense`, else per position in `sorted`), after the border between them
/// is smoothed (`smooth.rs`: teeth move to the other part, the faces of `pinned` stay, each
/// part keeps at least half of its faces). The cost of a border edge is its length, a tenth of
/// it on a hard edge (the segmentation's default hard-edge angle): splits have no feature
/// curves, and a cut should still end on a crease where one is near.
fn smooth_halves(
    mesh: &TriangleMesh,
    sorted: &[FaceId],
    dense: bool,
    side: &mut [u8],
    pinned: &[FaceId],
) -> (Vec<FaceId>, Vec<FaceId>) {
    let slot = |f: FaceId| {
        if dense {
            Some(f.index()).filter(|&k| k < mesh.num_faces())
        } else {
            sorted.binary_search(&f).ok()
        }
    };
    // The side of the `i`-th sorted face `f`, as stored.
    let side_at = |side: &[u8], i: usize, f: FaceId| if dense { side[f.index()] } else { side[i] };
    let mut sizes = [0usize; 3];
    for (i, &f) in sorted.iter().enumerate() {
        sizes[usize::from(side_at(side, i, f))] += 1;
    }
    sizes[0] = 0;
    smooth::smooth_borders(
        mesh,
        &mut smooth::SlotLabels { labels: side, slot },
        &|h| {
            let hard = mesh
                .dihedral_angle_rad(h)
                .is_some_and(|angle| angle >= options::DEFAULT_HARD_EDGE_ANGLE_RAD);
            mesh.edge_length_m(h)
                * if hard {
                    graph_cut::FEATURE_EDGE_WEIGHT
                } else {
                    1.0
                }
        },
        sorted,
        pinned,
        &mut sizes,
    );
    let half_a: Vec<FaceId> = sorted
        .iter()
        .enumerate()
        .filter(|&(i, &f)| side_at(side, i, f) != 2)
        .map(|(_, &f)| f)
        .collect();
    let half_b = sorted
        .iter()
        .enumerate()
        .filter(|&(i, &f)| side_at(side, i, f) == 2)
        .map(|(_, &f)| f)
        .collect();
    (half_a, half_b)
}

/// A chart cut in two by `far` (one flag per face of `faces`, in its order: the far side), with
/// the border between the parts smoothed as in [`grow_two`] (no face pinned; each part keeps
/// at least half of its faces): the near faces, then the far ones, each ascending.
pub(super) fn smooth_cut(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    far: &[bool],
) -> (Vec<FaceId>, Vec<FaceId>) {
    let sorted = sorted_faces(faces);
    let mut side = vec![1u8; sorted.len()];
    for (&f, &beyond) in faces.iter().zip(far) {
        if let (Ok(k), true) = (sorted.binary_search(&f), beyond) {
            side[k] = 2;
        }
    }
    smooth_halves(mesh, &sorted, false, &mut side, &[])
}

/// Merges adjacent charts, smallest chart first, while there are more than `cap` charts and the
/// union is still a disk. Returns the number of merges. Cost: up to `O(charts · F)` disk checks.
fn merge_to_cap(
    mesh: &TriangleMesh,
    charts: &mut Vec<Vec<FaceId>>,
    cap: usize,
    progress: &mut StageProgress<'_>,
) -> Result<usize, SegmentError> {
    let mut merges = 0;
    let mut label = vec![0u32; mesh.num_faces()];
    let excess = charts.len().saturating_sub(cap);
    'outer: while charts.len() > cap {
        checkpoint(progress.advance(merges, excess))?;
        for (i, c) in charts.iter().enumerate() {
            for f in c {
                label[f.index()] = i as u32;
            }
        }
        // Smallest first, ties by lowest face.
        let mut order: Vec<usize> = (0..charts.len()).collect();
        order.sort_by_key(|&i| (charts[i].len(), charts[i].first().copied()));
        for &i in &order {
            // Neighbouring charts by number of shared edges (most first), ties by index.
            let mut shared: std::collections::BTreeMap<u32, usize> = Default::default();
            for &f in &charts[i] {
                for g in mesh.face_neighbors(f).into_iter().flatten() {
                    let l = label[g.index()];
                    if l != i as u32 {
                        *shared.entry(l).or_default() += 1;
                    }
                }
            }
            let mut nbrs: Vec<(usize, u32)> = shared.into_iter().map(|(l, n)| (n, l)).collect();
            nbrs.sort_by(|x, y| y.0.cmp(&x.0).then(x.1.cmp(&y.1)));
            for (_, j) in nbrs {
                let j = j as usize;
                let (ci, cj) = (i as u32, j as u32);
                let mut union = charts[i].clone();
                union.extend_from_slice(&charts[j]);
                let inside = |f: FaceId| {
                    let l = label[f.index()];
                    l == ci || l == cj
                };
                if disk_check(mesh, &union, &inside).is_ok() {
                    let moved = std::mem::take(&mut charts[i]);
                    charts[j].extend(moved);
                    charts.swap_remove(i);
                    merges += 1;
                    continue 'outer;
                }
            }
        }
        break;
    }
    Ok(merges)
}
