//! `texatlas inspect FILE`
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct InspectArgs {
    /// The glTF asset (`.glb`, or `.gltf` with `data:` URIs or buffers beside it).
    pub file: std::path::PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(_args: &InspectArgs) -> anyhow::Result<ExitCode> {
    anyhow::bail!("inspect is being built")
}
