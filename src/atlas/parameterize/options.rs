//! Options of the parameterize stage ([`super::parameterize_charts`]): the validity bounds of
//! Lévy et al. 2002 §3.3 (stretch or area ratio), the merge-back's passes and size bound, and how
//! each chart is flattened ([`super::FlattenOptions`]).
//!
//! Invariant: [`ParameterizeOptions::check`] rejects meaningless values before any work; no
//! option uses 0 to mean "unlimited" (`Option` does). Units: ratios are plain ratios, fractions
//! are of the mesh's face count, counts are counts.
use super::FlattenOptions;
use super::ParameterizeChartsError;

/// Options of [`parameterize_charts`](super::parameterize_charts).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParameterizeOptions {
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
    /// stretch is the area-weighted quadratic mean of the charts' (as the report measures it), it
    /// is then at most this bound too. Tested on the map the stretch optimisation makes when
    /// [`Self::stretch_optimization`] is on (the chart's global descent runs before the test).
    /// Default `Some(1.07)`.
    pub max_stretch: Option<f64>,
    /// Largest allowed Sander L∞ stretch of a chart (the same scaling as [`Self::max_stretch`]:
    /// the larger of the largest singular value and the inverse of the smallest over its faces),
    /// or `None` for no bound. Ratio `>= 1`. A chart above it is split like one above
    /// `max_stretch`. Default `Some(3.0)`. Trade-off: the L2 bound alone lets a chart keep a
    /// few badly stretched faces (the long tail of L∞ on scans); a lower bound cuts more charts.
    pub max_linf: Option<f64>,
    /// Passes of the merge-back of valid charts into a neighbour (see `merge_back`): the first
    /// pass tries only the small charts, later ones every chart; merging stops early after a
    /// later pass without a merge. A count; 0 disables merging. Default 3. Trade-off: each later
    /// pass removes charts (and raises the global stretch a little, within the bound) for the
    /// cost of flattening unions of large charts; on meshes of more than
    /// [`LATE_MERGE_MAX_FACES`] faces only the first pass runs, since that cost grows with the
    /// mesh.
    pub merge_passes: usize,
    /// Largest chart the merge-back may make, as a fraction of the mesh's faces, or `None` for
    /// no bound: a union with more faces than this fraction (and more than
    /// [`MERGE_CAP_FLOOR_FACES`]) is not tried. Fraction in `(0, 1]`. It does not split
    /// charts: segmentation and validation may leave larger ones. Default `Some(0.10)`.
    /// Trade-off: the union solves of large charts are most of the stage's time and most of
    /// them fail the stretch bound; the bound leaves a few more charts for much less work.
    pub merge_max_chart_fraction: Option<f64>,
    /// How each chart is flattened. Default [`FlattenOptions::default`].
    pub flatten: FlattenOptions,
    /// The stretch optimisation of every valid chart's map, run last (`super::stretch`: a global
    /// descent of the L2 stretch, then optionally Sander et al. 2001's vertex passes). Default
    /// [`StretchOptimization::Global`].
    pub stretch_optimization: StretchOptimization,
    /// Passes of each vertex phase of [`StretchOptimization::LinfL2`] (L∞, then L2), at most; a
    /// phase stops early after a pass without a move. A count in `1..=64` (use
    /// [`StretchOptimization::Global`] for none). Default 4. Trade-off: each pass visits every
    /// vertex of every chart once (the L∞ phase only those near the chart's maximum); later
    /// passes gain less.
    pub stretch_passes: u32,
    /// Which energy the final maps minimise: [`Parameterization::Lscm`] (conformal, the
    /// default) or [`Parameterization::Asp`] (Degener et al. 2003, `super::asp`: after
    /// validation, every valid chart's LSCM map is relaxed for an angle/area trade-off, and kept
    /// only when it still passes the stage's tests).
    pub parameterization: Parameterization,
    /// ASP's θ, the weight of area against angle preservation (`super::asp`): 0 is the MIPS
    /// energy (angles only), larger values keep area at the cost of angles. Dimensionless, in
    /// `[0, ASP_MAX_THETA]`. Default 1 (the paper's "uniform sampling" energy
    /// `σ1² + σ2² + σ1⁻² + σ2⁻²`). Read only with [`Parameterization::Asp`].
    pub asp_theta: f64,
}

/// How the final chart maps are made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Parameterization {
    /// Least squares conformal maps (Lévy et al. 2002): angles kept, area free.
    #[default]
    Lscm,
    /// ASP (Degener et al. 2003): each valid chart's LSCM map relaxed for the energy
    /// `E_angle · E_area^θ` inside the no-flip kernel (`super::asp`).
    Asp,
}

impl Parameterization {
    /// The wire name (`lscm`, `asp`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Lscm => "lscm",
            Self::Asp => "asp",
        }
    }
}

