//! Hole filling: a chart anywhere on the page, including the empty space that the horizons
//! of [`super::horizon`] cannot reach.
//!
//! Purpose: the horizon packer of lscm-2002 §4 / isocharts-2004 §6 only ever places a chart
//! beyond the current horizon of each line it covers, so the space behind a horizon (between
//! charts, and whole regions walled in from all four sides) stays empty for good. This module
//! keeps the exact occupancy of the placed footprints `F` and finds positions in a box (the
//! page-sized box of [`super::horizon::HorizonPage::with_holes`]) where a new chart's padded
//! footprint `D` meets no placed `F`, near the top of the page, and takes the one whose
//! outline touches most: an extension of the papers' packers (they have nothing of the
//! kind). The caller updates the four horizons with the new `F` as for any placement.
//!
//! Model. [`Occupancy`] keeps, per canvas row, the texels of every placed `F` twice: as its
//! first and last occupied column with the sorted free runs in between (for the longest free
//! run of a row), and as a bitmap (exact: every texel of `F`, not a hull). A chart is tested
//! by the runs of its `D` (exact: the texels of `D` row by row, so that a concave chart can
//! wrap around placed ones; the per-row extents, a superset, in the plain first fit of
//! [`Occupancy::first_fit_only`]): at grid origin `(x, y)` it fits when, for every run
//! `[a, b]` of row `r`, the canvas texels `x + a ..= x + b` of row `y + r` are free, and the
//! grid lies inside the box. Exact on the texel grid: then `D` meets no `F`, so every `F`
//! keeps `padding` empty texels (Chebyshev) from every other `F`; and the box lies within the
//! page.
//!
//! Search: per orientation, rows of the box top to bottom, every position of a row at once.
//! Let `E` be the least grid end (`y + height`) of any orientation's first fit; the
//! candidates are both ends of every run of fitting positions on the rows whose grid ends at
//! most [`CANDIDATE_ROWS`] after `E`, and the winner has the highest score `2 · contact −
//! (y + height − E)`, where the contact counts the texels at distance 1 outside `D` that are
//! occupied or outside the box (the ring of `ring_runs`: where the chart's padded outline
//! touches placed charts or the page edge); ties by `(y + height, x, orientation)`. Best fit
//! by contact, near the top: small charts go to the gaps they fill snugly and leave the wide
//! ones to charts that need them. Deterministic, and exhaustive (every position of the
//! searched rows is decided). [`Occupancy::first_fit_only`] is the plain first fit: the least
//! `(y + height, x, orientation)`. A canvas row is skipped at once when one of the chart's
//! runs is longer than its longest free run. Along a row all positions are tested at once, 64
//! per word: each run `[a, b]` of `D` (the longest first, then the others spread out) keeps
//! only the positions where it lies inside one free run `[s, e]` of its canvas row — the
//! positions `s − a ..= e − b`, read from the row's sorted free runs, so a run costs the
//! words still alive plus the free runs they meet; where a canvas row is cut into many short
//! free runs (pages of thousands of charts) its free bits eroded by the run's length with
//! log-step shifts are cheaper and give the same bits — until none is left or every run is
//! done.
//! The orientations are searched in parallel, sharing the least first-fit end found so far
//! as a bound (never below `E`, so every search still collects every candidate within
//! [`CANDIDATE_ROWS`] of `E`): the same placement whatever the thread count. Only the
//! candidates within [`CANDIDATE_ROWS`] of `E` are scored (their contact counted), once `E`
//! is known.
//!
//! Units: texels (`i32` canvas coordinates).
//!
//! Cost per orientation: O(box rows × runs of `D`) for the row filter at worst, plus per
//! surviving row O(runs × (box width / 64 + free runs of the canvas row)) word operations
//! (fewer: only the words between the first and last position still possible are worked on,
//! and the row stops when none is left), for the rows down to its first fit and
//! [`CANDIDATE_ROWS`] more; per candidate O(ring runs × run length / 64); per commit,
//! O(runs of `F` × free runs of the rows it covers + texels of `F` / 64). Trade-off: the
//! exhaustive search costs more than a first fit by bisection, but finds fits a bisection
//! misses; the contact score (`2 · contact − rows below the highest first fit`) packs tighter
//! than the first fit alone for the price of scoring the candidates near it.
use super::place::{Orientation, EMPTY};
use super::placement::Placement;

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

    /// Calls `f(s, e)` for every maximal free run `s..=e` of the columns `0..=end` (`end` at or
    /// past the last occupied column) that meets columns `lo..=hi`, left to right. Cost:
    /// O(log runs + runs met).
    fn free_runs(&self, lo: i64, hi: i64, end: i64, mut f: impl FnMut(i64, i64)) {
        let mut emit = |s: i64, e: i64| {
            if s <= e && e >= lo && s <= hi {
                f(s, e);
            }
        };
        if self.first > self.last {
            emit(0, end);
            return;
        }
        emit(0, i64::from(self.first) - 1);
        let k = self.inner.partition_point(|g| i64::from(g.1) < lo);
        for &(s, e) in &self.inner[k..] {
            if i64::from(s) > hi {
                break;
            }
            emit(i64::from(s), i64::from(e));
        }
        emit(i64::from(self.last) + 1, end);
    }

    /// How many inner free runs meet columns `lo..=hi` (the outer two not counted). O(log runs).
    fn free_runs_met(&self, lo: i64, hi: i64) -> usize {
        let k0 = self.inner.partition_point(|g| i64::from(g.1) < lo);
        let k1 = self.inner.partition_point(|g| i64::from(g.0) <= hi);
        k1.saturating_sub(k0)
    }

    /// Longest free run within columns `x0..x1`, which hold every occupied texel of the row.
    fn max_gap(&self, x0: i32, x1: i32) -> i32 {
        if self.first > self.last {
            x1 - x0
        } else {
            self.inner_max.max(self.first - x0).max(x1 - 1 - self.last)
        }
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
    /// The same texels as a bitmap, `words_per_row` words per canvas row (bit `x % 64` of
    /// word `x / 64` is column `x`).
    bits: Vec<u64>,
    words_per_row: usize,
    /// Texels occupied in all (footprints never overlap, so each is counted once).
    occupied_texels: i64,
    /// Whether [`Self::find`] scores candidates (the default) or takes the plain first fit
    /// ([`Self::first_fit_only`]).
    scored: bool,
}

