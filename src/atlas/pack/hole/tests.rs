use super::{d_rows, set_bits, spread_out, Occupancy, RingBits, Row, ScanBuffers, CANDIDATE_ROWS};
use crate::atlas::pack::place::{orientations, prepare_chart};
use crate::atlas::pack::test_charts::{mixed_set, xorshift64};

/// A `w × h` canvas of random runs on every row: the first starts before `start`, each is
/// up to `run` texels longer than one, and gaps are 1 + up to `gap` texels. Returns the
/// occupancy and the same texels as a plain row-major bitmap.
fn striped_canvas(
    [w, h]: [i32; 2],
    next: &mut impl FnMut(i32) -> i32,
    [start, run, gap]: [i32; 3],
) -> (Occupancy, Vec<bool>) {
    // The plain first fit's map: its rows hold the occupied texels themselves.
    let mut occ = Occupancy::new(w, h).first_fit_only();
    let mut taken = vec![false; (w * h) as usize];
    for y in 0..h {
        let mut x = next(start);
        while x < w {
            let e = (x + next(run)).min(w - 1);
            occ.occupy(y, x, e);
            (x..=e).for_each(|c| taken[(y * w + c) as usize] = true);
            x = e + 2 + next(gap);
        }
    }
    (occ, taken)
}
use std::collections::BTreeSet;

/// The maximal runs `(first, last)` of the `x` in `lo..=hi` where `fits(x)`, in order.
fn maximal_runs(lo: i32, hi: i32, fits: impl Fn(i32) -> bool) -> Vec<(i32, i32)> {
    let mut runs = Vec::new();
    let mut x = lo;
    while x <= hi {
        if fits(x) {
            let s = x;
            while x < hi && fits(x + 1) {
                x += 1;
            }
            runs.push((s, x));
        }
        x += 1;
    }
    runs
}

/// A row of `W` columns filled by random disjoint runs, checked after every run against a
/// plain array: occupancy per column, the longest free run (columns outside `0..W` free, as
/// on the canvas beyond the placed charts), and the positions at which random chart rows fit
/// among random intervals of positions.
#[test]
fn a_row_agrees_with_a_plain_array() {
    const W: i32 = 160;
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = |n: i32| (xorshift64(&mut seed) % n as u64) as i32;
    let mut runs = 0;
    for _trial in 0..20 {
        let mut row = Row::empty();
        let mut taken = [false; W as usize];
        for _ in 0..40 {
            let s = next(W);
            let e = (s + next(12)).min(W - 1);
            if (s..=e).any(|x| taken[x as usize]) {
                continue;
            }
            row.occupy(s, e);
            runs += 1;
            (s..=e).for_each(|x| taken[x as usize] = true);
            let free = |x: i32| !(0..W).contains(&x) || !taken[x as usize];
            for x in 0..W {
                assert_eq!(row.get(x), !free(x), "column {x}");
            }
            let mut longest = 0;
            let mut current = 0;
            for x in 0..W {
                current = if free(x) { current + 1 } else { 0 };
                longest = longest.max(current);
            }
            assert_eq!(row.max_gap(0, W), longest);
            // The positions x among random intervals at which columns x + a ..= x + b lie in
            // free columns of 0..=end (beyond `end`, and before 0, columns count as occupied).
            let end = W + next(8);
            let free_in = |x: i32| (0..=end).contains(&x) && free(x);
            let a = next(6);
            let long = next(3) == 0;
            let b = a + next(if long { 40 } else { 6 });
            let mut cands = Vec::new();
            let mut x = next(12) - 8;
            while x < W + 4 {
                let q = x + next(30);
                cands.push((x, q));
                x = q + 2 + next(20);
            }
            let fits = |x: i32| (x + a..=x + b).all(free_in);
            let expected: Vec<(i32, i32)> = cands
                .iter()
                .flat_map(|&(p, q)| maximal_runs(p, q, fits))
                .collect();
            let mut got = Vec::new();
            row.fitting_positions(a, b, end, &cands, &mut got);
            assert_eq!(got, expected, "span {a}..={b} up to {end} in {cands:?}");
        }
    }
    assert!(runs > 200, "{runs}");
}

