//! Every option of [`super::generate`], grouped by stage, each with its unit, default and
//! meaning documented where it is defined.
//!
//! The wire forms (`crate::api`, `proto/options.schema.json`, CLI flags, HTTP query parameters)
//! use flat names and map onto these fields one to one; see `crate::api::OptionsJson`.
//!
//! Invariant: no option uses 0 to mean "unlimited" (`Option` does); [`AtlasOptions::check`]
//! rejects meaningless values before any work starts, naming the option and what to use.
use super::pack::PackOptions;
use super::parameterize::ParameterizeOptions;
use super::segment::SegmentOptions;
use super::AtlasError;

/// Options of the whole pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AtlasOptions {
    /// Chart segmentation (LSCM paper §3.1–3.2): feature fraction, string lengths, merge ε,
    /// optional chart cap.
    pub segment: SegmentOptions,
    /// Chart validation (§3.3) and the parameterizer it runs: stretch bound, area-ratio test,
    /// merge passes, solver.
    pub parameterize: ParameterizeOptions,
    /// Packing: page resolution, padding, texel density, rotations.
    pub pack: PackOptions,
}

/// Largest page side accepted, in texels: the packer's own bound.
pub const MAX_PAGE_SIDE_TEXELS: u32 = super::pack::MAX_PAGE_TEXELS;

impl AtlasOptions {
    /// Rejects meaningless values (module doc). Called by [`super::generate`].
    pub fn check(&self) -> Result<(), AtlasError> {
        self.segment.check().map_err(AtlasError::from)?;
        self.parameterize.check().map_err(AtlasError::from)?;
        self.pack.check().map_err(AtlasError::from)?;
        Ok(())
    }
}
