//! Which rotations each chart tries in one packing ([`chart_rotations`]): fewer for charts
//! whose other angles cannot pay (rectangles, tiny charts), more where they can (hole filling,
//! strips long for the page).

use super::{place, MAX_ROTATIONS};

/// Charts whose placed UV area is below this many texels² try only the quarter turns of the
/// diameter-vertical orientation (when `rotations` is a multiple of 4): a subset of the
/// angles, a quarter of the search. Not when the charts are packed again with hole filling
/// ([`super::hole`]): there a small chart goes into a gap between placed charts, where the angle
/// matters. Trade-off: such charts are a few texels across, where finer angles change the
/// packing little, and they can number thousands, so the search is several times faster.
pub const SMALL_CHART_TEXELS: f64 = 1024.0;

/// A [`place::PreparedChart::rectangular`] chart whose minimum-area rectangle is at least this
/// many times longer than wide, and at least [`DIAGONAL_MIN_PAGE_FRACTION`] of the page's longer
/// side long, also tries its eighth turns ([`chart_rotations`]): a strip laid along the page's
/// diagonal can be up to √2 times longer than one laid along a side, and parallel strips stack
/// along the diagonal as well as along a side. Only a strip that long sets the density; a
/// strip of aspect below about 2.4 (`1 + √2`) has a larger box turned an eighth than
/// axis-aligned. Trade-off: twice the orientations for the few charts that long. Measured on
/// strips that no cut can shorten (one triangle spans their whole length, 2026-12-07):
/// long_plank_one_ring 0.117 → 0.189, long_tubes_3_one_ring 0.270 → 0.452.
pub const DIAGONAL_MIN_ASPECT: f64 = 3.0;
/// See [`DIAGONAL_MIN_ASPECT`]: the length from which a rectangular chart is long for the page,
/// as a fraction of the page's longer side.
pub const DIAGONAL_MIN_PAGE_FRACTION: f64 = 0.7;

/// The rotations tried by the packing with hole filling ([`super::hole`]) for `rotations` asked:
/// half as many again (16 → 24) when `rotations` is a multiple of 8 (so that the quarter
/// turns still share footprints) and that stays within [`MAX_ROTATIONS`]; otherwise
/// `rotations`. Trade-off: hole filling places each chart in a gap of the page, where more
/// angles find more fits, at a search cost proportional to the angles.
pub fn hole_rotations(rotations: u32) -> u32 {
    let more = rotations + rotations / 2;
    if rotations % 8 == 0 && more <= MAX_ROTATIONS {
        more
    } else {
        rotations
    }
}

/// The rotations a chart tries in one packing, for `rotations` asked: the quarter turns of
/// its axis-aligned base orientation for a [`place::PreparedChart::rectangular`] chart (when
/// `rotations` is a multiple of 4, and not in a `scored` hole-filling packing, where a
/// rectangle turned to fit a gap between many charts pays), and the eighth turns (8) instead
/// when it is long for the page (`rotations` a multiple of 8: [`DIAGONAL_MIN_ASPECT`],
/// [`DIAGONAL_MIN_PAGE_FRACTION`] of `page_texels`' longer side at `texels_per_unit`); the
/// quarter turns of the diameter-vertical orientation for a chart below [`SMALL_CHART_TEXELS`]
/// at `texels_per_unit` (same condition, and not when filling `holes`); [`hole_rotations`] in
/// a `scored` hole-filling packing; else `rotations`.
pub fn chart_rotations(
    prep: &place::PreparedChart,
    texels_per_unit: f64,
    rotations: u32,
    holes: bool,
    scored: bool,
    page_texels: [u32; 2],
) -> u32 {
    let texels = prep.area_m2 * texels_per_unit * texels_per_unit;
    let small = texels < SMALL_CHART_TEXELS && !holes;
    if rotations % 4 == 0 && ((prep.rectangular && !scored) || small) {
        let [long, short] = prep.box_sides_m.map(|m| m * texels_per_unit);
        let page_side = f64::from(page_texels[0].max(page_texels[1]));
        let diagonal = !small
            && rotations % 8 == 0
            && long >= DIAGONAL_MIN_ASPECT * short
            && long >= DIAGONAL_MIN_PAGE_FRACTION * page_side;
        if diagonal {
            8
        } else {
            rotations.min(4)
        }
    } else if scored {
        hole_rotations(rotations)
    } else {
        rotations
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atlas::pack::PackChart;

    /// A `w × h` rectangle of two triangles (model units), its UVs at half scale and turned by
    /// 0.5 rad; its prepared sides agree with [`place::box_sides_m`].
    fn rectangle(w: f64, h: f64) -> place::PreparedChart {
        let (s, c) = 0.5f64.sin_cos();
        let uv = [[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]]
            .map(|[x, y]| [0.5 * (c * x - s * y), 0.5 * (s * x + c * y)]);
        let triangles = [[0, 1, 2], [0, 2, 3]];
        let chart = PackChart {
            uv: &uv,
            triangles: &triangles,
            area_m2: w * h,
        };
        let prep = place::prepare_chart(0, &chart).unwrap();
        let expected = place::box_sides_m(&chart);
        for (got, want) in prep.box_sides_m.iter().zip(expected) {
            assert!((got - want).abs() < 1e-9 * want, "{got} against {want}");
        }
        prep
    }

    /// A rectangular strip tries its eighth turns only when it is long for the page at the
    /// density, long and thin enough, and 45° is among the angles asked for.
    #[test]
    fn only_strips_long_for_the_page_try_the_eighth_turns() {
        let square = [1024, 1024];
        let strip = rectangle(20.0, 1.0);
        assert!(strip.rectangular);
        assert_eq!(strip.box_sides_m.map(|m| m.round()), [20.0, 1.0]);
        // 0.7 · 1024 texels: 35.84 texels per metre for 20 m.
        assert_eq!(chart_rotations(&strip, 36.0, 16, false, false, square), 8);
        assert_eq!(chart_rotations(&strip, 35.0, 16, false, false, square), 4);
        // The plain first fit of hole filling too; the scored search tries 24 angles anyway.
        assert_eq!(chart_rotations(&strip, 36.0, 16, true, false, square), 8);
        assert_eq!(chart_rotations(&strip, 36.0, 16, true, true, square), 24);
        // 45° is not among 12 angles.
        assert_eq!(chart_rotations(&strip, 36.0, 12, false, false, square), 4);
        // Long for the longer side of the page.
        assert_eq!(
            chart_rotations(&strip, 36.0, 16, false, false, [2048, 512]),
            4
        );
        assert_eq!(
            chart_rotations(&strip, 72.0, 16, false, false, [2048, 512]),
            8
        );
        // Aspect 2.5: its box turned an eighth is larger than axis-aligned.
        let wide = rectangle(20.0, 8.0);
        assert!(wide.rectangular);
        assert_eq!(chart_rotations(&wide, 36.0, 16, false, false, square), 4);
        // A chart that is not rectangular tries every angle.
        let mut l_shape = rectangle(20.0, 1.0);
        l_shape.rectangular = false;
        l_shape.box_sides_m = [0.0; 2];
        assert_eq!(
            chart_rotations(&l_shape, 36.0, 16, false, false, square),
            16
        );
    }
}
