//! The options of one unwrap on the wire ↔ `proto/options.schema.json`.
//!
//! One flat object whose names are the CLI flags (`--padding-texels` ↔ `padding_texels`), the
//! HTTP query parameters and the multipart `options` part. Every field is optional; a missing
//! field takes the default of the domain option it maps to ([`AtlasOptions`]). Unknown fields are
//! refused, so a typo is an error rather than a silently ignored option.
use serde::{Deserialize, Serialize};

use crate::atlas::parameterize::{Parameterization, ParameterizeMethod, StretchOptimization};
use crate::atlas::segment::SegmentMethod;
use crate::atlas::{AtlasError, AtlasOptions, TexelDensity};
use crate::gltf_io::{OutputFormat, UvTarget};

/// Page size: one side for a square page, or `[width, height]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ResolutionJson {
    /// A square page of this many texels per side.
    Square(u32),
    /// `[width, height]` in texels.
    Rect([u32; 2]),
}

impl ResolutionJson {
    /// `[width, height]` in texels.
    pub fn texels(self) -> [u32; 2] {
        match self {
            ResolutionJson::Square(s) => [s, s],
            ResolutionJson::Rect(r) => r,
        }
    }
}

/// Which solver flattens the charts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SolverJson {
    /// Direct for charts below 2^20 (about 1M) vertices, hierarchical (HLSCM) above.
    #[default]
    Auto,
    /// Sparse Cholesky.
    Direct,
    /// HLSCM (cascadic multigrid over a progressive mesh).
    Hierarchical,
}

/// Which stretch optimisation runs on every chart's map after validation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum StretchOptimizationJson {
    /// None: the conformal (LSCM) maps as they are.
    None,
    /// The global descent of each chart's L2 stretch (all vertices at once, never flipping).
    /// The default.
    #[default]
    Global,
    /// The global descent, then Sander et al. 2001's vertex moves: L∞ stretch first, then L2.
    LinfL2,
}

/// How the final chart maps are made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ParameterizationJson {
    /// Least squares conformal maps (the default).
    #[default]
    Lscm,
    /// ASP (Degener et al. 2003): the LSCM maps relaxed for the angle/area energy with θ =
    /// `asp_theta`.
    Asp,
}

/// Which segmentation cuts the mesh into charts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SegmentationJson {
    /// Feature curves and chart growing (Lévy et al. 2002 §3; the default).
    #[default]
    Features,
    /// Stretch-driven spectral segmentation (Iso-charts, Zhou et al. 2004 §4–5), bounded by
    /// `segmentation_max_stretch`.
    Stretch,
}

/// Where the atlas UVs go.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum UvSetJson {
    /// `"first_free"`: the lowest set that no triangle primitive of the asset has (`TEXCOORD_0`
    /// when none has UVs), one set for every primitive.
    Named(UvSetName),
    /// Replace `TEXCOORD_k` on every triangle primitive (added where a primitive lacks it).
    Index(u32),
}

/// The one named UV-set choice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UvSetName {
    /// See [`UvSetJson::Named`].
    FirstFree,
}

/// The container of the result.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum OutputFormatJson {
    /// Binary glTF.
    #[default]
    Glb,
    /// JSON glTF with one embedded `data:` buffer.
    Gltf,
}

