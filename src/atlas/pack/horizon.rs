//! The horizon ("Tetris") packer of lscm-2002 §4, inserting from four directions as
//! isocharts-2004 §6.
//!
//! Purpose: place charts one by one (callers sort them, largest first) on one page, each at the
//! position that wastes least space between its own horizon and the packing's current horizon.
//!
//! Model. The packing grows from its first chart outwards inside a canvas of `2W × 2H` texels;
//! its bounding box (of the padded footprints `D`) is kept within the page size `W × H`, so at
//! the end it is translated onto the page. Four horizons are kept over the canvas, of the
//! charts' footprints `F` (not padded): per column the first and the last occupied row, per row
//! the first and the last occupied column. A line no chart touches has the bounding box's far
//! side as its horizon (isocharts-2004: "the distance from the top of the packing to the
//! nearest chart", the full height when there is none).
//!
//! Insertion from, say, the +y side at column `x`: the chart's `D` must lie past the packing's
//! last occupied row in every column it covers, so it goes to the smallest `y` with
//! `y + Dmin[c] >= wall[x + c]` for every column `c`; the wasted space is
//! `Σ_c (y + Dmin[c] - wall[x + c])`, the area between the chart's bottom horizon and the
//! current horizon (lscm-2002 Fig. 7). Every `x` keeping the bounding box within `W × H` is
//! tried, for every orientation; the least waste wins (ties: first orientation, then smallest
//! `x`: deterministic). Directions: isocharts-2004 §6 picks a pair from the aspect ratio
//! (with the current box `W_curr × H_curr`, left/right if `H_curr · W / H > W_curr`, else
//! top/bottom) and lets its two members compete on waste. Here all four sides compete and the
//! aspect rule only orders them (which decides ties): a tighter packing for twice the search.
//! The page bound keeps the box within `W × H` either way.
//!
//! On a page made by [`HorizonPage::with_holes`], [`HorizonPage::find`] asks the page's
//! [`Occupancy`] instead ([`super::hole`], an extension of the papers): first fit anywhere in
//! the page-sized box centred in the canvas, so that charts also go into the space behind the
//! horizons; every commit records the chart's `F` in both (the box of the `D`s stays inside
//! that page-sized box, so the translation onto the page below holds).
//!
//! Invariant (the no-overlap guarantee, exact on the texel grid): a chart's padded footprint
//! `D` never meets the footprint `F` of a chart already placed, because in each line it covers
//! it lies entirely beyond the horizon of every earlier `F` (or, placed in a hole, meets no
//! occupied texel of the exact occupancy); and every `D` lies inside the
//! bounding box, hence inside the page after translation. So every `F` keeps `padding` empty
//! texels (Chebyshev) from every other `F` and from the page edge.
//!
//! Units: texels (`i32` canvas coordinates, `i64` waste in texels²).
//!
//! Cost per chart: O(canvas) to build the four walls, then per orientation and side
//! O(positions × lines) at worst, positions ≤ box extent + chart extent ≤ 2·W. In practice a
//! vectorized lower bound from the 4 most protruding lines rejects most positions with one
//! comparison (whole blocks of 64 positions at once when none of them can beat the best so
//! far: an exact test, the same argmin and ties), and the rest stop as soon as the waste cannot
//! beat the best so far. The buffers are reused across a side's orientations. The four
//! sides run in parallel (rayon) above `PARALLEL_WORK`, deterministically.
use super::hole::Occupancy;
use super::place::{Orientation, EMPTY};
use super::placement::Placement;

/// One page being packed.
#[derive(Debug, Clone)]
pub struct HorizonPage {
    bound: [i32; 2],
    /// Per canvas column, `(first, last)` occupied row of any `F` ([`EMPTY`] if none).
    cols: Vec<(i32, i32)>,
    /// Per canvas row, `(first, last)` occupied column.
    rows: Vec<(i32, i32)>,
    /// Bounding box of the `D`s placed: `[x0, y0, x1, y1)`.
    bbox: Option<[i32; 4]>,
    /// The placed `F`s, for hole filling ([`super::hole`]); `None` when the page packs by the
    /// horizons only.
    occupancy: Option<Occupancy>,
}