/// Scratch buffers of [`Occupancy::scan_row`]: the positions that fit every chart row so far,
/// and one chart row's eroded free bits.
#[derive(Debug, Default)]
struct ScanBuffers {
    fit: Vec<u64>,
    window: Vec<u64>,
}

impl Occupancy {
    /// An empty canvas of `width × height` texels.
    pub fn new(width: i32, height: i32) -> Self {
        let words_per_row = (width.max(1) as usize).div_ceil(64);
        Self {
            rows: vec![Row::empty(); height as usize],
            bits: vec![0; words_per_row * height as usize],
            words_per_row,
            occupied_texels: 0,
            scored: true,
        }
    }

    /// The same map, whose [`Self::find`] takes the plain first fit of the per-row extents of
    /// `D` (the least `(y + height, x, orientation)`, no contact score, no exact runs of `D`):
    /// the search before the contact score, kept for packings of few charts
    /// ([`super::HOLE_SCORED_MIN_CHARTS`]).
    pub fn first_fit_only(mut self) -> Self {
        self.scored = false;
        self
    }

    /// Marks texels `x0..=x1` of row `y` occupied (inside the canvas, `x0 <= x1`).
    pub fn occupy(&mut self, y: i32, x0: i32, x1: i32) {
        self.occupied_texels += i64::from(x1 - x0) + 1;
        self.rows[y as usize].occupy(x0, x1);
        let row = &mut self.bits[y as usize * self.words_per_row..][..self.words_per_row];
        let (x0, x1) = (x0 as usize, x1 as usize);
        for (k, w) in row.iter_mut().enumerate().take(x1 / 64 + 1).skip(x0 / 64) {
            let lo = if k == x0 / 64 { x0 % 64 } else { 0 };
            let hi = if k == x1 / 64 { x1 % 64 } else { 63 };
            *w |= (u64::MAX >> (63 - hi)) & (u64::MAX << lo);
        }
    }