/// The bit-parallel first fit of a row of positions agrees with testing every position
/// texel by texel, on random canvases (runs crossing word boundaries, widths not a
/// multiple of 64) and random charts (rows longer than a word, empty positions ranges).
#[test]
fn scan_row_finds_the_first_fit_of_a_brute_force() {
    const W: i32 = 300;
    const H: i32 = 24;
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = |n: i32| (xorshift64(&mut seed) % n as u64) as i32;
    let (mut found, mut none) = (0, 0);
    for _canvas in 0..30 {
        let density = 1 + next(6);
        let (occ, taken) = striped_canvas([W, H], &mut next, [20, 3 * density, 90 / density]);
        let free = |x: i32, y: i32| !taken[(y * W + x) as usize];
        for _chart in 0..20 {
            let h = 1 + next(6);
            let rows: Vec<(i32, i32, i32)> = (0..h)
                .map(|r| {
                    let a = next(8);
                    let long = next(4) == 0;
                    (r, a, a + next(if long { 140 } else { 12 }))
                })
                .collect();
            let width = rows.iter().map(|&(_, _, b)| b + 1).max().unwrap();
            let mut buffers = ScanBuffers::default();
            for y in 0..=H - h {
                let x_lo = next(40);
                let x_hi = (W - width - next(40)).min(W - width);
                let expected = (x_lo..=x_hi).find(|&x| {
                    rows.iter()
                        .all(|&(r, a, b)| (x + a..=x + b).all(|c| free(c, y + r)))
                });
                let got = occ.scan_row(y, x_lo, x_hi, &rows, &mut buffers);
                assert_eq!(got, expected, "y {y} rows {rows:?} x {x_lo}..={x_hi}");
                if got.is_some() {
                    // The candidates of `find` read every fitting position from `fit`: the
                    // maximal runs of fitting positions, in order.
                    let fits = |x: i32| {
                        rows.iter()
                            .all(|&(r, a, b)| (x + a..=x + b).all(|c| free(c, y + r)))
                    };
                    let want = maximal_runs(x_lo, x_hi, fits);
                    assert_eq!(buffers.fit, want, "y {y} rows {rows:?}");
                }
                if got.is_some() {
                    found += 1;
                } else {
                    none += 1;
                }
            }
        }
    }
    assert!(found > 200 && none > 200, "{found} found, {none} none");
}

/// Random sets of texels, some wider than a word: the ring (of `ring_runs` and of
/// `RingBits::around`) is exactly the texels outside the set at Chebyshev distance 1 from it,
/// each once.
#[test]
fn rings_are_the_texels_at_distance_one() {
    let mut seed = 0x51f1_5eed_0dd5_eed5u64;
    let mut next = |n: i32| (xorshift64(&mut seed) % n as u64) as i32;
    let mut texels = 0;
    for i in 0..300 {
        let (w, h) = (1 + next(if i % 3 == 0 { 150 } else { 20 }), 1 + next(12));
        let fill = 1 + next(4);
        let set: Vec<bool> = (0..w * h).map(|_| next(5) < fill).collect();
        let inside = |x: i32, y: i32| {
            (0..w).contains(&x) && (0..h).contains(&y) && set[(y * w + x) as usize]
        };
        let mut runs = Vec::new();
        for y in 0..h {
            let mut x = 0;
            while x < w {
                if inside(x, y) {
                    let start = x;
                    while x + 1 < w && inside(x + 1, y) {
                        x += 1;
                    }
                    runs.push((y, start, x));
                }
                x += 1;
            }
        }
        let mut got = BTreeSet::new();
        for (r, a, b) in ring_runs(&runs, h) {
            assert!(a <= b, "empty run {a}..={b}");
            for x in a..=b {
                assert!(got.insert((r, x)), "texel ({x}, {r}) twice");
            }
        }
        let mut expected = BTreeSet::new();
        for y in -1..=h {
            for x in -1..=w {
                let near = (-1..=1).any(|dy| (-1..=1).any(|dx| inside(x + dx, y + dy)));
                if !inside(x, y) && near {
                    expected.insert((y, x));
                }
            }
        }
        assert_eq!(got, expected, "set {w}x{h} runs {runs:?}");
        // The ring made word by word holds exactly these texels, each row's count with it.
        let bits = RingBits::around(&runs);
        let mut from_bits = BTreeSet::new();
        for (q, &(r, count)) in bits.rows.iter().enumerate() {
            let row = &bits.bits[q * bits.words..][..bits.words];
            let ones: u32 = row.iter().map(|w| w.count_ones()).sum();
            assert_eq!(ones, count, "row {r} of set {w}x{h}");
            for j in 0..64 * bits.words {
                if row[j / 64] >> (j % 64) & 1 == 1 {
                    from_bits.insert((r, bits.left + j as i32));
                }
            }
        }
        assert_eq!(from_bits, expected, "bits of set {w}x{h} runs {runs:?}");
        texels += got.len();
    }
    assert!(texels > 2000, "{texels}");
}