/// Which side a chart comes from, and the axis it slides along.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    /// From larger y (rests on the packing's last rows).
    PlusY,
    /// From smaller y.
    MinusY,
    /// From larger x.
    PlusX,
    /// From smaller x.
    MinusX,
}

/// Search work (lines × positions, roughly) above which the four sides run in parallel.
const PARALLEL_WORK: i64 = 200_000;

impl HorizonPage {
    /// An empty page of `width × height` texels (each `>= 1`, at most `i32::MAX / 4`).
    pub fn new(width_texels: u32, height_texels: u32) -> Self {
        let (w, h) = (width_texels as i32, height_texels as i32);
        Self {
            bound: [w, h],
            cols: vec![EMPTY; 2 * w as usize],
            rows: vec![EMPTY; 2 * h as usize],
            bbox: None,
            occupancy: None,
        }
    }

    /// An empty page like [`Self::new`] that packs by hole filling instead of the horizons:
    /// each chart goes to the first fit in the page-sized box ([`super::hole`]).
    /// With `scored` false the search is the plain first fit ([`Occupancy::first_fit_only`]).
    pub fn with_holes(width_texels: u32, height_texels: u32, scored: bool) -> Self {
        let mut page = Self::new(width_texels, height_texels);
        let occupancy = Occupancy::new(2 * page.bound[0], 2 * page.bound[1]);
        page.occupancy = Some(if scored {
            occupancy
        } else {
            occupancy.first_fit_only()
        });
        page
    }

    /// Bounding box of the placed padded footprints in canvas texels, `[x0, y0, x1, y1)`.
    pub fn bbox(&self) -> Option<[i32; 4]> {
        self.bbox
    }