    /// `words` × 64 bits of the *free* texels of row `y` from column `x` on (bit `j` of the
    /// string: column `x + j`), appended to `out`; columns outside the canvas count as occupied.
    fn free_words(&self, y: usize, x: i64, words: usize, out: &mut Vec<u64>) {
        let row = &self.bits[y * self.words_per_row..][..self.words_per_row];
        let word = |k: i64| -> u64 {
            if k < 0 || k as usize >= row.len() {
                0
            } else {
                !row[k as usize]
            }
        };
        let (k0, o) = (x.div_euclid(64), x.rem_euclid(64) as u32);
        if o == 0 {
            out.extend((0..words as i64).map(|k| word(k0 + k)));
        } else {
            let mut low = word(k0);
            for k in 1..=words as i64 {
                let high = word(k0 + k);
                out.push((low >> o) | (high << (64 - o)));
                low = high;
            }
        }
    }

    /// The best position inside `bbox` (`[x0, y0, x1, y1)`, canvas texels) for one of the
    /// `usable` orientations (module doc: the candidates near the highest first fit, the best
    /// contact score wins), or `None` when no orientation fits in the box. Does not modify the
    /// map.
    ///
    /// The orientations are searched in parallel (rayon). Let `E` be the least grid end
    /// (`y + height`) of any orientation's first fit. Each orientation collects its candidates
    /// (both ends of every run of fitting positions of a canvas row) on the rows whose grid
    /// ends at most [`CANDIDATE_ROWS`] after `E`; a shared bound, the least end found so far by
    /// any orientation (never below `E`), lets each search stop early, and only the
    /// candidates within [`CANDIDATE_ROWS`] of `E` itself are kept, which every search has
    /// collected whatever the bound was when it stopped. The winner is the highest
    /// `Self::contact` score, ties to the least `(y + height, x, orientation)`: the same
    /// placement whatever the thread count and the order the searches run in.
    pub fn find(
        &self,
        bbox: [i32; 4],
        orientations: &[Orientation],
        usable: &[bool],
    ) -> Option<Placement> {
        use rayon::prelude::*;
        use std::sync::atomic::AtomicI32;
        let [x0, y0, x1, y1] = bbox;
        // The longest free run of every canvas row of the box (the row filter below).
        let gaps: Vec<i32> = (y0..y1)
            .map(|y| self.rows[y as usize].max_gap(x0, x1))
            .collect();
        let window = if self.scored { CANDIDATE_ROWS } else { 0 };
        // The least grid end of a first fit found so far; `i32::MAX` while there is none.
        let bound = AtomicI32::new(i32::MAX);
        // The runs of `D` and the candidates `(end, x)` of every orientation.
        let searched: Vec<Searched> = (0..orientations.len())
            .into_par_iter()
            .filter(|&k| usable[k])
            .filter_map(|k| {
                let o = &orientations[k];
                let rows = if self.scored {
                    d_rows(o)
                } else {
                    o.dilated.as_ref().map(hull_rows)
                }?;
                let cands = self.candidates(bbox, o, &rows, &gaps, window, &bound);
                (!cands.is_empty()).then_some((k, rows, cands))
            })
            .collect();
        let first_end = searched
            .iter()
            .flat_map(|(_, _, c)| c.iter().map(|c| c.0))
            .min()?;
        // (end, x, orientation, contact) of the candidates within `window` rows of the first
        // fit (only they are scored: the contact of the others is never computed).
        let found: Vec<(i32, i32, usize, i64)> = searched
            .par_iter()
            .flat_map_iter(|(k, rows, cands)| {
                let k = *k;
                let near = cands.iter().filter(|c| c.0 <= first_end + window);
                if !self.scored {
                    return near.map(|&(end, x)| (end, x, k, 0)).collect::<Vec<_>>();
                }
                let near: Vec<(i32, i32)> = near.copied().collect();
                if near.is_empty() {
                    return Vec::new();
                }
                let h = orientations[k].height_texels as i32;
                let ring = RingBits::new(&ring_runs(rows, h));
                near.into_iter()
                    .map(|(end, x)| (end, x, k, self.contact_bits(bbox, &ring, x, end - h)))
                    .collect()
            })
            .collect();
        // Score: 2 · contact − rows below the highest first fit (see the module doc).
        let score = |c: &(i32, i32, usize, i64)| 2 * c.3 - i64::from(c.0 - first_end);
        let best = found.iter().min_by(|a, b| {
            score(b)
                .cmp(&score(a))
                .then((a.0, a.1, a.2).cmp(&(b.0, b.1, b.2)))
        })?;
        Some(Placement {
            orientation: best.2,
            x: best.1,
            y: best.0 - orientations[best.2].height_texels as i32,
        })
    }

