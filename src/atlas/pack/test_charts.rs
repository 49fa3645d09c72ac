//! Chart sets generated in code and an independent packing checker: test support for the unit
//! tests, `tests/it/pack_bench.rs` and benchmarks. Not part of the pipeline.
//!
//! The checker [`check_packing`] shares no code with the packer: it rasterizes each placed chart
//! by texel-centre sampling the way `../shared/eval/atlas_eval.py` does (a centre on an edge
//! counts as covered, which is stricter than the evaluator's top-left rule) and measures
//! overlap, padding (Chebyshev distance ≤ padding between texels of different charts), the
//! page-edge margin, UV range, density spread and packing efficiency.
use super::{PackChart, PackOptions, Packing};
use crate::atlas::parameterize::{flatten_chart, ChartMesh, FlattenOptions};
use crate::mesh::vector::{cross, norm, sub};

/// A chart that owns its data; [`OwnedChart::as_pack_chart`] borrows it for [`super::pack_charts`].
#[derive(Debug, Clone, PartialEq)]
pub struct OwnedChart {
    /// UV per vertex, model units.
    pub uv: Vec<[f64; 2]>,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
    /// 3-D area, model units².
    pub area_m2: f64,
}

impl OwnedChart {
    /// The borrowed form.
    pub fn as_pack_chart(&self) -> PackChart<'_> {
        PackChart {
            uv: &self.uv,
            triangles: &self.triangles,
            area_m2: self.area_m2,
        }
    }

    /// A planar chart whose 3-D area equals its UV area times `area_factor`.
    fn planar(uv: Vec<[f64; 2]>, triangles: Vec<[u32; 3]>, area_factor: f64) -> Self {
        let area: f64 = triangles
            .iter()
            .map(|t| signed_area(t.map(|i| uv[i as usize])).abs())
            .sum();
        Self {
            uv,
            triangles,
            area_m2: area * area_factor,
        }
    }
}

/// Borrows a whole set.
pub fn as_pack_charts(charts: &[OwnedChart]) -> Vec<PackChart<'_>> {
    charts.iter().map(OwnedChart::as_pack_chart).collect()
}

fn signed_area(p: [[f64; 2]; 3]) -> f64 {
    0.5 * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]))
}

/// A disc of `radius` as a fan of `segments` triangles.
pub fn disc(segments: usize, radius: f64) -> OwnedChart {
    let mut uv = vec![[0.0, 0.0]];
    for i in 0..segments {
        let a = 2.0 * std::f64::consts::PI * i as f64 / segments as f64;
        uv.push([radius * a.cos(), radius * a.sin()]);
    }
    let triangles = (0..segments as u32)
        .map(|i| [0, 1 + i, 1 + (i + 1) % segments as u32])
        .collect();
    OwnedChart::planar(uv, triangles, 1.0)
}

/// An L of arm length `a` and thickness `b` (`b < a`), made of unit-ish quads.
pub fn l_shape(a: f64, b: f64) -> OwnedChart {
    let uv = vec![[0.0, 0.0], [a, 0.0], [a, b], [b, b], [b, a], [0.0, a]];
    OwnedChart::planar(uv, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]], 1.0)
}

/// A strip `length × width` split into `n` quads along its length, bent into an arc of
/// `bend_rad` total angle (0 = straight).
pub fn strip(length: f64, width: f64, n: usize, bend_rad: f64) -> OwnedChart {
    let mut uv = Vec::new();
    for i in 0..=n {
        let s = i as f64 / n as f64;
        for side in [0.0, width] {
            if bend_rad.abs() < 1e-12 {
                uv.push([s * length, side]);
            } else {
                let r = length / bend_rad;
                let a = s * bend_rad;
                uv.push([(r + side) * a.sin(), r - (r + side) * a.cos()]);
            }
        }
    }
    let mut triangles = Vec::new();
    for i in 0..n as u32 {
        let (a, b, c, d) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        triangles.push([a, c, d]);
        triangles.push([a, d, b]);
    }
    OwnedChart::planar(uv, triangles, 1.0)
}

/// A single triangle.
pub fn triangle(p: [[f64; 2]; 3]) -> OwnedChart {
    OwnedChart::planar(p.to_vec(), vec![[0, 1, 2]], 1.0)
}

/// The next value of Marsaglia's xorshift64 generator (`state` must not be 0): the
/// deterministic randomness of the pack tests and fixtures.
pub fn xorshift64(state: &mut u64) -> u64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    *state
}