    /// The best placement of a chart given its orientations, or `None` when no orientation
    /// fits anywhere. Does not modify the page.
    pub fn find(&self, orientations: &[Orientation]) -> Option<Placement> {
        let [bw, bh] = self.bound;
        let fits = |o: &Orientation| {
            o.dilated.is_some()
                && o.width_texels <= i64::from(bw)
                && o.height_texels <= i64::from(bh)
        };
        // An orientation whose padded footprint repeats an earlier one's (small or symmetric
        // charts) cannot do better: skip it.
        let usable: Vec<bool> = (0..orientations.len())
            .map(|k| {
                let o = &orientations[k];
                fits(o)
                    && !orientations[..k].iter().any(|e| {
                        e.width_texels == o.width_texels
                            && e.height_texels == o.height_texels
                            && e.dilated == o.dilated
                    })
            })
            .collect();
        // Hole filling ([`super::hole`]): first fit in the whole page-sized box centred in the
        // canvas, from the first chart on (bottom-left fill); the horizons are not searched.
        if let Some(occupancy) = &self.occupancy {
            let page_box = [bw / 2, bh / 2, bw / 2 + bw, bh / 2 + bh];
            return occupancy.find(page_box, orientations, &usable);
        }
        let Some([x0, y0, x1, y1]) = self.bbox else {
            // First chart: the orientation with the smallest box, centred in the canvas.
            let (k, o) = orientations
                .iter()
                .enumerate()
                .filter(|(_, o)| fits(o))
                .min_by_key(|(k, o)| (o.width_texels * o.height_texels, *k))?;
            return Some(Placement {
                orientation: k,
                x: bw - (o.width_texels as i32 + 1) / 2,
                y: bh - (o.height_texels as i32 + 1) / 2,
            });
        };
        let widen = i64::from(y1 - y0) * i64::from(bw) > i64::from(x1 - x0) * i64::from(bh);
        // All four sides compete on waste (tighter than the pair of isocharts-2004 alone); the
        // aspect rule orders them, which decides ties.
        let sides = if widen {
            [Side::PlusX, Side::MinusX, Side::PlusY, Side::MinusY]
        } else {
            [Side::PlusY, Side::MinusY, Side::PlusX, Side::MinusX]
        };
        // Two passes (an exact pruning, the same result as one pass): first every side and
        // usable orientation is *prepared* (the vectorized lower bounds of every position, see
        // `Group`) and the position of least lower bound of each is evaluated exactly; the least
        // of these wastes, `cap`, is the waste of a real candidate, so the least waste of all is
        // at most `cap`. Then every side searches its positions keeping only candidates of waste
        // `<= cap` (then strictly better than its best so far, as in one pass), which skips
        // almost every block of positions from the start, where one pass only learns its bound
        // as it goes (and, in parallel, side by side). Ties are unchanged: a side's least waste
        // is found at its first position in (orientation, position) order whenever it is
        // `<= cap`, and a side whose least waste is above `cap` cannot win the reduction.
        let work: i64 = orientations
            .iter()
            .zip(&usable)
            .filter(|(_, &u)| u)
            .map(|(o, _)| o.width_texels + o.height_texels)
            .sum::<i64>()
            * i64::from(bw + bh);
        let parallel = work > PARALLEL_WORK;
        let prepare = |side: Side| -> (SideSearch, i64) {
            let wall = self.wall(side);
            let prefix = prefix_sums(&wall);
            let mut scratch = Scratch::default();
            let groups: Vec<Group> = orientations
                .iter()
                .enumerate()
                .filter(|&(k, _)| usable[k])
                .filter_map(|(k, o)| self.prepare(side, k, o, &wall, &prefix, &mut scratch))
                .collect();
            let probe = groups
                .iter()
                .filter_map(|g| g.probe(&wall, &prefix))
                .fold(i64::MAX, i64::min);
            (
                SideSearch {
                    side,
                    wall,
                    prefix,
                    groups,
                },
                probe,
            )
        };
        let prepared: Vec<(SideSearch, i64)> = if parallel {
            use rayon::prelude::*;
            sides.par_iter().map(|&s| prepare(s)).collect()
        } else {
            sides.iter().map(|&s| prepare(s)).collect()
        };
        let cap = prepared
            .iter()
            .map(|p| p.1)
            .fold(i64::MAX, i64::min)
            .saturating_add(1);
        // `start`: the best of the sides searched before (a candidate must beat it strictly,
        // as in the reduction below). Waste is never negative, so a zero ends the search.
        let per_side = |s: &SideSearch, start: Best| -> Best {
            let mut best = start;
            for g in &s.groups {
                if best.bound == 0 {
                    break;
                }
                g.scan(s.side, &s.wall, &s.prefix, &mut best);
            }
            best
        };
        let start = Best {
            bound: cap,
            found: None,
        };
        // Sides in parallel when there is enough work; each side's best is deterministic and
        // the reduction below takes the least waste, ties to the earlier side: the same result
        // as the sequential loop whatever the thread count.
        let results: Vec<Best> = if parallel {
            use rayon::prelude::*;
            prepared
                .par_iter()
                .map(|(s, _)| per_side(s, start))
                .collect()
        } else {
            // Sequentially, each side starts from the best so far: it only keeps a candidate
            // that beats it strictly, which is what the reduction would keep (same result).
            let mut best = start;
            for (s, _) in &prepared {
                best = per_side(s, best);
            }
            vec![best]
        };
        let mut best: Option<(i64, Placement)> = None;
        for r in results.into_iter().filter_map(|b| b.found) {
            if best.is_none_or(|b| r.0 < b.0) {
                best = Some(r);
            }
        }
        best.map(|(_, p)| p)
    }