    /// Texels of the ring `ring` (runs `(row, first, last)` relative to a grid origin, see
    /// [`ring_runs`]) placed at grid origin `(x, y)` that are occupied or outside `bbox`: how
    /// much of the chart's padded outline touches placed charts or the page edge. The
    /// reference of [`Self::contact_bits`], which the search uses.
    #[cfg(test)]
    fn contact(&self, bbox: [i32; 4], ring: &[(i32, i32, i32)], x: i32, y: i32) -> i64 {
        let [x0, y0, x1, y1] = bbox;
        let mut n = 0i64;
        for &(r, a, b) in ring {
            let cy = y + r;
            let (s, e) = (x + a, x + b);
            if cy < y0 || cy >= y1 {
                n += i64::from(e - s + 1);
                continue;
            }
            let (is, ie) = (s.max(x0), e.min(x1 - 1));
            n += i64::from(e - s + 1 - (ie - is + 1).max(0));
            if is <= ie {
                n += self.count_occupied(cy as usize, is as usize, ie as usize);
            }
        }
        n
    }

    /// Occupied texels of canvas row `y` in columns `s..=e`.
    #[cfg(test)]
    fn count_occupied(&self, y: usize, s: usize, e: usize) -> i64 {
        let row = &self.bits[y * self.words_per_row..][..self.words_per_row];
        let mut n = 0i64;
        for (k, w) in row.iter().enumerate().take(e / 64 + 1).skip(s / 64) {
            let lo = if k == s / 64 { s % 64 } else { 0 };
            let hi = if k == e / 64 { e % 64 } else { 63 };
            let m = (u64::MAX >> (63 - hi)) & (u64::MAX << lo);
            n += i64::from((w & m).count_ones());
        }
        n
    }

    /// [`Self::contact`] of the ring as [`RingBits`], word by word: the same count, with
    /// O(ring rows × ring width / 64) word operations instead of one bit loop per run.
    fn contact_bits(&self, bbox: [i32; 4], ring: &RingBits, x: i32, y: i32) -> i64 {
        let [x0, y0, x1, y1] = bbox;
        let words = ring.words;
        // Bit j of a ring row is column x + ring.left + j; the box keeps bits jlo..=jhi.
        let left = i64::from(x) + i64::from(ring.left);
        let (jlo, jhi) = (i64::from(x0) - left, i64::from(x1) - 1 - left);
        let mut n = 0i64;
        for (q, &(r, count)) in ring.rows.iter().enumerate() {
            let cy = y + r;
            if cy < y0 || cy >= y1 {
                n += i64::from(count);
                continue;
            }
            let bits = &ring.bits[q * words..][..words];
            let row = &self.bits[cy as usize * self.words_per_row..][..self.words_per_row];
            let word = |k: i64| -> u64 {
                if k < 0 || k as usize >= row.len() {
                    0
                } else {
                    row[k as usize]
                }
            };
            let whole = jlo <= 0 && jhi >= 64 * words as i64 - 1;
            for (k, &rw) in bits.iter().enumerate() {
                if rw == 0 {
                    continue;
                }
                // 64 canvas texels from column left + 64k.
                let c = left + 64 * k as i64;
                let (kc, o) = (c.div_euclid(64), c.rem_euclid(64) as u32);
                let canvas = if o == 0 {
                    word(kc)
                } else {
                    (word(kc) >> o) | (word(kc + 1) << (64 - o))
                };
                if whole {
                    n += i64::from((rw & canvas).count_ones());
                } else {
                    let (a, b) = (jlo - 64 * k as i64, jhi - 64 * k as i64);
                    let inside = if a > 63 || b < 0 || a > b {
                        0
                    } else {
                        let (a, b) = (a.max(0) as u32, b.min(63) as u32);
                        (u64::MAX >> (63 - b)) & (u64::MAX << a)
                    };
                    n += i64::from((rw & !inside).count_ones())
                        + i64::from((rw & inside & canvas).count_ones());
                }
            }
        }
        n
    }

