//! Mesh tests: every fixture category, every defect, and invariants recomputed independently
//! (hash sets over the input instead of the half-edge structure).
use std::collections::{BTreeMap, BTreeSet, HashSet};
use std::f64::consts::{FRAC_PI_2, PI};

use proptest::prelude::*;

use super::fixtures::*;
use super::*;

/// Builds, asserts the invariants and the independent input/output consistency checks.
fn build_ok(input: &MeshInput) -> BuiltMesh {
    let built = match TriangleMesh::build(input) {
        Ok(b) => b,
        Err(e) => panic!("build failed: {e}"),
    };
    check_against_input(input, &built.mesh);
    built
}

/// Checks, without using the half-edge structure, that the mesh is the input: same faces in the
/// same order, each corner at its source vertex's position (its vertex there too, or at a joined
/// copy's), three distinct vertices per face.
fn check_against_input(input: &MeshInput, m: &TriangleMesh) {
    assert_eq!(m.check_invariants(), Ok(()));
    assert_eq!(m.num_faces(), input.triangles.len());
    let z = |p: [f64; 3]| p.map(|x| if x == 0.0 { 0u64 } else { x.to_bits() });
    for (f, t) in input.triangles.iter().enumerate() {
        let f = FaceId(f as u32);
        let vs = m.face_vertices(f);
        assert!(vs[0] != vs[1] && vs[1] != vs[2] && vs[0] != vs[2]);
        for k in 0..3 {
            let c = f.corner(k);
            assert_eq!(m.corner_source(c), t[k]);
            // Each corner keeps its own position. Its vertex sits at the same point, except
            // where the weld joined near-coincident copies: then at the position of another
            // source of its weld group (the group's lowest), never at a point of its own making.
            let own = z(input.positions_m[t[k] as usize]);
            assert_eq!(z(m.corner_position(c)), own, "corner {c} moved");
            let at = z(m.position(vs[k]));
            assert!(
                at == own
                    || (input.positions_m.iter().zip(&input.weld_group))
                        .any(|(&p, &g)| g == input.weld_group[t[k] as usize] && z(p) == at),
                "corner {c}'s vertex is at a point no source of its weld group has"
            );
            assert_eq!(
                input.weld_group[t[k] as usize],
                m.vertex_weld_group(vs[k]),
                "corner {c} changed weld group"
            );
        }
    }
    // Source vertices per vertex, collected from the face list, match the one-ring answer.
    let mut sources: Vec<BTreeSet<u32>> = vec![BTreeSet::new(); m.num_vertices()];
    for c in (0..m.num_corners() as u32).map(CornerId) {
        sources[m.corner_vertex(c).index()].insert(m.corner_source(c));
    }
    for v in m.vertices() {
        let expected: Vec<u32> = sources[v.index()].iter().copied().collect();
        assert_eq!(m.source_vertices_of(v), expected, "{v}");
        assert_eq!(Some(&m.vertex_source(v)), expected.first(), "{v}");
    }
}

/// Euler characteristic and boundary-edge count recomputed from face vertex triples only.
fn independent_euler(m: &TriangleMesh) -> (i64, usize) {
    let mut edges: BTreeMap<(u32, u32), usize> = BTreeMap::new();
    let mut verts = BTreeSet::new();
    for f in m.faces() {
        let v = m.face_vertices(f);
        for k in 0..3 {
            let (a, b) = (v[k].0, v[(k + 1) % 3].0);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            verts.insert(a);
        }
    }
    let boundary = edges.values().filter(|&&n| n == 1).count();
    (
        verts.len() as i64 - edges.len() as i64 + m.num_faces() as i64,
        boundary,
    )
}

/// Independent count of distinct (group, position) among used source vertices.
fn independent_weld_count(input: &MeshInput) -> usize {
    let used: HashSet<u32> = input.triangles.iter().flatten().copied().collect();
    used.iter()
        .map(|&s| {
            let p = input.positions_m[s as usize];
            (
                input.weld_group[s as usize],
                p.map(|x| if x == 0.0 { 0u64 } else { x.to_bits() }),
            )
        })
        .collect::<HashSet<_>>()
        .len()
}

fn signed_volume_m3(m: &TriangleMesh) -> f64 {
    m.faces()
        .map(|f| {
            let [a, b, c] = m.face_positions(f);
            let n = [
                b[1] * c[2] - b[2] * c[1],
                b[2] * c[0] - b[0] * c[2],
                b[0] * c[1] - b[1] * c[0],
            ];
            (a[0] * n[0] + a[1] * n[1] + a[2] * n[2]) / 6.0
        })
        .sum()
}

struct Expect {
    vertices: usize,
    components: usize,
    boundary_loops: usize,
    genus: u32,
    euler: i64,
}

/// Data-driven check over the clean fixtures: counts, topology and no defects.
fn check_clean(name: &str, input: &MeshInput, e: Expect) {
    let b = build_ok(input);
    let m = &b.mesh;
    assert!(b.defects.is_empty(), "{name}: {:?}", b.defects);
    assert_eq!(m.num_vertices(), e.vertices, "{name} vertices");
    assert_eq!(m.num_vertices(), independent_weld_count(input), "{name}");
    let comps = m.components();
    assert_eq!(comps.len(), e.components, "{name} components");
    let loops = m.boundary_loops();
    assert_eq!(loops.len(), e.boundary_loops, "{name} loops");
    let (chi, boundary_edges) = independent_euler(m);
    assert_eq!(chi, e.euler, "{name} independent χ");
    assert_eq!(
        loops.iter().map(Vec::len).sum::<usize>(),
        boundary_edges,
        "{name} every boundary edge is in exactly one loop"
    );
    let total_chi: i64 = comps
        .components
        .iter()
        .map(|c| c.euler_characteristic)
        .sum();
    assert_eq!(total_chi, e.euler, "{name} χ");
    assert_eq!(
        comps.components.iter().map(|c| c.num_edges).sum::<usize>(),
        m.num_edges()
    );
    for c in &comps.components {
        assert_eq!(c.genus, e.genus, "{name} genus of {:?}", c.id);
        assert_eq!(c.weld_group, Some(0));
    }
}

