//! The validated triangle mesh and its half-edge connectivity.
//!
//! Purpose: navigation over a mesh that [`TriangleMesh::build`] has welded, validated and repaired:
//! next/prev/opposite half-edges, one-rings, boundary loops, face adjacency, and the map back to
//! source vertices.
//!
//! Representation (flat `u32` arrays, no per-vertex `Vec`s; about 60 bytes per face in total):
//! - `corner_vertex[c]`: the vertex at corner `c`. Half-edge `h` runs from `corner_vertex[h]` to
//!   `corner_vertex[next(h)]`; there are no explicit boundary half-edges, a half-edge without an
//!   opposite *is* on the boundary.
//! - `opposite[h]`: the reverse half-edge in the neighbouring face, or [`NONE`].
//! - `vertex_halfedge[v]`: one outgoing half-edge, the boundary one if `v` is on the boundary, so
//!   that rotating with `opposite(prev(h))` from it visits the whole one-ring.
//!
//! Invariants (checked by [`TriangleMesh::check_invariants`], asserted after every debug build):
//! - every face has three distinct vertices; every vertex has at least one face;
//! - `opposite(opposite(h)) == h`, `opposite(h) != h`, opposite half-edges run in reverse;
//! - every vertex's incident faces form one fan (a disk or half-disk): the mesh is a manifold
//!   with boundary, and it is oriented (glued half-edges always run in opposite directions).
//! - Edges are half-edge pairs, not vertex pairs: after the repair of a non-manifold edge, two
//!   distinct edges can join the same two vertices (a cut fin lying over a glued pair). Code that
//!   needs an edge key must use the half-edge (e.g. `min(h, opposite(h))`), never `(v0, v1)`.
//!
//! Units: none here; geometry lives in `geometry.rs`.
use super::defect::DegenerateKind;
use super::ids::{CornerId, FaceId, HalfedgeId, VertexId};

/// "No opposite half-edge" in the `opposite` array.
pub(crate) const NONE: u32 = u32::MAX;

/// A welded, validated, manifold, oriented triangle mesh. Built only by [`TriangleMesh::build`].
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleMesh {
    /// Position of each vertex in model units. Split copies share their original's position.
    pub(crate) positions_m: Vec<[f64; 3]>,
    /// Vertex at each corner, `3 * num_faces` entries.
    pub(crate) corner_vertex: Vec<VertexId>,
    /// Opposite half-edge or [`NONE`], `3 * num_faces` entries.
    pub(crate) opposite: Vec<u32>,
    /// One outgoing half-edge per vertex, the boundary one if any.
    pub(crate) vertex_halfedge: Vec<HalfedgeId>,
    /// Lowest source-vertex index (into `MeshInput::positions_m`) welded into each vertex.
    pub(crate) vertex_source: Vec<u32>,
    /// Weld group of each vertex (from `MeshInput::weld_group`).
    pub(crate) vertex_weld_group: Vec<u32>,
    /// The source-vertex index of each corner, i.e. the input triangles, flattened.
    pub(crate) corner_source: Vec<u32>,
    /// Degeneracy of each face, found at build time.
    pub(crate) face_degeneracy: Vec<Option<DegenerateKind>>,
    /// The source vertices whose own position differs from their vertex's (the weld joined
    /// them to a near-coincident copy), by source index: `(source, position)`. Empty on most
    /// meshes.
    pub(crate) moved_sources: Vec<(u32, [f64; 3])>,
}

/// A broken connectivity invariant: a bug in mesh building, never an input problem.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("mesh invariant violated: {0}")]
pub struct InvariantViolation(pub String);

impl TriangleMesh {
    /// Number of faces (= number of input triangles).
    #[inline]
    pub fn num_faces(&self) -> usize {
        self.corner_vertex.len() / 3
    }
    /// Number of vertices after welding and repair splits.
    #[inline]
    pub fn num_vertices(&self) -> usize {
        self.positions_m.len()
    }
    /// Number of half-edges (= `3 * num_faces`; boundary half-edges are not stored separately).
    #[inline]
    pub fn num_halfedges(&self) -> usize {
        self.corner_vertex.len()
    }
    /// Number of corners (= `3 * num_faces`).
    #[inline]
    pub fn num_corners(&self) -> usize {
        self.corner_vertex.len()
    }
    /// Number of undirected edges: glued pairs count once, boundary half-edges once.
    pub fn num_edges(&self) -> usize {
        let boundary = self.opposite.iter().filter(|&&o| o == NONE).count();
        (self.num_halfedges() + boundary) / 2
    }

