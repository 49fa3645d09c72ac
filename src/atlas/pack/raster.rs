//! Conservative rasterization of a chart onto the texel grid, and Chebyshev dilation.
//!
//! Purpose: the footprint the packer reasons about. [`rasterize_conservative`] marks every
//! texel that any triangle touches, texel `(i, j)` being the *closed* square
//! `[i, i+1] × [j, j+1]`; [`Mask::dilate`] grows a footprint by `r` texels in the Chebyshev
//! (square) metric, so that "the dilated footprint of A misses the footprint of B" is exactly
//! "every texel of A is at Chebyshev distance > r from every texel of B".
//!
//! Why that is enough for the quality report ([`crate::atlas::measure`]): it samples texel
//! centres. A centre that a triangle covers lies in the triangle, so its texel touches the
//! triangle and is in the conservative footprint. The footprint is a superset of any sampled
//! coverage, also after the `f32` rounding of the written UVs (that moves vertices by far less
//! than the half texel separating an untouched texel's centre from the triangle).
//!
//! Exactness: per texel row, the triangle is clipped to the closed slab `[j, j+1]` and the
//! x-range of the clipped (convex) polygon is taken; a texel of the row touches the triangle iff
//! its column interval meets that range (a convex set meets a box of the slab iff their
//! x-projections meet). Every range is widened by [`TOUCH_EPS_TEXELS`] so that rounding can only
//! add texels, never drop one.
//!
//! Preconditions: triangle corners finite, in local texel units (`_texels`). Corners outside the
//! mask are clipped to it (never a panic); callers lay charts out inside their mask.
//!
//! Cost: O(Σ over triangles of the rows it spans + texels set); [`Mask::dilate`] is
//! O(width × height / 64 × r).
//!
//! Reference: lscm-2002 §4 (discretized horizons "with texture resolution"), isocharts-2004 §6.

/// Widening of every touch test, texels: rounding may add a texel, never drop one.
pub const TOUCH_EPS_TEXELS: f64 = 1e-4;

/// A bit mask over a `width × height` texel grid, row-major, 64 texels per word.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mask {
    width: u32,
    height: u32,
    words_per_row: usize,
    bits: Vec<u64>,
}

impl Mask {
    /// An empty mask. Cost: `width × height / 8` bytes.
    pub fn new(width: u32, height: u32) -> Self {
        let words_per_row = (width as usize).div_ceil(64);
        Self {
            width,
            height,
            words_per_row,
            bits: vec![0; words_per_row * height as usize],
        }
    }