/// The options of one unwrap (module doc). `None` means "the default".
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OptionsJson {
    /// Page size in texels, default 1024 (square), at most 16384 per side.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution: Option<ResolutionJson>,
    /// Empty texels between charts and from the page edge, default 2.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub padding_texels: Option<u32>,
    /// Fixed texel density in texels per model unit; unset fits everything on one page.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texels_per_unit: Option<f64>,
    /// Rotations tried per chart when packing, 1..=64, default 16 (a multiple of 8 up to twice as
    /// many on an atlas of fewer than 33 charts that packs below 0.72).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotations: Option<u32>,
    /// Upper bound on the number of charts after segmentation (best effort); unset: no bound.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_charts: Option<usize>,
    /// Largest Sander L2 stretch of a chart before validation splits it, ≥ 1. Absent: 1.07;
    /// `null`: no stretch bound.
    #[serde(
        default,
        deserialize_with = "explicit_null",
        skip_serializing_if = "Option::is_none"
    )]
    pub max_stretch: Option<Option<f64>>,
    /// Largest Sander L∞ stretch of a chart before validation splits it, ≥ 1. Absent: 3;
    /// `null`: no bound.
    #[serde(
        default,
        deserialize_with = "explicit_null",
        skip_serializing_if = "Option::is_none"
    )]
    pub max_linf: Option<Option<f64>>,
    /// The LSCM paper's area test (§3.3): largest per-chart ratio between face area ratios
    /// (model / UV), ≥ 1, e.g. 2. Absent: no area test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_area_ratio: Option<f64>,
    /// Passes of merging valid charts back into a neighbour after validation; 0 disables
    /// merging. Default 3; meshes above 500k faces get the first pass only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub merge_passes: Option<usize>,
    /// Largest chart the merge-back may make, as a fraction of the mesh's faces, (0, 1]; unions
    /// of at most 4,096 faces are always tried. Absent: 0.1; `null`: no bound.
    #[serde(
        default,
        deserialize_with = "explicit_null",
        skip_serializing_if = "Option::is_none"
    )]
    pub merge_max_chart_fraction: Option<Option<f64>>,
    /// Segmentation method, default `features`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segmentation: Option<SegmentationJson>,
    /// The stretch segmentation's bound: a chart is split again while its flattening's L2
    /// stretch is above it (and the parameterize stage's `max_stretch` is bounded by it), >= 1.
    /// Default 1.03. Ignored by `features`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segmentation_max_stretch: Option<f64>,
    /// Fraction of edges kept as feature candidates, (0, 1], default 0.05.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feature_fraction: Option<f64>,
    /// Graph-cut border optimisation: the band around each border between two charts takes up
    /// to this fraction of each chart's area, (0, 1), e.g. 0.3. Absent or `null`: borders as grown.
    #[serde(
        default,
        deserialize_with = "explicit_null",
        skip_serializing_if = "Option::is_none"
    )]
    pub border_band_fraction: Option<Option<f64>>,
    /// Dihedral angle in degrees, (0, 180], from which an edge is a hard edge, a feature on
    /// components where the paper's feature curves find none. Absent: 60; `null`: no hard edges.
    #[serde(
        default,
        deserialize_with = "explicit_null",
        skip_serializing_if = "Option::is_none"
    )]
    pub hard_edge_angle_deg: Option<Option<f64>>,
    /// Solver, default `auto`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver: Option<SolverJson>,
    /// Stretch optimisation of every chart's map after validation, default `none`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stretch_optimization: Option<StretchOptimizationJson>,
    /// Passes of each phase of the stretch optimisation (L∞, then L2), >= 1. Default 4.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stretch_passes: Option<u32>,
    /// The parameterization of the final maps, default `lscm`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parameterization: Option<ParameterizationJson>,
    /// ASP's θ (area weight against angles), in `[0, 8]`. Default 1. Read with
    /// `parameterization: asp`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub asp_theta: Option<f64>,
    /// Which `TEXCOORD_k` receives the atlas on every triangle primitive, default
    /// `"first_free"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uv_set: Option<UvSetJson>,
    /// Container of the result, default `glb`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output_format: Option<OutputFormatJson>,
}

/// `Some(v)` for any present value, `null` included, so that an absent field (`None`, via
/// `#[serde(default)]`) and an explicit `null` (`Some(None)`) differ.
fn explicit_null<'de, D, T>(d: D) -> Result<Option<Option<T>>, D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    Option::<T>::deserialize(d).map(Some)
}

/// The domain options an [`OptionsJson`] stands for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnwrapSettings {
    /// The pipeline's options.
    pub atlas: AtlasOptions,
    /// Where the UVs go.
    pub uv_target: UvTarget,
    /// The output container.
    pub format: OutputFormat,
}

