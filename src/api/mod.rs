//! The wire types: the only serde types of the crate. Each mirrors a document in `proto/` and is
//! built from a domain type by an explicit conversion, so the domain stays free of serde.
//!
//! - [`InspectJson`] ↔ `proto/inspect.schema.json` (`texatlas inspect --json`);
//! - [`OptionsJson`] ↔ `proto/options.schema.json` (the options of an unwrap, the same names
//!   for CLI flags, HTTP query parameters and the multipart `options` part);
//! - [`ReportJson`] ↔ `proto/report.schema.json` (`texatlas unwrap --report`, the job report).
//! - [`JobJson`], [`JobListJson`], [`ApiProblemJson`] with its [`ProblemCode`] ↔
//!   `proto/openapi.json` (the HTTP service).
mod inspect;
mod job;
mod options;
mod problem;
mod report;

pub use inspect::*;
pub use job::*;
pub use options::*;
pub use problem::ProblemCode;
pub use report::*;