    /// All face ids in order.
    pub fn faces(&self) -> impl ExactSizeIterator<Item = FaceId> {
        (0..self.num_faces() as u32).map(FaceId)
    }
    /// All vertex ids in order.
    pub fn vertices(&self) -> impl ExactSizeIterator<Item = VertexId> {
        (0..self.num_vertices() as u32).map(VertexId)
    }
    /// All half-edge ids in order.
    pub fn halfedges(&self) -> impl ExactSizeIterator<Item = HalfedgeId> {
        (0..self.num_halfedges() as u32).map(HalfedgeId)
    }

    /// The reverse half-edge in the neighbouring face, or `None` on the boundary.
    #[inline]
    pub fn opposite(&self, h: HalfedgeId) -> Option<HalfedgeId> {
        let o = self.opposite[h.index()];
        (o != NONE).then_some(HalfedgeId(o))
    }
    /// True when `h` has no opposite (its edge is on the boundary).
    #[inline]
    pub fn is_boundary_halfedge(&self, h: HalfedgeId) -> bool {
        self.opposite[h.index()] == NONE
    }
    /// The next half-edge in the same face.
    #[inline]
    pub fn next(&self, h: HalfedgeId) -> HalfedgeId {
        h.next()
    }
    /// The previous half-edge in the same face.
    #[inline]
    pub fn prev(&self, h: HalfedgeId) -> HalfedgeId {
        h.prev()
    }
    /// The face `h` belongs to.
    #[inline]
    pub fn face(&self, h: HalfedgeId) -> FaceId {
        h.face()
    }
    /// The vertex `h` starts at.
    #[inline]
    pub fn from_vertex(&self, h: HalfedgeId) -> VertexId {
        self.corner_vertex[h.index()]
    }
    /// The vertex `h` points to.
    #[inline]
    pub fn to_vertex(&self, h: HalfedgeId) -> VertexId {
        self.corner_vertex[h.next().index()]
    }
    /// The vertex at corner `c`.
    #[inline]
    pub fn corner_vertex(&self, c: CornerId) -> VertexId {
        self.corner_vertex[c.index()]
    }
    /// The three half-edges of `f`, in corner order.
    #[inline]
    pub fn face_halfedges(&self, f: FaceId) -> [HalfedgeId; 3] {
        [f.halfedge(0), f.halfedge(1), f.halfedge(2)]
    }
    /// The three corners of `f`, in input order.
    #[inline]
    pub fn face_corners(&self, f: FaceId) -> [CornerId; 3] {
        [f.corner(0), f.corner(1), f.corner(2)]
    }
    /// The three (distinct) vertices of `f`, in input corner order.
    #[inline]
    pub fn face_vertices(&self, f: FaceId) -> [VertexId; 3] {
        let b = f.index() * 3;
        [
            self.corner_vertex[b],
            self.corner_vertex[b + 1],
            self.corner_vertex[b + 2],
        ]
    }
    /// The faces across half-edges 0, 1, 2 of `f` (`None` across a boundary edge).
    pub fn face_neighbors(&self, f: FaceId) -> [Option<FaceId>; 3] {
        self.face_halfedges(f)
            .map(|h| self.opposite(h).map(HalfedgeId::face))
    }
    /// How `f` is degenerate, if it is (found at build time; see [`DegenerateKind`]).
    #[inline]
    pub fn face_degeneracy(&self, f: FaceId) -> Option<DegenerateKind> {
        self.face_degeneracy[f.index()]
    }