#[test]
fn clean_fixtures_have_the_expected_topology() {
    check_clean(
        "grid",
        &grid(5, 3),
        Expect {
            vertices: 24,
            components: 1,
            boundary_loops: 1,
            genus: 0,
            euler: 1,
        },
    );
    check_clean(
        "cube",
        &cube_split_faces(),
        Expect {
            vertices: 8,
            components: 1,
            boundary_loops: 0,
            genus: 0,
            euler: 2,
        },
    );
    check_clean(
        "sphere",
        &uv_sphere(8, 12, 1.0),
        Expect {
            vertices: 2 + 7 * 12,
            components: 1,
            boundary_loops: 0,
            genus: 0,
            euler: 2,
        },
    );
    check_clean(
        "torus",
        &torus(12, 8, 2.0, 0.5),
        Expect {
            vertices: 96,
            components: 1,
            boundary_loops: 0,
            genus: 1,
            euler: 0,
        },
    );
    check_clean(
        "cylinder",
        &cylinder_open(10, 3, 1.0, 2.0),
        Expect {
            vertices: 40,
            components: 1,
            boundary_loops: 2,
            genus: 0,
            euler: 0,
        },
    );
    check_clean(
        "two components",
        &two_components(),
        Expect {
            vertices: 9 + 8,
            components: 2,
            boundary_loops: 1,
            genus: 0,
            euler: 3,
        },
    );
}

#[test]
fn fixture_source_counts_match_their_docs() {
    let s = uv_sphere(5, 7, 1.0);
    assert_eq!(s.positions_m.len(), 2 * 7 + 4 * 8);
    assert_eq!(s.triangles.len(), 2 * 7 * 4);
    let t = torus(6, 4, 2.0, 0.5);
    assert_eq!((t.positions_m.len(), t.triangles.len()), (7 * 5, 48));
    let c = cylinder_open(6, 2, 1.0, 1.0);
    assert_eq!((c.positions_m.len(), c.triangles.len()), (7 * 3, 24));
    assert_eq!(cube_split_faces().positions_m.len(), 24);
    let g = grid(4, 3);
    assert_eq!((g.positions_m.len(), g.triangles.len()), (20, 24));
    let smallest = build_ok(&uv_sphere(2, 3, 1.0)).mesh;
    assert_eq!(smallest.num_vertices(), 5);
    assert_eq!(smallest.components().components[0].genus, 0);
}

#[test]
fn closed_fixtures_are_oriented_outward() {
    // Signed volume by the divergence theorem, independent of the half-edge structure.
    let cube = build_ok(&cube_split_faces()).mesh;
    assert!((signed_volume_m3(&cube) - 1.0).abs() < 1e-12);
    let sphere = build_ok(&uv_sphere(16, 24, 2.0)).mesh;
    let v = signed_volume_m3(&sphere);
    let exact = 4.0 / 3.0 * PI * 8.0;
    assert!(v > 0.9 * exact && v < exact, "{v} vs {exact}");
    let torus = build_ok(&torus(24, 12, 2.0, 0.5)).mesh;
    let exact = 2.0 * PI * PI * 2.0 * 0.25;
    let v = signed_volume_m3(&torus);
    assert!(v > 0.9 * exact && v < exact, "{v} vs {exact}");
}

#[test]
fn clean_input_keeps_source_vertex_numbering() {
    let input = grid(3, 2);
    let m = build_ok(&input).mesh;
    for v in m.vertices() {
        assert_eq!(m.vertex_source(v), v.0);
        assert_eq!(m.source_vertices_of(v), vec![v.0]);
    }
}

#[test]
fn cube_corners_weld_three_source_vertices_each() {
    let input = cube_split_faces();
    let m = build_ok(&input).mesh;
    for v in m.vertices() {
        let s = m.source_vertices_of(v);
        assert_eq!(s.len(), 3, "{v}: {s:?}");
        assert_eq!(m.vertex_source(v), s[0]);
        for &i in &s {
            assert_eq!(input.positions_m[i as usize], m.position(v));
        }
        let faces = m
            .faces()
            .filter(|&f| m.face_vertices(f).contains(&v))
            .count();
        assert_eq!(m.vertex_face_count(v), faces);
        assert_eq!(
            m.vertex_neighbors(v).len(),
            faces,
            "closed: as many neighbours as faces"
        );
    }
    assert_eq!(m.num_edges(), 18);
}

#[test]
fn negative_zero_welds_and_weld_groups_separate() {
    let mut input = grid(1, 1);
    // Two triangles [0,1,3] [0,3,2]... the grid's corner (0,0) gets a -0.0 twin used by face 1.
    input.positions_m.push([-0.0, -0.0, 0.0]);
    input.weld_group.push(0);
    input.triangles[1][0] = 4;
    let m = build_ok(&input).mesh;
    assert_eq!(m.num_vertices(), 4);
    assert_eq!(m.source_vertices_of(VertexId(0)), vec![0, 4]);
    assert!(build_ok(&input).defects.is_empty());

    // The same cube with half its sides in another weld group does not weld across groups.
    let mut cube = cube_split_faces();
    for g in cube.weld_group.iter_mut().skip(12) {
        *g = 1;
    }
    let b = build_ok(&cube);
    assert_eq!(b.mesh.num_vertices(), independent_weld_count(&cube));
    assert!(b.mesh.num_vertices() > 8);
    let comps = b.mesh.components();
    assert_eq!(comps.len(), 2);
    assert_eq!(comps.components[0].weld_group, Some(0));
    assert_eq!(comps.components[1].weld_group, Some(1));
}