    /// The candidates of one orientation in `bbox`, as `(y + height, x)`: both ends of every
    /// run of fitting positions (of the runs `rows` of `D`) of each canvas row, from its first
    /// fit down to the rows whose grid ends `window` rows after the least of its own first
    /// fit's end and `bound` (the least end found by any orientation so far, read again
    /// before each canvas row; lowered to its own first fit's end when it finds it). Empty
    /// when it does not fit or its first fit ends more than `window` rows after `bound`.
    fn candidates(
        &self,
        bbox: [i32; 4],
        o: &Orientation,
        rows: &[(i32, i32, i32)],
        gaps: &[i32],
        window: i32,
        bound: &std::sync::atomic::AtomicI32,
    ) -> Vec<(i32, i32)> {
        use std::sync::atomic::Ordering;
        let publish = |end: i32| {
            bound.fetch_min(end, Ordering::Relaxed);
        };
        let bound = || bound.load(Ordering::Relaxed);
        let mut out = Vec::new();
        let [x0, y0, x1, y1] = bbox;
        let (w, h) = (o.width_texels as i32, o.height_texels as i32);
        if w > x1 - x0 || h > y1 - y0 || rows.is_empty() {
            return out;
        }
        // Exact pruning: every placed `F` lies inside the box, so the box has
        // `box area − occupied` free texels, and the runs of `D` need that many at least.
        let needed_texels: i64 = rows.iter().map(|&(_, a, b)| i64::from(b - a) + 1).sum();
        let free_texels = i64::from(x1 - x0) * i64::from(y1 - y0) - self.occupied_texels;
        if needed_texels > free_texels {
            return out;
        }
        // Longest run first (ties: first run): it rejects most canvas rows. The others spread
        // out (bit-reversed order of their row): far-apart rows are less alike than
        // neighbours, so the positions left die sooner. (The order only decides how soon a
        // canvas row is rejected, never whether.)
        let key = (0..rows.len())
            .max_by_key(|&i| (rows[i].2 - rows[i].1, std::cmp::Reverse(i)))
            .unwrap_or(0);
        let rows = spread_out(rows, key);
        let mut buffers = ScanBuffers::default();
        let (x_lo, x_hi) = (x0, x1 - w);
        let mut own_end: Option<i32> = None;
        'rows: for y in y0..=y1 - h {
            let limit = own_end.map_or(bound(), |e| e.min(bound()));
            if limit != i32::MAX && y + h > limit + window {
                break;
            }
            for &(r, a, b) in &rows {
                if gaps[(y - y0 + r) as usize] < b - a + 1 {
                    continue 'rows;
                }
            }
            let Some(x) = self.scan_row(y, x_lo, x_hi, &rows, &mut buffers) else {
                continue;
            };
            if own_end.is_none() {
                own_end = Some(y + h);
                publish(y + h);
            }
            // Every run of fitting positions (bits of `fit`, position `x_lo + j`): both ends.
            let fit = &buffers.fit;
            let bit = |j: usize| (fit[j / 64] >> (j % 64)) & 1 == 1;
            let n = (x_hi - x_lo + 1) as usize;
            let mut j = (x - x_lo) as usize;
            while j < n {
                if bit(j) {
                    let start = j;
                    while j + 1 < n && bit(j + 1) {
                        j += 1;
                    }
                    out.push((y + h, x_lo + start as i32));
                    if j > start {
                        out.push((y + h, x_lo + j as i32));
                    }
                }
                j += 1;
            }
        }
        out
    }

    /// The smallest `x` in `x_lo..=x_hi` where every chart row `(r, a, b)` finds canvas row
    /// `y + r` free in `x + a ..= x + b`, bit-parallel: `fit` holds one bit per position
    /// (`x_lo + j`), and each chart row keeps only the positions where its span lies inside
    /// one free run `[s, e]` of its canvas row (the positions `s - a ..= e - b`, from the
    /// sorted free runs of [`Row`]: the free bits eroded by the span's length, without
    /// touching the occupied bits). Only the words between the first and the last position
    /// still possible are worked on, and the scan stops when none is left. Cost per chart
    /// row: O(words still possible + free runs of its canvas row met by them) word operations.
    fn scan_row(
        &self,
        y: i32,
        x_lo: i32,
        x_hi: i32,
        rows: &[(i32, i32, i32)],
        buffers: &mut ScanBuffers,
    ) -> Option<i32> {
        if x_hi < x_lo {
            return None;
        }
        let positions = (x_hi - x_lo + 1) as usize;
        let ScanBuffers { fit, window } = buffers;
        fit.clear();
        fit.resize(positions.div_ceil(64), u64::MAX);
        if positions % 64 != 0 {
            *fit.last_mut().expect("at least one position") = (1u64 << (positions % 64)) - 1;
        }
        // Columns past the bitmap's words count as occupied (and before column 0).
        let canvas_end = (64 * self.words_per_row) as i64 - 1;
        let (mut first, mut last) = (0usize, fit.len() - 1);
        for &(r, a, b) in rows {
            let span = i64::from(b - a);
            // Position j reads columns base + j ..= base + j + span.
            let base = i64::from(x_lo) + i64::from(a);
            let (j_lo, j_hi) = (64 * first as i64, 64 * last as i64 + 63);
            let row = &self.rows[(y + r) as usize];
            let out_words = last - first + 1;
            let len = (b - a + 1) as usize;
            // Two exact ways to the same bits; the cheaper by its word operations: the free runs
            // met (few on most rows), or the free bits eroded by the span's length by log-step
            // shifts (rows cut into many short runs, as on pages of thousands of charts).
            let met = row.free_runs_met(base + j_lo, base + j_hi + span);
            let shift_words = (out_words + (len - 1).div_ceil(64) + 1)
                * (usize::BITS - len.leading_zeros()) as usize;
            if 4 * met > shift_words {
                let start = base + j_lo;
                let words = out_words + (len - 1).div_ceil(64) + 1;
                window.clear();
                self.free_words((y + r) as usize, start, words, window);
                let mut done = 1usize;
                while done < len {
                    let shift = done.min(len - done);
                    shift_and(window, shift);
                    done += shift;
                }
                for (f, w) in fit[first..=last].iter_mut().zip(window.iter()) {
                    *f &= *w;
                }
                while first <= last && fit[first] == 0 {
                    first += 1;
                }
                if first > last {
                    return None;
                }
                while fit[last] == 0 {
                    last -= 1;
                }
                continue;
            }
            window.clear();
            window.resize(out_words, 0);
            let mut any = false;
            row.free_runs(base + j_lo, base + j_hi + span, canvas_end, |s, e| {
                let (p, q) = ((s - base).max(j_lo), (e - span - base).min(j_hi));
                if p <= q {
                    set_bits(window, (p - j_lo) as usize, (q - j_lo) as usize);
                    any = true;
                }
            });
            if !any {
                return None;
            }
            for (f, w) in fit[first..=last].iter_mut().zip(window.iter()) {
                *f &= *w;
            }
            while first <= last && fit[first] == 0 {
                first += 1;
            }
            if first > last {
                return None;
            }
            while fit[last] == 0 {
                last -= 1;
            }
        }
        let j = 64 * first + fit[first].trailing_zeros() as usize;
        Some(x_lo + j as i32)
    }
}

