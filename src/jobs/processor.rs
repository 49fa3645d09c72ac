//! The work of one job: [`Processor`], and the production one, [`UnwrapProcessor`].
use crate::api::{ApiProblemJson, AssetDefectJson, OptionsJson, ProblemCode};
use crate::atlas::Progress;
use crate::gltf_io::{self, DecodeLimits, EncodeOptions, OutputFormat, Resources};
use crate::preview::{preview_size_px, render_preview};
use crate::unwrap::{unwrap_asset, UnwrapError};

/// The input of a job, as uploaded.
#[derive(Debug, Clone)]
pub struct JobInput {
    /// The `.glb` or `.gltf` bytes.
    pub asset: Vec<u8>,
    /// The external buffers and images of a `.gltf`, by URI.
    pub resources: Resources,
}

/// What a successful job produces.
#[derive(Debug, Clone, PartialEq)]
pub struct JobOutput {
    /// The asset with the atlas UVs as GLB.
    pub glb: Vec<u8>,
    /// The same as `.gltf` JSON with one embedded buffer.
    pub gltf: Vec<u8>,
    /// The report JSON (proto/report.schema.json).
    pub report_json: Vec<u8>,
    /// The UV layout of page 0 as PNG.
    pub preview_png: Vec<u8>,
    /// Triangles processed.
    pub triangles: u64,
    /// Wall-clock seconds per pipeline stage, in `Stage::ALL` order.
    pub stage_seconds: [f64; 4],
}

/// Why a job failed: a problem body for the job's `error`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{code}: {detail}")]
pub struct JobFailure {
    /// The stable code ([`ProblemCode::Cancelled`] for a cooperative stop).
    pub code: ProblemCode,
    /// What is wrong and how to fix it.
    pub detail: String,
    /// Defects of the asset, with JSON paths.
    pub defects: Vec<AssetDefectJson>,
    /// A fault of the service, not of the input (shown as status 500, detail kept generic).
    pub internal: bool,
}

impl JobFailure {
    /// A failure caused by the input or the options (status 422).
    pub fn input(code: ProblemCode, detail: impl Into<String>) -> JobFailure {
        JobFailure {
            code,
            detail: detail.into(),
            defects: Vec::new(),
            internal: false,
        }
    }

    /// A fault of the service (status 500).
    pub fn internal(code: ProblemCode, detail: impl Into<String>) -> JobFailure {
        JobFailure {
            internal: true,
            ..JobFailure::input(code, detail)
        }
    }

    /// The cooperative stop.
    pub fn cancelled() -> JobFailure {
        JobFailure::input(ProblemCode::Cancelled, "the job was cancelled")
    }

    /// The problem body stored as the job's `error`.
    pub fn problem(&self) -> ApiProblemJson {
        let (status, title) = if self.internal {
            (500, "Internal error")
        } else {
            (422, "The asset could not be unwrapped")
        };
        let mut p = ApiProblemJson::new(status, self.code, title, self.detail.clone());
        p.defects = self.defects.clone();
        p
    }
}

/// The work of one job. Called on a blocking thread; may take minutes; must call
/// `progress.advance` often enough for cancellation and progress to work, and stop with
/// `Err(JobFailure::cancelled())` when it returns `Break`.
pub trait Processor: Send + Sync + 'static {
    /// Runs the job.
    fn process(
        &self,
        input: &JobInput,
        options: &OptionsJson,
        progress: &mut dyn Progress,
    ) -> Result<JobOutput, JobFailure>;
}

/// The production processor: decode → [`unwrap_asset`] → both containers, report, preview.
#[derive(Debug, Clone, Default)]
pub struct UnwrapProcessor {
    /// Decoder limits (the service's triangle limit).
    pub limits: DecodeLimits,
}

impl Processor for UnwrapProcessor {
    fn process(
        &self,
        input: &JobInput,
        options: &OptionsJson,
        progress: &mut dyn Progress,
    ) -> Result<JobOutput, JobFailure> {
        let settings = options
            .to_settings()
            .map_err(|e| JobFailure::input(ProblemCode::InvalidOption, e.to_string()))?;
        let asset = gltf_io::decode(&input.asset, &input.resources, &self.limits).map_err(|e| {
            JobFailure {
                defects: vec![AssetDefectJson::from(&e)],
                ..JobFailure::input(ProblemCode::from(&e), e.to_string())
            }
        })?;
        let unwrapped = unwrap_asset(&asset, &settings, progress).map_err(|e| match &e {
            UnwrapError::Atlas(crate::atlas::AtlasError::Cancelled { .. }) => {
                JobFailure::cancelled()
            }
            UnwrapError::Encode(g) => JobFailure {
                defects: vec![AssetDefectJson::from(g)],
                ..JobFailure::input(ProblemCode::from(&e), e.to_string())
            },
            _ => JobFailure::input(ProblemCode::from(&e), e.to_string()),
        })?;
        // The other container from the same UVs, so `GET …/result` can serve either.
        let other_format = match settings.format {
            OutputFormat::Glb => OutputFormat::Gltf,
            OutputFormat::Gltf => OutputFormat::Glb,
        };
        let other = gltf_io::encode(
            &asset,
            &unwrapped.atlas.corner_uvs,
            &EncodeOptions {
                uv_target: settings.uv_target,
                format: other_format,
                ..EncodeOptions::default()
            },
        )
        .map_err(|e| JobFailure::internal(ProblemCode::EncodeFailed, e.to_string()))?;
        let (glb, gltf) = match settings.format {
            OutputFormat::Glb => (unwrapped.encoded.bytes, other.bytes),
            OutputFormat::Gltf => (other.bytes, unwrapped.encoded.bytes),
        };
        let report_json = serde_json::to_vec_pretty(&unwrapped.report)
            .map_err(|e| JobFailure::internal(ProblemCode::ReportFailed, e.to_string()))?;
        let pack = &settings.atlas.pack;
        let (w, h) = preview_size_px(pack.width_texels, pack.height_texels);
        let preview_png = render_preview(&unwrapped.atlas, 0, w, h);
        Ok(JobOutput {
            glb,
            gltf,
            report_json,
            preview_png,
            triangles: unwrapped.triangles as u64,
            stage_seconds: unwrapped.timings.stages_s,
        })
    }
}
