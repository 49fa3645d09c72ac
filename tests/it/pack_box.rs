//! The box of issue 21: unwrapping `tests/fixtures/Box.glb` lays every quadrilateral chart out
//! axis-aligned on the page (each edge of its outline parallel to u or v), checked on the
//! placed corner UVs that the pipeline writes.
use crate::common::fixture;
use texatlas::atlas::{generate, AtlasOptions, NoProgress};
use texatlas::gltf_io::{decode, DecodeLimits, Resources};
use texatlas::mesh::TriangleMesh;

fn cross(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Convex hull (monotone chain), counter-clockwise, collinear points dropped.
fn hull(mut p: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    p.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    p.dedup();
    let mut h: Vec<[f64; 2]> = Vec::new();
    for pass in 0..2 {
        let start = h.len();
        let pts: Vec<[f64; 2]> = if pass == 0 {
            p.clone()
        } else {
            p.iter().rev().copied().collect()
        };
        for q in pts {
            while h.len() >= start + 2 && cross(h[h.len() - 2], h[h.len() - 1], q) <= 1e-12 {
                h.pop();
            }
            h.push(q);
        }
        h.pop();
    }
    h
}

#[test]
fn box_quad_charts_are_axis_aligned_on_the_page() {
    let asset = decode(
        &fixture("Box.glb"),
        &Resources::new(),
        &DecodeLimits::default(),
    )
    .expect("Box.glb decodes");
    let mesh = TriangleMesh::build(asset.mesh_input())
        .expect("builds")
        .mesh;
    let atlas = generate(&mesh, &AtlasOptions::default(), &mut NoProgress).expect("unwraps");
    let charts = atlas.chart_page.len();
    let mut quads = 0;
    for c in 0..charts {
        let faces: Vec<usize> = (0..atlas.face_chart.len())
            .filter(|&f| atlas.face_chart[f] as usize == c)
            .collect();
        let corners: Vec<[f64; 2]> = faces
            .iter()
            .flat_map(|&f| atlas.corner_uvs[f].map(|q| q.map(f64::from)))
            .collect();
        let area: f64 = faces
            .iter()
            .map(|&f| {
                let t = atlas.corner_uvs[f].map(|q| q.map(f64::from));
                0.5 * cross(t[0], t[1], t[2]).abs()
            })
            .sum();
        let h = hull(corners);
        let hull_area: f64 = (1..h.len().saturating_sub(1))
            .map(|i| 0.5 * cross(h[0], h[i], h[i + 1]))
            .sum();
        // A quadrilateral chart: its outline is its 4-corner hull (it fills the hull).
        if h.len() != 4 || (area - hull_area).abs() > 1e-4 * hull_area {
            continue;
        }
        quads += 1;
        for i in 0..4 {
            let (p, q) = (h[i], h[(i + 1) % 4]);
            let (dx, dy) = ((q[0] - p[0]).abs(), (q[1] - p[1]).abs());
            assert!(
                dx.min(dy) <= 1e-5 * dx.max(dy).max(1e-3),
                "chart {c}: edge {p:?} → {q:?} is not parallel to a page axis (hull {h:?})"
            );
        }
    }
    assert!(
        quads >= 2,
        "{quads} quadrilateral charts of {charts}; expected the box's square and 2:1 strip"
    );
}