/// A uniform value in `[0, 1)` from [`xorshift64`].
pub fn xorshift(state: &mut u64) -> f64 {
    (xorshift64(state) >> 11) as f64 / (1u64 << 53) as f64
}

/// `n` charts of mixed shapes and sizes (discs, L-shapes, straight and bent strips, single
/// triangles), sizes spread over two orders of magnitude, deterministic in `seed`.
pub fn mixed_set(n: usize, seed: u64) -> Vec<OwnedChart> {
    let mut s = seed.max(1);
    (0..n)
        .map(|i| {
            let size = 0.05 + 2.0 * xorshift(&mut s).powi(3);
            let mut c = match i % 5 {
                0 => disc(6 + (xorshift(&mut s) * 40.0) as usize, size),
                1 => l_shape(size, size * (0.2 + 0.5 * xorshift(&mut s))),
                2 => strip(size * 3.0, size * 0.3, 8, 0.0),
                3 => strip(size * 3.0, size * 0.4, 16, 2.5 * xorshift(&mut s)),
                _ => triangle([
                    [0.0, 0.0],
                    [size, 0.1 * size],
                    [size * xorshift(&mut s), size * (0.3 + xorshift(&mut s))],
                ]),
            };
            // Flattenings come at arbitrary scale and rotation: the packer must undo both.
            let k = 0.1 + 3.0 * xorshift(&mut s);
            let a = 6.3 * xorshift(&mut s);
            let (sa, ca) = a.sin_cos();
            for p in &mut c.uv {
                *p = [
                    k * (ca * p[0] - sa * p[1]) + 5.0,
                    k * (sa * p[0] + ca * p[1]) - 2.0,
                ];
            }
            c
        })
        .collect()
}

/// Flattens a 3-D chart with LSCM ([`flatten_chart`]); the area is the 3-D area.
/// Panics if the chart cannot be parameterized (test data only).
pub fn parameterized(chart: &ChartMesh) -> OwnedChart {
    let map = flatten_chart(
        chart,
        &FlattenOptions::default(),
        &mut crate::atlas::StageProgress::ignored(crate::atlas::Stage::Parameterize),
    )
    .expect("test chart flattens");
    let area_m2 = chart
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| chart.positions_m[i as usize]);
            0.5 * norm(cross(sub(b, a), sub(c, a)))
        })
        .sum();
    OwnedChart {
        uv: map.uv,
        triangles: chart.triangles.clone(),
        area_m2,
    }
}

/// Realistic LSCM charts from `parameterize::test_meshes` at several scales: caps, hemispheres,
/// cut cylinders, noisy height fields; `copies` scaled copies of each (sizes vary 4:1).
pub fn realistic_set(copies: usize) -> Vec<OwnedChart> {
    use crate::atlas::parameterize::test_meshes as tm;
    let base = [
        parameterized(&tm::spherical_cap(24, 8, 1.0)),
        parameterized(&tm::hemisphere(24, 10)),
        parameterized(&tm::open_cylinder(24, 6, true)),
        parameterized(&tm::noisy_height_field(12, 0.5, 7)),
        parameterized(&tm::spherical_cap(16, 6, 2.0)),
        parameterized(&tm::open_cylinder(12, 12, true)),
    ];
    let mut out = Vec::new();
    for k in 0..copies {
        for (j, c) in base.iter().enumerate() {
            let f = 0.25 + 0.75 * (((k * 7 + j * 3) % 11) as f64 / 10.0);
            let mut c = c.clone();
            c.area_m2 *= f * f;
            out.push(c);
        }
    }
    out
}

/// What [`check_packing`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct PackCheck {
    /// Texels whose centre is covered by two different charts.
    pub overlap_texels: usize,
    /// Covered texels with a texel of another chart within Chebyshev distance ≤ padding.
    pub padding_violation_texels: usize,
    /// Covered texels closer than `padding` to the page edge.
    pub edge_violation_texels: usize,
    /// UVs outside \[0,1\] or not finite.
    pub out_of_range_uvs: usize,
    /// Σ placed UV area / (pages × page area).
    pub efficiency: f64,
    /// max/min − 1 of (placed UV area / 3-D area) over charts with area.
    pub density_spread: f64,
    /// Texels covered (all pages).
    pub covered_texels: usize,
}