/// Sets bits `p..=q` of a little-endian multi-word bit string.
fn set_bits(v: &mut [u64], p: usize, q: usize) {
    for (k, w) in v.iter_mut().enumerate().take(q / 64 + 1).skip(p / 64) {
        let lo = if k == p / 64 { p % 64 } else { 0 };
        let hi = if k == q / 64 { q % 64 } else { 63 };
        *w |= (u64::MAX >> (63 - hi)) & (u64::MAX << lo);
    }
}

/// The runs `rows` (rows `>= 0`) in the order of the search of [`Occupancy::candidates`]:
/// run `key` first, then the others by the bit-reversed index of their row, in their order
/// within a row. A counting sort: O(runs + rows).
fn spread_out(rows: &[(i32, i32, i32)], key: usize) -> Vec<(i32, i32, i32)> {
    let mut out = Vec::with_capacity(rows.len());
    let Some(&first) = rows.get(key) else {
        return out;
    };
    out.push(first);
    let h = rows.iter().map(|t| t.0.max(0) as usize).max().unwrap_or(0) + 1;
    // Runs grouped by row, in their order: `by_row[start[r]..start[r + 1]]`.
    let mut start = vec![0usize; h + 1];
    for (i, t) in rows.iter().enumerate() {
        if i != key {
            start[t.0.max(0) as usize + 1] += 1;
        }
    }
    for r in 0..h {
        start[r + 1] += start[r];
    }
    let mut next = start.clone();
    let mut by_row = vec![(0, 0, 0); rows.len() - 1];
    for (i, &t) in rows.iter().enumerate() {
        if i != key {
            let r = t.0.max(0) as usize;
            by_row[next[r]] = t;
            next[r] += 1;
        }
    }
    // Rows `0..h` in bit-reversed order: `i` over `0..2^bits`, row = `i` reversed in `bits`.
    let bits = usize::BITS - (h - 1).leading_zeros();
    for i in 0..1usize << bits {
        let r = if bits == 0 {
            0
        } else {
            i.reverse_bits() >> (usize::BITS - bits)
        };
        if r < h {
            out.extend_from_slice(&by_row[start[r]..start[r + 1]]);
        }
    }
    out
}

