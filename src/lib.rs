//! # texatlas
//!
//! A texture-atlas service: glTF 2.0 assets come in, their triangle meshes are cut into charts,
//! each chart is flattened (LSCM, and hierarchical LSCM for big charts) and the charts are packed
//! into one atlas. The same asset goes out with new UVs, plus a quality report.
//!
//! ## Bird's-eye view
//!
//! ```text
//!  bytes ──gltf_io::decode──▶ Asset ──Asset::mesh_input──▶ mesh::MeshInput
//!                                                              │ TriangleMesh::build (weld, validate, repair)
//!                                                              ▼
//!                                                        mesh::TriangleMesh
//!                                                              │ atlas::generate (segment → parameterize → pack → measure)
//!                                                              ▼
//!  bytes ◀──gltf_io::encode── Asset + per-corner UVs ◀──────── atlas
//! ```
//!
//! ## Code map
//!
//! - [`mesh`]: the validated triangle mesh: typed ids, weld by position, half-edge connectivity,
//!   defects and the repair policy. Depends on nothing else in the crate.
//! - [`numerics`]: sparse assembly, preconditioned CG, sparse Cholesky (faer, behind one module).
//!   Knows nothing of meshes.
//! - [`atlas`]: the pipeline, joined to the rest by one call, [`atlas::generate`]: segmentation
//!   into disk-shaped charts with validation (LSCM paper §3), chart parameterization (LSCM,
//!   progressive mesh, HLSCM), packing (horizon packer, LSCM paper §4 / Iso-charts §6) and the
//!   quality report (`atlas::measure`, the independent evaluator's definitions). Progress and
//!   cancellation go through [`atlas::Progress`].
//! - [`unwrap`]: one unwrap of one decoded asset (mesh build → `atlas::generate` → encode →
//!   report), timed; shared by the CLI and the job workers. Not core (wall-clock time).
//! - [`preview`]: the `--preview` PNG of a page's UV layout.
//! - [`gltf_io`]: the only module that knows glTF: decode (with JSON paths for every defect) and
//!   encode (split vertices at UV seams, carry everything else through).
//! - [`inspect`]: the `texatlas inspect` report (plain data, built from `gltf_io` + `mesh`).
//! - [`storage`]: the persistent state of the service behind two traits, `JobStore` (a
//!   lease-based job queue) and `BlobStore`; SQLite and local files today. The only SQL.
//! - [`jobs`]: submitting, running and reading jobs: the job service, the worker pool (the
//!   pipeline on the blocking pool, progress, cancel, panics, time limits), the sweeper, metrics.
//! - [`http`]: the only module that knows axum: the `/v1` API, problem+json errors, auth.
//! - [`service`]: the composition root of `texatlas serve`.
//! - [`api`]: the only serde wire types, each mirroring a document in `proto/` (inspect, options,
//!   report, openapi), with explicit conversions from and to the domain types.
//!
//! ## Architecture invariants
//!
//! - `mesh`, `numerics` and `atlas` do no IO, use no tokio, axum, serde, SQL, `std::fs`,
//!   `std::net` or wall-clock time, and are deterministic: the same input gives the same output
//!   bits whatever the thread count. `tests/architecture.rs` checks the `use` lines.
//! - Only `gltf_io` knows glTF. The decoder never touches the filesystem or the network: external
//!   buffers and images are handed to it by the caller as named byte blobs.
//! - SQL lives only in `storage`, axum only in `http`; `jobs` and `http` reach the database
//!   through the `JobStore` trait (checked by `tests/architecture.rs`).
//! - An accepted job is never lost: its inputs are stored before its row, and it leaves
//!   `running` only through a fenced write or an expired lease.
//! - Units are in names and types: model space is in the asset's units (`_m`, `_m2`), UVs are
//!   normalized to \[0,1\], angles are in radians (`_rad`).
pub mod api;
pub mod atlas;
pub mod gltf_io;
pub mod http;
pub mod inspect;
pub mod jobs;
pub mod mesh;
pub mod numerics;
pub mod preview;
pub mod service;
pub mod storage;
pub mod unwrap;