/// Checks a packing independently (module doc).
pub fn check_packing(
    charts: &[PackChart<'_>],
    packing: &Packing,
    options: &PackOptions,
) -> PackCheck {
    let (w, h) = (
        options.width_texels as usize,
        options.height_texels as usize,
    );
    let p = options.padding_texels as i64;
    let pages = packing.num_pages.max(1) as usize;
    const EMPTY: u32 = u32::MAX;
    const MANY: u32 = u32::MAX - 1;
    let mut label = vec![EMPTY; pages * w * h];
    let mut overlap = 0usize;
    let mut out_of_range = 0usize;
    let mut uv_area_sum = 0.0;
    let mut ratio_min = f64::INFINITY;
    let mut ratio_max = 0.0f64;
    for (ci, (chart, placed)) in charts.iter().zip(&packing.charts).enumerate() {
        out_of_range += placed
            .uv
            .iter()
            .filter(|q| {
                !(q[0].is_finite()
                    && q[1].is_finite()
                    && (0.0..=1.0).contains(&q[0])
                    && (0.0..=1.0).contains(&q[1]))
            })
            .count();
        let page = placed.page as usize;
        let mut area = 0.0;
        for t in chart.triangles {
            let q = t.map(|i| {
                let uv = placed.uv[i as usize];
                [uv[0] * w as f64, uv[1] * h as f64]
            });
            let a2 = signed_area(q);
            area += a2.abs();
            if a2 == 0.0 {
                continue;
            }
            let xmin = q.iter().map(|v| v[0]).fold(f64::INFINITY, f64::min);
            let xmax = q.iter().map(|v| v[0]).fold(f64::NEG_INFINITY, f64::max);
            let ymin = q.iter().map(|v| v[1]).fold(f64::INFINITY, f64::min);
            let ymax = q.iter().map(|v| v[1]).fold(f64::NEG_INFINITY, f64::max);
            let i0 = ((xmin - 0.5).floor().max(0.0)) as usize;
            let i1 = ((xmax - 0.5).ceil().min(w as f64 - 1.0)).max(0.0) as usize;
            let j0 = ((ymin - 0.5).floor().max(0.0)) as usize;
            let j1 = ((ymax - 0.5).ceil().min(h as f64 - 1.0)).max(0.0) as usize;
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let c = [i as f64 + 0.5, j as f64 + 0.5];
                    let e = |a: [f64; 2], b: [f64; 2]| {
                        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
                    };
                    let (e0, e1, e2) = (e(q[0], q[1]), e(q[1], q[2]), e(q[2], q[0]));
                    let inside = (e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0)
                        || (e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0);
                    if !inside {
                        continue;
                    }
                    let l = &mut label[(page * h + j) * w + i];
                    if *l == EMPTY {
                        *l = ci as u32;
                    } else if *l != ci as u32 && *l != MANY {
                        *l = MANY;
                        overlap += 1;
                    }
                }
            }
        }
        uv_area_sum += area;
        if chart.area_m2 > 0.0 && area > 0.0 {
            let r = area / chart.area_m2;
            ratio_min = ratio_min.min(r);
            ratio_max = ratio_max.max(r);
        }
    }
    let mut padding = 0usize;
    let mut edge = 0usize;
    let mut covered = 0usize;
    for page in 0..pages {
        for j in 0..h as i64 {
            for i in 0..w as i64 {
                let l = label[(page * h + j as usize) * w + i as usize];
                if l == EMPTY {
                    continue;
                }
                covered += 1;
                if i < p || j < p || i >= w as i64 - p || j >= h as i64 - p {
                    edge += 1;
                }
                if l == MANY {
                    continue;
                }
                'near: for dj in -p..=p {
                    for di in -p..=p {
                        let (x, y) = (i + di, j + dj);
                        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                            continue;
                        }
                        let o = label[(page * h + y as usize) * w + x as usize];
                        if o != EMPTY && o != l {
                            padding += 1;
                            break 'near;
                        }
                    }
                }
            }
        }
    }
    PackCheck {
        overlap_texels: overlap,
        padding_violation_texels: padding,
        edge_violation_texels: edge,
        out_of_range_uvs: out_of_range,
        efficiency: uv_area_sum / (pages as f64 * w as f64 * h as f64),
        density_spread: if ratio_max > 0.0 {
            ratio_max / ratio_min - 1.0
        } else {
            0.0
        },
        covered_texels: covered,
    }
}