    /// Records a chart at `placement` (its footprint `F` updates the horizons; its `D` the box).
    pub fn commit(&mut self, o: &Orientation, placement: Placement) {
        let (Some(f), Some(_)) = (&o.footprint, &o.dilated) else {
            return;
        };
        let (px, py) = (placement.x, placement.y);
        for (c, &(a, b)) in f.cols.iter().enumerate() {
            if (a, b) != EMPTY {
                let e = &mut self.cols[(px + c as i32) as usize];
                *e = (e.0.min(py + a), e.1.max(py + b));
            }
        }
        for (r, &(a, b)) in f.rows.iter().enumerate() {
            if (a, b) != EMPTY {
                let e = &mut self.rows[(py + r as i32) as usize];
                *e = (e.0.min(px + a), e.1.max(px + b));
            }
        }
        if let (Some(occupancy), Some(bits)) = (&mut self.occupancy, &o.footprint_bits) {
            bits.for_each_run(|r, a, b| {
                occupancy.occupy(py + r as i32, px + a as i32, px + b as i32);
            });
            if occupancy.keeps_out() {
                // The keep-out zone: `D` itself, or its per-row extents (a superset) when its
                // texels were not kept.
                let mut mark = |r: i32, a: i32, b: i32| occupancy.keep_out(py + r, px + a, px + b);
                match (&o.dilated_bits, &o.dilated) {
                    (Some(d), _) => d.for_each_run(|r, a, b| mark(r as i32, a as i32, b as i32)),
                    (None, Some(d)) => {
                        for (r, &(a, b)) in d.rows.iter().enumerate() {
                            if (a, b) != EMPTY {
                                mark(r as i32, a, b);
                            }
                        }
                    }
                    (None, None) => {}
                }
            }
        }
        let (w, h) = (o.width_texels as i32, o.height_texels as i32);
        let b = [px, py, px + w, py + h];
        self.bbox = Some(match self.bbox {
            None => b,
            Some(a) => [
                a[0].min(b[0]),
                a[1].min(b[1]),
                a[2].max(b[2]),
                a[3].max(b[3]),
            ],
        });
    }

    /// The wall a chart coming from `side` rests on, per canvas line along the slide axis, in
    /// the side's own coordinate `t` (for the minus sides `t = -position`, so every side is a
    /// "smallest t with t + prof ≥ wall" problem).
    fn wall(&self, side: Side) -> Vec<i32> {
        let [x0, y0, x1, y1] = self.bbox.unwrap_or([0; 4]);
        let (lines, empty) = match side {
            Side::PlusY | Side::MinusY => (&self.cols, if side == Side::PlusY { y0 } else { y1 }),
            Side::PlusX | Side::MinusX => (&self.rows, if side == Side::PlusX { x0 } else { x1 }),
        };
        let plus = matches!(side, Side::PlusY | Side::PlusX);
        lines
            .iter()
            .map(|&(a, b)| {
                let v = if (a, b) == EMPTY {
                    empty
                } else if plus {
                    b + 1
                } else {
                    a
                };
                if plus {
                    v
                } else {
                    -v
                }
            })
            .collect()
    }