    /// Width in texels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Whether texel `(x, y)` is set; `false` outside the mask.
    pub fn get(&self, x: i64, y: i64) -> bool {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return false;
        }
        let w = self.bits[y as usize * self.words_per_row + (x as usize >> 6)];
        (w >> (x & 63)) & 1 == 1
    }

    /// Sets texels `x0..=x1` of row `y` (clipped to the mask).
    pub fn set_span(&mut self, y: u32, x0: u32, x1: u32) {
        if y >= self.height || self.width == 0 {
            return;
        }
        let x1 = x1.min(self.width - 1);
        if x0 > x1 {
            return;
        }
        let row = &mut self.bits[y as usize * self.words_per_row..][..self.words_per_row];
        let (w0, w1) = ((x0 >> 6) as usize, (x1 >> 6) as usize);
        let lo = u64::MAX << (x0 & 63);
        let hi = u64::MAX >> (63 - (x1 & 63));
        if w0 == w1 {
            row[w0] |= lo & hi;
        } else {
            row[w0] |= lo;
            for w in &mut row[w0 + 1..w1] {
                *w = u64::MAX;
            }
            row[w1] |= hi;
        }
    }

    /// Number of set texels.
    pub fn count(&self) -> u64 {
        self.bits.iter().map(|w| u64::from(w.count_ones())).sum()
    }

    /// The mask grown by `r` texels in the Chebyshev metric, clipped to the same grid (callers
    /// leave an `r`-texel margin). Cost: O(width × height / 64 × r).
    pub fn dilate(&self, r: u32) -> Mask {
        if r == 0 {
            return self.clone();
        }
        let wpr = self.words_per_row;
        // Horizontal pass: OR of the row shifted by -r ..= r, word by word with carries.
        let mut horizontal = self.clone();
        if r < 64 {
            // Each word from its two neighbours, in one pass.
            for (row, out) in self
                .bits
                .chunks_exact(wpr.max(1))
                .zip(horizontal.bits.chunks_exact_mut(wpr.max(1)))
            {
                for k in 0..row.len() {
                    let c = row[k];
                    let prev = if k > 0 { row[k - 1] } else { 0 };
                    let next = if k + 1 < row.len() { row[k + 1] } else { 0 };
                    let mut acc = c;
                    for s in 1..=r {
                        acc |= (c << s) | (prev >> (64 - s)) | (c >> s) | (next << (64 - s));
                    }
                    out[k] = acc;
                }
            }
        } else {
            for y in 0..self.height as usize {
                let row = &self.bits[y * wpr..][..wpr];
                let out = &mut horizontal.bits[y * wpr..][..wpr];
                for s in 1..=r as usize {
                    let (ws, bs) = (s / 64, (s % 64) as u32);
                    for k in 0..wpr {
                        // Towards higher columns: bit x goes to x + s.
                        if k >= ws {
                            let mut v = row[k - ws] << bs;
                            if bs > 0 && k > ws {
                                v |= row[k - ws - 1] >> (64 - bs);
                            }
                            out[k] |= v;
                        }
                        // Towards lower columns: bit x goes to x - s.
                        if k + ws < wpr {
                            let mut v = row[k + ws] >> bs;
                            if bs > 0 && k + ws + 1 < wpr {
                                v |= row[k + ws + 1] << (64 - bs);
                            }
                            out[k] |= v;
                        }
                    }
                }
            }
        }
        horizontal.clear_padding_bits();
        // Vertical pass: row y is the OR of rows y - r ..= y + r (word-wise, whole rows).
        let mut out = Mask::new(self.width, self.height);
        if wpr == 0 {
            return out;
        }
        for (y, dst) in out.bits.chunks_exact_mut(wpr).enumerate() {
            let lo = y.saturating_sub(r as usize);
            let hi = (y + r as usize).min(self.height as usize - 1);
            for src in horizontal.bits[lo * wpr..(hi + 1) * wpr].chunks_exact(wpr) {
                for (d, s) in dst.iter_mut().zip(src) {
                    *d |= *s;
                }
            }
        }
        out
    }

    /// Adds the texels of `extra` that are not in `except` (same grid): `self |= extra & !except`.
    pub fn add_except(&mut self, extra: &Mask, except: &Mask) {
        assert!(
            (self.width, self.height) == (extra.width, extra.height)
                && (self.width, self.height) == (except.width, except.height),
            "masks on one grid"
        );
        for ((b, &x), &n) in self.bits.iter_mut().zip(&extra.bits).zip(&except.bits) {
            *b |= x & !n;
        }
    }

    /// Adds the texels of `extra` that are farther than `r` (Chebyshev) from every texel of this
    /// mask (same grid): `self |= extra & !self.dilate(r)`, the same bits. The dilation is made
    /// only at the words where `extra` has a texel outside this mask (a boundary band, where a
    /// footprint's touched texels lie), not over the whole grid. Cost: O(words × (2r + 1)) for
    /// those words, plus one pass over the grid; `r ≥ 64` dilates the whole grid.
    pub fn add_except_dilated(&mut self, extra: &Mask, r: u32) {
        assert!(
            (self.width, self.height) == (extra.width, extra.height),
            "masks on one grid"
        );
        if r >= 64 {
            let near = self.dilate(r);
            self.add_except(extra, &near);
            return;
        }
        let wpr = self.words_per_row;
        if wpr == 0 {
            return;
        }
        let h = self.height as usize;
        let last_word_mask = match self.width % 64 {
            0 => u64::MAX,
            rem => (1u64 << rem) - 1,
        };
        // Word `k` of row `y` grown by `r` along the row, as `dilate`'s horizontal pass.
        let grown = |y: usize, k: usize| -> u64 {
            let row = &self.bits[y * wpr..][..wpr];
            let c = row[k];
            let prev = if k > 0 { row[k - 1] } else { 0 };
            let next = if k + 1 < wpr { row[k + 1] } else { 0 };
            let mut acc = c;
            for s in 1..=r {
                acc |= (c << s) | (prev >> (64 - s)) | (c >> s) | (next << (64 - s));
            }
            if k + 1 == wpr {
                acc &= last_word_mask;
            }
            acc
        };
        let mut add: Vec<(usize, u64)> = Vec::new();
        for (i, (&x, &own)) in extra.bits.iter().zip(&self.bits).enumerate() {
            let outside = x & !own;
            if outside == 0 {
                continue;
            }
            let (y, k) = (i / wpr, i % wpr);
            // Row `y` first, then the rows outwards: most such texels are next to this mask
            // in their own row, and the search stops once every one is near.
            let mut left = outside & !grown(y, k);
            for d in 1..=r as usize {
                if left == 0 {
                    break;
                }
                if d <= y {
                    left &= !grown(y - d, k);
                }
                if y + d < h {
                    left &= !grown(y + d, k);
                }
            }
            if left != 0 {
                add.push((i, left));
            }
        }
        for (i, bits) in add {
            self.bits[i] |= bits;
        }
    }

    /// The 64 texels of row `y` from column `x` on (bit `k`: column `x + k`; texels past the
    /// width count as clear).
    fn word_at(&self, y: u32, x: u32) -> u64 {
        let row = &self.bits[y as usize * self.words_per_row..][..self.words_per_row];
        let (k, o) = ((x >> 6) as usize, x & 63);
        let lo = row.get(k).copied().unwrap_or(0);
        if o == 0 {
            lo
        } else {
            let hi = row.get(k + 1).copied().unwrap_or(0);
            (lo >> o) | (hi << (64 - o))
        }
    }

    /// The transpose of the window of `w × h` texels at `(x0, y0)`: a mask `h` wide and `w`
    /// tall whose texel `(j, i)` is texel `(x0 + i, y0 + j)` of this one. By 64 × 64 blocks
    /// (a bit-matrix transpose in six swap steps), so O(w × h / 64 × 6) word operations
    /// instead of one per texel. The window lies inside the mask.
    pub fn transposed_window(&self, x0: u32, y0: u32, w: u32, h: u32) -> Mask {
        let mut out = Mask::new(h, w);
        let mut block = [0u64; 64];
        for jb in (0..h).step_by(64) {
            for ib in (0..w).step_by(64) {
                let cols = (w - ib).min(64);
                let keep = if cols == 64 {
                    u64::MAX
                } else {
                    (1u64 << cols) - 1
                };
                for (k, b) in block.iter_mut().enumerate() {
                    let j = jb + k as u32;
                    *b = if j < h {
                        self.word_at(y0 + j, x0 + ib) & keep
                    } else {
                        0
                    };
                }
                transpose64(&mut block);
                for (m, &b) in block.iter().enumerate().take(cols as usize) {
                    out.bits[(ib as usize + m) * out.words_per_row + (jb >> 6) as usize] = b;
                }
            }
        }
        out
    }

    /// Clears the bits past `width` in each row's last word.
    fn clear_padding_bits(&mut self) {
        let rem = self.width % 64;
        if rem == 0 || self.words_per_row == 0 {
            return;
        }
        let keep = (1u64 << rem) - 1;
        for y in 0..self.height as usize {
            self.bits[y * self.words_per_row + self.words_per_row - 1] &= keep;
        }
    }

    /// The runs of set texels of row `y`, as inclusive `(first, last)` columns, left to right.
    pub fn runs(&self, y: u32) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        if y >= self.height {
            return out;
        }
        let row = &self.bits[y as usize * self.words_per_row..][..self.words_per_row];
        let mut start: Option<u32> = None;
        for x in 0..self.width {
            let set = (row[(x >> 6) as usize] >> (x & 63)) & 1 == 1;
            match (set, start) {
                (true, None) => start = Some(x),
                (false, Some(s)) => {
                    out.push((s, x - 1));
                    start = None;
                }
                _ => {}
            }
        }
        if let Some(s) = start {
            out.push((s, self.width - 1));
        }
        out
    }

    /// The runs of set texels of row `y` within columns `x0..x1`, as inclusive `(first, last)`
    /// columns, left to right (clipped to the window), in `out` (cleared first: one buffer
    /// serves every row). Cost: O((x1 - x0) / 64 + runs).
    pub fn runs_in(&self, y: u32, x0: u32, x1: u32, out: &mut Vec<(u32, u32)>) {
        out.clear();
        let x1 = x1.min(self.width);
        if y >= self.height || x0 >= x1 {
            return;
        }
        let row = &self.bits[y as usize * self.words_per_row..][..self.words_per_row];
        // Bit x of the row, restricted to the window: word k masked to [x0, x1).
        let word = |k: usize| -> u64 {
            let mut v = row[k];
            let base = (k * 64) as u32;
            if base < x0 {
                v &= u64::MAX << (x0 - base);
            }
            if base + 64 > x1 {
                v &= u64::MAX >> (base + 64 - x1);
            }
            v
        };
        let (k0, k1) = ((x0 >> 6) as usize, ((x1 - 1) >> 6) as usize);
        let mut start: Option<u32> = None;
        for k in k0..=k1 {
            let v = word(k);
            let base = (k * 64) as u32;
            let mut pos = 0u32;
            // Walk the word's runs: alternately the next set bit and the next clear bit.
            while pos < 64 {
                match start {
                    None => {
                        let rest = v >> pos;
                        if rest == 0 {
                            break;
                        }
                        pos += rest.trailing_zeros();
                        start = Some(base + pos);
                    }
                    Some(s) => {
                        let rest = !v >> pos;
                        if rest == 0 {
                            break;
                        }
                        pos += rest.trailing_zeros();
                        out.push((s, base + pos - 1));
                        start = None;
                    }
                }
            }
        }
        if let Some(s) = start {
            out.push((s, x1 - 1));
        }
    }

    /// Per column, the first and last set row (`None` for an empty column). Cost:
    /// O(height × width / 64 + width).
    pub fn column_extents(&self) -> Vec<Option<(u32, u32)>> {
        let wpr = self.words_per_row;
        let mut first = vec![u32::MAX; self.width as usize];
        let mut last = vec![0u32; self.width as usize];
        let mut seen = vec![0u64; wpr];
        for y in 0..self.height {
            let row = &self.bits[y as usize * wpr..][..wpr];
            for k in 0..wpr {
                let mut new = row[k] & !seen[k];
                seen[k] |= row[k];
                while new != 0 {
                    let b = new.trailing_zeros();
                    first[k * 64 + b as usize] = y;
                    new &= new - 1;
                }
            }
        }
        seen.iter_mut().for_each(|w| *w = 0);
        for y in (0..self.height).rev() {
            let row = &self.bits[y as usize * wpr..][..wpr];
            for k in 0..wpr {
                let mut new = row[k] & !seen[k];
                seen[k] |= row[k];
                while new != 0 {
                    let b = new.trailing_zeros();
                    last[k * 64 + b as usize] = y;
                    new &= new - 1;
                }
            }
        }
        first
            .iter()
            .zip(&last)
            .map(|(&a, &b)| (a != u32::MAX).then_some((a, b)))
            .collect()
    }

    /// Per row, the first and last set column (`None` for an empty row). Cost:
    /// O(height × width / 64).
    pub fn row_extents(&self) -> Vec<Option<(u32, u32)>> {
        let wpr = self.words_per_row;
        (0..self.height as usize)
            .map(|y| {
                let row = &self.bits[y * wpr..][..wpr];
                let a = row.iter().position(|&w| w != 0)?;
                let b = row.iter().rposition(|&w| w != 0)?;
                Some((
                    (a * 64) as u32 + row[a].trailing_zeros(),
                    (b * 64) as u32 + 63 - row[b].leading_zeros(),
                ))
            })
            .collect()
    }
}

