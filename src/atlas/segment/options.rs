//! Options of the segmentation stage ([`super::segment_charts`]).
//!
//! Purpose: every knob of the segmentation with its unit, default and meaning, behind a
//! [`SegmentMethod`] enum: the LSCM-paper method (Lévy et al. 2002, §3.1–§3.2,
//! [`Lscm2002Options`]) and the stretch-driven spectral method of Iso-charts (Zhou et al. 2004,
//! §4–5, [`StretchSegmentOptions`]), each with its own option block.
//!
//! Invariants: [`SegmentOptions::check`] rejects values that make no sense (a fraction outside
//! `(0, 1]`, a zero string length); no option uses 0 to mean "unlimited" (`Option` does).
//!
//! Units: fractions are plain ratios in `(0, 1]`; lengths are counts of mesh edges.
//!
//! References: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least Squares Conformal Maps for
//! Automatic Texture Atlas Generation", SIGGRAPH 2002, §3.1 (feature fraction 5 %,
//! `max_string_length` 5, `min_feature_length` 15) and §3.2 (ε = maxdist / 4).
use super::SegmentError;

/// Which segmentation algorithm cuts the mesh into charts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SegmentMethod {
    /// Feature detection + multi-source chart growing of the LSCM paper (§3.1–§3.2), followed by
    /// the disk guarantee. Tuned by [`SegmentOptions::lscm`].
    #[default]
    Lscm2002,
    /// Stretch-driven spectral segmentation of Iso-charts (Zhou et al. 2004, §4–5,
    /// `spectral.rs`): landmark geodesics, landmark MDS, spectral clustering, each chart split
    /// again while its flattening's L2 stretch is above [`StretchSegmentOptions::max_stretch`].
    /// Tuned by [`SegmentOptions::stretch`].
    Stretch,
}

impl SegmentMethod {
    /// The wire name (`features`, `stretch`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Lscm2002 => "features",
            Self::Stretch => "stretch",
        }
    }
}

/// Options of the stretch-driven method ([`SegmentMethod::Stretch`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StretchSegmentOptions {
    /// A chart is split again while the Sander L2 stretch of its flattening (the chart scaled to
    /// UV area = model area) is above this; the parameterize stage's merge-back then keeps it
    /// too (the pipeline bounds its `max_stretch` by it). Ratio `>= 1`. Default `1.03`.
    pub max_stretch: f64,
    /// Landmarks of the landmark MDS per chart (Iso-charts §6 uses 100, UVAtlas 25). At least
    /// 3. Default `25`.
    pub landmarks: usize,
    /// A chart with fewer faces than this is not split for stretch (it is still made a disk).
    /// At least 2. Default `32`.
    pub min_split_faces: usize,
}

impl Default for StretchSegmentOptions {
    fn default() -> Self {
        Self {
            max_stretch: 1.03,
            landmarks: 25,
            min_split_faces: 32,
        }
    }
}

/// Options of the LSCM-paper method ([`SegmentMethod::Lscm2002`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lscm2002Options {
    /// Fraction of the mesh's interior edges (with a defined dihedral angle) whose sharpness is at
    /// least the feature threshold τ, i.e. τ is the `1 − feature_fraction` quantile of sharpness.
    /// Ratio in `(0, 1]`. Default `0.05` (the paper keeps 5 % of the edges).
    pub feature_fraction: f64,
    /// Length of the look-ahead strings of Algorithm 1, in edges: gaps shorter than this along a
    /// feature are bridged. At least 1. Default `5`.
    pub max_string_length: usize,
    /// A grown feature curve is kept only when it has more than this many edges; shorter ones are
    /// treated as noise. Default `15`.
    pub min_feature_length: usize,
    /// Merge threshold ε of Algorithm 2 as a fraction of `maxdist`, the largest
    /// distance-to-features on the mesh: two charts merge when they meet at a face whose distance
    /// is within ε of both charts' largest distance (i.e. close to both seeds). Ratio `>= 0`;
    /// 0 disables merging. Default `0.25` (ε = maxdist / 4).
    pub merge_epsilon_fraction: f64,
    /// Hard-edge angle: on a connected component where Algorithm 1 keeps no feature curve, every
    /// edge whose sharpness (angle between its faces' normals) is at least this, and that lies
    /// on a connected set of at least [`super::features::MIN_HARD_CHAIN_EDGES`] such edges, is a
    /// feature edge by itself; `None` for Algorithm 1 alone. Radians in `(0, π]`. Default
    /// `Some(π/3)` (60°). Why: Algorithm 1 is made for dense meshes; on a low-poly mesh a crease
    /// is a handful of edges, shorter than `min_feature_length` and than the
    /// `max_string_length` look-ahead, so a 12-triangle cube had no feature at all and was cut
    /// by the diameter rule into two star-shaped charts (packing 0.365); with hard edges it gets
    /// its 6 sides. A crease of 60° or more is a natural seam whatever the tessellation.
    pub hard_edge_angle_rad: Option<f64>,
}

