//! The mesh API as downstream stages use it (public items only): build, walk, measure, report.
use std::f64::consts::FRAC_PI_2;

use texatlas::mesh::{
    fixtures, BuiltMesh, FaceData, FaceId, MeshBuildError, MeshDefect, MeshInput, TriangleMesh,
};

fn build(input: &MeshInput) -> BuiltMesh {
    match TriangleMesh::build(input) {
        Ok(b) => b,
        Err(e) => panic!("{e}"),
    }
}

/// Feature detection as in LSCM paper §3.1: edges whose dihedral angle exceeds a threshold.
#[test]
fn sharp_edges_of_a_cube_are_its_twelve_edges() {
    let m = build(&fixtures::cube_split_faces()).mesh;
    let threshold_rad = 0.25 * FRAC_PI_2;
    let sharp: Vec<_> = m
        .edges()
        .filter(|&h| m.dihedral_angle_rad(h).is_some_and(|a| a > threshold_rad))
        .collect();
    assert_eq!(sharp.len(), 12);
    assert_eq!(m.edges().count(), 18);
    for h in sharp {
        assert!(
            (m.edge_length_m(h) - 1.0).abs() < 1e-15,
            "cube edges have length 1"
        );
    }
}

/// Chart growing walks the face graph; per-face data is indexed by `FaceId`.
#[test]
fn flood_fill_over_face_neighbours_reaches_each_component() {
    let m = build(&fixtures::two_components()).mesh;
    let mut label: FaceData<Option<u32>> = FaceData::filled(m.num_faces(), None);
    let mut next_label = 0;
    for seed in m.faces() {
        if label[seed].is_some() {
            continue;
        }
        let mut stack = vec![seed];
        label[seed] = Some(next_label);
        while let Some(f) = stack.pop() {
            for n in m.face_neighbors(f).into_iter().flatten() {
                if label[n].is_none() {
                    label[n] = Some(next_label);
                    stack.push(n);
                }
            }
        }
        next_label += 1;
    }
    let comps = m.components();
    assert_eq!(next_label as usize, comps.len());
    for f in m.faces() {
        assert_eq!(label[f], Some(comps.of_face(f).0));
    }
    assert_eq!(comps.of_face(FaceId(8)).0, 1, "the cube starts at face 8");
}

/// What `texatlas inspect` prints: counts, topology per component, every defect with its code.
#[test]
fn inspect_style_summary() {
    let input = fixtures::concat(&[fixtures::torus(10, 6, 2.0, 0.5), fixtures::fin()]);
    let b = build(&input);
    let comps = b.mesh.components();
    let lines: Vec<String> = comps
        .components
        .iter()
        .map(|c| {
            format!(
                "component {} faces={} V={} E={} b={} χ={} genus={}",
                c.id.0,
                c.num_faces,
                c.num_vertices,
                c.num_edges,
                c.num_boundary_loops,
                c.euler_characteristic,
                c.genus
            )
        })
        .collect();
    assert_eq!(lines[0], "component 0 faces=120 V=60 E=180 b=0 χ=0 genus=1");
    assert_eq!(
        lines.len(),
        3,
        "torus, glued pair of the fin, the fin itself"
    );
    let codes: Vec<&str> = b.defects.iter().map(MeshDefect::code).collect();
    assert_eq!(
        codes,
        [
            "non_manifold_edge",
            "non_manifold_vertex",
            "non_manifold_vertex"
        ]
    );
    assert_eq!(b.num_welded_vertices, 60 + 5);
    assert_eq!(b.mesh.num_vertices(), 60 + 5 + 2);
}

#[test]
fn errors_carry_a_code_and_a_fix() {
    let e = TriangleMesh::build(&MeshInput::single_group(vec![[0.0; 3]], vec![]));
    let Err(e @ MeshBuildError::NoTriangles) = e else {
        panic!("expected NoTriangles")
    };
    assert_eq!(e.code(), "zero_triangles");
    assert!(e.to_string().contains("give at least one triangle"));
}