/// Marks in `mask` every texel that a triangle touches (closed texel squares, module doc).
/// Triangles are given by their corners in the mask's texel units.
///
/// Per triangle, the x-range of its intersection with each texel line `y = L` is computed once
/// (two edge crossings), and row `j`'s range is the hull of lines `j` and `j + 1` and of the
/// corners inside the slab: the exact x-range of the triangle clipped to the slab.
///
/// Cost: O(rows spanned) per triangle plus the spans written.
pub fn rasterize_conservative(mask: &mut Mask, triangles: impl IntoIterator<Item = [[f64; 2]; 3]>) {
    rasterize_touching(mask, triangles, TOUCH_EPS_TEXELS);
}

/// [`rasterize_conservative`] with every touch test widened by `eps_texels` instead of
/// [`TOUCH_EPS_TEXELS`]: every texel within `eps_texels` of a triangle (segments `[p, q, q]`
/// included) is marked.
pub fn rasterize_touching(
    mask: &mut Mask,
    triangles: impl IntoIterator<Item = [[f64; 2]; 3]>,
    eps_texels: f64,
) {
    if mask.width() == 0 || mask.height() == 0 {
        return;
    }
    let (w, h) = (i64::from(mask.width()), i64::from(mask.height()));
    let eps = eps_texels.max(TOUCH_EPS_TEXELS);
    for mut t in triangles {
        if t.iter().any(|p| {
            !(p[0].is_finite() && p[1].is_finite() && p[0].abs() < 1e15 && p[1].abs() < 1e15)
        }) {
            continue;
        }
        // Sort corners by y: a (lowest), b, c (highest).
        if t[1][1] < t[0][1] {
            t.swap(0, 1);
        }
        if t[2][1] < t[1][1] {
            t.swap(1, 2);
        }
        if t[1][1] < t[0][1] {
            t.swap(0, 1);
        }
        let [a, b, c] = t;
        // Rows whose closed slab [j, j+1] meets [a.y - eps, c.y + eps]: ceil(lo) - 1 ..= floor(hi).
        let j0 = (ceil_i(a[1] - eps) - 1).max(0);
        let j1 = floor_i(c[1] + eps).min(h - 1);
        if j0 > j1 {
            continue;
        }
        let on = |p: [f64; 2], q: [f64; 2], y: f64| {
            let s = ((y - p[1]) / (q[1] - p[1])).clamp(0.0, 1.0);
            p[0] + s * (q[0] - p[0])
        };
        // The triangle's x-range on the line y = l, if it meets it.
        let line = |l: f64| -> Option<(f64, f64)> {
            if l < a[1] || l > c[1] {
                return None;
            }
            let x1 = if c[1] > a[1] { on(a, c, l) } else { a[0] };
            let x2 = if l <= b[1] {
                if b[1] > a[1] {
                    on(a, b, l)
                } else {
                    b[0]
                }
            } else {
                on(b, c, l)
            };
            Some((x1.min(x2), x1.max(x2)))
        };
        let mut below = line(j0 as f64);
        for j in j0..=j1 {
            let (lo, hi) = (j as f64, j as f64 + 1.0);
            let above = line(hi);
            let mut xmin = f64::INFINITY;
            let mut xmax = f64::NEG_INFINITY;
            for (x0, x1) in [below, above].into_iter().flatten() {
                xmin = xmin.min(x0);
                xmax = xmax.max(x1);
            }
            for p in [a, b, c] {
                if p[1] >= lo - eps && p[1] <= hi + eps {
                    xmin = xmin.min(p[0]);
                    xmax = xmax.max(p[0]);
                }
            }
            below = above;
            if xmin > xmax {
                continue;
            }
            // Columns whose closed interval [i, i+1] meets [xmin - eps, xmax + eps].
            let i0 = (ceil_i(xmin - eps) - 1).max(0);
            let i1 = floor_i(xmax + eps).min(w - 1);
            if i0 <= i1 {
                mask.set_span(j as u32, i0 as u32, i1 as u32);
            }
        }
    }
}