    /// Prepares the search of orientation `k` from `side`: the positions along the slide axis
    /// and, per position, the lower bound of its waste from the key lines (`Group`); `None`
    /// when no position keeps the box within the bound.
    fn prepare(
        &self,
        side: Side,
        k: usize,
        o: &Orientation,
        wall: &[i32],
        prefix: &[i64],
        scratch: &mut Scratch,
    ) -> Option<Group> {
        let [x0, y0, x1, y1] = self.bbox.unwrap_or([0; 4]);
        let [bw, bh] = self.bound;
        let d = o.dilated.as_ref()?;
        let (w, h) = (o.width_texels as i32, o.height_texels as i32);
        // Along-axis profile and range, and the bound on t.
        // Positions keep the box within the bound and touch the box's range: all positions
        // wholly beside it see the same flat wall, so the touching one stands for them.
        let (lines, len, lo, hi, t_max) = match side {
            Side::PlusY => (
                &d.cols,
                w,
                (x1 - bw).max(x0 - w),
                (x0 + bw - w).min(x1),
                i64::from(y0 + bh - h),
            ),
            Side::MinusY => (
                &d.cols,
                w,
                (x1 - bw).max(x0 - w),
                (x0 + bw - w).min(x1),
                i64::from(bh - y1),
            ),
            Side::PlusX => (
                &d.rows,
                h,
                (y1 - bh).max(y0 - h),
                (y0 + bh - h).min(y1),
                i64::from(x0 + bw - w),
            ),
            Side::MinusX => (
                &d.rows,
                h,
                (y1 - bh).max(y0 - h),
                (y0 + bh - h).min(y1),
                i64::from(bw - x1),
            ),
        };
        let plus = matches!(side, Side::PlusY | Side::PlusX);
        let t_min = i64::from(match side {
            Side::PlusY => y1 - bh,
            Side::MinusY => h - y0 - bh,
            Side::PlusX => x1 - bw,
            Side::MinusX => w - x0 - bw,
        });
        // prof[c]: the chart's near edge in line c, in the side's t coordinate; an empty line
        // gets a huge value so that it never constrains (wall - prof stays very negative).
        let prof: Vec<i32> = lines
            .iter()
            .map(|&(a, b)| {
                if (a, b) == EMPTY {
                    NO_LINE
                } else if plus {
                    a
                } else {
                    -(b + 1)
                }
            })
            .collect();
        let Scratch {
            empty_lines,
            t_key,
            base,
        } = scratch;
        // One pass over the lines: how many have footprint, the sum of their profile, and the
        // 4 most protruding (the least `(prof, line)`, in that order: the key lines below).
        let (mut n, mut sum_prof) = (0i64, 0i64);
        let mut top = [(NO_LINE, usize::MAX); 4];
        empty_lines.clear();
        for (c, &p) in prof.iter().enumerate() {
            if p == NO_LINE {
                empty_lines.push(c);
                continue;
            }
            n += 1;
            sum_prof += i64::from(p);
            if (p, c) < top[3] {
                let mut i = 3;
                while i > 0 && (p, c) < top[i - 1] {
                    top[i] = top[i - 1];
                    i -= 1;
                }
                top[i] = (p, c);
            }
        }
        if n == 0 {
            return None;
        }
        // The key lines: the 4 most protruding, plus the most protruding of each of
        // `KEY_SEGMENTS` equal runs of lines (a bump of the wall anywhere under the chart is
        // seen). A lower bound of t at every position from them, computed line by line over all
        // positions (contiguous, vectorizes), rejects most positions with one comparison; any
        // set of lines gives a true lower bound, so the result does not depend on the choice.
        let mut key: Vec<usize> = top
            .iter()
            .take(n.min(4) as usize)
            .map(|&(_, c)| c)
            .collect();
        if prof.len() > 2 * KEY_SEGMENTS {
            let step = prof.len().div_ceil(KEY_SEGMENTS);
            for s0 in (0..prof.len()).step_by(step) {
                let e0 = (s0 + step).min(prof.len());
                if let Some(c) = (s0..e0)
                    .filter(|&c| prof[c] != NO_LINE)
                    .min_by_key(|&c| (prof[c], c))
                {
                    if !key.contains(&c) {
                        key.push(c);
                    }
                }
            }
        }
        // The lines without footprint (`empty_lines`): the wall sum over the others is the
        // prefix sum over all lines less theirs (usually none or few).
        let lo = lo.max(0);
        let hi = hi.min(wall.len() as i32 - len);
        if lo > hi {
            return None;
        }
        let npos = (hi - lo + 1) as usize;
        let (lo_u, len_u) = (lo as usize, len as usize);
        t_key.clear();
        t_key.resize(npos, i32::MIN);
        for &c in &key {
            let start = lo_u + c;
            let pc = prof[c];
            for (t, &wv) in t_key.iter_mut().zip(&wall[start..start + npos]) {
                *t = (*t).max(wv - pc);
            }
        }
        // base[i] = Σ prof - Σ wall over the chart's lines at position lo + i, so that the
        // waste at t is n·t + base (exact integers: the order of the sums does not matter).
        base.clear();
        base.extend(
            prefix[lo_u + len_u..lo_u + len_u + npos]
                .iter()
                .zip(&prefix[lo_u..lo_u + npos])
                .map(|(&a, &z)| sum_prof - (a - z)),
        );
        for &c in empty_lines.iter() {
            let start = lo_u + c;
            for (b, &wv) in base.iter_mut().zip(&wall[start..start + npos]) {
                *b += i64::from(wv);
            }
        }
        // lb[i]: the waste at the key lines' t (a lower bound of the position's waste, as t only
        // grows below), or i64::MAX when that t is already past the bound on t: a position is
        // rejected by the key lines exactly when lb[i] >= the best waste so far.
        let lb: Vec<i64> = t_key
            .iter()
            .zip(base.iter())
            .map(|(&t0, &b)| {
                let t0 = i64::from(t0);
                if t0 > t_max {
                    i64::MAX
                } else {
                    n * t0 + b
                }
            })
            .collect();
        Some(Group {
            k,
            prof,
            key,
            empty: empty_lines.clone(),
            sum_prof,
            lb,
            n,
            lo,
            t_max,
            t_min,
        })
    }
}