/// Runs `(row, first, last)` of a set of texels relative to a grid origin.
type Runs = Vec<(i32, i32, i32)>;

/// One orientation's search: its index, the runs of its `D` and its candidates `(end, x)`.
type Searched = (usize, Runs, Vec<(i32, i32)>);

/// How many canvas rows below the highest first fit ([`Occupancy::find`]) candidates are
/// still scored. Trade-off: fewer rows miss better-touching positions, more rows cost time
/// without packing tighter.
pub const CANDIDATE_ROWS: i32 = 16;

/// The rows of `D` as runs `(row, first, last)`, row by row, left to right (exact: the
/// texels of `D` themselves; the per-row extents only when `D`'s bits are missing).
fn d_rows(o: &Orientation) -> Option<Vec<(i32, i32, i32)>> {
    let d = o.dilated.as_ref()?;
    Some(match &o.dilated_bits {
        Some(bits) => {
            let mut v = Vec::new();
            bits.for_each_run(|r, a, b| v.push((r as i32, a as i32, b as i32)));
            v
        }
        None => hull_rows(d),
    })
}

/// The per-row extents of `D` as runs `(row, first, last)` (a superset of its texels).
fn hull_rows(d: &super::place::Extents) -> Vec<(i32, i32, i32)> {
    d.rows
        .iter()
        .enumerate()
        .filter(|(_, &e)| e != EMPTY)
        .map(|(r, &(a, b))| (r as i32, a, b))
        .collect()
}

/// A ring (runs `(row, first, last)` relative to a grid origin, see [`ring_runs`]) as one bit
/// string per row that has texels: bit `j` of a row is column `left + j`.
#[derive(Debug, Clone)]
struct RingBits {
    /// Least column of any run.
    left: i32,
    /// Words per row.
    words: usize,
    /// `(row, texels)` of each row, in the order of `bits`.
    rows: Vec<(i32, u32)>,
    bits: Vec<u64>,
}

impl RingBits {
    /// The ring of disjoint runs `ring` (as [`ring_runs`] returns them).
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
/// column) of a set `h` rows tall: `(row, first, last)`, rows `-1..=h`.
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

/// `v &= v >> shift` over a little-endian multi-word bit string (bit `j` of the result: bits
/// `j` and `j + shift` of `v`; bits past the end count as clear). In place, low words first
/// (each reads only words at or above its own, not yet written).
fn shift_and(v: &mut [u64], shift: usize) {
    let (ws, bs) = (shift / 64, (shift % 64) as u32);
    let n = v.len();
    if ws >= n {
        v.fill(0);
        return;
    }
    // Words whose sources are all inside `v`, then the tail.
    let inner = n - ws - 1;
    if bs == 0 {
        for k in 0..n - ws {
            v[k] &= v[k + ws];
        }
    } else {
        for k in 0..inner {
            v[k] &= (v[k + ws] >> bs) | (v[k + ws + 1] << (64 - bs));
        }
        v[inner] &= v[n - 1] >> bs;
    }
    v[n - ws..].fill(0);
}

#[cfg(test)]
mod tests;