/// Marks in `mask` every texel whose *centre* lies in a triangle grown by `grow_texels` (each
/// edge pushed outwards by that distance, clipped to the triangle's bounding box grown by as
/// much): a superset of the texels the evaluator samples as covered (centre in the closed
/// triangle), also after the rounding of the written UVs when `grow_texels` exceeds it.
/// Triangles too thin for a stable edge normal are rasterized conservatively instead
/// ([`rasterize_conservative`], a superset of the grown triangle's centres).
///
/// Returns whether it marked anything (or rasterized a thin triangle conservatively).
///
/// Cost: O(rows spanned) per triangle plus the spans written.
pub fn rasterize_centres(
    mask: &mut Mask,
    triangles: impl IntoIterator<Item = [[f64; 2]; 3]>,
    grow_texels: f64,
) -> bool {
    let mut any = false;
    if mask.width() == 0 || mask.height() == 0 {
        return any;
    }
    let (w, h) = (i64::from(mask.width()), i64::from(mask.height()));
    let g = grow_texels.max(0.0);
    for t in triangles {
        if t.iter().any(|p| {
            !(p[0].is_finite() && p[1].is_finite() && p[0].abs() < 1e15 && p[1].abs() < 1e15)
        }) {
            continue;
        }
        let [a, b, c] = t;
        let xmin = a[0].min(b[0]).min(c[0]);
        let xmax = a[0].max(b[0]).max(c[0]);
        let ymin = a[1].min(b[1]).min(c[1]);
        let ymax = a[1].max(b[1]).max(c[1]);
        let span = (xmax - xmin).max(ymax - ymin);
        let area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if !(area2.abs() > 1e-6 * span * span && span > 1e-9) {
            rasterize_conservative(mask, [t]);
            any = true;
            continue;
        }
        // Centres j + 0.5 in the grown box; none: nothing to do (most small triangles).
        let j0 = ceil_i(ymin - g - 0.5).max(0);
        let j1 = floor_i(ymax + g - 0.5).min(h - 1);
        let c0 = ceil_i(xmin - g - 0.5).max(0);
        let c1 = floor_i(xmax + g - 0.5).min(w - 1);
        if j0 > j1 || c0 > c1 {
            continue;
        }
        // Counter-clockwise in the sign of area2 > 0: inside is cross(p, q, x) >= 0 per edge.
        // Each edge is pushed out by g·(|ea| + |eb|) >= g·|normal| (no square root needed).
        let t = if area2 > 0.0 { t } else { [a, c, b] };
        let mut lines = [(0.0f64, 0.0f64, 0.0f64); 3];
        for k in 0..3 {
            let (p, q) = (t[k], t[(k + 1) % 3]);
            let (ea, eb) = (-(q[1] - p[1]), q[0] - p[0]);
            // Stored divided by ea (x bound = -(eb·y + ec) / ea); ea = 0 keeps the raw line.
            let ec = -(ea * p[0] + eb * p[1]) + g * (ea.abs() + eb.abs());
            lines[k] = if ea != 0.0 {
                (ea, eb / ea, ec / ea)
            } else {
                (0.0, eb, ec)
            };
        }
        for j in j0..=j1 {
            let y = j as f64 + 0.5;
            let (mut xl, mut xr) = (xmin - g, xmax + g);
            for &(ea, eb, ec) in &lines {
                let r = eb * y + ec;
                if ea > 0.0 {
                    xl = xl.max(-r);
                } else if ea < 0.0 {
                    xr = xr.min(-r);
                } else if r < 0.0 {
                    xl = f64::INFINITY;
                }
            }
            if xl.is_nan() || xr.is_nan() || xl > xr {
                continue;
            }
            let i0 = ceil_i(xl - 0.5).max(c0);
            let i1 = floor_i(xr - 0.5).min(c1);
            if i0 <= i1 {
                mask.set_span(j as u32, i0 as u32, i1 as u32);
                any = true;
            }
        }
    }
    any
}

