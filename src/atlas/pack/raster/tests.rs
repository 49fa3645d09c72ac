use super::*;

/// Brute-force oracle: does the closed triangle meet the closed square [i,i+1]×[j,j+1]?
/// Separating axis test over the two box axes and the three edge normals (exact geometry).
fn touches(tri: &[[f64; 2]; 3], i: i64, j: i64) -> bool {
    let bx = [i as f64, i as f64 + 1.0];
    let by = [j as f64, j as f64 + 1.0];
    let corners = [
        [bx[0], by[0]],
        [bx[1], by[0]],
        [bx[1], by[1]],
        [bx[0], by[1]],
    ];
    let mut axes = vec![[1.0, 0.0], [0.0, 1.0]];
    for k in 0..3 {
        let a = tri[k];
        let b = tri[(k + 1) % 3];
        axes.push([a[1] - b[1], b[0] - a[0]]);
    }
    axes.iter().all(|ax| {
        let proj = |p: &[f64; 2]| p[0] * ax[0] + p[1] * ax[1];
        let (t0, t1) = tri
            .iter()
            .map(proj)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, v| {
                (a.0.min(v), a.1.max(v))
            });
        let (c0, c1) = corners
            .iter()
            .map(proj)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, v| {
                (a.0.min(v), a.1.max(v))
            });
        t0 <= c1 && c0 <= t1
    })
}

use crate::atlas::pack::test_charts::xorshift;

#[test]
fn conservative_raster_never_misses_a_touched_texel_and_adds_only_near_ones() {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    for case in 0..400 {
        let mut tri = [[0.0; 2]; 3];
        for p in &mut tri {
            // Some corners on exact texel lines and corners, to hit the closed boundaries.
            let snap = case % 3 == 0;
            let c = |s: &mut u64| {
                let v = 1.0 + 10.0 * xorshift(s);
                if snap {
                    (v * 2.0).round() / 2.0
                } else {
                    v
                }
            };
            *p = [c(&mut state), c(&mut state)];
        }
        let mut mask = Mask::new(14, 14);
        rasterize_conservative(&mut mask, [tri]);
        for j in 0..14 {
            for i in 0..14 {
                let oracle = touches(&tri, i, j);
                if oracle {
                    assert!(
                        mask.get(i, j),
                        "case {case}: touched texel ({i},{j}) missed for {tri:?}"
                    );
                }
                if mask.get(i, j) && !oracle {
                    // Only texels within the widening of the exact footprint may be extra.
                    let near = [
                        (-1, 0),
                        (1, 0),
                        (0, -1),
                        (0, 1),
                        (-1, -1),
                        (1, 1),
                        (-1, 1),
                        (1, -1),
                    ]
                    .iter()
                    .any(|(di, dj)| touches(&tri, i + di, j + dj));
                    assert!(near, "case {case}: texel ({i},{j}) far from {tri:?}");
                }
            }
        }
    }
}

#[test]
fn centre_raster_holds_every_covered_centre_and_only_near_ones() {
    let mut state = 0x1234_5678_9abc_def1u64;
    for case in 0..400 {
        let mut tri = [[0.0; 2]; 3];
        for p in &mut tri {
            let snap = case % 3 == 0;
            let v = |s: &mut u64| {
                let v = 1.0 + 10.0 * xorshift(s);
                if snap {
                    (v * 2.0).round() / 2.0
                } else {
                    v
                }
            };
            *p = [v(&mut state), v(&mut state)];
        }
        let area2 = (tri[1][0] - tri[0][0]) * (tri[2][1] - tri[0][1])
            - (tri[1][1] - tri[0][1]) * (tri[2][0] - tri[0][0]);
        if area2 == 0.0 {
            // Sampled coverage of a degenerate triangle is empty (the evaluator skips it).
            continue;
        }
        let mut mask = Mask::new(14, 14);
        let marked = rasterize_centres(&mut mask, [tri], 0.01);
        assert_eq!(marked, mask.count() > 0, "case {case}");
        let mut conservative = Mask::new(14, 14);
        rasterize_conservative(&mut conservative, [tri]);
        for j in 0..14 {
            for i in 0..14 {
                let c = [i as f64 + 0.5, j as f64 + 0.5];
                let e = |a: [f64; 2], b: [f64; 2]| {
                    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
                };
                let (e0, e1, e2) = (e(tri[0], tri[1]), e(tri[1], tri[2]), e(tri[2], tri[0]));
                let inside =
                    (e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0) || (e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0);
                if inside {
                    assert!(mask.get(i, j), "case {case}: centre ({i},{j}) missed");
                }
                if mask.get(i, j) {
                    assert!(conservative.get(i, j), "case {case}: ({i},{j}) far");
                }
            }
        }
    }
}