#[test]
fn mixed_weld_group_component_has_no_single_group() {
    let mut input = grid(1, 1);
    input.weld_group[2] = 7;
    let comps = build_ok(&input).mesh.components();
    assert_eq!(comps.components[0].weld_group, None);
}

#[test]
fn one_ring_iterates_whole_fans() {
    let m = build_ok(&grid(4, 4)).mesh;
    for v in m.vertices() {
        // Independent one-ring from the face list.
        let mut faces = 0;
        let mut nbrs = BTreeSet::new();
        for f in m.faces() {
            let fv = m.face_vertices(f);
            if let Some(k) = fv.iter().position(|&x| x == v) {
                faces += 1;
                nbrs.insert(fv[(k + 1) % 3]);
                nbrs.insert(fv[(k + 2) % 3]);
            }
        }
        let out: Vec<_> = m.outgoing_halfedges(v).collect();
        assert_eq!(out.len(), faces, "{v}");
        assert!(out.iter().all(|&h| m.from_vertex(h) == v));
        let ring = m.vertex_neighbors(v);
        assert_eq!(ring.len(), nbrs.len(), "{v}: {ring:?}");
        assert_eq!(ring.iter().copied().collect::<BTreeSet<_>>(), nbrs);
        let pos = m.position(v);
        let on_border = pos[0] == 0.0 || pos[0] == 4.0 || pos[1] == 0.0 || pos[1] == 4.0;
        assert_eq!(m.is_boundary_vertex(v), on_border, "{v}");
        if on_border {
            assert!(m.is_boundary_halfedge(out[0]));
        }
    }
    // Corner (0,0) has faces [0,1,6] and [0,6,5]: 2 faces, 3 neighbours; the centre has 6 faces.
    assert_eq!(m.vertex_face_count(VertexId(0)), 2);
    assert_eq!(m.vertex_neighbors(VertexId(0)).len(), 3);
    assert_eq!(m.vertex_face_count(VertexId(12)), 6);
    assert_eq!(m.vertex_neighbors(VertexId(12)).len(), 6);
}

#[test]
fn boundary_loops_walk_the_border() {
    let m = build_ok(&grid(3, 2)).mesh;
    let loops = m.boundary_loops();
    assert_eq!(loops.len(), 1);
    let lp = &loops[0];
    assert_eq!(lp.len(), 2 * (3 + 2));
    for i in 0..lp.len() {
        let (h, n) = (lp[i], lp[(i + 1) % lp.len()]);
        assert!(m.is_boundary_halfedge(h));
        assert_eq!(m.to_vertex(h), m.from_vertex(n));
        assert_eq!(m.next_boundary_halfedge(h), Some(n));
    }
    // Walking with the face on the left goes counter-clockwise around a +z-facing disk:
    // the shoelace area of the loop is positive and equals the grid area.
    let area: f64 = lp
        .iter()
        .map(|&h| {
            let (a, b) = (m.position(m.from_vertex(h)), m.position(m.to_vertex(h)));
            0.5 * (a[0] * b[1] - b[0] * a[1])
        })
        .sum();
    assert!((area - 6.0).abs() < 1e-12, "{area}");
    let interior = m.halfedges().find(|&h| !m.is_boundary_halfedge(h));
    assert_eq!(interior.and_then(|h| m.next_boundary_halfedge(h)), None);

    let cyl = build_ok(&cylinder_open(7, 2, 1.0, 1.0)).mesh;
    let loops = cyl.boundary_loops();
    assert_eq!(loops.iter().map(Vec::len).collect::<Vec<_>>(), vec![7, 7]);
}

#[test]
fn face_neighbors_match_shared_edges() {
    let m = build_ok(&grid(2, 2)).mesh;
    // Face 0 = [0,1,4], face 1 = [0,4,3], face 2 = [1,2,5].
    assert_eq!(
        m.face_neighbors(FaceId(0)),
        [None, Some(FaceId(3)), Some(FaceId(1))]
    );
    for f in m.faces() {
        for (k, n) in m.face_neighbors(f).into_iter().enumerate() {
            let h = f.halfedge(k);
            if let Some(n) = n {
                let o = m.opposite(h).map(HalfedgeId::face);
                assert_eq!(o, Some(n));
                assert!(m.face_neighbors(n).contains(&Some(f)));
            } else {
                assert!(m.is_boundary_halfedge(h));
            }
        }
    }
}

#[test]
fn bowtie_vertex_is_split_into_two_sheets() {
    let b = build_ok(&bowtie());
    assert_eq!(
        b.defects,
        vec![MeshDefect::NonManifoldVertex {
            source_vertex: 0,
            vertices: vec![VertexId(0), VertexId(1)]
        }]
    );
    let m = &b.mesh;
    assert_eq!(m.num_vertices(), 6);
    assert_eq!(b.num_welded_vertices, 5);
    assert_eq!(m.face_vertices(FaceId(0))[0], VertexId(0));
    assert_eq!(m.face_vertices(FaceId(1))[0], VertexId(1));
    assert_eq!(m.position(VertexId(0)), m.position(VertexId(1)));
    assert_eq!(m.vertex_source(VertexId(1)), 0);
    let comps = m.components();
    assert_eq!(comps.len(), 2);
    assert!(comps
        .components
        .iter()
        .all(|c| c.num_boundary_loops == 1 && c.genus == 0));
    assert!(b.defects[0].to_string().contains("2 separate sheets"));
}