/// The default of [`Lscm2002Options::hard_edge_angle_rad`] (60°), also the angle from which the
/// border smoothing of a two-way split treats an edge as hard.
pub const DEFAULT_HARD_EDGE_ANGLE_RAD: f64 = std::f64::consts::FRAC_PI_3;

impl Default for Lscm2002Options {
    fn default() -> Self {
        Self {
            feature_fraction: 0.05,
            max_string_length: 5,
            min_feature_length: 15,
            merge_epsilon_fraction: 0.25,
            hard_edge_angle_rad: Some(DEFAULT_HARD_EDGE_ANGLE_RAD),
        }
    }
}

/// Options of [`super::segment_charts`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SegmentOptions {
    /// The algorithm. Default [`SegmentMethod::Lscm2002`].
    pub method: SegmentMethod,
    /// Tuning of [`SegmentMethod::Lscm2002`] (ignored by other methods).
    pub lscm: Lscm2002Options,
    /// Tuning of [`SegmentMethod::Stretch`] (ignored by other methods).
    pub stretch: StretchSegmentOptions,
    /// Upper bound on the number of charts, or `None` for no bound (default). Best effort: once
    /// the charts are grown, adjacent charts are merged, smallest first, while the merged chart is
    /// still a disk and there are more charts than the bound. The disk guarantee always wins, so
    /// a mesh with more connected components than the bound still gets one chart per component.
    pub max_charts: Option<usize>,
    /// Graph-cut border optimisation (Iso-charts §5.2, `graph_cut.rs`): the medial band around
    /// the border of each pair of adjacent charts takes up to this fraction of each chart's
    /// area, and the border moves to the band's minimum cut (short borders on sharp edges).
    /// `None` keeps the borders as grown. Ratio in `(0, 1)`; the paper's medial region is 30 %
    /// of the unsplit patch. Default `None`: on the corpus it shortens seams (bunny
    /// `seam_edge_ratio` 11.8 → 10.6, 2CylinderEngine 90 → 69) and lowers L∞ on the scans
    /// (bunny 3.95 → 2.81), but raises the chart count after validation on armadillo, spot and
    /// DepthOfField and lowers bunny's packing (0.66 → 0.63), so it is opt-in until the
    /// stretch-driven segmentation gives it the paper's distortion term. With
    /// [`SegmentMethod::Stretch`] the cut runs on the border of every split as it is made, with
    /// the paper's distortion term on binary splits (`spectral.rs`), instead of once at the end.
    pub border_band_fraction: Option<f64>,
}

impl SegmentOptions {
    /// Rejects meaningless values, naming the option and how to fix it.
    pub fn check(&self) -> Result<(), SegmentError> {
        let l = &self.lscm;
        let bad = |option: &'static str, detail: String| {
            Err(SegmentError::InvalidOption { option, detail })
        };
        if !(l.feature_fraction > 0.0 && l.feature_fraction <= 1.0) {
            return bad(
                "lscm.feature_fraction",
                format!("{} is not in (0, 1]; use e.g. 0.05", l.feature_fraction),
            );
        }
        if l.max_string_length == 0 {
            return bad(
                "lscm.max_string_length",
                "0 edges; use at least 1 (default 5)".into(),
            );
        }
        if !(l.merge_epsilon_fraction >= 0.0 && l.merge_epsilon_fraction.is_finite()) {
            return bad(
                "lscm.merge_epsilon_fraction",
                format!(
                    "{} is not a finite ratio >= 0; use e.g. 0.25",
                    l.merge_epsilon_fraction
                ),
            );
        }
        if let Some(a) = l.hard_edge_angle_rad {
            if !(a > 0.0 && a <= std::f64::consts::PI) {
                return bad(
                    "lscm.hard_edge_angle_rad",
                    format!("{a} rad is not in (0, π]; use e.g. π/3 (60°), or None"),
                );
            }
        }
        if let Some(b) = self.border_band_fraction {
            if !(b > 0.0 && b < 1.0) {
                return bad(
                    "border_band_fraction",
                    format!("{b} is not in (0, 1); use e.g. 0.3, or None to keep grown borders"),
                );
            }
        }
        let st = &self.stretch;
        if !(st.max_stretch >= 1.0 && st.max_stretch.is_finite()) {
            return bad(
                "stretch.max_stretch",
                format!(
                    "{} is not a finite ratio >= 1; use e.g. 1.03",
                    st.max_stretch
                ),
            );
        }
        if st.landmarks < 3 {
            return bad(
                "stretch.landmarks",
                format!("{} landmarks; use at least 3 (default 25)", st.landmarks),
            );
        }
        if st.min_split_faces < 2 {
            return bad(
                "stretch.min_split_faces",
                format!("{} faces; use at least 2 (default 32)", st.min_split_faces),
            );
        }
        if self.max_charts == Some(0) {
            return bad(
                "max_charts",
                "Some(0) allows no chart; use None for no bound or a positive count".into(),
            );
        }
        Ok(())
    }
}
