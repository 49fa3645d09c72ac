//! `texatlas inspect FILE [--json]`: what an asset holds and what is wrong with it.
use std::fmt::Write as _;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context as _;
use texatlas::api::{InspectJson, TimingsJson};
use texatlas::inspect::{inspect, InspectReport};

use super::load::load_asset;

#[derive(Debug, clap::Args)]
pub struct InspectArgs {
    /// The glTF asset: `.glb`, or `.gltf` with `data:` URIs or with its buffers and images in
    /// the same directory (nothing outside that directory is ever opened).
    pub file: std::path::PathBuf,
    /// Print one JSON object (schema: proto/inspect.schema.json) instead of text.
    #[arg(long)]
    pub json: bool,
}

/// How many components and defects of each kind the text form lists before summarising.
const TEXT_LIST_LIMIT: usize = 20;

pub fn run(args: &InspectArgs) -> anyhow::Result<ExitCode> {
    let started = Instant::now();
    let loaded = load_asset(&args.file)?;
    let decode_s = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let report = inspect(&loaded.asset);
    let build_s = started.elapsed().as_secs_f64();
    let timings = TimingsJson { decode_s, build_s };
    let file = args.file.display().to_string();
    if args.json {
        let json = InspectJson::new(file, loaded.file_bytes, &report, timings);
        println!(
            "{}",
            serde_json::to_string_pretty(&json).context("serialising the report")?
        );
    } else {
        print!("{}", text(&args.file, loaded.file_bytes, &report, timings));
    }
    Ok(ExitCode::SUCCESS)
}

fn text(file: &Path, file_bytes: u64, report: &InspectReport, timings: TimingsJson) -> String {
    let mut out = String::new();
    let a = &report.asset;
    let _ = writeln!(
        out,
        "file: {} ({file_bytes} bytes, {:?})",
        file.display(),
        a.format
    );
    let _ = writeln!(
        out,
        "meshes: {}, nodes: {}, triangles: {}, vertices before welding: {}",
        a.meshes.len(),
        a.node_count,
        report.triangles,
        report.source_vertices
    );
    if !a.extensions_used.is_empty() {
        let _ = writeln!(out, "extensionsUsed: {}", a.extensions_used.join(", "));
    }
    if !a.extensions_required.is_empty() {
        let _ = writeln!(
            out,
            "extensionsRequired: {}",
            a.extensions_required.join(", ")
        );
    }
    for (m, mesh) in a.meshes.iter().enumerate() {
        let _ = writeln!(
            out,
            "mesh {m}{}: {} primitive(s), {} instance(s)",
            mesh.name
                .as_deref()
                .map(|n| format!(" \"{n}\""))
                .unwrap_or_default(),
            mesh.primitives.len(),
            mesh.instances
        );
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let triangles = prim
                .triangle_count
                .map(|t| format!("{t} triangles"))
                .unwrap_or_else(|| "no triangles (carried through untouched)".to_string());
            let _ = writeln!(
                out,
                "  primitive {p}: mode {}, {} vertices, {triangles}, {}{}[{}]",
                prim.mode,
                prim.vertex_count,
                if prim.indexed { "indexed, " } else { "" },
                if prim.morph_targets > 0 {
                    format!("{} morph targets, ", prim.morph_targets)
                } else {
                    String::new()
                },
                prim.attributes.join(", ")
            );
        }
    }
    match &report.surface {
        Err(err) => {
            let _ = writeln!(out, "surface: none ({}): {err}", err.code());
        }
        Ok(s) => {
            let _ = writeln!(
                out,
                "surface: {} welded vertices ({} after repair), {} edges, {} boundary loops, {} connected component(s)",
                s.welded_vertices,
                s.mesh_vertices,
                s.edges,
                s.boundary_loops,
                s.components.len()
            );
            for c in s.components.iter().take(TEXT_LIST_LIMIT) {
                let _ = writeln!(
                    out,
                    "  component {}: mesh {}, F={} V={} E={} boundary loops={} χ={} genus={}",
                    c.id.index(),
                    c.weld_group
                        .map(|g| g.to_string())
                        .unwrap_or_else(|| "?".into()),
                    c.num_faces,
                    c.num_vertices,
                    c.num_edges,
                    c.num_boundary_loops,
                    c.euler_characteristic,
                    c.genus
                );
            }
            if s.components.len() > TEXT_LIST_LIMIT {
                let _ = writeln!(
                    out,
                    "  … {} more components (use --json for all)",
                    s.components.len() - TEXT_LIST_LIMIT
                );
            }
            if s.defects.is_empty() {
                let _ = writeln!(out, "defects: none");
            } else {
                let _ = writeln!(out, "defects: {}", s.defects.len());
                let mut codes: Vec<&str> = s.defects.iter().map(|d| d.code()).collect();
                codes.sort_unstable();
                codes.dedup();
                for code in codes {
                    let of_code: Vec<_> = s.defects.iter().filter(|d| d.code() == code).collect();
                    let _ = writeln!(out, "  {code}: {}", of_code.len());
                    for d in of_code.iter().take(TEXT_LIST_LIMIT) {
                        let _ = writeln!(out, "    {d}");
                    }
                    if of_code.len() > TEXT_LIST_LIMIT {
                        let _ = writeln!(
                            out,
                            "    … {} more (use --json for all)",
                            of_code.len() - TEXT_LIST_LIMIT
                        );
                    }
                }
            }
        }
    }
    let _ = writeln!(
        out,
        "time: decode {:.3} s, weld + validate {:.3} s",
        timings.decode_s, timings.build_s
    );
    out
}