#[test]
fn fin_keeps_the_lowest_consistent_pair_and_cuts_the_rest() {
    let b = build_ok(&fin());
    let m = &b.mesh;
    assert_eq!(
        b.defects[0],
        MeshDefect::NonManifoldEdge {
            faces: vec![FaceId(0), FaceId(1), FaceId(2)],
            glued: vec![[FaceId(0), FaceId(1)]],
            source_vertices: [0, 1],
        }
    );
    assert_eq!(b.defects[0].code(), "non_manifold_edge");
    // The two end points of the edge are split: one copy for the glued pair, one for the fin.
    let split: Vec<u32> = b.defects[1..]
        .iter()
        .map(|d| match d {
            MeshDefect::NonManifoldVertex {
                source_vertex,
                vertices,
            } => {
                assert_eq!(vertices.len(), 2);
                *source_vertex
            }
            other => panic!("unexpected {other:?}"),
        })
        .collect();
    assert_eq!(split, vec![0, 1]);
    assert_eq!(
        m.opposite(FaceId(0).halfedge(0)),
        Some(FaceId(1).halfedge(0))
    );
    assert_eq!(m.face_neighbors(FaceId(2)), [None, None, None]);
    assert_eq!(m.components().len(), 2);
}

#[test]
fn fin_without_consistent_pair_is_cut_apart() {
    let mut input = fin();
    input.triangles[1] = [0, 1, 3]; // now all three run 0 -> 1
    let b = build_ok(&input);
    assert!(matches!(
        &b.defects[0],
        MeshDefect::NonManifoldEdge { glued, faces, .. } if glued.is_empty() && faces.len() == 3
    ));
    assert!(b.defects[0].to_string().contains("all are cut apart"));
    assert_eq!(b.mesh.components().len(), 3);
}

#[test]
fn four_faces_on_an_edge_become_two_glued_sheets() {
    // Two closed cubes (8 vertices each after welding) sharing one edge: x = 1, y = 1, z in [0, 1].
    let a = cube_split_faces();
    let mut b = cube_split_faces();
    for p in &mut b.positions_m {
        p[0] += 1.0;
        p[1] += 1.0;
    }
    let built = build_ok(&concat(&[a, b]));
    let edges: Vec<_> = built
        .defects
        .iter()
        .filter_map(|d| match d {
            MeshDefect::NonManifoldEdge { faces, glued, .. } => Some((faces.len(), glued.len())),
            _ => None,
        })
        .collect();
    assert_eq!(edges, vec![(4, 2)]);
    let text = built.defects[0].to_string();
    assert!(
        text.contains("stay joined as separate sheets") && !text.contains("cut off"),
        "{text}"
    );
    // Both cubes stay closed spheres; the two shared corners are split, one copy per cube.
    let comps = built.mesh.components();
    assert_eq!(comps.len(), 2);
    for c in &comps.components {
        assert_eq!(
            (
                c.num_vertices,
                c.num_boundary_loops,
                c.genus,
                c.euler_characteristic
            ),
            (8, 0, 0, 2)
        );
    }
    let split: usize = built
        .defects
        .iter()
        .filter(
            |d| matches!(d, MeshDefect::NonManifoldVertex { vertices, .. } if vertices.len() == 2),
        )
        .count();
    assert_eq!(split, 2);
}

#[test]
fn flipped_face_is_cut_from_all_its_neighbours() {
    let b = build_ok(&flipped_face());
    let m = &b.mesh;
    let orient: Vec<[FaceId; 2]> = b
        .defects
        .iter()
        .filter_map(|d| match d {
            MeshDefect::InconsistentOrientation { faces, .. } => Some(*faces),
            _ => None,
        })
        .collect();
    assert_eq!(
        orient,
        vec![
            [FaceId(0), FaceId(3)],
            [FaceId(2), FaceId(3)],
            [FaceId(3), FaceId(6)]
        ]
    );
    assert_eq!(m.face_neighbors(FaceId(3)), [None, None, None]);
    // Face order and corner order are untouched: face 3 still runs 1 -> 4 -> 5.
    let src = m.face_corners(FaceId(3)).map(|c| m.corner_source(c));
    assert_eq!(src, [1, 4, 5]);
    // Source vertex 1 had faces 0, 2, 3, now three separate sheets.
    assert!(b.defects.contains(&MeshDefect::NonManifoldVertex {
        source_vertex: 1,
        vertices: m.vertices().filter(|&v| m.vertex_source(v) == 1).collect(),
    }));
    assert_eq!(m.vertices().filter(|&v| m.vertex_source(v) == 1).count(), 3);
}

