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
//! Model. [`Occupancy`] keeps, per canvas row, the first and last occupied column with the
//! sorted free runs in between (their longest, for the row filter, and apart those at least
//! `LONG_RUNS` texels long, which long chart runs search), and the placed `F` as a bitmap
//! (for the contact score). What the rows hold depends on the search:
//! - **Scored** (the default): the union of the placed `D` (each `F` grown by the padding,
//!   the *keep-out zones*), tested by the runs of the new chart's `F` (exact: the texels of
//!   `F` row by row, so that a concave chart can wrap around placed ones). `F` meets no placed
//!   `D` exactly when the new `D` meets no placed `F` (Chebyshev distance is symmetric, and
//!   `D` is `F` grown by the padding, never cut by its grid, see `place::orientation`). The
//!   keep-out zones close the thin gaps between placed charts, so rows hold far fewer and
//!   shorter free runs than the placed `F` leave.
//! - **Plain first fit** ([`Occupancy::first_fit_only`]): the placed `F`, tested by the per-row
//!   extents of the new chart's `D` (a superset of its texels).
//!
//! At grid origin `(x, y)` a chart fits when, for every run `[a, b]` of its row `r`, the
//! canvas texels `x + a ..= x + b` of row `y + r` are free, and the grid lies inside the box.
//! Exact on the texel grid: then every `F` keeps `padding` empty texels (Chebyshev) from
//! every other `F`; and the box lies within the page.
//!
//! Search: per orientation, rows of the box top to bottom, every position of a row at once.
//! Let `E` be the least grid end (`y + height`) of any orientation's first fit; the
//! candidates are both ends of every run of fitting positions on the rows whose grid ends at
//! most [`CANDIDATE_ROWS`] after `E`, and the winner has the highest score `2 · contact −
//! (y + height − E)`, where the contact counts the texels at distance 1 outside `D` that are
//! occupied or outside the box (the ring of `RingBits::around`: where the chart's padded outline
//! touches placed charts or the page edge); ties by `(y + height, x, orientation)`. Best fit
//! by contact, near the top: small charts go to the gaps they fill snugly and leave the wide
//! ones to charts that need them. Deterministic, and exhaustive (every position of the
//! searched rows is decided). [`Occupancy::first_fit_only`] is the plain first fit: the least
//! `(y + height, x, orientation)`. A canvas row is skipped at once when one of the chart's
//! first [`FILTER_ROWS`] rows (in the search order below) has a run longer than the longest
//! free run of its canvas row, or when the canvas row that rejected the last one does so again
//! for the chart row now on it. The runs of `F` of an orientation half a turn from another are
//! that one's turned, and the runs of `D` are made only for the orientations whose candidates
//! are scored. Along a row the fitting positions are kept as
//! sorted intervals: each run `[a, b]` of the chart (the longest first, then the others
//! spread out) keeps only the positions where it lies inside one free run `[s, e]` of its
//! canvas row at least as long — the positions `s − a ..= e − b` — until none is left or
//! every run is done.
//! The orientations are searched in parallel (each worker a share of them, going down the
//! box together [`SCAN_BLOCK_ROWS`] rows at a time, so that a first fit stops the others soon
//! after it), sharing the least first-fit end found so far as a bound (never below `E`, so
//! every search still collects every candidate within [`CANDIDATE_ROWS`] of `E`): the same
//! placement whatever the thread count. Only the
//! candidates within [`CANDIDATE_ROWS`] of `E` are scored (their contact counted), once `E`
//! is known.
//!
//! Units: texels (`i32` canvas coordinates).
//!
//! Cost per orientation: O(box rows × [`FILTER_ROWS`]) for the row filter at worst, plus
//! per surviving row O(intervals left × log free runs + long enough free runs met) per chart
//! run, for the rows down to its first fit and [`CANDIDATE_ROWS`] more (the row stops when no
//! position is left); per candidate O(ring runs × run length / 64); per commit, O(runs of
//! `D` × free runs of the rows it covers + texels of `F` / 64). Trade-off: the
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
    /// The runs of `inner` at least [`LONG_RUNS`]`[k]` long, for each `k`, in order: a chart
    /// row that long skips the shorter free runs of the row at once.
    long: [Vec<(i32, i32)>; 2],
}

