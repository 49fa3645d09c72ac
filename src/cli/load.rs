//! Reading an asset from disk for the CLI: the file itself, plus, for a `.gltf`, the external
//! buffers and images it references — only files inside the asset's own directory.
//!
//! The decoder never touches the filesystem; this is the one place the CLI does, and it opens
//! only what `gltf_io::required_resources` lists (relative references without `..`, schemes or
//! absolute paths), after checking that the canonical path (symlinks followed) is still inside
//! the asset's directory.
use std::path::Path;

use anyhow::Context as _;
use texatlas::gltf_io::{self, Asset, DecodeLimits, Resources};

/// A decoded asset and its size on disk.
pub struct LoadedAsset {
    pub asset: Asset,
    pub file_bytes: u64,
}

pub fn load_asset(path: &Path) -> anyhow::Result<LoadedAsset> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let mut resources = Resources::new();
    let uris = gltf_io::required_resources(&bytes)
        .with_context(|| format!("reading the glTF document in {}", path.display()))?;
    if !uris.is_empty() {
        let dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .canonicalize()
            .with_context(|| format!("resolving the directory of {}", path.display()))?;
        for uri in uris {
            // A missing or escaping file is simply not supplied; the decoder then reports it
            // with its JSON path (`resource_missing`), which says more than an IO error here.
            let Ok(candidate) = dir.join(gltf_io::relative_path_of(&uri)).canonicalize() else {
                continue;
            };
            if !candidate.starts_with(&dir) || !candidate.is_file() {
                continue;
            }
            let blob = std::fs::read(&candidate)
                .with_context(|| format!("reading {}", candidate.display()))?;
            resources.insert(uri, blob);
        }
    }
    let asset = gltf_io::decode(&bytes, &resources, &DecodeLimits::default())
        .with_context(|| format!("decoding {}", path.display()))?;
    Ok(LoadedAsset {
        asset,
        file_bytes: bytes.len() as u64,
    })
}
