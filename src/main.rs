//! The `texatlas` binary: thin. Parses the command line and calls into the library.
use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cli;

#[derive(Debug, Parser)]
#[command(
    name = "texatlas",
    version,
    about = "Texture atlases for glTF 2.0 assets"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Print meshes, primitives, triangles, welded vertices, boundary loops, genus per connected
    /// component, and every defect of a glTF asset.
    Inspect(cli::inspect::InspectArgs),
    /// Cut, flatten and pack every triangle mesh of a glTF asset into one atlas and write the
    /// asset back with the new UVs (plus `--report` JSON and `--preview` PNG).
    Unwrap(cli::unwrap::UnwrapArgs),
    /// The HTTP service: upload assets, poll jobs, download results (see README, "Service").
    Serve(cli::serve::ServeArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Inspect(args) => cli::inspect::run(&args),
        Command::Unwrap(args) => cli::unwrap::run(&args),
        Command::Serve(args) => cli::serve::run(&args),
    };
    match result {
        Ok(code) => code,
        Err(err) => {
            eprintln!("texatlas: error: {err:#}");
            ExitCode::from(2)
        }
    }
}