impl OptionsJson {
    /// The domain options, checked: an [`AtlasError::InvalidOption`] names the first bad field.
    pub fn to_settings(&self) -> Result<UnwrapSettings, AtlasError> {
        let mut atlas = AtlasOptions::default();
        if let Some(r) = self.resolution {
            let [w, h] = r.texels();
            atlas.pack.width_texels = w;
            atlas.pack.height_texels = h;
        }
        if let Some(p) = self.padding_texels {
            atlas.pack.padding_texels = p;
        }
        if let Some(d) = self.texels_per_unit {
            atlas.pack.density = TexelDensity::TexelsPerUnit(d);
        }
        if let Some(r) = self.rotations {
            atlas.pack.rotations = r;
        }
        atlas.segment.max_charts = self.max_charts;
        if let Some(r) = self.max_stretch {
            atlas.parameterize.max_stretch = r;
        }
        if let Some(r) = self.max_linf {
            atlas.parameterize.max_linf = r;
        }
        if let Some(r) = self.max_area_ratio {
            atlas.parameterize.max_area_ratio = Some(r);
        }
        if let Some(n) = self.merge_passes {
            atlas.parameterize.merge_passes = n;
        }
        if let Some(f) = self.merge_max_chart_fraction {
            atlas.parameterize.merge_max_chart_fraction = f;
        }
        atlas.segment.method = match self.segmentation.unwrap_or_default() {
            SegmentationJson::Features => SegmentMethod::Lscm2002,
            SegmentationJson::Stretch => SegmentMethod::Stretch,
        };
        if let Some(b) = self.segmentation_max_stretch {
            atlas.segment.stretch.max_stretch = b;
        }
        if let Some(f) = self.feature_fraction {
            atlas.segment.lscm.feature_fraction = f;
        }
        if let Some(f) = self.border_band_fraction {
            atlas.segment.border_band_fraction = f;
        }
        if let Some(a) = self.hard_edge_angle_deg {
            if let Some(deg) = a.filter(|d| !(*d > 0.0 && *d <= 180.0)) {
                return Err(AtlasError::InvalidOption {
                    option: "hard_edge_angle_deg",
                    detail: format!(
                        "{deg}° is not in (0, 180]; use e.g. 60, or null (`none` on the CLI) for no hard edges"
                    ),
                });
            }
            atlas.segment.lscm.hard_edge_angle_rad = a.map(f64::to_radians);
        }
        atlas.parameterize.flatten.method = match self.solver.unwrap_or_default() {
            SolverJson::Auto => ParameterizeMethod::Auto,
            SolverJson::Direct => ParameterizeMethod::Direct,
            SolverJson::Hierarchical => ParameterizeMethod::Hierarchical,
        };
        atlas.parameterize.stretch_optimization =
            match self.stretch_optimization.unwrap_or_default() {
                StretchOptimizationJson::None => StretchOptimization::None,
                StretchOptimizationJson::Global => StretchOptimization::Global,
                StretchOptimizationJson::LinfL2 => StretchOptimization::LinfL2,
            };
        if let Some(n) = self.stretch_passes {
            atlas.parameterize.stretch_passes = n;
        }
        atlas.parameterize.parameterization = match self.parameterization.unwrap_or_default() {
            ParameterizationJson::Lscm => Parameterization::Lscm,
            ParameterizationJson::Asp => Parameterization::Asp,
        };
        if let Some(t) = self.asp_theta {
            atlas.parameterize.asp_theta = t;
        }
        atlas.check()?;
        let uv_target = match self.uv_set {
            None | Some(UvSetJson::Named(UvSetName::FirstFree)) => UvTarget::FirstFree,
            Some(UvSetJson::Index(k)) => UvTarget::Replace(k),
        };
        let format = match self.output_format.unwrap_or_default() {
            OutputFormatJson::Glb => OutputFormat::Glb,
            OutputFormatJson::Gltf => OutputFormat::Gltf,
        };
        Ok(UnwrapSettings {
            atlas,
            uv_target,
            format,
        })
    }

