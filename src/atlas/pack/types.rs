//! The pack stage's contract: its options, the chart it takes, the packing it returns and its
//! errors. Units as in [`super`]: chart UVs in model units, placed UVs in \[0,1\]², sizes in
//! texels, densities in texels per model unit.

/// How big charts are on the page.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TexelDensity {
    /// The largest uniform density at which every chart fits on one page. The default.
    FitToPage,
    /// A fixed density in texels per model unit (`> 0`, finite); more pages open when the charts
    /// do not fit on one.
    TexelsPerUnit(f64),
}

/// Which packer a [`TexelDensity::FitToPage`] packing searches the density with first; the
/// other packer then runs only to beat the density found, and the denser packing is kept.
/// Ignored with [`TexelDensity::TexelsPerUnit`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FirstPacker {
    /// Hole filling ([`hole`](super::hole)), then the horizons, for fewer than
    /// [`HOLE_SCORED_MIN_CHARTS`](super::HOLE_SCORED_MIN_CHARTS) charts, where hole filling is
    /// the plain first fit, whose trials cost about as much as the horizons'; more charts
    /// search as [`FirstPacker::Horizons`]. The default. Trade-off: on the large meshes
    /// measured, hole filling packed such charts as densely or more (bunny 0.602 → 0.620), and
    /// the horizons' full search, which hole filling then beat anyway, is not paid (armadillo's
    /// pack stage 0.77×). The contact-scored search of many charts costs up to 10× a horizons
    /// trial, and started from the horizons' density it found denser packings than from the
    /// fill density (beast_sub2_1M 0.769 against 0.751).
    #[default]
    HoleFilling,
    /// The horizons ([`horizon`](super::horizon)), then hole filling only where they leave the
    /// page sparse ([`HOLE_FILL_BELOW`](super::HOLE_FILL_BELOW),
    /// [`HOLE_FILL_BELOW_FEW_CHARTS`](super::HOLE_FILL_BELOW_FEW_CHARTS)). The packing-aware
    /// cuts search this way: their choices of cuts were measured with it.
    Horizons,
}

/// Options of [`pack_charts`](super::pack_charts).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PackOptions {
    /// Page width in texels, `>= 1`. Default 1024.
    pub width_texels: u32,
    /// Page height in texels, `>= 1`. Default 1024.
    pub height_texels: u32,
    /// Empty texels kept between any two charts and between a chart and the page edge. Default 2.
    pub padding_texels: u32,
    /// Texel density. Default [`TexelDensity::FitToPage`].
    pub density: TexelDensity,
    /// Rotations tried per chart, evenly spaced over a full turn after orienting the chart's
    /// maximum diameter vertically (a nearly rectangular chart: its minimum-area rectangle
    /// axis-aligned, and at most the 4 quarter turns, or the 8 eighth turns for a strip long
    /// for the page, see
    /// [`chart_rotations`](super::chart_rotations)); `1` means the base orientation only. `>= 1`.
    /// Default 16 (isocharts-2004 §6). Charts smaller than
    /// [`SMALL_CHART_TEXELS`](super::SMALL_CHART_TEXELS) try at most the 4 quarter turns when
    /// this is a multiple of 4, except when the charts are packed again with hole filling
    /// ([`hole`](super::hole)), where every chart tries
    /// [`hole_rotations`](super::hole_rotations) (24 for 16) when there are at least
    /// [`HOLE_SCORED_MIN_CHARTS`](super::HOLE_SCORED_MIN_CHARTS) charts. A multiple of 8 is
    /// also raised to 1.5 and 2 times itself by the last tries of the packing-aware cuts, on
    /// fewer than [`HOLE_SCORED_MIN_CHARTS`](super::HOLE_SCORED_MIN_CHARTS) charts that pack
    /// below their target (`atlas::packing_cuts`).
    pub rotations: u32,
    /// The packer a fit-to-page density search runs first. Default
    /// [`FirstPacker::HoleFilling`].
    pub first_packer: FirstPacker,
}

impl Default for PackOptions {
    fn default() -> Self {
        Self {
            width_texels: 1024,
            height_texels: 1024,
            padding_texels: 2,
            density: TexelDensity::FitToPage,
            rotations: 16,
            first_packer: FirstPacker::HoleFilling,
        }
    }
}

/// One flattened chart to place.
#[derive(Debug, Clone, Copy)]
pub struct PackChart<'a> {
    /// UV per chart vertex in model units (any similarity of the final shape).
    pub uv: &'a [[f64; 2]],
    /// Triangles as indices into `uv`.
    pub triangles: &'a [[u32; 3]],
    /// The chart's 3-D surface area, model units². With `uv` it fixes the chart's scale:
    /// placed UV area = area_m2 × density² (in texels²).
    pub area_m2: f64,
}

/// A placed chart.
#[derive(Debug, Clone, PartialEq)]
pub struct PlacedChart {
    /// The page it is on, `0..Packing::num_pages`.
    pub page: u32,
    /// UV per chart vertex, normalized page coordinates in \[0,1\]².
    pub uv: Vec<[f64; 2]>,
}

/// The result of [`pack_charts`](super::pack_charts).
#[derive(Debug, Clone, PartialEq)]
pub struct Packing {
    /// One entry per input chart, same order.
    pub charts: Vec<PlacedChart>,
    /// Pages used (1 with [`TexelDensity::FitToPage`]).
    pub num_pages: u32,
    /// The density used, texels per model unit.
    pub texels_per_unit: f64,
    /// Packings run to find the density (1 with [`TexelDensity::TexelsPerUnit`]); a cost
    /// diagnostic for reports and benchmarks.
    pub trials: u32,
}

/// Errors of [`pack_charts`](super::pack_charts); each says what to change.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PackError {
    /// An option has a meaningless value.
    #[error("invalid packing option `{option}`: {detail}")]
    InvalidOption {
        /// The option's name, e.g. `padding_texels`.
        option: &'static str,
        /// What is wrong and what to use instead.
        detail: String,
    },
    /// A chart cannot fit on a page even alone.
    #[error("chart {chart} needs {needed_texels:?} texels (with padding) but a page has {page_texels:?}; lower texels_per_unit or raise the resolution")]
    ChartTooLarge {
        /// Index of the chart.
        chart: usize,
        /// Width and height it needs.
        needed_texels: [u64; 2],
        /// Page size.
        page_texels: [u32; 2],
    },
    /// A chart's data is unusable.
    #[error("chart {chart} cannot be packed: {detail}")]
    InvalidChart {
        /// Index of the chart.
        chart: usize,
        /// What is wrong and how to fix it.
        detail: String,
    },
    /// With [`TexelDensity::FitToPage`]: even at a density where every chart is one texel, the
    /// charts and their padding do not fit on one page.
    #[error("{charts} charts with {padding_texels} texels of padding do not fit on one {page_texels:?} page at any density; raise the resolution, lower padding_texels, or use TexelsPerUnit (more pages)")]
    DoesNotFit {
        /// Number of charts to place.
        charts: usize,
        /// Page size.
        page_texels: [u32; 2],
        /// Padding asked for.
        padding_texels: u32,
    },
    /// The monitor asked to stop.
    #[error("packing was cancelled")]
    Cancelled,
}
