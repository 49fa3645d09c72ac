//! Hole filling: places a chart inside the packing's bounding box, in the empty space that
//! the horizons of [`super::horizon`] cannot reach.
//!
//! Purpose: the horizon packer of lscm-2002 §4 / isocharts-2004 §6 only ever places a chart
//! beyond the current horizon of each line it covers, so the space behind a horizon (between
//! charts, and whole regions walled in from all four sides) stays empty for good. This module
//! keeps the exact occupancy of the placed footprints `F` and finds a position *inside* the
//! current bounding box where a new chart's padded footprint `D` meets no placed `F`. It
//! extends the papers' packers (they have nothing of the kind); placing there does not grow the
//! box, and the caller updates the four horizons with the new `F` as for any placement, so the
//! horizon invariant stays true for later charts.
//!
//! Model. [`Occupancy`] keeps, per canvas row, the texels of every placed `F` as its first and
//! last occupied column and the sorted free runs in between (exact: every texel of `F`, not a
//! hull). A chart is tested by the per-row extents of its `D` (the interval `[a_r, b_r]` of
//! row `r`, a superset of `D`'s texels in that row): at grid origin `(x, y)` it fits when, for
//! every row `r`, the canvas texels `x + a_r ..= x + b_r` of row `y + r` lie in one free run,
//! and the grid lies inside the box. Exact on the texel grid: then `D` meets no `F`, so every
//! `F` keeps `padding` empty texels (Chebyshev) from every other `F`; and the box lies within
//! the page.
//!
//! Search: first fit per orientation, rows of the box top to bottom, columns left to right;
//! among orientations the one whose grid ends highest wins (smallest `y + height`), ties by
//! `x`, then by orientation index: deterministic. A canvas row is skipped at once when one of
//! the chart's rows is longer than its longest free run (the chart's longest row first). Along
//! a row the chart's rows are intersected by leapfrogging: each row moves `x` to the next
//! position where it fits (a binary search in its free runs), until all rows agree.
//!
//! Units: texels (`i32` canvas coordinates).
//!
//! Cost per orientation: O(box rows × chart rows) for the row filter at worst (most canvas
//! rows fail on the longest chart row), plus per surviving row O(leapfrog steps × log runs),
//! bounded by [`SEARCH_STEPS_PER_ROW`] × chart rows steps (past it the orientation is given
//! up: the search is then not exhaustive, but still exact in what it places); per commit,
//! O(runs of `F` × free runs of the rows it covers).
use super::horizon::Placement;
use super::place::{Orientation, EMPTY};

/// Steps (a chart row tested against a canvas row, or one leapfrog step) at most per
/// orientation and search, per row of the chart's `D`: the search gives up on an orientation
/// past it (deterministic: a count, not a time). Measured on 2CylinderEngine (1,743 packed
/// charts, loaded machine): unbounded 0.519 packing / 28.8 s pack stage; 1024 → 0.523 / 13 s;
/// 256 → 0.446 / 7.7 s; a flat 4096 per orientation → 0.433, and the bunny fell to 0.642.
pub const SEARCH_STEPS_PER_ROW: i64 = 1024;

/// The free space of one canvas row: the occupied span and the free runs inside it.
#[derive(Debug, Clone, Default)]
struct Row {
    /// First and last occupied column; `first > last` when the row is empty.
    first: i32,
    last: i32,
    /// Free runs strictly inside `first..=last`, inclusive, sorted, disjoint, non-empty.
    inner: Vec<(i32, i32)>,
    /// The length of the longest run of `inner` (0 if none).
    inner_max: i32,
}

impl Row {
    fn empty() -> Self {
        Self {
            first: i32::MAX,
            last: i32::MIN,
            inner: Vec::new(),
            inner_max: 0,
        }
    }