/// Random canvases and rings: the contact is the number of ring texels that are occupied
/// or outside the box.
#[test]
fn contact_counts_occupied_texels_and_texels_outside_the_box() {
    const W: i32 = 200;
    const H: i32 = 40;
    let mut seed = 0x0c0f_fee0_dead_beefu64;
    let mut next = |n: i32| (xorshift64(&mut seed) % n as u64) as i32;
    let (occ, taken) = striped_canvas([W, H], &mut next, [10, 9, 30]);
    let bbox = [10, 5, 190, 35];
    let (mut partial, mut outside) = (0, 0);
    for _ in 0..300 {
        let ring: Vec<(i32, i32, i32)> = (0..1 + next(8))
            .map(|_| {
                let a = next(32) - 1;
                (next(10) - 1, a, a + next(140))
            })
            .collect();
        let (x, y) = (next(180) - 10, next(36) - 2);
        let mut expected = 0;
        let mut out = 0;
        for &(r, a, b) in &ring {
            for c in x + a..=x + b {
                let cy = y + r;
                if c < bbox[0] || c >= bbox[2] || cy < bbox[1] || cy >= bbox[3] {
                    out += 1;
                } else if taken[(cy * W + c) as usize] {
                    expected += 1;
                }
            }
        }
        let got = occ.contact(bbox, &ring, x, y);
        assert_eq!(got, expected + out, "ring {ring:?} at ({x}, {y})");
        partial += usize::from(expected > 0);
        outside += usize::from(out > 0);
    }
    assert!(partial > 100 && outside > 100, "{partial} {outside}");
}