/// Runs of a chart's lines whose most protruding line joins the key lines of
/// [`HorizonPage::prepare`]. Trade-off: more key lines reject more positions by the bound, but
/// the bound itself costs more; the placements are the same either way.
const KEY_SEGMENTS: usize = 4;

/// Profile of the chart's lines that are empty (never constrain `t`).
const NO_LINE: i32 = 1 << 29;

/// Best candidate so far: its waste and placement, and the bound a candidate must be below to
/// replace it (its waste, or the cap of the search before any is found).
#[derive(Debug, Clone, Copy)]
struct Best {
    bound: i64,
    found: Option<(i64, Placement)>,
}

/// One side's wall (and its prefix sums) and its prepared orientations.
struct SideSearch {
    side: Side,
    wall: Vec<i32>,
    prefix: Vec<i64>,
    groups: Vec<Group>,
}

/// One orientation prepared for one side ([`HorizonPage::prepare`]).
struct Group {
    /// Index of the orientation.
    k: usize,
    /// The chart's near edge per line in the side's `t` coordinate ([`NO_LINE`] if empty).
    prof: Vec<i32>,
    /// The key lines ([`HorizonPage::prepare`]): at position `i`, they force
    /// `t >= max over key lines c of wall[lo + i + c] - prof[c]`.
    key: Vec<usize>,
    /// The lines without footprint.
    empty: Vec<usize>,
    /// `Σ prof` over the non-empty lines: with the wall's prefix sums, the waste at position
    /// `i` is `n·t + base(i)`, `base(i) = Σ prof - Σ wall` over those lines.
    sum_prof: i64,
    /// Per position, the lower bound of the waste from the key lines, texels² (`i64::MAX`
    /// when that `t` is past `t_max`).
    lb: Vec<i64>,
    /// Number of non-empty lines.
    n: i64,
    /// Slide-axis position of index 0.
    lo: i32,
    /// Bounds on `t` keeping the box within the page bound.
    t_max: i64,
    t_min: i64,
}

