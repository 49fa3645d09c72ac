//! Options of the parameterize stage.
use super::ParameterizeOptions;
use crate::atlas::segment::SegmentError;

/// Options of [`validate_charts`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidateOptions {
    /// The paper's area test (§3.3): largest allowed ratio between the largest and the smallest
    /// per-face area ratio (model area / UV area) within a chart, or `None` for no area test.
    /// Plain ratio `>= 1`. Default `None`: the per-chart stretch bound
    /// [`Self::max_stretch`] replaces it (module doc, "deviation"). `Some(2.0)` with
    /// [`Self::area_ratio_trim`] 0 is the paper's test.
    pub max_area_ratio: Option<f64>,
    /// Fraction of a chart's model area ignored at each end of the distribution of per-face area
    /// ratios by the area test: the ratio is measured between the area-weighted `trim` and
    /// `1 − trim` quantiles instead of the minimum and maximum. Ratio in `[0, 0.5)`. Default 0
    /// (the paper's max / min).
    pub area_ratio_trim: f64,
    /// Largest allowed Sander L2 stretch of a chart (Sander et al. 2001, the chart scaled so
    /// that its UV area equals its model area, as the packer does), or `None` for no bound.
    /// Ratio `>= 1` (1 is isometric). A chart above it is split from its faces of smallest and
    /// largest model area per UV area, like the paper's area test. Since the atlas' global L2
    /// stretch is the area-weighted quadratic mean of the charts' (issue 5 measures it so), it
    /// is then at most this bound too. Default `Some(1.1)` (issue 5's target for the bunny).
    pub max_stretch: Option<f64>,
    /// Passes of the merge-back of valid charts into a neighbour (see `merge_back`): the first
    /// pass tries only the small charts, later ones every chart; merging stops early after a
    /// later pass without a merge. A count; 0 disables merging. Default 3: on the corpus (one
    /// run, release, before [`Self::merge_max_chart_fraction`]) the third pass was the last
    /// that merged anything (4 merges on armadillo, 1 on spot) and more passes changed only
    /// 2CylinderEngine, by one chart. With the default chart size bound, 1, 2 and 3 passes
    /// leave armadillo at 74, 45 and 39 charts (issue 4: at most 40) and bunny at 28, 21 and
    /// 21, for a global L2 stretch of 1.037 → 1.062 (armadillo) and 1.022 → 1.037 (bunny),
    /// within issue 5's 1.10 (one run each, release). The later passes flatten unions of large
    /// charts and cost most of the validation time (without the bound, bunny: about 0.2 s of
    /// CPU for the first pass, 0.8 s for the other two, one thread, machine under load). On
    /// meshes of more than [`LATE_MERGE_MAX_FACES`]
    /// faces only the first pass runs: the later passes' cost grows with the mesh
    /// (beast_sub2_1M, 1.03M faces: 324 → 194 charts for 11.2 → 18.4 s of pipeline, over issue
    /// 5's 15 s).
    pub merge_passes: usize,
    /// Largest chart the merge-back may make, as a fraction of the mesh's faces, or `None` for
    /// no bound: a union with more faces than this fraction (and more than
    /// [`MERGE_CAP_FLOOR_FACES`]) is not tried. Fraction in `(0, 1]`. It does not split
    /// charts: segmentation and validation may leave larger ones. Default `Some(0.10)`.
    ///
    /// Why: the union solves of large charts are most of the validation time and most of them
    /// fail the stretch bound. Measured on bunny (one run, release, one thread, machine under
    /// load): without the bound, 3 passes factor 5.0M complex entries of `L` in all (1.1M for
    /// segmentation's charts, their splits and the first merge pass) and 11 of the 16 tries of
    /// unions above 10,000 faces fail; with 0.10, 1.8M entries, validation 0.9 → 0.35 s, 21
    /// charts instead of 14 at a global L2 stretch of 1.037 instead of 1.053 (issue 4 asks at
    /// most 30 charts in 0.3 s). Armadillo stays at 39 charts (1.062 instead of 1.068); fandisk
    /// 5 → 6 charts; spot, the tube, the torus, the sphere and the cube are unchanged (their
    /// unions stay under the floor).
    pub merge_max_chart_fraction: Option<f64>,
    /// How each chart is flattened. Default [`ParameterizeOptions::default`].
    pub parameterize: ParameterizeOptions,
}

/// Meshes with more faces than this get only the first merge pass
/// ([`ValidateOptions::merge_passes`]).
pub const LATE_MERGE_MAX_FACES: usize = 500_000;

/// Unions of at most this many faces are always tried by the merge-back, whatever
/// [`ValidateOptions::merge_max_chart_fraction`] says: their solve is cheap (a few ms), and on
/// small meshes the fraction would forbid the merges that undo over-segmentation (the 2,304-face
/// tube: 12 segmented charts, 2 after merging; with the fraction alone, 12).
pub const MERGE_CAP_FLOOR_FACES: usize = 4096;

impl Default for ValidateOptions {
    fn default() -> Self {
        Self {
            max_area_ratio: None,
            area_ratio_trim: 0.0,
            max_stretch: Some(1.1),
            merge_passes: 3,
            merge_max_chart_fraction: Some(0.10),
            parameterize: ParameterizeOptions::default(),
        }
    }
}

impl ValidateOptions {
    /// The paper's validation (§3.3): the max / min area-ratio test with threshold 2 and no
    /// stretch bound.
    pub fn paper() -> Self {
        Self {
            max_area_ratio: Some(2.0),
            area_ratio_trim: 0.0,
            max_stretch: None,
            ..Self::default()
        }
    }

    /// Rejects meaningless values, naming the option and how to fix it.
    pub fn check(&self) -> Result<(), SegmentError> {
        if let Some(r) = self.max_area_ratio {
            if !(r >= 1.0 && r.is_finite()) {
                return Err(SegmentError::InvalidOption {
                    option: "max_area_ratio",
                    detail: format!("{r} is not a finite ratio >= 1; use e.g. 2.0, or None"),
                });
            }
        }
        if !(self.area_ratio_trim >= 0.0 && self.area_ratio_trim < 0.5) {
            return Err(SegmentError::InvalidOption {
                option: "area_ratio_trim",
                detail: format!(
                    "{} is not a fraction in [0, 0.5); use 0 for max / min",
                    self.area_ratio_trim
                ),
            });
        }
        if let Some(r) = self.max_stretch {
            if !(r >= 1.0 && r.is_finite()) {
                return Err(SegmentError::InvalidOption {
                    option: "max_stretch",
                    detail: format!("{r} is not a finite ratio >= 1; use e.g. 1.1, or None"),
                });
            }
        }
        if let Some(f) = self.merge_max_chart_fraction {
            if !(f > 0.0 && f <= 1.0) {
                return Err(SegmentError::InvalidOption {
                    option: "merge_max_chart_fraction",
                    detail: format!(
                        "{f} is not a fraction in (0, 1]; use e.g. 0.1, or None for no bound"
                    ),
                });
            }
        }
        Ok(())
    }
}