#[test]
fn degenerate_triangles_are_kept_reported_and_isolated_when_needed() {
    let input = degenerate();
    let b = build_ok(&input);
    let m = &b.mesh;
    assert_eq!(
        b.defects,
        vec![
            MeshDefect::DegenerateTriangle {
                face: FaceId(2),
                kind: DegenerateKind::ZeroArea
            },
            MeshDefect::DegenerateTriangle {
                face: FaceId(3),
                kind: DegenerateKind::RepeatedVertex
            },
            MeshDefect::DegenerateTriangle {
                face: FaceId(4),
                kind: DegenerateKind::RepeatedVertex
            },
        ]
    );
    assert_eq!(b.defects[0].code(), "degenerate_triangle_zero_area");
    assert_eq!(b.defects[2].code(), "degenerate_triangle_repeated_vertex");
    // The zero-area face stays glued to face 0 and has no normal.
    assert_eq!(m.face_neighbors(FaceId(2))[0], Some(FaceId(0)));
    assert_eq!(m.face_normal(FaceId(2)), None);
    assert_eq!(m.face_degeneracy(FaceId(2)), Some(DegenerateKind::ZeroArea));
    assert_eq!(m.face_degeneracy(FaceId(0)), None);
    // Repeated-vertex faces are isolated with 3 vertex copies each: 5 + 3 + 3 vertices.
    assert_eq!(m.face_neighbors(FaceId(3)), [None; 3]);
    assert_eq!(m.face_neighbors(FaceId(4)), [None; 3]);
    assert_eq!(m.num_vertices(), 11);
    assert_eq!(b.num_welded_vertices, 5);
    assert_eq!(
        m.face_degeneracy(FaceId(4)),
        Some(DegenerateKind::RepeatedVertex)
    );
    let comps = m.components();
    assert_eq!(comps.len(), 3);
    assert_eq!(comps.components[0].num_faces, 3);
}

#[test]
fn fatal_errors_name_their_elements() {
    assert_eq!(
        TriangleMesh::build(&MeshInput::default()).err(),
        Some(MeshBuildError::NoTriangles)
    );

    let mut input = grid(1, 1);
    input.weld_group.pop();
    assert!(matches!(
        TriangleMesh::build(&input),
        Err(MeshBuildError::WeldGroupLengthMismatch {
            positions: 4,
            weld_groups: 3
        })
    ));

    let mut input = grid(1, 1);
    input.triangles[1][2] = 99;
    let e = TriangleMesh::build(&input).err();
    let Some(MeshBuildError::IndexOutOfRange {
        offenders,
        num_positions: 4,
    }) = &e
    else {
        panic!("{e:?}")
    };
    assert_eq!(
        offenders.first,
        vec![BadIndex {
            face: FaceId(1),
            slot: 2,
            index: 99
        }]
    );
    assert!(e
        .as_ref()
        .map(|e| e.to_string())
        .unwrap_or_default()
        .contains("f1 corner 2 = 99"));

    // A hostile input with many bad indices gives a small error.
    let input = MeshInput {
        positions_m: vec![[0.0; 3]; 3],
        triangles: vec![[7, 8, 9]; 1000],
        weld_group: vec![0; 3],
    };
    let Err(MeshBuildError::IndexOutOfRange { offenders, .. }) = TriangleMesh::build(&input) else {
        panic!()
    };
    assert_eq!((offenders.first.len(), offenders.total), (MAX_LISTED, 3000));

    let mut input = grid(1, 1);
    input.positions_m[2][1] = f64::NAN;
    input.positions_m[3][0] = f64::NEG_INFINITY;
    let e = TriangleMesh::build(&input).err();
    let Some(MeshBuildError::NonFiniteCoordinate { source_vertices }) = &e else {
        panic!("{e:?}")
    };
    assert_eq!(source_vertices.first, vec![2, 3]);
    assert_eq!(e.map(|e| e.code()), Some("non_finite_coordinate"));
}

#[test]
fn unused_vertices_are_reported_not_fatal() {
    let mut input = grid(1, 1);
    input.positions_m.push([f64::NAN, 0.0, 0.0]);
    input.positions_m.push([9.0, 9.0, 9.0]);
    input.weld_group.extend([0, 0]);
    let b = build_ok(&input);
    assert_eq!(b.mesh.num_vertices(), 4);
    let MeshDefect::UnreferencedVertices { source_vertices } = &b.defects[0] else {
        panic!()
    };
    assert_eq!(source_vertices.first, vec![4, 5]);
    assert_eq!(b.defects[0].code(), "unreferenced_vertices");
}

