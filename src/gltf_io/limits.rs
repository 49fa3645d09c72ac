//! [`DecodeLimits`]: the bounds on what one decode may allocate, read by the decoder and the
//! accessor reader alike.

/// Bounds on what one decode may allocate. Defaults keep a decode under about 1 GB.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DecodeLimits {
    /// Largest accessor, in packed bytes (count × element size). Accessors with a buffer view
    /// are also bounded by their real bytes; this cap matters for accessors without one (all
    /// zeros, maybe sparse), whose `count` is backed by nothing. Default: 256 MiB.
    pub max_accessor_bytes: u64,
    /// Most vertices over all triangle primitives (shared POSITION accessors of one mesh count
    /// once). `None` = no limit. Default: `Some(16_777_216)`.
    pub max_vertices: Option<u64>,
    /// Most triangles over all triangle primitives. `None` = no limit. Default:
    /// `Some(16_777_216)`.
    pub max_triangles: Option<u64>,
}

impl Default for DecodeLimits {
    fn default() -> Self {
        DecodeLimits {
            max_accessor_bytes: 256 << 20,
            max_vertices: Some(1 << 24),
            max_triangles: Some(1 << 24),
        }
    }
}