impl Group {
    /// The exact `t` and waste of position index `i` when its waste is below `bound` and it
    /// keeps the box within the bound; `None` otherwise.
    fn eval(&self, wall: &[i32], prefix: &[i64], i: usize, bound: i64) -> Option<(i64, i64)> {
        const CHUNK: usize = 32;
        let p = (self.lo + i as i32) as usize;
        let len = self.prof.len();
        // `base(i)` and the key lines' `t`, as `prepare` computed them for its bound.
        let base_i = self.sum_prof - (prefix[p + len] - prefix[p])
            + self
                .empty
                .iter()
                .map(|&c| i64::from(wall[p + c]))
                .sum::<i64>();
        let (n, t_max) = (self.n, self.t_max);
        let reject = |t: i64| t > t_max || n * t + base_i >= bound;
        let mut t = self
            .key
            .iter()
            .map(|&c| wall[p + c] - self.prof[c])
            .fold(i32::MIN, i32::max);
        let window = &wall[p..p + len];
        for (wc, pc) in window.chunks(CHUNK).zip(self.prof.chunks(CHUNK)) {
            // Branch-free over a chunk (vectorizes), then one test.
            let m = wc
                .iter()
                .zip(pc)
                .map(|(a, b)| a - b)
                .fold(i32::MIN, i32::max);
            t = t.max(m);
            if reject(i64::from(t)) {
                return None;
            }
        }
        // The grid's near side must keep the box within the bound too (a sampled footprint
        // need not reach its grid's side): moving out is always allowed.
        let t = i64::from(t).max(self.t_min);
        if reject(t) {
            return None;
        }
        Some((t, n * t + base_i))
    }

    /// The exact waste at the first position of least lower bound (an upper bound of the
    /// least waste of the page, when some position is feasible).
    fn probe(&self, wall: &[i32], prefix: &[i64]) -> Option<i64> {
        let (i, &lb) = self.lb.iter().enumerate().min_by_key(|&(i, &v)| (v, i))?;
        if lb == i64::MAX {
            return None;
        }
        self.eval(wall, prefix, i, i64::MAX).map(|(_, waste)| waste)
    }

    /// Updates `best` with every position, in order, whose waste is below the bound so far.
    fn scan(&self, side: Side, wall: &[i32], prefix: &[i64], best: &mut Best) {
        // Positions in blocks: a block whose least lower bound cannot beat the best so far is
        // skipped whole (the best does not change inside a skipped block, so this rejects exactly
        // the positions the test per position would).
        const BLOCK: usize = 64;
        for (bi, lb_block) in self.lb.chunks(BLOCK).enumerate() {
            if best.bound == 0 {
                // Waste is never negative: nothing can beat a perfect fit.
                return;
            }
            if lb_block.iter().copied().fold(i64::MAX, i64::min) >= best.bound {
                continue;
            }
            for (j, &lb_i) in lb_block.iter().enumerate() {
                if best.bound == 0 {
                    return;
                }
                if lb_i >= best.bound {
                    continue;
                }
                let i = bi * BLOCK + j;
                let Some((t, waste)) = self.eval(wall, prefix, i, best.bound) else {
                    continue;
                };
                let pos = self.lo + i as i32;
                let (x, y) = match side {
                    Side::PlusY => (pos, t as i32),
                    Side::MinusY => (pos, -(t as i32)),
                    Side::PlusX => (t as i32, pos),
                    Side::MinusX => (-(t as i32), pos),
                };
                best.bound = waste;
                best.found = Some((
                    waste,
                    Placement {
                        orientation: self.k,
                        x,
                        y,
                    },
                ));
            }
        }
    }
}

/// Buffers of [`HorizonPage::prepare`], reused across the orientations of a side.
#[derive(Debug, Default)]
struct Scratch {
    /// The chart's empty lines.
    empty_lines: Vec<usize>,
    /// Per position, the `t` the key lines force.
    t_key: Vec<i32>,
    /// Per position, `Σ prof - Σ wall` over the chart's lines, texels².
    base: Vec<i64>,
}

fn prefix_sums(v: &[i32]) -> Vec<i64> {
    let mut out = Vec::with_capacity(v.len() + 1);
    let mut s = 0i64;
    out.push(0);
    for &x in v {
        s += i64::from(x);
        out.push(s);
    }
    out
}
