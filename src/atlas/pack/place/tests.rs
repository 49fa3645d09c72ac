use super::*;
use crate::atlas::pack::raster::fill_chain;
use crate::mesh::vector::orient2;

#[test]
fn dilated_extents_are_the_extents_of_the_dilated_mask() {
    let mut state = 987654321u64;
    let mut next = |m: u32| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % u64::from(m)) as u32
    };
    for case in 0..300 {
        let (w, h) = (1 + next(150), 1 + next(90));
        let mut mask = Mask::new(w, h);
        // A few random spans, sometimes none (an empty mask), some at the grid's edges.
        for _ in 0..next(12) {
            let y = next(h);
            let x0 = next(w);
            let x1 = (x0 + next(40)).min(w - 1);
            mask.set_span(y, x0, x1);
        }
        for r in [0, 1, 2, 3, 7, 70] {
            assert_eq!(
                Extents::of(&mask).dilated(r),
                Extents::of(&mask.dilate(r)),
                "case {case}: {w}x{h}, r {r}"
            );
        }
    }
}

#[test]
fn outline_triangles_give_the_extents_and_box_of_all_triangles() {
    let sets = [
        crate::atlas::pack::test_charts::mixed_set(40, 7),
        crate::atlas::pack::test_charts::realistic_set(2),
    ];
    let mut skipped = 0usize;
    let mut total = 0usize;
    for set in &sets {
        for (i, owned) in set.iter().enumerate() {
            let chart = owned.as_pack_chart();
            let prep = prepare_chart(i, &chart).unwrap();
            skipped += chart.triangles.len() - prep.outline.len();
            total += chart.triangles.len();
            let all = PreparedChart {
                outline: (0..chart.triangles.len() as u32).collect(),
                ..prep.clone()
            };
            for density in [3.0, 17.5, 90.0] {
                let a = orientations(&chart, &prep, density, 8, 2, [1024, 1024], true);
                let b = orientations(&chart, &all, density, 8, 2, [1024, 1024], true);
                for (x, y) in a.iter().zip(&b) {
                    assert_eq!(x.affine, y.affine, "chart {i}");
                    assert_eq!(x.footprint, y.footprint, "chart {i}");
                    assert_eq!(x.dilated, y.dilated, "chart {i}");
                }
            }
        }
    }
    assert!(skipped > 0 && skipped < total, "{skipped} of {total}");
}

