//! [`AtlasError`], the one error type of [`generate`](super::generate), and its conversions
//! from the stages' errors.

use super::pack::PackError;
use super::parameterize::ParameterizeChartsError;
use super::progress::Stage;
use super::segment::SegmentError;

/// Errors of [`generate`](super::generate). Each says what is wrong and how to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AtlasError {
    /// An option has a meaningless value.
    #[error("invalid option `{option}`: {detail}")]
    InvalidOption {
        /// The option's name, as on the wire (e.g. `padding_texels`).
        option: &'static str,
        /// What is wrong and what to use instead.
        detail: String,
    },
    /// The caller's [`Progress`](super::Progress) asked to stop.
    #[error("cancelled during the {} stage", .stage.name())]
    Cancelled {
        /// The stage that was running.
        stage: Stage,
    },
    /// A chart could not be flattened (e.g. all its triangles have zero area).
    #[error("chart {chart} ({faces} faces) could not be flattened: {detail}; repair or remove the degenerate triangles")]
    Unparameterizable {
        /// Index of the chart in the validated segmentation.
        chart: usize,
        /// Its face count.
        faces: usize,
        /// The parameterizer's reason.
        detail: String,
    },
    /// Packing failed (e.g. one chart is larger than a page at the requested density).
    #[error("packing failed: {0}")]
    Pack(PackError),
}

impl From<SegmentError> for AtlasError {
    fn from(e: SegmentError) -> Self {
        match e {
            SegmentError::InvalidOption { option, detail } => {
                AtlasError::InvalidOption { option, detail }
            }
            // Only `generate`'s own stages can be cancelled, and it maps this with the stage.
            SegmentError::Cancelled => AtlasError::Cancelled {
                stage: Stage::Segment,
            },
        }
    }
}

impl From<ParameterizeChartsError> for AtlasError {
    fn from(e: ParameterizeChartsError) -> Self {
        match e {
            ParameterizeChartsError::InvalidOption { option, detail } => {
                AtlasError::InvalidOption { option, detail }
            }
            ParameterizeChartsError::Cancelled => AtlasError::Cancelled {
                stage: Stage::Parameterize,
            },
        }
    }
}

impl From<PackError> for AtlasError {
    fn from(e: PackError) -> Self {
        match e {
            // The packer names its options as the wire does, but for the density field.
            PackError::InvalidOption { option, detail } => AtlasError::InvalidOption {
                option: if option == "density" {
                    "texels_per_unit"
                } else {
                    option
                },
                detail,
            },
            PackError::Cancelled => AtlasError::Cancelled { stage: Stage::Pack },
            other => AtlasError::Pack(other),
        }
    }
}