/// Real charts on random canvases: `find` returns a position where the chart's exact `D`
/// meets no occupied texel inside the box, and the best-scoring candidate of a brute force
/// over every position (both ends of each run of fitting positions, on the rows within
/// `CANDIDATE_ROWS` of the highest fit of any orientation; score 2 · contact − rows below
/// it; ties by end, column, orientation).
#[test]
fn find_takes_the_best_scoring_candidate_of_a_brute_force() {
    const W: i32 = 160;
    const H: i32 = 120;
    let mut seed = 0x7777_1234_abcd_0001u64;
    let mut next = |n: i32| (xorshift64(&mut seed) % n as u64) as i32;
    let charts = mixed_set(10, 3);
    let (mut placed, mut not_first) = (0, 0);
    for canvas in 0..6 {
        let mut occ = Occupancy::new(W, H);
        let mut taken = vec![false; (W * H) as usize];
        let bbox = [8, 6, W - 8, H - 6];
        for _ in 0..30 + 10 * canvas {
            // Taken texels at least the padding inside the box, as placed `F` are (their `D`
            // lies inside the box).
            let (x, y) = (bbox[0] + 2 + next(126), bbox[1] + 2 + next(96));
            let (w, h) = (1 + next(16), 1 + next(12));
            for r in y..(y + h).min(bbox[3] - 2) {
                let e = (x + w - 1).min(bbox[2] - 3);
                if (x..=e).any(|c| taken[(r * W + c) as usize]) {
                    continue;
                }
                occ.occupy(r, x, e);
                (x..=e).for_each(|c| taken[(r * W + c) as usize] = true);
            }
        }
        // The keep-out zones: every texel within the padding (2) of a taken one, row by row.
        for r in 0..H {
            let near = |c: i32| {
                (r - 2..=r + 2).any(|v| {
                    (c - 2..=c + 2).any(|u| {
                        (0..W).contains(&u) && (0..H).contains(&v) && taken[(v * W + u) as usize]
                    })
                })
            };
            let mut c = 0;
            while c < W {
                if near(c) {
                    let s = c;
                    while c + 1 < W && near(c + 1) {
                        c += 1;
                    }
                    occ.keep_out(r, s, c);
                }
                c += 1;
            }
        }
        for (i, owned) in charts.iter().enumerate() {
            let chart = owned.as_pack_chart();
            let prep = prepare_chart(i, &chart).unwrap();
            let orients = orientations(&chart, &prep, 9.0, 8, 2, [1024, 1024], true);
            let usable: Vec<bool> = orients.iter().map(|o| o.dilated.is_some()).collect();
            // Brute force: (score, end, x, k) of every candidate.
            let mut fits_of = Vec::new();
            for (k, o) in orients.iter().enumerate().filter(|(k, _)| usable[*k]) {
                let rows = d_rows(o).unwrap();
                let (w, h) = (o.width_texels as i32, o.height_texels as i32);
                let fits = |x: i32, y: i32| {
                    x >= bbox[0]
                        && y >= bbox[1]
                        && x + w <= bbox[2]
                        && y + h <= bbox[3]
                        && rows.iter().all(|&(r, a, b)| {
                            (x + a..=x + b).all(|c| !taken[((y + r) * W + c) as usize])
                        })
                };
                for y in bbox[1]..=bbox[3] - h {
                    for x in bbox[0]..=bbox[2] - w {
                        if fits(x, y) && (!fits(x - 1, y) || !fits(x + 1, y)) {
                            let ring = ring_runs(&rows, h);
                            fits_of.push((y + h, x, k, occ.contact(bbox, &ring, x, y)));
                        }
                    }
                }
            }
            let got = occ.find(bbox, &orients, &usable);
            let Some(first_end) = fits_of.iter().map(|f| f.0).min() else {
                assert_eq!(got, None, "chart {i} on canvas {canvas}");
                continue;
            };
            let best = fits_of
                .iter()
                .filter(|f| f.0 <= first_end + CANDIDATE_ROWS)
                .max_by(|a, b| {
                    let s = |f: &(i32, i32, usize, i64)| 2 * f.3 - i64::from(f.0 - first_end);
                    s(a).cmp(&s(b)).then((b.0, b.1, b.2).cmp(&(a.0, a.1, a.2)))
                })
                .unwrap();
            let got = got.expect("a fit exists");
            let h = orients[best.2].height_texels as i32;
            assert_eq!(
                (got.orientation, got.x, got.y),
                (best.2, best.1, best.0 - h),
                "chart {i} on canvas {canvas}"
            );
            placed += 1;
            not_first += usize::from(best.0 > first_end);
        }
    }
    assert!(
        placed > 30 && not_first > 0,
        "{placed} placed, {not_first} below the first fit"
    );
}

/// The search order of the runs: the key run, then the others by bit-reversed row
/// (stable), as a comparison sort would give.
#[test]
fn spread_out_is_a_stable_sort_by_bit_reversed_row() {
    let mut seed = 0x0bad_cafe_1234_5678u64;
    let mut next = |n: i32| (xorshift64(&mut seed) % n as u64) as i32;
    for _ in 0..300 {
        let h = 1 + next(70);
        let rows: Vec<(i32, i32, i32)> = (0..1 + next(150))
            .map(|_| (next(h), next(50), next(50)))
            .collect();
        let key = next(rows.len() as i32) as usize;
        let mut expected = vec![rows[key]];
        let mut rest: Vec<_> = (0..rows.len())
            .filter(|&i| i != key)
            .map(|i| rows[i])
            .collect();
        rest.sort_by_key(|&(r, _, _)| (r as u32).reverse_bits());
        expected.extend(rest);
        assert_eq!(spread_out(&rows, key), expected, "key {key} rows {rows:?}");
    }
}

