//! Sparse linear algebra. Knows nothing of meshes.
