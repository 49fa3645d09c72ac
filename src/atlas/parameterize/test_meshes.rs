//! Disk-shaped (and a few non-disk) meshes generated in code, and an independent energy oracle:
//! test support for the unit tests, the oracle tests in `tests/` and benchmarks. Not part of the
//! pipeline.
use super::chart::ChartMesh;

/// An `nx × ny` quad grid over `[0,nx]×[0,ny]`, each quad split along its (0,0)-(1,1)
/// diagonal, vertices placed by `place(x, y)`. Counter-clockwise seen from +z when `place` is
/// the identity on the plane.
pub fn grid(nx: usize, ny: usize, place: impl Fn(f64, f64) -> [f64; 3]) -> ChartMesh {
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let mut positions_m = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            positions_m.push(place(i as f64, j as f64));
        }
    }
    let mut triangles = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    ChartMesh {
        positions_m,
        triangles,
    }
}

/// A cylinder of radius 1 around z with `segments` around and `rings` along. With `cut`, the
/// seam is left open (a disk: the cylinder cut along a generator); without, it is an annulus.
pub fn open_cylinder(segments: usize, rings: usize, cut: bool) -> ChartMesh {
    let cols = if cut { segments + 1 } else { segments };
    let mut positions_m = Vec::new();
    for j in 0..=rings {
        for i in 0..cols {
            let a = 2.0 * std::f64::consts::PI * i as f64 / segments as f64;
            // Outward-facing with counter-clockwise triangles: go clockwise seen from +z.
            positions_m.push([a.cos(), -a.sin(), j as f64 * 0.7]);
        }
    }
    let id = |i: usize, j: usize| (j * cols + (i % cols)) as u32;
    let mut triangles = Vec::new();
    let quads = if cut { cols - 1 } else { cols };
    for j in 0..rings {
        for i in 0..quads {
            triangles.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
            triangles.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
        }
    }
    ChartMesh {
        positions_m,
        triangles,
    }
}

/// A hemisphere of radius 1 (the upper half, pole at +z), as a latitude-longitude mesh with
/// a pole fan: a disk whose boundary is the equator.
pub fn hemisphere(segments: usize, rings: usize) -> ChartMesh {
    spherical_cap(segments, rings, std::f64::consts::FRAC_PI_2)
}

/// The cap of the unit sphere from the pole (+z) down to polar angle `max_polar_rad`, as a
/// latitude-longitude mesh with a pole fan: a disk (for `max_polar_rad < π`) whose boundary is
/// the lowest ring.
pub fn spherical_cap(segments: usize, rings: usize, max_polar_rad: f64) -> ChartMesh {
    let mut positions_m = vec![[0.0, 0.0, 1.0]];
    for j in 1..=rings {
        let polar = max_polar_rad * j as f64 / rings as f64;
        for i in 0..segments {
            let a = 2.0 * std::f64::consts::PI * i as f64 / segments as f64;
            positions_m.push([polar.sin() * a.cos(), polar.sin() * a.sin(), polar.cos()]);
        }
    }
    let id = |i: usize, j: usize| (1 + (j - 1) * segments + (i % segments)) as u32;
    let mut triangles = Vec::new();
    for i in 0..segments {
        triangles.push([0, id(i, 1), id(i + 1, 1)]);
    }
    for j in 1..rings {
        for i in 0..segments {
            triangles.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
            triangles.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
        }
    }
    ChartMesh {
        positions_m,
        triangles,
    }
}

/// A height field over an `n × n` grid with deterministic pseudo-random noise of amplitude
/// `noise` on top of a smooth bump (xorshift with a fixed seed).
pub fn noisy_height_field(n: usize, noise: f64, seed: u64) -> ChartMesh {
    let mut state = seed.max(1);
    let mut heights = Vec::new();
    for _ in 0..(n + 1) * (n + 1) {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        heights.push((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5);
    }
    grid(n, n, |x, y| {
        let k = (y as usize) * (n + 1) + x as usize;
        let s = 1.0 / n as f64;
        let bump = 0.3 * ((x * s * 3.0).sin() * (y * s * 2.0).cos());
        [x * s, y * s, bump + noise * s * heights[k]]
    })
}

/// The conformal energy `C(U)` recomputed as an oracle: twice the cotangent Dirichlet energy
/// minus twice the signed UV area (∫|∇u|²+|∇v|² − 2·det J = ∫|∂U/∂x + i∂U/∂y|²). It shares no
/// code with the solver nor with [`super::conformal_energy`], so tests can compare the two.
pub fn cotan_conformal_energy(chart: &ChartMesh, uv: &[[f64; 2]]) -> f64 {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let mut e = 0.0;
    for t in &chart.triangles {
        let p = t.map(|i| chart.positions_m[i as usize]);
        let q = t.map(|i| uv[i as usize]);
        for k in 0..3 {
            let (i, j, o) = (k, (k + 1) % 3, (k + 2) % 3);
            let (a, b) = (sub(p[i], p[o]), sub(p[j], p[o]));
            let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            let c = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            let cot = dot / (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            let (du, dv) = (q[i][0] - q[j][0], q[i][1] - q[j][1]);
            e += 0.5 * cot * (du * du + dv * dv);
        }
        // 2 × signed area (the cross product is twice the area).
        e -= (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]);
    }
    2.0 * e
}