/// The lengths from which [`Row::long`] keeps a free run. Trade-off: each level costs a copy
/// of the row's long runs per change of the row; rows of pages with thousands of charts hold
/// hundreds of free runs, most of them a few texels long.
const LONG_RUNS: [i32; 2] = [8, 32];

impl Row {
    fn empty() -> Self {
        Self {
            first: i32::MAX,
            last: i32::MIN,
            inner: Vec::new(),
            inner_max: 0,
            long: [Vec::new(), Vec::new()],
        }
    }

    /// Marks columns `s..=e` occupied (some may be already); returns how many were free.
    fn occupy(&mut self, s: i32, e: i32) -> i64 {
        if self.first > self.last {
            self.first = s;
            self.last = e;
            return i64::from(e - s) + 1;
        }
        // Free before: the columns outside the span, and the inner runs met.
        let overlap = |a: i32, b: i32| i64::from((b.min(e) - a.max(s) + 1).max(0));
        let mut newly = overlap(i32::MIN, self.first - 1) + overlap(self.last + 1, i32::MAX);
        let lo = self.inner.partition_point(|g| g.1 < s);
        newly += self.inner[lo..]
            .iter()
            .take_while(|g| g.0 <= e)
            .map(|g| overlap(g.0, g.1))
            .sum::<i64>();
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
        for (list, &min) in self.long.iter_mut().zip(&LONG_RUNS) {
            list.clear();
            list.extend(self.inner.iter().filter(|g| g.1 - g.0 + 1 >= min));
        }
        newly
    }