    /// Marks columns `s..=e` occupied.
    fn occupy(&mut self, s: i32, e: i32) {
        if self.first > self.last {
            self.first = s;
            self.last = e;
            return;
        }
        // The free space between the run and the current span becomes an inner run.
        if e + 1 < self.first {
            self.inner.insert(0, (e + 1, self.first - 1));
        }
        if s > self.last + 1 {
            self.inner.push((self.last + 1, s - 1));
        }
        self.first = self.first.min(s);
        self.last = self.last.max(e);
        // Subtract s..=e from the inner runs.
        let lo = self.inner.partition_point(|g| g.1 < s);
        let hi = self.inner.partition_point(|g| g.0 <= e);
        if lo < hi {
            let (g0, g1) = (self.inner[lo].0, self.inner[hi - 1].1);
            let mut rest: [(i32, i32); 2] = [(0, -1); 2];
            let mut n = 0;
            if g0 < s {
                rest[n] = (g0, s - 1);
                n += 1;
            }
            if g1 > e {
                rest[n] = (e + 1, g1);
                n += 1;
            }
            self.inner.splice(lo..hi, rest[..n].iter().copied());
        }
        self.inner_max = self.inner.iter().map(|g| g.1 - g.0 + 1).max().unwrap_or(0);
    }

    /// Longest free run within columns `x0..x1`, which hold every occupied texel of the row.
    fn max_gap(&self, x0: i32, x1: i32) -> i32 {
        if self.first > self.last {
            x1 - x0
        } else {
            self.inner_max.max(self.first - x0).max(x1 - 1 - self.last)
        }
    }

    /// The smallest `x' >= x` at which columns `x' + a ..= x' + b` are free.
    fn next_fit(&self, x: i32, a: i32, b: i32) -> i32 {
        if self.first > self.last || x + b < self.first {
            return x;
        }
        let start = self.inner.partition_point(|g| g.1 < x + b);
        for &(g0, g1) in &self.inner[start..] {
            let xs = x.max(g0 - a);
            if xs + b <= g1 {
                return xs;
            }
        }
        x.max(self.last + 1 - a)
    }

    /// Whether column `x` is occupied (the tests' view of the row).
    #[cfg(test)]
    fn get(&self, x: i32) -> bool {
        if self.first > self.last || x < self.first || x > self.last {
            return false;
        }
        let i = self.inner.partition_point(|g| g.1 < x);
        !(i < self.inner.len() && self.inner[i].0 <= x)
    }
}

/// The placed footprints `F` of one page, per canvas row.
#[derive(Debug, Clone)]
pub struct Occupancy {
    rows: Vec<Row>,
    /// Texels occupied in all (footprints never overlap, so each is counted once).
    occupied_texels: i64,
}

impl Occupancy {
    /// An empty canvas of `height` rows.
    pub fn new(height: i32) -> Self {
        Self {
            rows: vec![Row::empty(); height as usize],
            occupied_texels: 0,
        }
    }

    /// Marks texels `x0..=x1` of row `y` occupied (inside the canvas, `x0 <= x1`).
    pub fn occupy(&mut self, y: i32, x0: i32, x1: i32) {
        self.occupied_texels += i64::from(x1 - x0) + 1;
        self.rows[y as usize].occupy(x0, x1);
    }

