//! Every option of [`super::generate`], grouped by stage, each with its unit, default and
//! meaning documented where it is defined.
//!
//! The wire forms (`crate::api`, `proto/options.schema.json`, CLI flags, HTTP query parameters)
//! use flat names and map onto these fields one to one; see `crate::api::OptionsJson`.
//!
//! Invariant: no option uses 0 to mean "unlimited" (`Option` does); [`AtlasOptions::check`]
//! rejects meaningless values before any work starts, naming the option and what to use.
use super::pack::{PackOptions, TexelDensity};
use super::segment::{SegmentOptions, ValidateOptions};
use super::AtlasError;

/// Options of the whole pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AtlasOptions {
    /// Chart segmentation (LSCM paper §3.1–3.2): feature fraction, string lengths, merge ε,
    /// optional chart cap.
    pub segment: SegmentOptions,
    /// Chart validation (§3.3) and the parameterizer it runs: stretch bound, area-ratio test,
    /// merge passes, solver.
    pub validate: ValidateOptions,
    /// Packing: page resolution, padding, texel density, rotations.
    pub pack: PackOptions,
}

/// Largest page side accepted, in texels: the packer's own bound.
pub const MAX_PAGE_SIDE_TEXELS: u32 = super::pack::MAX_PAGE_TEXELS;

impl AtlasOptions {
    /// Rejects meaningless values (module doc). Called by [`super::generate`].
    pub fn check(&self) -> Result<(), AtlasError> {
        self.segment.check().map_err(AtlasError::from)?;
        self.validate.check().map_err(AtlasError::from)?;
        let p = &self.pack;
        for (name, side) in [
            ("width_texels", p.width_texels),
            ("height_texels", p.height_texels),
        ] {
            if side == 0 || side > MAX_PAGE_SIDE_TEXELS {
                return Err(invalid(
                    name,
                    format!("{side} texels is outside 1..={MAX_PAGE_SIDE_TEXELS}; use e.g. 1024"),
                ));
            }
        }
        let min_side = p.width_texels.min(p.height_texels);
        if u64::from(p.padding_texels) * 2 + 1 > u64::from(min_side) {
            return Err(invalid(
                "padding_texels",
                format!(
                    "{} texels leaves no room on a {}×{} page; use a padding below {}",
                    p.padding_texels,
                    p.width_texels,
                    p.height_texels,
                    min_side.div_ceil(2)
                ),
            ));
        }
        if p.rotations == 0 || p.rotations > super::pack::MAX_ROTATIONS {
            return Err(invalid(
                "rotations",
                format!(
                    "{} is outside 1..={}; use 1 (no rotation) to 16",
                    p.rotations,
                    super::pack::MAX_ROTATIONS
                ),
            ));
        }
        if let TexelDensity::TexelsPerUnit(d) = p.density {
            if !(d > 0.0 && d.is_finite()) {
                return Err(invalid(
                    "texels_per_unit",
                    format!("{d} is not a finite density > 0; use e.g. 256, or leave it unset to fit the page"),
                ));
            }
        }
        Ok(())
    }
}

fn invalid(option: &'static str, detail: String) -> AtlasError {
    AtlasError::InvalidOption { option, detail }
}