#[test]
fn transposed_window_matches_a_texel_by_texel_transpose() {
    let mut state = 0x5151_2727_9e37_79b9u64;
    for case in 0..40 {
        let (w, h) = (
            1 + (xorshift(&mut state) * 200.0) as u32,
            1 + (xorshift(&mut state) * 150.0) as u32,
        );
        let mut m = Mask::new(w, h);
        for y in 0..h {
            for x in 0..w {
                if xorshift(&mut state) < 0.4 {
                    m.set_span(y, x, x);
                }
            }
        }
        let x0 = (xorshift(&mut state) * f64::from(w)) as u32;
        let y0 = (xorshift(&mut state) * f64::from(h)) as u32;
        let (ww, wh) = (
            1 + (xorshift(&mut state) * f64::from(w - x0 - 1)) as u32,
            1 + (xorshift(&mut state) * f64::from(h - y0 - 1)) as u32,
        );
        let t = m.transposed_window(x0, y0, ww, wh);
        assert_eq!((t.width(), t.height()), (wh, ww), "case {case}");
        for i in 0..i64::from(ww) {
            for j in 0..i64::from(wh) {
                assert_eq!(
                    t.get(j, i),
                    m.get(i64::from(x0) + i, i64::from(y0) + j),
                    "case {case}: ({i}, {j})"
                );
            }
        }
        // Nothing past the width of any row (the padding bits stay clear).
        assert_eq!(
            t.count(),
            (0..ww)
                .map(|i| (0..wh)
                    .filter(|&j| m.get(i64::from(x0 + i), i64::from(y0 + j)))
                    .count() as u64)
                .sum::<u64>(),
            "case {case}"
        );
    }
}

#[test]
fn a_triangle_on_texel_lines_touches_the_neighbours_it_meets() {
    // The closed square [2,3]² touches all 16 texels of [1,4]² in the closed sense.
    let mut mask = Mask::new(8, 8);
    rasterize_conservative(
        &mut mask,
        [
            [[2.0, 2.0], [3.0, 2.0], [3.0, 3.0]],
            [[2.0, 2.0], [3.0, 3.0], [2.0, 3.0]],
        ],
    );
    for j in 0..8 {
        for i in 0..8 {
            assert_eq!(
                mask.get(i, j),
                (1..=3).contains(&i) && (1..=3).contains(&j),
                "({i},{j})"
            );
        }
    }
}

#[test]
fn dilation_is_chebyshev_and_extents_are_per_line() {
    let mut m = Mask::new(70, 9);
    m.set_span(4, 3, 3);
    m.set_span(4, 66, 66);
    let d = m.dilate(2);
    for y in 0..9 {
        for x in 0..70 {
            let near = |cx: i64| (x - cx).abs() <= 2 && (y - 4i64).abs() <= 2;
            assert_eq!(d.get(x, y), near(3) || near(66), "({x},{y})");
        }
    }
    assert_eq!(d.count(), 50);
    assert_eq!(m.runs(4), vec![(3, 3), (66, 66)]);
    // Across word boundaries and with a radius beyond a word, against a brute force.
    let mut big = Mask::new(300, 5);
    for x in [0u32, 63, 64, 127, 190, 299] {
        big.set_span(2, x, x);
    }
    big.set_span(0, 100, 140);
    for r in [1u32, 5, 63, 64, 70] {
        let d = big.dilate(r);
        for y in 0..5i64 {
            for x in 0..300i64 {
                let want = (0..5i64).any(|yy| {
                    (0..300i64).any(|xx| {
                        big.get(xx, yy) && (xx - x).abs() <= r as i64 && (yy - y).abs() <= r as i64
                    })
                });
                assert_eq!(d.get(x, y), want, "r {r} ({x},{y})");
            }
        }
        let ext = d.column_extents();
        let rows = d.row_extents();
        for x in 0..300u32 {
            let col: Vec<u32> = (0..5).filter(|&y| d.get(x as i64, y as i64)).collect();
            assert_eq!(
                ext[x as usize],
                col.first().map(|&a| (a, *col.last().unwrap()))
            );
        }
        for y in 0..5u32 {
            let row: Vec<u32> = (0..300).filter(|&x| d.get(x as i64, y as i64)).collect();
            assert_eq!(
                rows[y as usize],
                row.first().map(|&a| (a, *row.last().unwrap()))
            );
        }
    }
    assert_eq!(d.column_extents()[3], Some((2, 6)));
    assert_eq!(d.row_extents()[4], Some((1, 68)));
}

#[test]
fn adding_except_near_equals_adding_except_the_dilation() {
    let mut state = 0x0bad_cafe_1234_5678u64;
    for case in 0..60 {
        let (w, h) = (
            1 + (xorshift(&mut state) * 200.0) as u32,
            1 + (xorshift(&mut state) * 120.0) as u32,
        );
        // Sparse and dense masks both: the own texels at one density, the extra at another.
        let (p_own, p_extra) = (xorshift(&mut state) * 0.3, xorshift(&mut state) * 0.5);
        let mut own = Mask::new(w, h);
        let mut extra = Mask::new(w, h);
        for y in 0..h {
            for x in 0..w {
                if xorshift(&mut state) < p_own {
                    own.set_span(y, x, x);
                }
                if xorshift(&mut state) < p_extra {
                    extra.set_span(y, x, x);
                }
            }
        }
        for r in [0, 1, 2, 3, 5, 63, 64, 70] {
            let mut expected = own.clone();
            expected.add_except(&extra, &own.dilate(r));
            let mut got = own.clone();
            got.add_except_dilated(&extra, r);
            assert_eq!(got.count(), expected.count(), "case {case}, r {r}");
            for y in 0..i64::from(h) {
                for x in 0..i64::from(w) {
                    assert_eq!(
                        got.get(x, y),
                        expected.get(x, y),
                        "case {case}, r {r}: ({x}, {y})"
                    );
                }
            }
        }
    }
}
