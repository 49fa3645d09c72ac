//! The `texatlas inspect` report.