    /// One outgoing half-edge of `v`: the boundary one (no opposite) if `v` is on the boundary.
    #[inline]
    pub fn vertex_halfedge(&self, v: VertexId) -> HalfedgeId {
        self.vertex_halfedge[v.index()]
    }
    /// True when `v` lies on the boundary (its fan is open).
    #[inline]
    pub fn is_boundary_vertex(&self, v: VertexId) -> bool {
        self.is_boundary_halfedge(self.vertex_halfedge(v))
    }
    /// The outgoing half-edges of `v`, one per incident face, in rotation order
    /// (`h -> opposite(prev(h))`). For a boundary vertex the first one is the boundary half-edge.
    /// Since half-edge and corner numbers coincide, these are also the corners at `v`.
    pub fn outgoing_halfedges(&self, v: VertexId) -> OutgoingHalfedges<'_> {
        let start = self.vertex_halfedge(v);
        OutgoingHalfedges {
            mesh: self,
            start,
            current: Some(start),
        }
    }
    /// The corners at `v` (one per incident face), in rotation order; the same numbers as
    /// [`Self::outgoing_halfedges`].
    pub fn vertex_corners(&self, v: VertexId) -> impl Iterator<Item = CornerId> + '_ {
        self.outgoing_halfedges(v).map(HalfedgeId::corner)
    }
    /// One half-edge per undirected edge: each boundary half-edge, and the lower-numbered
    /// half-edge of each glued pair. Use it as the edge key (see the module invariants).
    pub fn edges(&self) -> impl Iterator<Item = HalfedgeId> + '_ {
        self.halfedges()
            .filter(|&h| self.opposite(h).is_none_or(|o| h < o))
    }
    /// The neighbouring vertices of `v` in rotation order. A boundary vertex with `k` faces has
    /// `k + 1` neighbours, an interior one `k`. Cost: one rotation around `v`.
    pub fn vertex_neighbors(&self, v: VertexId) -> Vec<VertexId> {
        let mut out = Vec::new();
        let mut last = None;
        for h in self.outgoing_halfedges(v) {
            out.push(self.to_vertex(h));
            last = Some(h);
        }
        if let Some(last) = last {
            let incoming = last.prev();
            if self.is_boundary_halfedge(incoming) {
                out.push(self.from_vertex(incoming));
            }
        }
        out
    }
    /// Number of faces incident to `v`. Cost: one rotation around `v`.
    pub fn vertex_face_count(&self, v: VertexId) -> usize {
        self.outgoing_halfedges(v).count()
    }

    /// The boundary half-edge that follows the boundary half-edge `h` along its boundary loop
    /// (the face stays on the left), or `None` if `h` is not on the boundary.
    pub fn next_boundary_halfedge(&self, h: HalfedgeId) -> Option<HalfedgeId> {
        if !self.is_boundary_halfedge(h) {
            return None;
        }
        // The fan at `to_vertex(h)` is open and `h` enters it on its last side, so the outgoing
        // boundary half-edge stored for that vertex continues the loop.
        let n = self.vertex_halfedge(self.to_vertex(h));
        self.is_boundary_halfedge(n).then_some(n)
    }

    /// Every boundary loop as its half-edges in walking order (face on the left), loops ordered
    /// by their lowest half-edge id, each starting at that lowest id. Cost: O(half-edges).
    pub fn boundary_loops(&self) -> Vec<Vec<HalfedgeId>> {
        let mut visited = vec![false; self.num_halfedges()];
        let mut loops = Vec::new();
        for h in self.halfedges() {
            if visited[h.index()] || !self.is_boundary_halfedge(h) {
                continue;
            }
            let mut lp = Vec::new();
            let mut cur = h;
            loop {
                visited[cur.index()] = true;
                lp.push(cur);
                match self.next_boundary_halfedge(cur) {
                    Some(n) if n == h => break,
                    Some(n) if !visited[n.index()] => cur = n,
                    // Unreachable for a mesh that passed `check_invariants`; stop rather than loop.
                    _ => break,
                }
            }
            loops.push(lp);
        }
        loops
    }

    /// The lowest source-vertex index (into `MeshInput::positions_m`) welded into `v`.
    #[inline]
    pub fn vertex_source(&self, v: VertexId) -> u32 {
        self.vertex_source[v.index()]
    }
    /// Every source vertex welded into `v` (through the corners at `v`), ascending, no repeats.
    /// Cost: one rotation around `v` plus a sort of its corners.
    pub fn source_vertices_of(&self, v: VertexId) -> Vec<u32> {
        let mut s: Vec<u32> = self
            .outgoing_halfedges(v)
            .map(|h| self.corner_source[h.index()])
            .collect();
        s.sort_unstable();
        s.dedup();
        s
    }
    /// The source-vertex index of corner `c`: exactly the input triangle's index.
    #[inline]
    pub fn corner_source(&self, c: CornerId) -> u32 {
        self.corner_source[c.index()]
    }
    /// The position of corner `c`'s source vertex, as the input holds it: its vertex's position,
    /// except where the weld joined near-coincident copies (the weld rule of [`crate::mesh`]).
    #[inline]
    pub fn corner_position(&self, c: CornerId) -> [f64; 3] {
        if !self.moved_sources.is_empty() {
            let s = self.corner_source[c.index()];
            if let Ok(j) = self.moved_sources.binary_search_by_key(&s, |e| e.0) {
                return self.moved_sources[j].1;
            }
        }
        self.positions_m[self.corner_vertex[c.index()].index()]
    }
    /// Whether some corner's source position differs from its vertex's
    /// ([`TriangleMesh::corner_position`]).
    #[inline]
    pub fn has_moved_sources(&self) -> bool {
        !self.moved_sources.is_empty()
    }
    /// The weld group (from `MeshInput::weld_group`) of `v`.
    #[inline]
    pub fn vertex_weld_group(&self, v: VertexId) -> u32 {
        self.vertex_weld_group[v.index()]
    }

    /// Checks every connectivity invariant listed in the module doc. Cost: O(half-edges).
    /// A failure is a bug in this module, never a property of the input.
    pub fn check_invariants(&self) -> Result<(), InvariantViolation> {
        let bad = |s: String| Err(InvariantViolation(s));
        let nh = self.num_halfedges();
        let nv = self.num_vertices();
        if nh % 3 != 0 || nh == 0 {
            return bad(format!("{nh} corners is not a positive multiple of 3"));
        }
        if self.opposite.len() != nh
            || self.corner_source.len() != nh
            || self.face_degeneracy.len() != nh / 3
        {
            return bad("per-corner / per-face array lengths differ".into());
        }
        if self.vertex_halfedge.len() != nv
            || self.vertex_source.len() != nv
            || self.vertex_weld_group.len() != nv
        {
            return bad("per-vertex array lengths differ".into());
        }
        let mut corners_at = vec![0u32; nv];
        for f in self.faces() {
            let [a, b, c] = self.face_vertices(f);
            if a.index() >= nv || b.index() >= nv || c.index() >= nv {
                return bad(format!("{f} has a vertex id out of range"));
            }
            if a == b || b == c || a == c {
                return bad(format!("{f} has a repeated vertex {a} {b} {c}"));
            }
            for v in [a, b, c] {
                corners_at[v.index()] += 1;
            }
        }
        for h in self.halfedges() {
            if let Some(o) = self.opposite(h) {
                if o.index() >= nh {
                    return bad(format!("opposite({h}) = {o} out of range"));
                }
                if o == h || self.opposite(o) != Some(h) {
                    return bad(format!("opposite is not an involution at {h}"));
                }
                if self.from_vertex(o) != self.to_vertex(h)
                    || self.to_vertex(o) != self.from_vertex(h)
                {
                    return bad(format!("{h} and its opposite {o} do not run in reverse"));
                }
            }
        }
        for v in self.vertices() {
            let h = self.vertex_halfedge(v);
            if h.index() >= nh || self.from_vertex(h) != v {
                return bad(format!("vertex_halfedge({v}) = {h} does not leave {v}"));
            }
            // The rotation must visit every corner at `v` exactly once (one fan per vertex) and
            // must start on the boundary if there is one.
            let mut count = 0u32;
            let mut cur = h;
            let mut ended_open = false;
            loop {
                count += 1;
                if count > corners_at[v.index()] {
                    return bad(format!("rotation around {v} does not close"));
                }
                if self.from_vertex(cur) != v {
                    return bad(format!(
                        "rotation around {v} reached {cur} which leaves elsewhere"
                    ));
                }
                match self.opposite(cur.prev()) {
                    None => {
                        ended_open = true;
                        break;
                    }
                    Some(n) if n == h => break,
                    Some(n) => cur = n,
                }
            }
            if count != corners_at[v.index()] {
                return bad(format!(
                    "{v} has {} corners but its fan has {count}: more than one sheet",
                    corners_at[v.index()]
                ));
            }
            if ended_open != self.is_boundary_halfedge(h) {
                return bad(format!(
                    "fan of {v} is open but does not start on its boundary half-edge"
                ));
            }
        }
        Ok(())
    }
}

/// Iterator over the outgoing half-edges of a vertex; see [`TriangleMesh::outgoing_halfedges`].
#[derive(Debug, Clone)]
pub struct OutgoingHalfedges<'a> {
    mesh: &'a TriangleMesh,
    start: HalfedgeId,
    current: Option<HalfedgeId>,
}

impl Iterator for OutgoingHalfedges<'_> {
    type Item = HalfedgeId;
    fn next(&mut self) -> Option<HalfedgeId> {
        let h = self.current?;
        self.current = match self.mesh.opposite(h.prev()) {
            Some(n) if n != self.start => Some(n),
            _ => None,
        };
        Some(h)
    }
}