/// Marks in `mask` every texel whose centre has a nonzero winding number with respect to the
/// closed edge chain `edges` (directed segments in the mask's texel units), or lies within
/// Chebyshev distance `band_texels` of one of its edges.
///
/// Why (the boundary fill of [`super::place`]): for triangles all oriented counter-clockwise,
/// the chain `B = Σ ∂T` (interior edges cancel against their opposite) has winding number
/// `wind(B, p) = #{T : p ∈ int T}` at every point off `B`, so the nonzero-winding fill is the
/// union of the triangles (their overlaps too), whatever their number: the cost is that of the
/// boundary, not of the triangles. A centre within `band_texels` of the union but outside it
/// is within that distance of `∂U ⊆ B`, hence in the band.
///
/// Per row `j`, the chain's crossings with the line `y = j + 1/2` (half-open rule at vertices,
/// so that a closed chain's crossings sum to zero) are sorted by `x` and swept. Crossings out of
/// order by rounding only affect points within rounding of an edge, all in the band.
///
/// Returns whether it marked anything. Cost: O(Σ rows spanned per edge + crossings · log).
pub fn fill_chain(mask: &mut Mask, edges: &[[[f64; 2]; 2]], band_texels: f64) -> bool {
    fill_chain_with_core(mask, edges, band_texels).0
}