    /// The positions `x` among `cands` (sorted, disjoint, inclusive intervals) at which the
    /// columns `x + a ..= x + b` are free in this row, as sorted disjoint intervals appended
    /// to `out`: for every free run `[s, e]` of the columns `0..=end` (`end` at or past the
    /// last occupied column) at least `b − a + 1` long, the positions `s − a ..= e − b`, cut to
    /// `cands`. Cost: O(cands × log runs + long enough runs met), the runs taken from the
    /// shortest list of [`Self::long`] that holds every run long enough.
    fn fitting_positions(
        &self,
        a: i32,
        b: i32,
        end: i32,
        cands: &[(i32, i32)],
        out: &mut Vec<(i32, i32)>,
    ) {
        let len = b - a + 1;
        let mut emit = |s: i32, e: i32, p: i32, q: i32| {
            let (lo, hi) = ((s - a).max(p), (e - b).min(q));
            if lo <= hi {
                out.push((lo, hi));
            }
        };
        if self.first > self.last {
            for &(p, q) in cands {
                emit(0, end, p, q);
            }
            return;
        }
        let list: &[(i32, i32)] = match LONG_RUNS.iter().rposition(|&m| m <= len) {
            Some(k) => &self.long[k],
            None => &self.inner,
        };
        let use_inner = len <= self.inner_max;
        let mut k = 0;
        for &(p, q) in cands {
            // Runs [s, e] whose positions meet p..=q: s ≤ q + a and e ≥ p + b.
            if self.first >= len {
                emit(0, self.first - 1, p, q);
            }
            if use_inner {
                // The first run from k on ending at or after p + b: galloping (it is usually
                // near k), then bisection.
                let target = p + b;
                let (mut lo, mut hi, mut step) = (k, k, 1);
                while hi < list.len() && list[hi].1 < target {
                    lo = hi + 1;
                    hi += step;
                    step *= 2;
                }
                let hi = hi.min(list.len());
                k = lo + list[lo..hi].partition_point(|g| g.1 < target);
                for &(s, e) in &list[k..] {
                    if s > q + a {
                        break;
                    }
                    if e - s + 1 >= len {
                        emit(s, e, p, q);
                    }
                }
            }
            if end - self.last >= len {
                emit(self.last + 1, end, p, q);
            }
        }
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

/// The placed charts of one page: per canvas row, the texels that the searched runs must
/// avoid (the placed footprints `F`, or with the contact score their keep-out zones `D`), and
/// the placed `F` as a bitmap (the contact score).
#[derive(Debug, Clone)]
pub struct Occupancy {
    /// The placed `F` ([`Self::first_fit_only`]: searched with the runs of the new chart's
    /// `D`), or the union of the placed `D` (scored: searched with the runs of its `F`).
    rows: Vec<Row>,
    /// The placed `F` as a bitmap, `words_per_row` words per canvas row (bit `x % 64` of
    /// word `x / 64` is column `x`).
    bits: Vec<u64>,
    words_per_row: usize,
    /// Texels occupied in `rows` in all (each counted once).
    occupied_texels: i64,
    /// Whether [`Self::find`] scores candidates (the default) or takes the plain first fit
    /// ([`Self::first_fit_only`]).
    scored: bool,
}

/// One orientation's search in a box ([`Occupancy::scan_start`], [`Occupancy::scan_rows`]).
#[derive(Debug)]
struct Scan {
    /// The chart's runs `(row, first, last)`, in the order they are tested.
    rows: Vec<(i32, i32, i32)>,
    /// The row filter of [`Occupancy::scan_rows`]: the first [`FILTER_ROWS`] chart rows in the
    /// order of `rows` (the key run's row first), each once, with the length of its longest run.
    filter: Vec<(i32, i32)>,
    /// The length of the longest run of each chart row (0 for a row without runs).
    longest: Vec<i32>,
    /// The box row (from the box's top) whose longest free run last rejected a canvas row, or
    /// -1: the next canvas rows test it first.
    blocked: i32,
    /// Grid height, texels.
    height: i32,
    /// The grid origins' columns that keep the grid in the box.
    x_range: (i32, i32),
    /// The next grid row to test.
    y: i32,
    /// The grid end of its first fit, once found.
    own_end: Option<i32>,
    /// Its candidates `(y + height, x)`.
    out: Vec<(i32, i32)>,
    buffers: ScanBuffers,
    /// Whether its search is over.
    done: bool,
}

/// Rows each orientation's search goes down before the next orientation's takes its turn
/// ([`Occupancy::find`]). Trade-off: fewer rows let a first fit bound the other orientations
/// sooner (each searches at most this many rows more than it needs), more rows cost fewer
/// switches between the searches.
pub const SCAN_BLOCK_ROWS: i32 = 8;

/// Chart rows the row filter of [`Occupancy::find`] tests before the exact test of a canvas
/// row (which rejects the same canvas rows, and more). Trade-off: a canvas row that a chart's
/// key row lets through mostly passes every other row of the filter too, which then costs one
/// test per chart row for nothing; a short filter still rejects most of the canvas rows that
/// the whole filter rejects. Measured (callgrind, one thread, cakeBirthday's whole command):
/// every row 8.45G instructions, 8 rows 7.99G; a build reading the count at run time gave 4,
/// 12 and 32 rows 8.02G, 8.02G and 8.06G.
pub const FILTER_ROWS: usize = 8;

/// Scratch buffers of [`Occupancy::scan_row`]: the positions that fit every chart row so far
/// (sorted, disjoint, inclusive intervals), and those that also fit the next chart row.
#[derive(Debug, Default)]
struct ScanBuffers {
    fit: Vec<(i32, i32)>,
    next: Vec<(i32, i32)>,
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

    /// Whether the placed charts' keep-out zones are marked too ([`Self::keep_out`]): the
    /// scored search tests the runs of a chart's `F` against them.
    pub fn keeps_out(&self) -> bool {
        self.scored
    }

    /// Marks texels `x0..=x1` of row `y` as part of a placed keep-out zone `D` (with
    /// [`Self::keeps_out`]; inside the canvas, `x0 <= x1`; zones may overlap). A texel where
    /// no new `F` may go: within `padding` (Chebyshev) of a placed `F`.
    pub fn keep_out(&mut self, y: i32, x0: i32, x1: i32) {
        self.occupied_texels += self.rows[y as usize].occupy(x0, x1);
    }

    /// Marks texels `x0..=x1` of row `y` as part of a placed footprint `F` (inside the canvas,
    /// `x0 <= x1`, not marked before).
    pub fn occupy(&mut self, y: i32, x0: i32, x1: i32) {
        if !self.scored {
            self.occupied_texels += self.rows[y as usize].occupy(x0, x1);
        }
        let row = &mut self.bits[y as usize * self.words_per_row..][..self.words_per_row];
        let (x0, x1) = (x0 as usize, x1 as usize);
        for (k, w) in row.iter_mut().enumerate().take(x1 / 64 + 1).skip(x0 / 64) {
            let lo = if k == x0 / 64 { x0 % 64 } else { 0 };
            let hi = if k == x1 / 64 { x1 % 64 } else { 63 };
            *w |= (u64::MAX >> (63 - hi)) & (u64::MAX << lo);
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
        // The runs of `D` and the candidates `(end, x)` of every orientation: scored, the runs
        // of `F` against the placed keep-out zones (`F` meets no placed `D` exactly when `D`,
        // which is `F` grown by the padding, meets no placed `F`); else the extents of `D`
        // against the placed `F`.
        // Scored, the runs of `D` are made only for the orientations whose candidates are
        // scored (most orientations have none near the first fit).
        let n = orientations.len();
        let f_runs = if self.scored {
            f_rows_of(orientations, usable)
        } else {
            Vec::new()
        };
        let mut scans: Vec<(usize, Scan)> = (0..n)
            .into_par_iter()
            .filter(|&k| usable[k])
            .filter_map(|k| {
                let o = &orientations[k];
                let scan = if self.scored {
                    o.dilated.as_ref()?;
                    self.scan_start(bbox, o, f_runs[k].as_ref()?)?
                } else {
                    let rows = o.dilated.as_ref().map(hull_rows)?;
                    self.scan_start(bbox, o, &rows)?
                };
                Some((k, scan))
            })
            .collect();
        // The orientations go down the box together, [`SCAN_BLOCK_ROWS`] rows at a time (each
        // worker a share of them), so that the first fit any of them finds bounds the others
        // before they search far below it.
        let share = scans
            .len()
            .div_ceil(rayon::current_num_threads().max(1))
            .max(1);
        scans.par_chunks_mut(share).for_each(|part| {
            let mut until = y0;
            while part.iter().any(|s| !s.1.done) {
                until += SCAN_BLOCK_ROWS;
                for (_, scan) in part.iter_mut().filter(|s| !s.1.done) {
                    self.scan_rows(scan, until, bbox, &gaps, window, &bound);
                }
            }
        });
        let searched: Vec<Searched> = scans
            .into_iter()
            .filter(|s| !s.1.out.is_empty())
            .map(|(k, scan)| (k, scan.out))
            .collect();
        let first_end = searched
            .iter()
            .flat_map(|(_, c)| c.iter().map(|c| c.0))
            .min()?;
        // (end, x, orientation, contact) of the candidates within `window` rows of the first
        // fit (only they are scored: the contact of the others is never computed).
        let found: Vec<(i32, i32, usize, i64)> = searched
            .par_iter()
            .flat_map_iter(|(k, cands)| {
                let k = *k;
                let near = cands.iter().filter(|c| c.0 <= first_end + window);
                if !self.scored {
                    return near.map(|&(end, x)| (end, x, k, 0)).collect::<Vec<_>>();
                }
                let near: Vec<(i32, i32)> = near.copied().collect();
                if near.is_empty() {
                    return Vec::new();
                }
                let o = &orientations[k];
                let Some(rows) = d_rows(o) else {
                    return Vec::new();
                };
                let h = o.height_texels as i32;
                let ring = RingBits::around(&rows);
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
    /// `tests::ring_runs`) placed at grid origin `(x, y)` that are occupied or outside
    /// `bbox`: how much of the chart's padded outline touches placed charts or the page edge.
    /// The reference of [`Self::contact_bits`], which the search uses.
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

    /// The search of one orientation in `bbox` with the chart runs `rows`, before its first
    /// canvas row, or `None` when it cannot fit: its grid is larger than the box, or the runs
    /// need more texels than the box has free (exact: every occupied texel lies inside the
    /// box, inside a placed grid).
    fn scan_start(
        &self,
        bbox: [i32; 4],
        o: &Orientation,
        rows: &[(i32, i32, i32)],
    ) -> Option<Scan> {
        let [x0, y0, x1, y1] = bbox;
        let (w, h) = (o.width_texels as i32, o.height_texels as i32);
        if w > x1 - x0 || h > y1 - y0 || rows.is_empty() {
            return None;
        }
        let needed_texels: i64 = rows.iter().map(|&(_, a, b)| i64::from(b - a) + 1).sum();
        let free_texels = i64::from(x1 - x0) * i64::from(y1 - y0) - self.occupied_texels;
        if needed_texels > free_texels {
            return None;
        }
        // Longest run first (ties: first run): it rejects most canvas rows. The others spread
        // out (bit-reversed order of their row): far-apart rows are less alike than
        // neighbours, so the positions left die sooner. (The order only decides how soon a
        // canvas row is rejected, never whether.)
        let key = (0..rows.len())
            .max_by_key(|&i| (rows[i].2 - rows[i].1, std::cmp::Reverse(i)))
            .unwrap_or(0);
        let rows = spread_out(rows, key);
        let mut longest = vec![0i32; h.max(0) as usize];
        for &(r, a, b) in &rows {
            if let Some(l) = longest.get_mut(r as usize) {
                *l = (*l).max(b - a + 1);
            }
        }
        let mut seen = vec![false; longest.len()];
        let filter = rows
            .iter()
            .filter_map(|&(r, _, _)| {
                let k = usize::try_from(r).ok().filter(|&k| k < seen.len())?;
                (!std::mem::replace(&mut seen[k], true)).then_some((r, longest[k]))
            })
            .take(FILTER_ROWS)
            .collect();
        Some(Scan {
            rows,
            filter,
            longest,
            blocked: -1,
            height: h,
            x_range: (x0, x1 - w),
            y: y0,
            own_end: None,
            out: Vec::new(),
            buffers: ScanBuffers::default(),
            done: false,
        })
    }

    /// Goes on with the search `scan` on the canvas rows before `until_y`: collects its
    /// candidates `(y + height, x)`, both ends of every run of fitting positions of each
    /// canvas row, from its first fit down to the rows whose grid ends `window` rows after the
    /// least of its own first fit's end and `bound` (the least end found by any orientation so
    /// far, read again before each canvas row; lowered to its own first fit's end when it
    /// finds it), and marks it done there or at the box's last row. No candidate when it does
    /// not fit or its first fit ends more than `window` rows after `bound`.
    fn scan_rows(
        &self,
        scan: &mut Scan,
        until_y: i32,
        bbox: [i32; 4],
        gaps: &[i32],
        window: i32,
        bound: &std::sync::atomic::AtomicI32,
    ) {
        use std::sync::atomic::Ordering;
        let [_, y0, _, y1] = bbox;
        let h = scan.height;
        let (x_lo, x_hi) = scan.x_range;
        let last = (y1 - h).min(until_y - 1);
        'rows: while scan.y <= last {
            let y = scan.y;
            scan.y += 1;
            let b = bound.load(Ordering::Relaxed);
            let limit = scan.own_end.map_or(b, |e| e.min(b));
            if limit != i32::MAX && y + h > limit + window {
                scan.done = true;
                return;
            }
            // The row filter (exact: a chart row needs a free run as long as its longest run
            // in its canvas row). The box row that rejected the last canvas row first: where a
            // long chart row failed, the rows of the chart above it usually fail there too.
            let top = y - y0;
            if scan.blocked >= 0 {
                let r = scan.blocked - top;
                if r >= 0
                    && (r as usize) < scan.longest.len()
                    && scan.longest[r as usize] > gaps[scan.blocked as usize]
                {
                    continue;
                }
            }
            for &(r, len) in &scan.filter {
                if gaps[(top + r) as usize] < len {
                    scan.blocked = top + r;
                    continue 'rows;
                }
            }
            if self
                .scan_row(y, x_lo, x_hi, &scan.rows, &mut scan.buffers)
                .is_none()
            {
                continue;
            }
            if scan.own_end.is_none() {
                scan.own_end = Some(y + h);
                bound.fetch_min(y + h, Ordering::Relaxed);
            }
            // Every run of fitting positions: both ends.
            for &(p, q) in &scan.buffers.fit {
                scan.out.push((y + h, p));
                if q > p {
                    scan.out.push((y + h, q));
                }
            }
        }
        if scan.y > y1 - h {
            scan.done = true;
        }
    }

    /// The smallest `x` in `x_lo..=x_hi` where every chart row `(r, a, b)` finds canvas row
    /// `y + r` free in `x + a ..= x + b`; every such `x` is left in `buffers.fit` as sorted,
    /// disjoint, maximal intervals. The positions start as `x_lo..=x_hi`, and each chart row
    /// keeps those where its span lies inside one free run `[s, e]` of its canvas row (the
    /// positions `s - a ..= e - b`, from the row's free runs at least as long as the span,
    /// [`Row::fitting_positions`]); the scan stops when none is left. Cost per chart row:
    /// O(intervals left × log free runs + long enough free runs met).
    fn scan_row(
        &self,
        y: i32,
        x_lo: i32,
        x_hi: i32,
        rows: &[(i32, i32, i32)],
        buffers: &mut ScanBuffers,
    ) -> Option<i32> {
        let ScanBuffers { fit, next } = buffers;
        fit.clear();
        if x_hi < x_lo {
            return None;
        }
        fit.push((x_lo, x_hi));
        // Columns past the bitmap's words count as occupied (and before column 0).
        let canvas_end = (64 * self.words_per_row) as i32 - 1;
        for &(r, a, b) in rows {
            next.clear();
            self.rows[(y + r) as usize].fitting_positions(a, b, canvas_end, fit, next);
            std::mem::swap(fit, next);
            if fit.is_empty() {
                return None;
            }
        }
        Some(fit[0].0)
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

/// One orientation's search: its index and its candidates `(end, x)`.
type Searched = (usize, Vec<(i32, i32)>);

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
            let mut v = Vec::with_capacity(o.height_texels.max(0) as usize);
            bits.for_each_run(|r, a, b| v.push((r as i32, a as i32, b as i32)));
            v
        }
        None => hull_rows(d),
    })
}

/// [`f_rows`] of every orientation of `usable` (`None` for the others): an orientation half a
/// turn from another usable one shares its mask, and its runs are that one's turned
/// (`FootprintBits::runs_from_half_turn`), which saves half of the bit scans and of the
/// transposes of the odd quarter turns.
fn f_rows_of(orientations: &[Orientation], usable: &[bool]) -> Vec<Option<Vec<(i32, i32, i32)>>> {
    use rayon::prelude::*;
    let n = orientations.len();
    let bits = |k: usize| orientations[k].footprint_bits.as_ref();
    let partner: Vec<Option<usize>> = (0..n)
        .map(|k| {
            let own = bits(k).filter(|_| usable[k])?;
            (0..n).find(|&j| usable[j] && bits(j).is_some_and(|b| own.is_half_turn_of(b)))
        })
        .collect();
    let direct: Vec<Option<Vec<(i32, i32, i32)>>> = (0..n)
        .into_par_iter()
        .map(|k| {
            (usable[k] && partner[k].is_none())
                .then(|| f_rows(&orientations[k]))
                .flatten()
        })
        .collect();
    let turned: Vec<Option<Vec<(i32, i32, i32)>>> = (0..n)
        .into_par_iter()
        .map(|k| Some(bits(k)?.runs_from_half_turn(direct[partner[k]?].as_ref()?)))
        .collect();
    direct
        .into_iter()
        .zip(turned)
        .zip(&partner)
        .map(|((own, turned), p)| if p.is_some() { turned } else { own })
        .collect()
}

/// The rows of `F` as runs `(row, first, last)` on the grid of `D`, row by row, left to right
/// (exact: the texels of `F`; `None` when not rasterized).
fn f_rows(o: &Orientation) -> Option<Vec<(i32, i32, i32)>> {
    let bits = o.footprint_bits.as_ref()?;
    let mut v = Vec::with_capacity(o.height_texels.max(0) as usize);
    bits.for_each_run(|r, a, b| v.push((r as i32, a as i32, b as i32)));
    Some(v)
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

/// A ring (the texels at distance 1 outside a set, relative to a grid origin,
/// [`RingBits::around`]) as one bit string per row that has texels: bit `j` of a row is
/// column `left + j`.
#[derive(Debug, Clone)]
struct RingBits {
    /// The column of bit 0.
    left: i32,
    /// Words per row.
    words: usize,
    /// `(row, texels)` of each row, in the order of `bits`.
    rows: Vec<(i32, u32)>,
    bits: Vec<u64>,
}

impl RingBits {
    /// The ring of the set of runs `rows` (`(row, first, last)`, disjoint): the texels at
    /// Chebyshev distance exactly 1 from the set (those of `tests::ring_runs`), made word by
    /// word: each row of the set grown by a column both ways, ORed with the rows above and
    /// below, less the set. Cost: O(runs + rows × words), without the per-row sorts of
    /// `tests::ring_runs`.
    fn around(rows: &[(i32, i32, i32)]) -> Self {
        let (Some(top), Some(bottom)) = (
            rows.iter().map(|t| t.0).min(),
            rows.iter().map(|t| t.0).max(),
        ) else {
            return Self {
                left: 0,
                words: 1,
                rows: Vec::new(),
                bits: Vec::new(),
            };
        };
        // Bit j of a frame row is column `left + j`; frame row q is row `top - 1 + q`.
        let left = rows.iter().map(|t| t.1).min().unwrap_or(0) - 1;
        let right = rows.iter().map(|t| t.2).max().unwrap_or(0) + 1;
        let words = ((right - left + 1) as usize).div_ceil(64);
        let height = (bottom - top + 3) as usize;
        let mut set = vec![0u64; height * words];
        for &(r, a, b) in rows {
            let q = (r - top + 1) as usize;
            set_bits(
                &mut set[q * words..][..words],
                (a - left) as usize,
                (b - left) as usize,
            );
        }
        // Each row grown by a column both ways (bits carried across words).
        let mut grown = vec![0u64; height * words];
        for (g, s) in grown.chunks_mut(words).zip(set.chunks(words)) {
            for k in 0..words {
                let mut v = s[k] | s[k] << 1 | s[k] >> 1;
                if k > 0 {
                    v |= s[k - 1] >> 63;
                }
                if k + 1 < words {
                    v |= s[k + 1] << 63;
                }
                g[k] = v;
            }
        }
        let mut out_rows = Vec::new();
        let mut bits = Vec::with_capacity(height * words);
        for q in 0..height {
            let start = bits.len();
            let mut count = 0u32;
            for k in 0..words {
                let near = (q.saturating_sub(1)..(q + 2).min(height))
                    .fold(0u64, |v, p| v | grown[p * words + k]);
                let v = near & !set[q * words + k];
                count += v.count_ones();
                bits.push(v);
            }
            if count > 0 {
                out_rows.push((top - 1 + q as i32, count));
            } else {
                bits.truncate(start);
            }
        }
        Self {
            left,
            words,
            rows: out_rows,
            bits,
        }
    }
}

#[cfg(test)]
mod tests;