#[test]
fn chain_fill_holds_every_covered_centre_and_only_near_ones() {
    let sets = [
        crate::atlas::pack::test_charts::mixed_set(30, 13),
        crate::atlas::pack::test_charts::realistic_set(1),
    ];
    let mut checked = 0u64;
    for set in &sets {
        for (i, owned) in set.iter().enumerate() {
            let chart = owned.as_pack_chart();
            let prep = prepare_chart(i, &chart).unwrap();
            for density in [3.0, 17.5, 90.0] {
                for o in orientations(&chart, &prep, density, 3, 2, [1024, 1024], true) {
                    if o.dilated.is_none() {
                        continue;
                    }
                    let (w, h) = (o.width_texels as u32, o.height_texels as u32);
                    let local: Vec<[f64; 2]> =
                        chart.uv.iter().map(|&p| o.apply(prep.centre, p)).collect();
                    let tri = |t: &[u32; 3]| t.map(|k| local[k as usize]);
                    let mut new = Mask::new(w, h);
                    let edges: Vec<[[f64; 2]; 2]> = prep
                        .chain
                        .iter()
                        .map(|e| e.map(|k| local[k as usize]))
                        .collect();
                    fill_chain(&mut new, &edges, CENTRE_GROW_TEXELS);
                    rasterize_centres(
                        &mut new,
                        prep.loose
                            .iter()
                            .map(|&t| tri(&chart.triangles[t as usize])),
                        CENTRE_GROW_TEXELS,
                    );
                    let mut wide = Mask::new(w, h);
                    rasterize_centres(&mut wide, chart.triangles.iter().map(tri), 0.03);
                    for y in 0..i64::from(h) {
                        for x in 0..i64::from(w) {
                            if new.get(x, y) {
                                assert!(wide.get(x, y), "chart {i}: far texel {x},{y}");
                            }
                        }
                    }
                    // Every centre in a closed triangle is marked (exact orientation tests).
                    for t in chart.triangles {
                        let [a, b, c] = tri(t);
                        let s = orient2(a, b, c).signum();
                        let (x0, x1) = (a[0].min(b[0]).min(c[0]), a[0].max(b[0]).max(c[0]));
                        let (y0, y1) = (a[1].min(b[1]).min(c[1]), a[1].max(b[1]).max(c[1]));
                        for y in
                            (y0.floor() as i64).max(0)..=(y1.ceil() as i64).min(i64::from(h) - 1)
                        {
                            for x in (x0.floor() as i64).max(0)
                                ..=(x1.ceil() as i64).min(i64::from(w) - 1)
                            {
                                let p = [x as f64 + 0.5, y as f64 + 0.5];
                                let inside = [(a, b), (b, c), (c, a)]
                                    .iter()
                                    .all(|&(u, v)| orient2(u, v, p) * s >= 0.0);
                                if inside && s != 0.0 {
                                    checked += 1;
                                    assert!(new.get(x, y), "chart {i}: missed centre {x},{y}");
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    assert!(checked > 10_000, "{checked}");
}

/// `f(chart, orientations)` for the orientations (8 rotations, padding 2, a 1024² page) of
/// every chart of `mixed_set(n, seed)`, at densities 4 and 23.
fn for_each_orientation_set(n: usize, seed: u64, mut f: impl FnMut(usize, &[Orientation])) {
    let set = crate::atlas::pack::test_charts::mixed_set(n, seed);
    for (i, owned) in set.iter().enumerate() {
        let chart = owned.as_pack_chart();
        let prep = prepare_chart(i, &chart).unwrap();
        for density in [4.0, 23.0] {
            f(
                i,
                &orientations(&chart, &prep, density, 8, 2, [1024, 1024], true),
            );
        }
    }
}

/// `f(chart, orientation index, orientation)` for every orientation of
/// [`for_each_orientation_set`].
fn for_each_orientation(n: usize, seed: u64, mut f: impl FnMut(usize, usize, &Orientation)) {
    for_each_orientation_set(n, seed, |i, orients| {
        for (k, o) in orients.iter().enumerate() {
            f(i, k, o);
        }
    });
}

#[test]
fn footprint_bits_agree_with_the_extents_in_every_turn() {
    // The runs of every orientation (the quarter turns share a mask turned on demand) give
    // back its per-row and per-column extents of F exactly, and stay on its grid.
    let mut turned = 0;
    for_each_orientation(20, 5, |i, k, o| {
        let (Some(f), Some(bits)) = (&o.footprint, &o.footprint_bits) else {
            return;
        };
        turned += usize::from(k >= 2);
        let (w, h) = (o.width_texels as usize, o.height_texels as usize);
        let mut rows = vec![EMPTY; h];
        let mut cols = vec![EMPTY; w];
        bits.for_each_run(|r, a, b| {
            let (r, a, b) = (r as usize, a as i32, b as i32);
            assert!(
                r < h && a <= b && (b as usize) < w,
                "chart {i} run {r} {a} {b}"
            );
            rows[r] = (rows[r].0.min(a), rows[r].1.max(b));
            for c in a..=b {
                let e = &mut cols[c as usize];
                *e = (e.0.min(r as i32), e.1.max(r as i32));
            }
        });
        assert_eq!(rows, f.rows, "chart {i} orientation {k} rows");
        assert_eq!(cols, f.cols, "chart {i} orientation {k} columns");
    });
    assert!(turned > 20, "{turned}");
}

#[test]
fn runs_from_a_half_turn_are_the_runs_of_the_turned_bits() {
    // The hole search takes the runs of the half-turned orientations from their partners':
    // the same runs in the same order as scanning the turned bits, for both parities.
    let runs = |b: &FootprintBits| {
        let mut v = Vec::new();
        b.for_each_run(|r, a, c| v.push((r as i32, a as i32, c as i32)));
        v
    };
    let mut derived = [0usize; 2];
    for_each_orientation_set(12, 3, |i, orients| {
        for (k, o) in orients.iter().enumerate() {
            let Some(bits) = &o.footprint_bits else {
                continue;
            };
            for (j, p) in orients.iter().enumerate() {
                let Some(back) = p
                    .footprint_bits
                    .as_ref()
                    .filter(|b| bits.is_half_turn_of(b))
                else {
                    continue;
                };
                assert_eq!(
                    bits.runs_from_half_turn(&runs(back)),
                    runs(bits),
                    "chart {i} orientation {k} from {j}"
                );
                derived[usize::from(bits.turns % 2)] += 1;
            }
        }
    });
    assert!(derived[0] > 10 && derived[1] > 10, "{derived:?}");
}

#[test]
fn dilated_bits_are_the_chebyshev_dilation_of_the_footprint_in_every_turn() {
    // The texels of `D` that hole filling tests are exactly the grid texels within
    // `padding` (Chebyshev) of a texel of `F`, and their per-row hull is `D`'s extents.
    let mut concave = 0;
    for_each_orientation(15, 7, |i, k, o| {
        let (Some(d), Some(f), Some(db)) = (&o.dilated, &o.footprint_bits, &o.dilated_bits) else {
            return;
        };
        let (w, h) = (o.width_texels as i32, o.height_texels as i32);
        let mut fset = vec![false; (w * h) as usize];
        f.for_each_run(|r, a, b| {
            for c in a..=b {
                fset[(r * w as u32 + c) as usize] = true;
            }
        });
        let mut got = vec![false; (w * h) as usize];
        let mut runs_per_row = vec![0; h as usize];
        db.for_each_run(|r, a, b| {
            runs_per_row[r as usize] += 1;
            for c in a..=b {
                got[(r * w as u32 + c) as usize] = true;
            }
        });
        concave += usize::from(runs_per_row.iter().any(|&n| n > 1));
        // `D` is `F` grown by the padding whole, never cut by the grid's edge: every texel
        // of `F` lies at least the padding inside the grid (the keep-out zones of the hole
        // search rely on it).
        f.for_each_run(|r, a, b| {
            let (r, a, b) = (r as i32, a as i32, b as i32);
            assert!(
                r >= 2 && r < h - 2 && a >= 2 && b < w - 2,
                "chart {i} orientation {k}: F run ({r}, {a}, {b}) within the padding of the {w}×{h} grid's edge"
            );
        });
        for y in 0..h {
            for x in 0..w {
                let near = (y - 2..=y + 2).any(|v| {
                    (x - 2..=x + 2).any(|u| {
                        (0..w).contains(&u) && (0..h).contains(&v) && fset[(v * w + u) as usize]
                    })
                });
                assert_eq!(
                    got[(y * w + x) as usize],
                    near,
                    "chart {i} orientation {k} texel ({x}, {y})"
                );
            }
            let row: Vec<i32> = (0..w).filter(|&x| got[(y * w + x) as usize]).collect();
            let hull = match (row.first(), row.last()) {
                (Some(&a), Some(&b)) => (a, b),
                _ => EMPTY,
            };
            assert_eq!(
                hull, d.rows[y as usize],
                "chart {i} orientation {k} row {y}"
            );
        }
    });
    assert!(
        concave > 0,
        "no orientation with a row of D in several runs"
    );
}

#[test]
fn footprints_of_slivers_keep_the_padding_inside_their_grid() {
    // Thin triangles at random angles and densities: their footprints take the touched
    // texels beyond the sampled ones, which can reach past the chart's texel span; the
    // grid still holds `F` grown by the padding whole (so `D` is never cut by the grid).
    let mut seed = 0x5eed_0f51_1ce5u64;
    let mut next = || crate::atlas::pack::test_charts::xorshift(&mut seed);
    let mut runs = 0;
    for i in 0..300 {
        let a = [next() * 3.0, next() * 3.0];
        let b = [a[0] + 1.0 + next() * 4.0, a[1] + next() * 4.0];
        let t = next() * 0.02;
        let c = [(a[0] + b[0]) / 2.0 + t, (a[1] + b[1]) / 2.0 - t];
        let owned = crate::atlas::pack::test_charts::triangle([a, b, c]);
        let chart = owned.as_pack_chart();
        let prep = prepare_chart(i, &chart).unwrap();
        let density = 1.0 + 9.0 * next();
        for o in orientations(&chart, &prep, density, 8, 2, [1024, 1024], true) {
            let (w, h) = (o.width_texels as u32, o.height_texels as u32);
            let Some(f) = &o.footprint_bits else { continue };
            f.for_each_run(|r, a, b| {
                runs += 1;
                assert!(
                    r >= 2 && r + 2 < h && a >= 2 && b + 2 < w,
                    "sliver {i}: F run ({r}, {a}, {b}) within the padding of the {w}×{h} grid's edge"
                );
            });
        }
    }
    assert!(runs > 1000, "{runs}");
}

#[test]
fn quarter_turn_extents_equal_a_direct_rasterization() {
    // An L-shaped chart: its 90° footprint derived by re-indexing equals rasterizing it
    // turned (up to where the layout centres it, which is the same by symmetry here).
    let uv = [
        [0.0, 0.0],
        [3.0, 0.0],
        [3.0, 1.0],
        [1.0, 1.0],
        [1.0, 2.0],
        [0.0, 2.0],
    ];
    let tris = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]];
    let chart = PackChart {
        uv: &uv,
        triangles: &tris,
        area_m2: 4.0,
    };
    let prep = prepare_chart(0, &chart).unwrap();
    let four = orientations(&chart, &prep, 7.3, 4, 2, [1024, 1024], true);
    let turned = orient(
        &chart,
        &prep,
        prep.base_angle_rad + std::f64::consts::FRAC_PI_2,
        7.3,
        2,
        [1024, 1024],
        true,
    );
    assert_eq!(four[1].width_texels, turned.width_texels);
    assert_eq!(four[1].height_texels, turned.height_texels);
    assert_eq!(four[1].footprint, turned.footprint);
    assert_eq!(four[1].dilated, turned.dilated);
    // And every vertex lands at the same place.
    for &p in &uv {
        let (a, b) = (four[1].apply(prep.centre, p), turned.apply(prep.centre, p));
        assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9);
    }
}