/// How many texel centres [`fill_chain_with_core`] tests for a core centre at most.
pub const CORE_CANDIDATES: usize = 16;

/// [`fill_chain`], and whether it found a *core* centre: a marked centre of nonzero winding
/// number farther than `band_texels` (Euclidean) from every edge, so inside the union by more
/// than the band — moving the chain by less than that (rounding, the `f32` of written UVs)
/// keeps it covered. Its winding number is exact (rounding of the crossings only matters
/// within rounding of an edge). The candidates are the middle centres of the
/// [`CORE_CANDIDATES`] longest runs of the fill (ties by row, then column), each tested
/// against every edge: `false` when none of them is a core centre, which may miss one
/// (callers treat `false` conservatively).
///
/// Returns `(marked anything, found a core centre)`. Cost: that of [`fill_chain`] plus
/// O([`CORE_CANDIDATES`] × edges).
pub fn fill_chain_with_core(
    mask: &mut Mask,
    edges: &[[[f64; 2]; 2]],
    band_texels: f64,
) -> (bool, bool) {
    let mut any = false;
    if mask.width() == 0 || mask.height() == 0 || edges.is_empty() {
        return (any, false);
    }
    // The runs of nonzero winding, `(row, first, last)`.
    let mut runs: Vec<(u32, u32, u32)> = Vec::new();
    let (w, h) = (i64::from(mask.width()), i64::from(mask.height()));
    let e = band_texels.max(0.0);
    // Crossings per row: (row, x, +1 / -1), sorted by row then x.
    let mut crossings: Vec<(u32, f64, i32)> = Vec::new();
    for &[p, q] in edges {
        if ![p[0], p[1], q[0], q[1]]
            .iter()
            .all(|v| v.is_finite() && v.abs() < 1e15)
        {
            continue;
        }
        let (lo, hi, dir) = if p[1] <= q[1] { (p, q, 1) } else { (q, p, -1) };
        // Rows whose centre y = j + 0.5 satisfies lo.y <= y < hi.y.
        let j0 = ceil_i(lo[1] - 0.5).max(0);
        let j1 = (ceil_i(hi[1] - 0.5) - 1).min(h - 1);
        if hi[1] > lo[1] {
            let slope = (hi[0] - lo[0]) / (hi[1] - lo[1]);
            for j in j0..=j1 {
                let y = j as f64 + 0.5;
                crossings.push((j as u32, lo[0] + (y - lo[1]) * slope, dir));
            }
        }
        // The band: centres within Chebyshev distance e of the segment.
        let b0 = ceil_i(lo[1] - e - 0.5).max(0);
        let b1 = floor_i(hi[1] + e - 0.5).min(h - 1);
        for j in b0..=b1 {
            let y = j as f64 + 0.5;
            let (xa, xb) = if hi[1] > lo[1] {
                let s0 = ((y - e - lo[1]) / (hi[1] - lo[1])).clamp(0.0, 1.0);
                let s1 = ((y + e - lo[1]) / (hi[1] - lo[1])).clamp(0.0, 1.0);
                let x0 = lo[0] + s0 * (hi[0] - lo[0]);
                let x1 = lo[0] + s1 * (hi[0] - lo[0]);
                (x0.min(x1), x0.max(x1))
            } else {
                (lo[0].min(hi[0]), lo[0].max(hi[0]))
            };
            let i0 = ceil_i(xa - e - 0.5).max(0);
            let i1 = floor_i(xb + e - 0.5).min(w - 1);
            if i0 <= i1 {
                mask.set_span(j as u32, i0 as u32, i1 as u32);
                any = true;
            }
        }
    }
    // Sorted by row, then by x, stably (the order of `sort_by` on `(row, x)`): grouped by row
    // in edge order (a counting sort), then each row's few crossings sorted by x.
    let mut row_start = vec![0usize; h as usize + 1];
    for c in &crossings {
        row_start[c.0 as usize + 1] += 1;
    }
    for j in 0..h as usize {
        row_start[j + 1] += row_start[j];
    }
    let mut sorted = vec![(0.0f64, 0i32); crossings.len()];
    {
        let mut next = row_start.clone();
        for &(row, x, d) in &crossings {
            sorted[next[row as usize]] = (x, d);
            next[row as usize] += 1;
        }
    }
    for j in 0..h as usize {
        sort_row_by_x(&mut sorted[row_start[j]..row_start[j + 1]]);
    }
    let mut emit = |mask: &mut Mask, row: u32, xa: f64, xb: f64| {
        let i0 = ceil_i(xa - 0.5).max(0);
        let i1 = if xb.is_finite() {
            floor_i(xb - 0.5).min(w - 1)
        } else {
            w - 1
        };
        if i0 <= i1 {
            mask.set_span(row, i0 as u32, i1 as u32);
            if xb.is_finite() {
                runs.push((row, i0 as u32, i1 as u32));
            }
            any = true;
        }
    };
    for row in 0..h as usize {
        let mut wind = 0i32;
        let mut start = 0.0;
        for &(x, d) in &sorted[row_start[row]..row_start[row + 1]] {
            if wind == 0 {
                start = x;
            }
            wind += d;
            if wind == 0 {
                emit(mask, row as u32, start, x);
            }
        }
        let row = row as u32;
        if wind != 0 {
            // Not closed in this row (only for a chain that is not a cycle): conservative.
            emit(mask, row, start, f64::INFINITY);
        }
    }
    let key = |&(row, a, b): &(u32, u32, u32)| (std::cmp::Reverse(b - a), row, a);
    let far = |c: [f64; 2]| {
        edges.iter().all(|&[p, q]| {
            let d = [q[0] - p[0], q[1] - p[1]];
            let len2 = d[0] * d[0] + d[1] * d[1];
            let t = if len2 > 0.0 {
                (((c[0] - p[0]) * d[0] + (c[1] - p[1]) * d[1]) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (dx, dy) = (c[0] - p[0] - t * d[0], c[1] - p[1] - t * d[1]);
            // NaN (non-finite edges, skipped by the fill) counts as near.
            dx * dx + dy * dy > e * e
        })
    };
    let middle = |&(row, a, b): &(u32, u32, u32)| {
        far([f64::from(a + (b - a) / 2) + 0.5, f64::from(row) + 0.5])
    };
    // The longest run first (it nearly always passes), then the others of the longest
    // `CORE_CANDIDATES`: the same answer as testing those in order, without sorting all.
    let core = match runs.iter().min_by_key(|r| key(r)) {
        None => false,
        Some(r) if middle(r) => true,
        Some(_) => {
            runs.sort_by_key(key);
            runs.iter().take(CORE_CANDIDATES).skip(1).any(middle)
        }
    };
    (any, core)
}

/// Sorts one row's crossings `(x, direction)` by `x`, stably (`total_cmp`): an insertion sort,
/// as a row holds a few crossings, and `sort_by` on long rows.
fn sort_row_by_x(row: &mut [(f64, i32)]) {
    if row.len() > 16 {
        row.sort_by(|a, b| a.0.total_cmp(&b.0));
        return;
    }
    for i in 1..row.len() {
        let mut j = i;
        while j > 0 && row[j - 1].0.total_cmp(&row[j].0) == std::cmp::Ordering::Greater {
            row.swap(j - 1, j);
            j -= 1;
        }
    }
}

/// Transposes a 64 × 64 bit matrix in place (row `k` = word `k`, column `m` = bit `m`): bit
/// `m` of word `k` becomes bit `k` of word `m`. Six steps, each swapping the off-diagonal
/// blocks of half the size (Warren, "Hacker's Delight", §7-3).
fn transpose64(a: &mut [u64; 64]) {
    let mut j = 32usize;
    let mut m: u64 = 0x0000_0000_FFFF_FFFF;
    while j != 0 {
        let mut k = 0usize;
        while k < 64 {
            let t = ((a[k] >> j) ^ a[k + j]) & m;
            a[k + j] ^= t;
            a[k] ^= t << j;
            k = (k + j + 1) & !j;
        }
        j >>= 1;
        m ^= m << j;
    }
}

/// `floor` as an integer for |x| < 2^62, without a libm call.
fn floor_i(x: f64) -> i64 {
    let i = x as i64;
    if (i as f64) > x {
        i - 1
    } else {
        i
    }
}

/// `ceil` as an integer for |x| < 2^62.
fn ceil_i(x: f64) -> i64 {
    -floor_i(-x)
}

#[cfg(test)]
mod tests;