#[test]
fn geometry_matches_closed_forms() {
    let m = build_ok(&grid(3, 2)).mesh;
    for f in m.faces() {
        assert!((m.face_area_m2(f) - 0.5).abs() < 1e-15);
        assert_eq!(m.face_normal(f), Some([0.0, 0.0, 1.0]));
        let sum: f64 = m
            .face_corners(f)
            .iter()
            .map(|&c| m.corner_angle_rad(c))
            .sum();
        assert!((sum - PI).abs() < 1e-12);
    }
    assert!((m.surface_area_m2() - 6.0).abs() < 1e-12);
    // Interior vertex: angles around it sum to 2π (flat).
    let v = VertexId(5);
    assert!(!m.is_boundary_vertex(v));
    let total: f64 = m
        .outgoing_halfedges(v)
        .map(|h| m.corner_angle_rad(h.corner()))
        .sum();
    assert!((total - 2.0 * PI).abs() < 1e-12);
    // Face 0 = [0,1,5]: edge 1 -> 5 is vertical, edge 5 -> 0 the diagonal.
    assert!((m.edge_length_m(FaceId(0).halfedge(1)) - 1.0).abs() < 1e-15);
    assert!((m.edge_length_m(FaceId(0).halfedge(2)) - 2f64.sqrt()).abs() < 1e-15);
    assert!(m
        .halfedges()
        .filter_map(|h| m.dihedral_angle_rad(h))
        .all(|a| a.abs() < 1e-12));
    assert_eq!(m.dihedral_angle_rad(FaceId(0).halfedge(0)), None);
    let bb = m.bounding_box();
    assert_eq!((bb.min_m, bb.max_m), ([0.0; 3], [3.0, 2.0, 0.0]));
    assert!((bb.diagonal_m() - 13f64.sqrt()).abs() < 1e-15);

    // Cube: dihedral angles are π/2 across sides and 0 across the side diagonals.
    let cube = build_ok(&cube_split_faces()).mesh;
    let mut right = 0;
    let mut flat = 0;
    for h in cube.halfedges() {
        let a = cube.dihedral_angle_rad(h).unwrap_or(f64::NAN);
        if (a - FRAC_PI_2).abs() < 1e-12 {
            right += 1;
        } else if a.abs() < 1e-12 {
            flat += 1;
        }
    }
    assert_eq!((right, flat), (24, 12));

    // Sphere normals point away from the centre.
    let s = build_ok(&uv_sphere(6, 9, 1.0)).mesh;
    for f in s.faces() {
        let p = s.face_positions(f);
        let c = [0, 1, 2].map(|k| (p[0][k] + p[1][k] + p[2][k]) / 3.0);
        let n = s.face_normal(f).unwrap_or([0.0; 3]);
        assert!(c[0] * n[0] + c[1] * n[1] + c[2] * n[2] > 0.0, "{f}");
        assert!(((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn zero_area_predicate_has_a_relative_threshold() {
    assert!(triangle_is_zero_area(&[
        [0.0; 3],
        [1.0, 0.0, 0.0],
        [2.0, 0.0, 0.0]
    ]));
    assert!(triangle_is_zero_area(&[[1.0; 3]; 3]));
    // Collinear but not axis-aligned: rounding noise only.
    assert!(triangle_is_zero_area(&[
        [0.1, 0.2, 0.3],
        [0.4, 0.5, 0.6],
        [0.7, 0.8, 0.9]
    ]));
    // A 1e-6 sliver is a real triangle, at any scale, even near f64::MAX.
    for s in [1e-200, 1.0, 1e200] {
        let p = [[0.0, 0.0, 0.0], [s, 0.0, 0.0], [0.5 * s, 1e-6 * s, 0.0]];
        assert!(!triangle_is_zero_area(&p), "scale {s}");
    }
    let huge = [[-1e308, 0.0, 0.0], [1e308, 0.0, 0.0], [0.0, 1e308, 0.0]];
    assert!(!triangle_is_zero_area(&huge));
}

#[test]
fn corner_angles_are_finite_on_degenerate_faces() {
    let m = build_ok(&degenerate()).mesh;
    for c in (0..m.num_corners() as u32).map(CornerId) {
        assert!(m.corner_angle_rad(c).is_finite());
    }
    // Zero-area face [2,1,4] with 4 the midpoint of 2-1: angle π at corner 2 (vertex 4).
    assert!((m.corner_angle_rad(FaceId(2).corner(2)) - PI).abs() < 1e-12);
}

#[test]
fn build_is_deterministic_across_thread_counts() {
    let input = concat(&[
        torus(20, 10, 2.0, 0.5),
        fin(),
        bowtie(),
        degenerate(),
        flipped_face(),
    ]);
    let a = build_ok(&input);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build();
    let Ok(pool) = pool else {
        panic!("thread pool")
    };
    let b = pool.install(|| build_ok(&input));
    assert_eq!(a.mesh, b.mesh);
    assert_eq!(a.defects, b.defects);
}

#[test]
fn id_vec_data_per_face() {
    let m = build_ok(&grid(2, 1)).mesh;
    let areas: FaceData<f64> = FaceData::from_vec(m.faces().map(|f| m.face_area_m2(f)).collect());
    assert_eq!(areas.len(), m.num_faces());
    assert_eq!(areas[FaceId(3)], 0.5);
    let comps = m.components();
    assert_eq!(m.vertex_component(&comps, VertexId(5)), ComponentId(0));
    assert_eq!(comps.of_face(FaceId(2)), ComponentId(0));
    assert!(!comps.is_empty());
}

fn soup() -> impl Strategy<Value = MeshInput> {
    // Few distinct positions (duplicates weld), few vertices (repeats, fins, bowties happen).
    (1usize..10, 1usize..24).prop_flat_map(|(nv, nf)| {
        (
            proptest::collection::vec(proptest::collection::vec(0i8..3, 3), nv),
            proptest::collection::vec(proptest::collection::vec(0u32..nv as u32, 3), nf),
            proptest::collection::vec(0u32..2, nv),
        )
            .prop_map(|(p, t, g)| MeshInput {
                positions_m: p
                    .iter()
                    .map(|c| [f64::from(c[0]), f64::from(c[1]), -f64::from(c[2])])
                    .collect(),
                triangles: t.iter().map(|t| [t[0], t[1], t[2]]).collect(),
                weld_group: g,
            })
    })
}

proptest! {
    #[test]
    fn random_soups_build_into_valid_meshes(input in soup()) {
        let built = TriangleMesh::build(&input);
        let b = match built {
            Ok(b) => b,
            Err(e) => return Err(TestCaseError::fail(format!("unexpected error {e}"))),
        };
        check_against_input(&input, &b.mesh);
        let m = &b.mesh;
        let comps = m.components();
        // Repair can leave two distinct edges between the same two vertices (e.g. a cut fin over
        // a glued pair), so edges are counted on the half-edge structure here; the vertex-pair
        // count is used on the clean fixtures only.
        let chi = m.num_vertices() as i64 - m.num_edges() as i64 + m.num_faces() as i64;
        prop_assert_eq!(comps.components.iter().map(|c| c.euler_characteristic).sum::<i64>(), chi);
        let boundary = m.halfedges().filter(|&h| m.opposite(h).is_none()).count();
        prop_assert_eq!(m.boundary_loops().iter().map(Vec::len).sum::<usize>(), boundary);
        for c in &comps.components {
            let twice_g = 2 - c.euler_characteristic - c.num_boundary_loops as i64;
            prop_assert!(twice_g >= 0 && twice_g % 2 == 0);
        }
        // Every repeated-vertex face is reported, and only those are isolated by force.
        for f in m.faces() {
            let t = input.triangles[f.index()];
            let w = t.map(|i| (input.weld_group[i as usize], input.positions_m[i as usize].map(|x| if x == 0.0 { 0 } else { x.to_bits() })));
            let repeated = w[0] == w[1] || w[1] == w[2] || w[0] == w[2];
            prop_assert_eq!(repeated, m.face_degeneracy(f) == Some(DegenerateKind::RepeatedVertex));
            let reported = b.defects.iter().any(|d| matches!(d, MeshDefect::DegenerateTriangle { face, .. } if *face == f));
            prop_assert_eq!(reported, m.face_degeneracy(f).is_some());
        }
        for d in &b.defects {
            prop_assert!(!d.to_string().is_empty());
        }
    }

    #[test]
    fn arbitrary_indices_and_coordinates_never_panic(
        pos in proptest::collection::vec(proptest::collection::vec(proptest::num::f64::ANY, 3), 0..8),
        tris in proptest::collection::vec(proptest::collection::vec(0u32..10, 3), 0..12),
    ) {
        let input = MeshInput {
            weld_group: vec![0; pos.len()],
            positions_m: pos.iter().map(|c| [c[0], c[1], c[2]]).collect(),
            triangles: tris.iter().map(|t| [t[0], t[1], t[2]]).collect(),
        };
        if let Ok(b) = TriangleMesh::build(&input) {
            check_against_input(&input, &b.mesh);
            for f in b.mesh.faces() {
                let _ = b.mesh.face_normal(f);
                prop_assert!(b.mesh.face_area_m2(f) >= 0.0 || b.mesh.face_area_m2(f).is_nan());
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Realistic damage on a closed torus: reversed faces, duplicated faces (as is or reversed),
    /// shuffled face order. The result is always a valid mesh with every face kept, reversing a
    /// face of a closed surface is always reported, and shuffling alone changes no topology.
    #[test]
    fn damaged_torus_is_repaired_and_reported(
        flips in proptest::collection::vec(0usize..128, 0..4),
        dups in proptest::collection::vec((0usize..128, any::<bool>()), 0..4),
        shuffle in proptest::collection::vec(any::<proptest::sample::Index>(), 128),
    ) {
        let mut input = torus(8, 8, 2.0, 0.5);
        // Shuffle the face order (a permutation by Fisher-Yates on the given indices).
        for (i, idx) in shuffle.iter().enumerate().rev() {
            let j = idx.index(i + 1);
            input.triangles.swap(i, j);
        }
        let shuffled = build_ok(&input);
        prop_assert!(shuffled.defects.is_empty());
        prop_assert_eq!(shuffled.mesh.num_vertices(), 64);
        let c = shuffled.mesh.components();
        prop_assert_eq!((c.len(), c.components[0].genus), (1, 1));

        let mut flipped = BTreeSet::new();
        for &f in &flips {
            input.triangles[f].swap(1, 2);
            if !flipped.insert(f) {
                flipped.remove(&f);
            }
        }
        for &(f, reverse) in &dups {
            let mut t = input.triangles[f];
            if reverse {
                t.swap(1, 2);
            }
            input.triangles.push(t);
        }
        let b = build_ok(&input);
        let orientation_or_edge = b.defects.iter().any(|d| matches!(
            d,
            MeshDefect::InconsistentOrientation { .. } | MeshDefect::NonManifoldEdge { .. }
        ));
        prop_assert_eq!(orientation_or_edge, !flipped.is_empty() || !dups.is_empty());
        if flipped.is_empty() && dups.is_empty() {
            prop_assert!(b.defects.is_empty());
        }
        // Every face named by a defect exists, and every edge defect names the faces on it.
        for d in &b.defects {
            for f in d.faces() {
                prop_assert!(f.index() < b.mesh.num_faces());
            }
        }
    }
}

#[test]
fn hostile_edge_shared_by_many_faces_is_handled_in_linear_time() {
    // 100k triangles on the edge 0-1, alternating direction: a "book" with 100k pages.
    let n = 100_000u32;
    let mut positions_m = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
    let mut triangles = Vec::new();
    for i in 0..n {
        let a = 2.0 * std::f64::consts::PI * f64::from(i) / f64::from(n);
        positions_m.push([0.5, a.cos(), a.sin()]);
        triangles.push(if i % 2 == 0 {
            [0, 1, i + 2]
        } else {
            [1, 0, i + 2]
        });
    }
    let b = build_ok(&MeshInput::single_group(positions_m, triangles));
    let MeshDefect::NonManifoldEdge { faces, glued, .. } = &b.defects[0] else {
        panic!("{:?}", b.defects.first())
    };
    assert_eq!((faces.len(), glued.len()), (n as usize, n as usize / 2));
    assert_eq!(glued[1], [FaceId(2), FaceId(3)]);
    // Each glued pair is its own sheet: both edge end points get n/2 copies.
    assert_eq!(b.mesh.num_vertices(), n as usize + 2 * (n as usize / 2));
    assert_eq!(b.mesh.components().len(), n as usize / 2);
}

#[test]
fn navigation_wrappers_agree_with_id_arithmetic() {
    let m = build_ok(&uv_sphere(4, 5, 1.0)).mesh;
    assert_eq!(m.num_halfedges(), 3 * m.num_faces());
    assert_eq!(m.num_corners(), m.num_halfedges());
    assert_eq!(m.positions_m().len(), m.num_vertices());
    let mut per_halfedge: HalfedgeData<f64> = HalfedgeData::filled(m.num_halfedges(), 0.0);
    for h in m.halfedges() {
        assert_eq!(m.next(h), h.next());
        assert_eq!(m.prev(h), h.prev());
        assert_eq!(m.face(h), h.face());
        assert_eq!(m.from_vertex(m.next(h)), m.to_vertex(h));
        assert_eq!(
            m.positions_m()[m.from_vertex(h).index()],
            m.position(m.from_vertex(h))
        );
        per_halfedge[h] = m.edge_length_m(h);
    }
    // Opposite half-edges have the same length.
    for h in m.halfedges() {
        let o = m.opposite(h).unwrap_or(h);
        assert_eq!(per_halfedge[h], per_halfedge[o]);
    }
    let per_corner: CornerData<f64> = CornerData::from_vec(
        (0..m.num_corners() as u32)
            .map(|c| m.corner_angle_rad(CornerId(c)))
            .collect(),
    );
    // Angle defects sum to 2πχ = 4π on a closed genus-0 surface (discrete Gauss–Bonnet).
    let defect: f64 = m
        .vertices()
        .map(|v| 2.0 * PI - m.vertex_corners(v).map(|c| per_corner[c]).sum::<f64>())
        .sum();
    assert!((defect - 4.0 * PI).abs() < 1e-9, "{defect}");
}

/// The weld rule's one tolerance: the ends of a zero-area face's edge at most
/// `NEAR_WELD_RELATIVE` of its longest edge are one vertex (the face then repeats a vertex);
/// a zero-area face whose shortest edge is longer keeps its three vertices.
#[test]
fn near_coincident_ends_of_a_zero_area_face_are_joined_and_only_those() {
    // Two faces on either side of the x axis meeting at copies 0 and 3 of one point, `gap`
    // apart, with the zero-area slit [1, 3, 0] between them.
    let slit = |gap: f64| {
        MeshInput::single_group(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.5, 1.0, 0.0],
                [gap, 0.0, 0.0],
                [0.5, -1.0, 0.0],
            ],
            vec![[0, 1, 2], [1, 3, 0], [1, 3, 4]],
        )
    };
    // (Not `build_ok`: corner 1 of face 1 and of face 2 is at source 3, 1e-16 from the
    // position of the vertex it joined, source 0's.)
    let b = TriangleMesh::build(&slit(1e-16)).expect("builds");
    assert_eq!(b.mesh.check_invariants(), Ok(()));
    assert_eq!(
        b.mesh.position(b.mesh.face_vertices(FaceId(2))[1]),
        [0.0; 3]
    );
    // ... and the corner keeps its own position, as the file holds it.
    assert!(b.mesh.has_moved_sources());
    assert_eq!(
        b.mesh.corner_position(FaceId(2).corner(1)),
        [1e-16, 0.0, 0.0]
    );
    assert_eq!(b.mesh.corner_position(FaceId(0).corner(0)), [0.0; 3]);
    assert_eq!(
        b.mesh.face_degeneracy(FaceId(1)),
        Some(DegenerateKind::RepeatedVertex)
    );
    assert_eq!(b.num_welded_vertices, 4);
    // The real faces share the edge 0–1 now: glued, one vertex at the point.
    let [a0, a1, _] = b.mesh.face_vertices(FaceId(0));
    let [c0, c1, _] = b.mesh.face_vertices(FaceId(2));
    assert_eq!((a0, a1), (c1, c0));
    // A gap of 1e-6 of the edge is a real (if thin) feature: nothing is joined.
    let b = build_ok(&slit(1e-6));
    assert_eq!(
        b.mesh.face_degeneracy(FaceId(1)),
        Some(DegenerateKind::ZeroArea)
    );
    assert_eq!(b.num_welded_vertices, 5);
    assert!(!b.mesh.has_moved_sources());
    assert_ne!(
        b.mesh.face_vertices(FaceId(0))[0],
        b.mesh.face_vertices(FaceId(2))[1]
    );
}

/// A zero-area face of the weld rule whose short edge is a real edge of the surface (a needle
/// to one stray vertex far away: zero-area relative to its own length) keeps that edge's ends
/// apart: a face of area has both. (A vertex moved to 1e38 in a scanned ball joined two
/// vertices 0.4 apart and collapsed the faces of area between them.)
#[test]
fn a_needle_to_a_far_vertex_does_not_join_a_real_edge() {
    let needle = |far: f64| {
        MeshInput::single_group(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
                [far, -0.5, 0.0],
            ],
            vec![[0, 1, 2], [0, 2, 3], [1, 0, 4]],
        )
    };
    for far in [1e12, 1e38] {
        let b = build_ok(&needle(far));
        assert_eq!(b.mesh.face_degeneracy(FaceId(0)), None, "{far}");
        assert_eq!(b.mesh.face_degeneracy(FaceId(1)), None, "{far}");
        assert_eq!(
            b.mesh.face_degeneracy(FaceId(2)),
            Some(DegenerateKind::ZeroArea),
            "{far}"
        );
        assert_eq!(b.num_welded_vertices, 5, "{far}");
        assert!(!b.mesh.has_moved_sources(), "{far}");
    }
}
