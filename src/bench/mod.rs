//! Benchmarks behind `texatlas bench`. NOT core: may use wall-clock time, processes and the
//! filesystem (the core modules `mesh`, `numerics`, `atlas` never do).
pub mod parameterize;
pub mod pipeline;