    /// The best position inside `bbox` (`[x0, y0, x1, y1)`, canvas texels) for one of the
    /// `usable` orientations (module doc: first fit per orientation, the grid ending highest
    /// wins), or `None` when no orientation fits in the box. Does not modify the map.
    pub fn find(
        &self,
        bbox: [i32; 4],
        orientations: &[Orientation],
        usable: &[bool],
    ) -> Option<Placement> {
        let [x0, y0, x1, y1] = bbox;
        // (y + height, x, orientation).
        let mut best: Option<(i32, i32, usize)> = None;
        let mut rows: Vec<(i32, i32, i32)> = Vec::new();
        for (k, o) in orientations.iter().enumerate() {
            if !usable[k] {
                continue;
            }
            let Some(d) = o.dilated.as_ref() else {
                continue;
            };
            let (w, h) = (o.width_texels as i32, o.height_texels as i32);
            if w > x1 - x0 || h > y1 - y0 {
                continue;
            }
            rows.clear();
            rows.extend(
                d.rows
                    .iter()
                    .enumerate()
                    .filter(|(_, &e)| e != EMPTY)
                    .map(|(r, &(a, b))| (r as i32, a, b)),
            );
            if rows.is_empty() {
                continue;
            }
            // Exact pruning: every placed `F` lies inside the box, so the box has
            // `box area − occupied` free texels, and the rows of `D` need that many at least.
            let needed_texels: i64 = rows.iter().map(|&(_, a, b)| i64::from(b - a) + 1).sum();
            let free_texels = i64::from(x1 - x0) * i64::from(y1 - y0) - self.occupied_texels;
            if needed_texels > free_texels {
                continue;
            }
            // Longest row first (ties: first row): it rejects most canvas rows.
            let key = (0..rows.len())
                .max_by_key(|&i| (rows[i].2 - rows[i].1, std::cmp::Reverse(i)))
                .unwrap_or(0);
            rows.swap(0, key);
            let (x_lo, x_hi) = (x0, x1 - w);
            let mut y_hi = y1 - h;
            if let Some((end, _, _)) = best {
                y_hi = y_hi.min(end - h);
            }
            let mut budget = SEARCH_STEPS_PER_ROW * rows.len() as i64;
            'rows: for y in y0..=y_hi {
                for &(r, a, b) in &rows {
                    budget -= 1;
                    if self.rows[(y + r) as usize].max_gap(x0, x1) < b - a + 1 {
                        if budget <= 0 {
                            break 'rows;
                        }
                        continue 'rows;
                    }
                }
                // Positions must beat the best so far: on its last row, only smaller x.
                let x_end = match best {
                    Some((end, bx, _)) if end == y + h => x_hi.min(bx - 1),
                    _ => x_hi,
                };
                if let Some(x) = self.scan_row(y, x_lo, x_end, &rows, &mut budget) {
                    best = Some((y + h, x, k));
                    break;
                }
                if budget <= 0 {
                    break;
                }
            }
        }
        best.map(|(end, x, k)| Placement {
            orientation: k,
            x,
            y: end - orientations[k].height_texels as i32,
        })
    }

    /// The smallest `x` in `x_lo..=x_hi` where every chart row `(r, a, b)` finds canvas row
    /// `y + r` free in `x + a ..= x + b`: leapfrogging over the rows until all agree.
    fn scan_row(
        &self,
        y: i32,
        x_lo: i32,
        x_hi: i32,
        rows: &[(i32, i32, i32)],
        budget: &mut i64,
    ) -> Option<i32> {
        let n = rows.len();
        let mut x = x_lo;
        let mut agree = 0;
        let mut i = 0;
        while x <= x_hi {
            let (r, a, b) = rows[i];
            *budget -= 1;
            let next = self.rows[(y + r) as usize].next_fit(x, a, b);
            // Row i fits at `next`, the rows that agreed before only at the old `x`.
            agree = if next == x { agree + 1 } else { 1 };
            x = next;
            if agree == n && x <= x_hi {
                return Some(x);
            }
            i = (i + 1) % n;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::Row;

    /// A row of `W` columns filled by random disjoint runs, checked after every run against a
    /// plain array: occupancy per column, the longest free run, and the first fit of random
    /// chart rows (columns outside `0..W` are free, as on the canvas beyond the placed charts).
    #[test]
    fn a_row_agrees_with_a_plain_array() {
        const W: i32 = 160;
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = |n: i32| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % n as u64) as i32
        };
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
                for _ in 0..50 {
                    let (x, a) = (next(W + 20) - 10, next(6));
                    let b = a + next(15);
                    let expected = (x..)
                        .find(|&p| (p + a..=p + b).all(free))
                        .expect("the row is free past its last run");
                    assert_eq!(row.next_fit(x, a, b), expected, "x {x} a {a} b {b}");
                }
            }
        }
        assert!(runs > 200, "{runs}");
    }
}
