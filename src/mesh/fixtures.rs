//! Test data: small generated meshes covering every fixture category (disk, closed, high genus,
//! multi-component, degenerate, non-manifold, seams already present).
//!
//! Purpose: one shared, categorised mesh suite for unit tests, integration tests and benches
//! across the crate, without files. Not product code: nothing in the pipeline calls it.
//!
//! Invariants: every generator is deterministic and its exact counts are documented on it (the
//! mesh tests assert them). Closed and open surfaces are oriented outward (counter-clockwise seen
//! from outside). Seam vertices of periodic surfaces are *duplicated* source vertices with
//! bit-identical positions (angles come from `index % n`), so they exercise welding.
//!
//! Units: metres.
use std::f64::consts::PI;

use super::input::MeshInput;

fn single_group(positions_m: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> MeshInput {
    MeshInput::single_group(positions_m, triangles)
}

/// A flat `nx` × `ny` grid of unit squares in the z = 0 plane, each split into two triangles,
/// facing +z. `(nx+1)(ny+1)` vertices, `2·nx·ny` triangles, one boundary loop (a disk).
/// Vertex `(i, j)` (column `i`, row `j`) is source vertex `j·(nx+1) + i`.
pub fn grid(nx: u32, ny: u32) -> MeshInput {
    let mut positions = Vec::with_capacity(((nx + 1) * (ny + 1)) as usize);
    for j in 0..=ny {
        for i in 0..=nx {
            positions.push([f64::from(i), f64::from(j), 0.0]);
        }
    }
    let id = |i: u32, j: u32| j * (nx + 1) + i;
    let mut tris = Vec::with_capacity((2 * nx * ny) as usize);
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    single_group(positions, tris)
}

/// The unit cube `[0, 1]³` with split faces, as exported for flat shading: 24 source vertices
/// (4 per side, each a separate copy), 12 triangles, outward. Welds to 8 vertices, closed, genus 0.
pub fn cube_split_faces() -> MeshInput {
    // Each side: an origin corner and two edge directions whose cross product points outward.
    let sides: [([f64; 3], [f64; 3], [f64; 3]); 6] = [
        ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]), // z = 0, normal -z
        ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]), // z = 1, normal +z
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]), // y = 0, normal -y
        ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]), // y = 1, normal +y
        ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]), // x = 0, normal -x
        ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]), // x = 1, normal +x
    ];
    let mut positions = Vec::with_capacity(24);
    let mut tris = Vec::with_capacity(12);
    for (o, u, v) in sides {
        let base = positions.len() as u32;
        for (a, b) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
            positions.push([0, 1, 2].map(|k| o[k] + a * u[k] + b * v[k]));
        }
        tris.push([base, base + 1, base + 2]);
        tris.push([base, base + 2, base + 3]);
    }
    single_group(positions, tris)
}

/// A UV sphere of radius `radius_m` with `n_lat >= 2` latitude bands and `n_lon >= 3` longitude
/// segments, laid out like an exported textured sphere: each ring has a duplicated seam vertex
/// (`n_lon + 1` per ring) and each pole has one copy per cap triangle (`n_lon`). Source vertices
/// `2·n_lon + (n_lat − 1)(n_lon + 1)`, welding to `2 + (n_lat − 1)·n_lon`; `2·n_lon·(n_lat − 1)`
/// triangles; closed, genus 0.
pub fn uv_sphere(n_lat: u32, n_lon: u32, radius_m: f64) -> MeshInput {
    let mut positions = Vec::new();
    let north = |j: u32| j;
    let ring = |i: u32, j: u32| n_lon + (i - 1) * (n_lon + 1) + j;
    let south = |j: u32| n_lon + (n_lat - 1) * (n_lon + 1) + j;
    positions.extend((0..n_lon).map(|_| [0.0, 0.0, radius_m]));
    for i in 1..n_lat {
        let theta = PI * f64::from(i) / f64::from(n_lat);
        for j in 0..=n_lon {
            let phi = 2.0 * PI * f64::from(j % n_lon) / f64::from(n_lon);
            positions.push([
                radius_m * theta.sin() * phi.cos(),
                radius_m * theta.sin() * phi.sin(),
                radius_m * theta.cos(),
            ]);
        }
    }
    positions.extend((0..n_lon).map(|_| [0.0, 0.0, -radius_m]));
    let mut tris = Vec::new();
    // Rows go south, columns go east; every triangle is counter-clockwise seen from outside.
    for j in 0..n_lon {
        tris.push([north(j), ring(1, j), ring(1, j + 1)]);
    }
    for i in 1..n_lat - 1 {
        for j in 0..n_lon {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i + 1, j),
                ring(i + 1, j + 1),
                ring(i, j + 1),
            );
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    for j in 0..n_lon {
        tris.push([ring(n_lat - 1, j), south(j), ring(n_lat - 1, j + 1)]);
    }
    single_group(positions, tris)
}