/// Largest accepted [`ParameterizeOptions::asp_theta`]: the paper reports numerical problems
/// (strongly sheared triangles) for high θ, and above it the area term swamps the angle term.
pub const ASP_MAX_THETA: f64 = 8.0;

/// Which stretch optimisation runs on every chart's map after validation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StretchOptimization {
    /// Maps are kept as the parameterizer made them (conformal).
    None,
    /// The global descent of each chart's L2 stretch only (`super::stretch`'s `global`). The
    /// default: it brings the L2 stretch of the scans close to 1 and their area distortion p95
    /// from 1.45–1.6 to 1.14–1.17 for about a third more time on the bunny.
    #[default]
    Global,
    /// The global descent, then Sander et al. 2001's vertex passes: L∞ stretch first, then L2
    /// (`super::stretch`'s module doc), [`ParameterizeOptions::stretch_passes`] of each.
    LinfL2,
}

impl StretchOptimization {
    /// The wire name (`none`, `global`, `linf_l2`).
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Global => "global",
            Self::LinfL2 => "linf_l2",
        }
    }
}

/// Meshes with more faces than this get only the first merge pass
/// ([`ParameterizeOptions::merge_passes`]).
pub const LATE_MERGE_MAX_FACES: usize = 500_000;

/// Unions of at most this many faces are always tried by the merge-back, whatever
/// [`ParameterizeOptions::merge_max_chart_fraction`] says: their solve is cheap, and on small
/// meshes the fraction alone would forbid the merges that undo over-segmentation.
pub const MERGE_CAP_FLOOR_FACES: usize = 4096;

impl Default for ParameterizeOptions {
    fn default() -> Self {
        Self {
            max_area_ratio: None,
            area_ratio_trim: 0.0,
            max_stretch: Some(1.07),
            max_linf: Some(3.0),
            merge_passes: 3,
            merge_max_chart_fraction: Some(0.10),
            flatten: FlattenOptions::default(),
            stretch_optimization: StretchOptimization::Global,
            stretch_passes: 4,
            parameterization: Parameterization::Lscm,
            asp_theta: 1.0,
        }
    }
}

impl ParameterizeOptions {
    /// The paper's validation (§3.3): the max / min area-ratio test with threshold 2 and no
    /// stretch bound.
    pub fn paper() -> Self {
        Self {
            max_area_ratio: Some(2.0),
            area_ratio_trim: 0.0,
            max_stretch: None,
            max_linf: None,
            ..Self::default()
        }
    }

    /// Rejects meaningless values, naming the option and how to fix it.
    pub fn check(&self) -> Result<(), ParameterizeChartsError> {
        if let Some(r) = self.max_area_ratio {
            if !(r >= 1.0 && r.is_finite()) {
                return Err(ParameterizeChartsError::InvalidOption {
                    option: "max_area_ratio",
                    detail: format!("{r} is not a finite ratio >= 1; use e.g. 2.0, or None"),
                });
            }
        }
        if !(self.area_ratio_trim >= 0.0 && self.area_ratio_trim < 0.5) {
            return Err(ParameterizeChartsError::InvalidOption {
                option: "area_ratio_trim",
                detail: format!(
                    "{} is not a fraction in [0, 0.5); use 0 for max / min",
                    self.area_ratio_trim
                ),
            });
        }
        if let Some(r) = self.max_stretch {
            if !(r >= 1.0 && r.is_finite()) {
                return Err(ParameterizeChartsError::InvalidOption {
                    option: "max_stretch",
                    detail: format!("{r} is not a finite ratio >= 1; use e.g. 1.07, or None"),
                });
            }
        }
        if let Some(r) = self.max_linf {
            if !(r >= 1.0 && r.is_finite()) {
                return Err(ParameterizeChartsError::InvalidOption {
                    option: "max_linf",
                    detail: format!("{r} is not a finite ratio >= 1; use e.g. 3, or None"),
                });
            }
        }
        if !(1..=64).contains(&self.stretch_passes) {
            return Err(ParameterizeChartsError::InvalidOption {
                option: "stretch_passes",
                detail: format!(
                    "{} is not a pass count in 1..=64; use e.g. 4, or stretch_optimization none",
                    self.stretch_passes
                ),
            });
        }
        if !(0.0..=ASP_MAX_THETA).contains(&self.asp_theta) {
            return Err(ParameterizeChartsError::InvalidOption {
                option: "asp_theta",
                detail: format!(
                    "{} is not a weight in [0, {ASP_MAX_THETA}]; use e.g. 1.0 (area and angle \
                     alike), 0 for angles only (MIPS), or a larger value to keep area more",
                    self.asp_theta
                ),
            });
        }
        if let Some(f) = self.merge_max_chart_fraction {
            if !(f > 0.0 && f <= 1.0) {
                return Err(ParameterizeChartsError::InvalidOption {
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