    /// Every option with its effective value (defaults filled in), for the report.
    pub fn effective(settings: &UnwrapSettings) -> OptionsJson {
        let a = &settings.atlas;
        OptionsJson {
            resolution: Some(if a.pack.width_texels == a.pack.height_texels {
                ResolutionJson::Square(a.pack.width_texels)
            } else {
                ResolutionJson::Rect([a.pack.width_texels, a.pack.height_texels])
            }),
            padding_texels: Some(a.pack.padding_texels),
            texels_per_unit: match a.pack.density {
                TexelDensity::FitToPage => None,
                TexelDensity::TexelsPerUnit(d) => Some(d),
            },
            rotations: Some(a.pack.rotations),
            max_charts: a.segment.max_charts,
            max_stretch: Some(a.parameterize.max_stretch),
            max_linf: Some(a.parameterize.max_linf),
            max_area_ratio: a.parameterize.max_area_ratio,
            merge_passes: Some(a.parameterize.merge_passes),
            merge_max_chart_fraction: Some(a.parameterize.merge_max_chart_fraction),
            segmentation: Some(match a.segment.method {
                SegmentMethod::Lscm2002 => SegmentationJson::Features,
                SegmentMethod::Stretch => SegmentationJson::Stretch,
            }),
            segmentation_max_stretch: Some(a.segment.stretch.max_stretch),
            feature_fraction: Some(a.segment.lscm.feature_fraction),
            border_band_fraction: Some(a.segment.border_band_fraction),
            // Rounded to 1e-9° so that 60 reads back as 60, not 59.99999999999999.
            hard_edge_angle_deg: Some(
                a.segment
                    .lscm
                    .hard_edge_angle_rad
                    .map(|r| (r.to_degrees() * 1e9).round() / 1e9),
            ),
            solver: Some(match a.parameterize.flatten.method {
                ParameterizeMethod::Direct => SolverJson::Direct,
                ParameterizeMethod::Hierarchical => SolverJson::Hierarchical,
                _ => SolverJson::Auto,
            }),
            stretch_optimization: Some(match a.parameterize.stretch_optimization {
                StretchOptimization::None => StretchOptimizationJson::None,
                StretchOptimization::Global => StretchOptimizationJson::Global,
                StretchOptimization::LinfL2 => StretchOptimizationJson::LinfL2,
            }),
            stretch_passes: Some(a.parameterize.stretch_passes),
            parameterization: Some(match a.parameterize.parameterization {
                Parameterization::Lscm => ParameterizationJson::Lscm,
                Parameterization::Asp => ParameterizationJson::Asp,
            }),
            asp_theta: Some(a.parameterize.asp_theta),
            uv_set: Some(match settings.uv_target {
                UvTarget::FirstFree => UvSetJson::Named(UvSetName::FirstFree),
                UvTarget::Replace(k) => UvSetJson::Index(k),
            }),
            output_format: Some(match settings.format {
                OutputFormat::Glb => OutputFormatJson::Glb,
                OutputFormat::Gltf => OutputFormatJson::Gltf,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_options_are_the_defaults() {
        let o: OptionsJson = serde_json::from_str("{}").unwrap();
        let s = o.to_settings().unwrap();
        assert_eq!(s.atlas, AtlasOptions::default());
        assert_eq!(s.uv_target, UvTarget::FirstFree);
        assert_eq!(s.format, OutputFormat::Glb);
    }

    #[test]
    fn every_field_maps_and_round_trips() {
        let text = r#"{"resolution":[2048,512],"padding_texels":4,"texels_per_unit":300.5,
            "rotations":4,"max_charts":12,"max_stretch":1.2,"max_linf":4.5,"max_area_ratio":3.0,"merge_passes":2,
            "merge_max_chart_fraction":0.25,"feature_fraction":0.1,"border_band_fraction":0.2,
            "segmentation":"stretch","segmentation_max_stretch":1.05,
            "hard_edge_angle_deg":45.5,"solver":"hierarchical","stretch_optimization":"linf_l2",
            "stretch_passes":7,"parameterization":"asp","asp_theta":0.75,"uv_set":2,
            "output_format":"gltf"}"#;
        let o: OptionsJson = serde_json::from_str(text).unwrap();
        let s = o.to_settings().unwrap();
        assert_eq!(
            (s.atlas.pack.width_texels, s.atlas.pack.height_texels),
            (2048, 512)
        );
        assert_eq!(s.atlas.pack.padding_texels, 4);
        assert_eq!(s.atlas.pack.density, TexelDensity::TexelsPerUnit(300.5));
        assert_eq!(s.atlas.pack.rotations, 4);
        assert_eq!(s.atlas.segment.max_charts, Some(12));
        assert_eq!(s.atlas.parameterize.max_area_ratio, Some(3.0));
        assert_eq!(s.atlas.parameterize.max_stretch, Some(1.2));
        assert_eq!(s.atlas.parameterize.max_linf, Some(4.5));
        assert_eq!(s.atlas.parameterize.merge_passes, 2);
        assert_eq!(s.atlas.parameterize.merge_max_chart_fraction, Some(0.25));
        assert_eq!(s.atlas.segment.lscm.feature_fraction, 0.1);
        assert_eq!(s.atlas.segment.border_band_fraction, Some(0.2));
        assert_eq!(s.atlas.segment.method, SegmentMethod::Stretch);
        assert_eq!(s.atlas.segment.stretch.max_stretch, 1.05);
        assert_eq!(
            s.atlas.segment.lscm.hard_edge_angle_rad,
            Some(45.5f64.to_radians())
        );
        assert_eq!(
            s.atlas.parameterize.flatten.method,
            ParameterizeMethod::Hierarchical
        );
        assert_eq!(
            s.atlas.parameterize.stretch_optimization,
            StretchOptimization::LinfL2
        );
        assert_eq!(s.atlas.parameterize.stretch_passes, 7);
        assert_eq!(s.atlas.parameterize.parameterization, Parameterization::Asp);
        assert_eq!(s.atlas.parameterize.asp_theta, 0.75);
        assert_eq!(s.uv_target, UvTarget::Replace(2));
        assert_eq!(s.format, OutputFormat::Gltf);
        assert_eq!(OptionsJson::effective(&s), o);
    }

    #[test]
    fn null_max_stretch_removes_the_bound_and_absent_keeps_the_default() {
        let absent: OptionsJson = serde_json::from_str("{}").unwrap();
        assert_eq!(
            absent.to_settings().unwrap().atlas.parameterize.max_stretch,
            Some(1.07)
        );
        assert_eq!(
            absent.to_settings().unwrap().atlas.parameterize.max_linf,
            Some(3.0)
        );
        let null: OptionsJson = serde_json::from_str(r#"{"max_stretch":null}"#).unwrap();
        assert_eq!(null.max_stretch, Some(None));
        let s = null.to_settings().unwrap();
        assert_eq!(s.atlas.parameterize.max_stretch, None);
        let back = serde_json::to_string(&OptionsJson::effective(&s)).unwrap();
        assert!(back.contains(r#""max_stretch":null"#), "{back}");
        let null: OptionsJson = serde_json::from_str(r#"{"max_linf":null}"#).unwrap();
        let s = null.to_settings().unwrap();
        assert_eq!(s.atlas.parameterize.max_linf, None);
        let back = serde_json::to_string(&OptionsJson::effective(&s)).unwrap();
        assert!(back.contains(r#""max_linf":null"#), "{back}");
    }

    #[test]
    fn hard_edges_default_to_60_degrees_and_null_turns_them_off() {
        let absent: OptionsJson = serde_json::from_str("{}").unwrap();
        let s = absent.to_settings().unwrap();
        let back = serde_json::to_string(&OptionsJson::effective(&s)).unwrap();
        assert!(back.contains(r#""hard_edge_angle_deg":60.0"#), "{back}");
        let null: OptionsJson = serde_json::from_str(r#"{"hard_edge_angle_deg":null}"#).unwrap();
        let s = null.to_settings().unwrap();
        assert_eq!(s.atlas.segment.lscm.hard_edge_angle_rad, None);
        let back = serde_json::to_string(&OptionsJson::effective(&s)).unwrap();
        assert!(back.contains(r#""hard_edge_angle_deg":null"#), "{back}");
    }

    #[test]
    fn bad_values_name_the_option() {
        for (text, option) in [
            (r#"{"padding_texels":600}"#, "padding_texels"),
            (r#"{"resolution":0}"#, "width_texels"),
            (r#"{"rotations":0}"#, "rotations"),
            (r#"{"rotations":65}"#, "rotations"),
            (r#"{"resolution":16385}"#, "width_texels"),
            (r#"{"texels_per_unit":-1}"#, "texels_per_unit"),
            (r#"{"max_area_ratio":0.5}"#, "max_area_ratio"),
            (r#"{"max_stretch":0.9}"#, "max_stretch"),
            (r#"{"max_linf":0.5}"#, "max_linf"),
            (r#"{"feature_fraction":2}"#, "lscm.feature_fraction"),
            (r#"{"hard_edge_angle_deg":0}"#, "hard_edge_angle_deg"),
            (r#"{"hard_edge_angle_deg":181}"#, "hard_edge_angle_deg"),
            (r#"{"max_charts":0}"#, "max_charts"),
            (
                r#"{"parameterization":"asp","asp_theta":-0.5}"#,
                "asp_theta",
            ),
            (r#"{"parameterization":"asp","asp_theta":9}"#, "asp_theta"),
        ] {
            let o: OptionsJson = serde_json::from_str(text).unwrap();
            match o.to_settings() {
                Err(AtlasError::InvalidOption { option: got, .. }) => {
                    assert_eq!(got, option, "{text}")
                }
                other => panic!("{text}: expected InvalidOption({option}), got {other:?}"),
            }
        }
    }

    #[test]
    fn unknown_fields_are_refused() {
        let e = serde_json::from_str::<OptionsJson>(r#"{"padding":2}"#).unwrap_err();
        assert!(e.to_string().contains("unknown field `padding`"), "{e}");
    }
}