/// A torus around the z axis with major radius `major_m`, minor radius `minor_m`, `n_major >= 3`
/// segments around the axis and `n_minor >= 3` around the tube. Both seams are duplicated:
/// `(n_major + 1)(n_minor + 1)` source vertices, welding to `n_major·n_minor`;
/// `2·n_major·n_minor` triangles; closed, genus 1.
pub fn torus(n_major: u32, n_minor: u32, major_m: f64, minor_m: f64) -> MeshInput {
    let mut positions = Vec::new();
    for i in 0..=n_major {
        for j in 0..=n_minor {
            let u = 2.0 * PI * f64::from(i % n_major) / f64::from(n_major);
            let v = 2.0 * PI * f64::from(j % n_minor) / f64::from(n_minor);
            let r = major_m + minor_m * v.cos();
            positions.push([r * u.cos(), r * u.sin(), minor_m * v.sin()]);
        }
    }
    let id = |i: u32, j: u32| i * (n_minor + 1) + j;
    let mut tris = Vec::new();
    for i in 0..n_major {
        for j in 0..n_minor {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    single_group(positions, tris)
}

/// An open cylinder (tube) of radius `radius_m` and height `height_m` along z, `n_around >= 3`
/// segments and `n_height >= 1` rings of quads, with a duplicated seam:
/// `(n_around + 1)(n_height + 1)` source vertices, welding to `n_around·(n_height + 1)`;
/// `2·n_around·n_height` triangles; two boundary loops, genus 0 (an annulus), normals outward.
pub fn cylinder_open(n_around: u32, n_height: u32, radius_m: f64, height_m: f64) -> MeshInput {
    let mut positions = Vec::new();
    for i in 0..=n_height {
        for j in 0..=n_around {
            let phi = 2.0 * PI * f64::from(j % n_around) / f64::from(n_around);
            let z = height_m * f64::from(i) / f64::from(n_height);
            positions.push([radius_m * phi.cos(), radius_m * phi.sin(), z]);
        }
    }
    let id = |i: u32, j: u32| i * (n_around + 1) + j;
    let mut tris = Vec::new();
    for i in 0..n_height {
        for j in 0..n_around {
            let (a, b, c, d) = (id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    single_group(positions, tris)
}

/// Concatenates soups: triangles of part `k` follow those of part `k − 1` and index its own
/// positions (offset). Weld groups are kept as given, so parts with the same group and
/// bit-identical positions weld together.
pub fn concat(parts: &[MeshInput]) -> MeshInput {
    let mut out = MeshInput::default();
    for p in parts {
        let base = out.positions_m.len() as u32;
        out.positions_m.extend_from_slice(&p.positions_m);
        out.weld_group.extend_from_slice(&p.weld_group);
        out.triangles
            .extend(p.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    out
}

/// Two components: a 2×2 grid (8 triangles, faces 0–7) and the split-face cube moved to
/// x ∈ [5, 6] (12 triangles, faces 8–19).
pub fn two_components() -> MeshInput {
    let mut cube = cube_split_faces();
    for p in &mut cube.positions_m {
        p[0] += 5.0;
    }
    concat(&[grid(2, 2), cube])
}

/// Two triangles touching at one vertex only (a bowtie): source vertex 0 is shared by face 0
/// `[0, 1, 2]` and face 1 `[0, 3, 4]`. The build splits vertex 0 into two copies.
pub fn bowtie() -> MeshInput {
    single_group(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 0.0, 0.0],
            [-1.0, -1.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 3, 4]],
    )
}

/// Three triangles on one edge (source vertices 0–1): face 0 `[0, 1, 2]` and face 1 `[1, 0, 3]`
/// are a consistently oriented pair, face 2 `[0, 1, 4]` is the fin.
pub fn fin() -> MeshInput {
    single_group(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 1.0, 0.0],
            [0.5, -1.0, 0.0],
            [0.5, 0.0, 1.0],
        ],
        vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
    )
}

/// A 2×2 grid whose face 3 (an interior triangle) has its corner order reversed, so it runs
/// along each of its three edges in the same direction as its neighbour.
pub fn flipped_face() -> MeshInput {
    let mut m = grid(2, 2);
    m.triangles[3].swap(1, 2);
    m
}

/// A unit square (faces 0 `[0,1,2]` and 1 `[0,2,3]`) plus degenerate triangles:
/// face 2 `[2, 1, 4]` is zero-area (vertex 4 is the midpoint of 1–2) and glued to face 0;
/// face 3 `[3, 3, 0]` repeats a source index; face 4 `[0, 5, 1]` repeats a position (source
/// vertex 5 is a copy of vertex 0, so it welds to it).
pub fn degenerate() -> MeshInput {
    single_group(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.5, 0.0],
            [0.0, 0.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 2, 3], [2, 1, 4], [3, 3, 0], [0, 5, 1]],
    )
}