/// The word-by-word contact of a ring agrees with the run-by-run count, on rings of
/// random sets (wider than a word too) at random positions, inside the box, across its
/// edges and outside it.
#[test]
fn contact_bits_agrees_with_contact() {
    const W: i32 = 260;
    const H: i32 = 60;
    let mut seed = 0xfeed_f00d_2468_1357u64;
    let mut next = |n: i32| (xorshift64(&mut seed) % n as u64) as i32;
    let (occ, _) = striped_canvas([W, H], &mut next, [10, 9, 30]);
    let bbox = [7, 4, 250, 55];
    let (mut edge, mut occupied) = (0, 0);
    for _ in 0..400 {
        let wide = next(3) == 0;
        let (w, h) = (1 + next(if wide { 150 } else { 20 }), 1 + next(12));
        let fill = 1 + next(4);
        let runs: Vec<(i32, i32, i32)> = (0..h)
            .flat_map(|r| {
                let mut v = Vec::new();
                let mut x = next(3);
                while x < w {
                    let e = (x + next(2 * fill + 1)).min(w - 1);
                    v.push((r, x, e));
                    x = e + 2 + next(4);
                }
                v
            })
            .collect();
        let ring = ring_runs(&runs, h);
        let bits = RingBits::new(&ring);
        let (x, y) = (next(W + 20) - 10, next(H + 10) - 5);
        let expected = occ.contact(bbox, &ring, x, y);
        assert_eq!(
            occ.contact_bits(bbox, &bits, x, y),
            expected,
            "{runs:?} at ({x}, {y})"
        );
        edge += usize::from(x <= bbox[0] || x + w >= bbox[2] || y <= bbox[1]);
        occupied += usize::from(expected > 0);
    }
    assert!(edge > 50 && occupied > 200, "{edge} {occupied}");
}

impl RingBits {
    /// The ring of disjoint runs `ring` (as [`ring_runs`] returns them): the reference of
    /// [`Self::around`].
    fn new(ring: &[(i32, i32, i32)]) -> Self {
        let left = ring.iter().map(|t| t.1).min().unwrap_or(0);
        let right = ring.iter().map(|t| t.2).max().unwrap_or(0);
        let top = ring.iter().map(|t| t.0).min().unwrap_or(0);
        let bottom = ring.iter().map(|t| t.0).max().unwrap_or(-1);
        let words = ((right - left + 1).max(1) as usize).div_ceil(64);
        let height = (bottom - top + 1).max(0) as usize;
        let mut all_rows: Vec<(i32, u32)> = (0..height).map(|q| (top + q as i32, 0)).collect();
        let mut all_bits = vec![0u64; height * words];
        for &(r, a, b) in ring {
            let q = (r - top) as usize;
            set_bits(
                &mut all_bits[q * words..][..words],
                (a - left) as usize,
                (b - left) as usize,
            );
            all_rows[q].1 += (b - a + 1) as u32;
        }
        let mut rows = Vec::new();
        let mut bits = Vec::new();
        for (q, &row) in all_rows.iter().enumerate() {
            if row.1 > 0 {
                rows.push(row);
                bits.extend_from_slice(&all_bits[q * words..][..words]);
            }
        }
        Self {
            left,
            words,
            rows,
            bits,
        }
    }
}

/// The texels at Chebyshev distance exactly 1 from the runs `rows` (sorted by row, then
/// column) of a set `h` rows tall: `(row, first, last)`, rows `-1..=h` (the reference of
/// [`RingBits::around`]).
fn ring_runs(rows: &[(i32, i32, i32)], h: i32) -> Vec<(i32, i32, i32)> {
    let mut by_row: Vec<Vec<(i32, i32)>> = vec![Vec::new(); h.max(0) as usize];
    for &(r, a, b) in rows {
        by_row[r as usize].push((a, b));
    }
    let mut out = Vec::new();
    for r in -1..=h {
        let mut iv: Vec<(i32, i32)> = (r - 1..=r + 1)
            .filter(|&q| q >= 0 && q < h)
            .flat_map(|q| by_row[q as usize].iter().map(|&(a, b)| (a - 1, b + 1)))
            .collect();
        iv.sort_unstable();
        let mut merged: Vec<(i32, i32)> = Vec::new();
        for (a, b) in iv {
            match merged.last_mut() {
                Some(m) if a <= m.1 + 1 => m.1 = m.1.max(b),
                _ => merged.push((a, b)),
            }
        }
        let own: &[(i32, i32)] = if (0..h).contains(&r) {
            &by_row[r as usize]
        } else {
            &[]
        };
        for (s, e) in merged {
            let mut c = s;
            for &(a, b) in own.iter().filter(|&&(a, b)| b >= s && a <= e) {
                if a > c {
                    out.push((r, c, a - 1));
                }
                c = c.max(b + 1);
            }
            if c <= e {
                out.push((r, c, e));
            }
        }
    }
    out
}
