//! Connected components of a [`TriangleMesh`] and their topology.
//!
//! Purpose: what `texatlas inspect` prints per component (faces, vertices, edges, boundary loops,
//! Euler characteristic, genus, weld group) and what segmentation starts from (charts never span
//! components).
//!
//! Invariants:
//! - Components are connected through glued edges (faces sharing only a vertex were split apart
//!   by the build, so they are in different components unless also joined elsewhere).
//! - `ComponentId(i)` is ordered by lowest face id: component 0 holds face 0.
//! - The built mesh is an oriented 2-manifold with boundary, so for every component
//!   `2 - χ - b` is even and non-negative and the genus `g = (2 - χ - b) / 2` is exact.
//!
//! Units: counts only.
//!
//! References: Euler–Poincaré formula for orientable surfaces with boundary,
//! `χ = V - E + F = 2 - 2g - b`.
use super::ids::{ComponentId, FaceData, FaceId, VertexId};
use super::topology::TriangleMesh;

/// Topology of one connected component.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ComponentInfo {
    /// This component's id.
    pub id: ComponentId,
    /// Its lowest face id.
    pub first_face: FaceId,
    /// F: number of faces.
    pub num_faces: usize,
    /// V: number of vertices.
    pub num_vertices: usize,
    /// E: number of undirected edges (glued pairs once, boundary edges once).
    pub num_edges: usize,
    /// b: number of boundary loops (0 for a closed surface).
    pub num_boundary_loops: usize,
    /// χ = V − E + F.
    pub euler_characteristic: i64,
    /// g = (2 − χ − b) / 2: 0 for a disk or a sphere, 1 for a torus.
    pub genus: u32,
    /// The weld group of its vertices, or `None` if its triangles mix vertices of several groups.
    pub weld_group: Option<u32>,
}

/// The partition of a mesh into connected components.
#[derive(Debug, Clone, PartialEq)]
pub struct Components {
    /// The component of each face.
    pub face_component: FaceData<ComponentId>,
    /// One entry per component, indexed by `ComponentId::index()`.
    pub components: Vec<ComponentInfo>,
}

impl Components {
    /// The component that face `f` belongs to.
    pub fn of_face(&self, f: FaceId) -> ComponentId {
        self.face_component[f]
    }
    /// Number of components.
    pub fn len(&self) -> usize {
        self.components.len()
    }
    /// Always false for a built mesh (it has at least one face).
    pub fn is_empty(&self) -> bool {
        self.components.is_empty()
    }
}

impl TriangleMesh {
    /// The component that vertex `v` belongs to, given the partition from [`Self::components`].
    pub fn vertex_component(&self, comps: &Components, v: VertexId) -> ComponentId {
        comps.of_face(self.vertex_halfedge(v).face())
    }

    /// Connected components with their topology. Cost: O(half-edges) time and memory.
    pub fn components(&self) -> Components {
        let nf = self.num_faces();
        const UNSET: u32 = u32::MAX;
        let mut comp = vec![UNSET; nf];
        let mut infos: Vec<ComponentInfo> = Vec::new();
        let mut stack: Vec<FaceId> = Vec::new();
        for f in self.faces() {
            if comp[f.index()] != UNSET {
                continue;
            }
            let id = ComponentId(infos.len() as u32);
            comp[f.index()] = id.0;
            stack.push(f);
            let mut num_faces = 0usize;
            let mut num_edges = 0usize;
            while let Some(g) = stack.pop() {
                num_faces += 1;
                for h in self.face_halfedges(g) {
                    match self.opposite(h) {
                        None => num_edges += 1,
                        Some(o) => {
                            if h < o {
                                num_edges += 1;
                            }
                            let n = o.face();
                            if comp[n.index()] == UNSET {
                                comp[n.index()] = id.0;
                                stack.push(n);
                            }
                        }
                    }
                }
            }
            infos.push(ComponentInfo {
                id,
                first_face: f,
                num_faces,
                num_vertices: 0,
                num_edges,
                num_boundary_loops: 0,
                euler_characteristic: 0,
                genus: 0,
                weld_group: None,
            });
        }
        // Weld group: the group shared by all vertices, None when mixed.
        let mut group: Vec<Option<Option<u32>>> = vec![None; infos.len()];
        for v in self.vertices() {
            let c = comp[self.vertex_halfedge(v).face().index()] as usize;
            infos[c].num_vertices += 1;
            let g = self.vertex_weld_group(v);
            group[c] = match group[c] {
                None => Some(Some(g)),
                Some(Some(x)) if x == g => Some(Some(g)),
                Some(_) => Some(None),
            };
        }
        for lp in self.boundary_loops() {
            if let Some(h) = lp.first() {
                infos[comp[h.face().index()] as usize].num_boundary_loops += 1;
            }
        }
        for (info, g) in infos.iter_mut().zip(group) {
            info.weld_group = g.flatten();
            let chi = info.num_vertices as i64 - info.num_edges as i64 + info.num_faces as i64;
            info.euler_characteristic = chi;
            // Exact for an oriented manifold (see module invariants); clamped so that a broken
            // invariant shows up as a wrong count in tests rather than a panic.
            let twice_g = 2 - chi - info.num_boundary_loops as i64;
            debug_assert!(
                twice_g >= 0 && twice_g % 2 == 0,
                "χ={chi} b={}",
                info.num_boundary_loops
            );
            info.genus = u32::try_from(twice_g.max(0) / 2).unwrap_or(u32::MAX);
        }
        Components {
            face_component: FaceData::from_vec(comp.into_iter().map(ComponentId).collect()),
            components: infos,
        }
    }
}
