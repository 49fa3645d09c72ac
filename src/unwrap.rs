//! One unwrap of one asset, end to end: the shell around [`atlas::generate`] that the CLI
//! (`texatlas unwrap`, the `pipeline` benchmark) and the job workers share.
//!
//! Purpose: decoded [`Asset`] + [`UnwrapSettings`] → the same asset with atlas UVs (bytes), the
//! [`Atlas`] and the JSON report ([`ReportJson`]), with wall-clock time per step.
//!
//! Not core: it measures wall-clock time (the report's `timings_s`), and joins `gltf_io`,
//! `mesh`, `atlas` and `api`. It does no IO: bytes in, bytes out.
//!
//! Dependency direction: `unwrap` → `api`, never back. `api` is the wire layer built from
//! domain types (`mesh`, `atlas`, `gltf_io`); this module is a shell above it that produces
//! the wire report for the CLI, the bench and the jobs alike, so it converts its own
//! [`StepTimings`] to the wire's [`TimingsJsonS`].
//!
//! Errors: [`UnwrapError`], each with a stable [`ProblemCode`] (`ProblemCode::from(&error)`) for
//! problem+json bodies and a message that says what to fix.
use std::ops::ControlFlow;
use std::time::Instant;

use crate::api::{OptionsJson, ProblemCode, ReportJson, TimingsJsonS, UnwrapSettings};
use crate::atlas::{self, Atlas, AtlasError, Progress, Stage};
use crate::gltf_io::{self, Asset, EncodeOptions, EncodedAsset, GltfError};
use crate::mesh::{MeshBuildError, TriangleMesh};

/// Why an unwrap failed. The message includes the inner error's, so the inner error is not
/// also reported as a `source` (an error chain printed with `{:#}` would repeat it).
#[derive(Debug, thiserror::Error)]
pub enum UnwrapError {
    /// The triangles cannot form a mesh (no triangles, bad indices, non-finite coordinates).
    #[error("the asset's triangles cannot be unwrapped: {0}")]
    Mesh(MeshBuildError),
    /// The pipeline failed or was cancelled.
    #[error("{0}")]
    Atlas(AtlasError),
    /// Writing the asset back failed.
    #[error("writing the result failed: {0}")]
    Encode(GltfError),
}

impl From<MeshBuildError> for UnwrapError {
    fn from(e: MeshBuildError) -> Self {
        UnwrapError::Mesh(e)
    }
}

impl From<AtlasError> for UnwrapError {
    fn from(e: AtlasError) -> Self {
        UnwrapError::Atlas(e)
    }
}

impl From<GltfError> for UnwrapError {
    fn from(e: GltfError) -> Self {
        UnwrapError::Encode(e)
    }
}

impl From<&UnwrapError> for ProblemCode {
    fn from(e: &UnwrapError) -> ProblemCode {
        match e {
            UnwrapError::Mesh(e) => e.into(),
            UnwrapError::Atlas(e) => e.into(),
            UnwrapError::Encode(e) => e.into(),
        }
    }
}

/// Wall-clock seconds per step of one unwrap (the report's `timings_s`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepTimings {
    /// Welding and validating the triangles.
    pub build_s: f64,
    /// Per pipeline stage, in [`Stage::ALL`] order.
    pub stages_s: [f64; 4],
    /// Writing the asset back.
    pub encode_s: f64,
    /// Everything above.
    pub total_s: f64,
}

impl From<&StepTimings> for TimingsJsonS {
    fn from(t: &StepTimings) -> TimingsJsonS {
        let stage = |st: Stage| t.stages_s[st as usize];
        TimingsJsonS {
            build: t.build_s,
            segment: stage(Stage::Segment),
            parameterize: stage(Stage::Parameterize),
            pack: stage(Stage::Pack),
            measure: stage(Stage::Measure),
            encode: t.encode_s,
            total: t.total_s,
        }
    }
}

/// The result of [`unwrap_asset`].
#[derive(Debug)]
pub struct Unwrapped {
    /// The asset with the atlas UVs, in the requested container.
    pub encoded: EncodedAsset,
    /// The atlas (per-corner UVs, charts, pages, the report's plain data).
    pub atlas: Atlas,
    /// Faces of the mesh (= triangles of the asset).
    pub triangles: usize,
    /// Wall-clock time per step.
    pub timings: StepTimings,
    /// The JSON report.
    pub report: ReportJson,
}

/// Forwards progress to the caller's [`Progress`] and times every stage.
struct Timed<'a> {
    inner: &'a mut dyn Progress,
    started: Option<(Stage, Instant)>,
    stages_s: [f64; 4],
}

impl Progress for Timed<'_> {
    fn stage_started(&mut self, stage: Stage) {
        self.started = Some((stage, Instant::now()));
        self.inner.stage_started(stage);
    }
    fn advance(&mut self, stage: Stage, done: usize, total: usize) -> ControlFlow<()> {
        self.inner.advance(stage, done, total)
    }
    fn stage_finished(&mut self, stage: Stage) {
        if let Some((s, t)) = self.started.take() {
            if s == stage {
                self.stages_s[stage as usize] = t.elapsed().as_secs_f64();
            }
        }
        self.inner.stage_finished(stage);
    }
}

/// Unwraps every triangle primitive of `asset` as one atlas and writes it back.
pub fn unwrap_asset(
    asset: &Asset,
    settings: &UnwrapSettings,
    progress: &mut dyn Progress,
) -> Result<Unwrapped, UnwrapError> {
    let started = Instant::now();
    let built = TriangleMesh::build(asset.mesh_input())?;
    let build_s = started.elapsed().as_secs_f64();
    let mut timed = Timed {
        inner: progress,
        started: None,
        stages_s: [0.0; 4],
    };
    let atlas = atlas::generate(&built.mesh, &settings.atlas, &mut timed)?;
    let stages_s = timed.stages_s;
    let t = Instant::now();
    let encoded = gltf_io::encode_pages(
        asset,
        &atlas.corner_uvs,
        &atlas.face_page,
        &EncodeOptions {
            uv_target: settings.uv_target,
            format: settings.format,
            ..EncodeOptions::default()
        },
    )?;
    let encode_s = t.elapsed().as_secs_f64();
    let timings = StepTimings {
        build_s,
        stages_s,
        encode_s,
        total_s: started.elapsed().as_secs_f64(),
    };
    let report = ReportJson::new(
        asset,
        &built,
        &atlas,
        &encoded,
        &OptionsJson::effective(settings),
        TimingsJsonS::from(&timings),
    );
    Ok(Unwrapped {
        encoded,
        triangles: built.mesh.num_faces(),
        atlas,
        timings,
        report,
    })
}
