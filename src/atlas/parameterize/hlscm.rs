//! Hierarchical LSCM: cascadic multigrid over a progressive mesh (Ray & Lévy 2003,
//! hlscm-2003 §3.3 and §4.1).
//!
//! Why (§3.2): "the system is able to efficiently solve high frequencies, but convergence is
//! slower for low frequencies". The cure (§3.3): "The simplest multigrid algorithm (m1 = 0 and
//! mc = 1) is called cascadic multigrid … The idea is to solve the coarser problem and to use it
//! as initial solution to solve higher frequencies. Each frequency is just visited once." It
//! works for LSCM because the conformal energy "does not depend on the mesh resolution"
//! (lscm-2002 appendix A.4), provided "the geometry does not vary too much between two
//! consecutive levels", which the geometry-aware decimation of [`super::progressive_mesh`]
//! ensures.
//!
//! The stages, in the paper's words (§4.1) and here:
//! 1. "the coarsest mesh is parameterized": direct sparse Cholesky on the coarsest level.
//! 2. "the result is propagated to a finer one … during the vsplit operations … its textures
//!    coordinates are estimated using a barycentric interpolation in the nearest triangle":
//!    [`super::progressive_mesh::ProgressiveMesh::split_to`].
//! 3. "LSCM is launched each time there are 10 times as many vertices as in the previous level":
//!    levels hold `n, n/r, n/r², …` vertices with `r = level_ratio` (default 10) down to
//!    `coarsest_max_vertices`.
//! 4. "The number of iterations needed at each level depends of the quality of the coarse
//!    approximation": intermediate levels get `relax_iterations` Jacobi-CG iterations; the
//!    finest level runs CG to `final_tolerance` (relative residual of the normal equations).
//!
//! The pins (lscm-2002 §2.6) are chosen on the full chart and locked in the progressive mesh,
//! so every level solves the same pinned problem.
//!
//! Tolerance stated (measured with `texatlas bench parameterize`, see the crate report): with
//! the defaults the final energy is within 1e-4 relative of the direct solve's energy on the
//! benchmark height fields. Units as in [`super`]: UVs in model units.
use std::ops::ControlFlow;

use crate::numerics::CgOptions;

use super::chart::{ChartMesh, ChartTopology};
use super::lscm::{LscmSystem, Pin};
use super::progressive_mesh::{build_progressive_mesh, ProgressiveMeshOptions};
use super::ParameterizeError;

/// HLSCM tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HlscmOptions {
    /// Vertex-count ratio between consecutive levels. Default 10 (hlscm-2003 §4.1).
    pub level_ratio: f64,
    /// The coarsest level has at most this many vertices (fewer if the ratio lands below) and is
    /// solved directly. Default 20_000.
    pub coarsest_max_vertices: usize,
    /// CG iterations on each intermediate level. Default 40.
    pub relax_iterations: usize,
    /// Finest-level stopping rule, part 1: relative residual `‖Aᵀb − AᵀA·x‖/‖Aᵀb‖`.
    /// Default 1e-9.
    pub final_tolerance: f64,
    /// Finest-level stopping rule, part 2 (whichever comes first): stop when the conformal
    /// energy decreased by at most `final_energy_tolerance · C(x)` over the last
    /// `energy_window` iterations. CG decreases `C` monotonically, so this detects that the
    /// remaining error no longer moves the energy. Default 1e-7.
    pub final_energy_tolerance: f64,
    /// Window (iterations) of the energy rule. Default 20.
    pub energy_window: usize,
    /// Finest-level iteration cap. Default 2_000.
    pub final_max_iterations: usize,
    /// Largest angular defect of a removable vertex, radians. Default 70° (hlscm-2003 §4).
    pub max_angular_defect_rad: f64,
}

impl Default for HlscmOptions {
    fn default() -> Self {
        Self {
            level_ratio: 10.0,
            coarsest_max_vertices: 20_000,
            relax_iterations: 40,
            final_tolerance: 1e-9,
            final_energy_tolerance: 1e-7,
            energy_window: 20,
            final_max_iterations: 2_000,
            max_angular_defect_rad: 70f64.to_radians(),
        }
    }
}

/// What happened on one level, coarsest first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HlscmLevel {
    /// Vertices of the level.
    pub vertices: usize,
    /// CG iterations run (0 on the directly solved coarsest level).
    pub iterations: usize,
    /// Relative residual after the level's solve.
    pub relative_residual: f64,
}

/// Summary of an HLSCM solve.
#[derive(Debug, Clone, PartialEq)]
pub struct HlscmReport {
    /// Levels, coarsest first; the last one is the full chart.
    pub levels: Vec<HlscmLevel>,
    /// Collapses in the progressive mesh.
    pub collapses: usize,
    /// CG iterations on the finest level.
    pub finest_iterations: usize,
    /// Whether the finest level reached `final_tolerance`.
    pub converged: bool,
}

/// Runs HLSCM on a validated chart with the given pins. `monitor` receives
/// `(finest-level iterations done, cap)`; `Break` cancels.
pub fn solve_hlscm(
    chart: &ChartMesh,
    topology: &ChartTopology,
    pins: &[Pin],
    options: &HlscmOptions,
    monitor: &mut dyn FnMut((usize, usize)) -> ControlFlow<()>,
) -> Result<(Vec<[f64; 2]>, HlscmReport), ParameterizeError> {
    let n = chart.positions_m.len();
    let ratio = if options.level_ratio > 1.0 {
        options.level_ratio
    } else {
        10.0
    };
    // Vertex targets n, n/r, n/r², … down to the coarsest size.
    let coarsest = options.coarsest_max_vertices.max(3);
    let mut targets = vec![n];
    while let Some(&last) = targets.last() {
        if last <= coarsest {
            break;
        }
        targets.push(((last as f64 / ratio).ceil() as usize).max(3));
    }
    let locked: Vec<u32> = pins.iter().map(|p| p.vertex).collect();
    let pm_options = ProgressiveMeshOptions {
        max_angular_defect_rad: options.max_angular_defect_rad,
        min_vertices: targets.last().copied().unwrap_or(n),
    };
    let pm = if targets.len() > 1 {
        build_progressive_mesh(chart, &locked, &pm_options)?
    } else {
        super::progressive_mesh::ProgressiveMesh {
            vertex_count: n,
            collapses: Vec::new(),
        }
    };
    // Collapses applied at each level, coarsest first, deduplicated (decimation may stall).
    let mut applied: Vec<usize> = targets
        .iter()
        .map(|&t| (n - t.min(n)).min(pm.collapses.len()))
        .collect();
    applied.dedup();
    applied.reverse();

    let mut uv = vec![[0.0f64; 2]; n];
    let mut levels = Vec::with_capacity(applied.len());
    let mut finest_iterations = 0;
    let mut converged = false;
    let mut previous_applied: Option<usize> = None;
    for (index, &m) in applied.iter().enumerate() {
        let finest = index + 1 == applied.len();
        let level = pm.level(chart, m)?;
        let level_topology;
        let topo = if m == 0 {
            topology
        } else {
            level_topology = level.chart.validate().map_err(|e| ParameterizeError::Internal {
                detail: format!("progressive mesh level with {m} collapses is not a disk: {e}"),
            })?;
            &level_topology
        };
        let level_pins: Vec<Pin> = pins
            .iter()
            .map(|p| Pin {
                vertex: level.level_vertex[p.vertex as usize],
                uv: p.uv,
            })
            .collect();
        let system = LscmSystem::assemble(&level.chart, topo, &level_pins)?;
        let (x, iterations, relative_residual) = match previous_applied {
            None => {
                let x = system.solve_direct()?;
                (x, 0, 0.0)
            }
            Some(coarse_m) => {
                // Vertex splits from the previous level down to this one.
                pm.split_to(&mut uv, coarse_m, m);
                let level_uv: Vec<[f64; 2]> =
                    level.chart_vertex.iter().map(|&v| uv[v as usize]).collect();
                let mut x = system.solution_from_uv(&level_uv);
                let cg = if finest {
                    CgOptions {
                        tolerance: options.final_tolerance,
                        max_iterations: options.final_max_iterations,
                    }
                } else {
                    CgOptions {
                        tolerance: options.final_tolerance,
                        max_iterations: options.relax_iterations,
                    }
                };
                let mut cancelled = false;
                let mut energy_converged = false;
                let window = options.energy_window.max(1);
                let mut history: Vec<f64> = Vec::new();
                let outcome = system.solve_cg(&mut x, &cg, &mut |step| {
                    if !finest {
                        return ControlFlow::Continue(());
                    }
                    let flow = monitor((step.iteration, cg.max_iterations));
                    if flow.is_break() {
                        cancelled = true;
                        return flow;
                    }
                    let energy = system.energy_from_residual(step.x, step.residual);
                    history.push(energy);
                    if history.len() > window {
                        let before = history[history.len() - 1 - window];
                        if before - energy <= options.final_energy_tolerance * energy.abs() {
                            energy_converged = true;
                            return ControlFlow::Break(());
                        }
                    }
                    ControlFlow::Continue(())
                })?;
                if cancelled {
                    return Err(ParameterizeError::Cancelled);
                }
                if finest {
                    converged = outcome.converged || energy_converged;
                }
                (x, outcome.iterations, outcome.relative_residual)
            }
        };
        if previous_applied.is_none() && finest {
            converged = true;
        }
        let level_uv = system.uv_from_solution(&x);
        for (l, &v) in level.chart_vertex.iter().enumerate() {
            uv[v as usize] = level_uv[l];
        }
        if finest {
            finest_iterations = iterations;
        }
        levels.push(HlscmLevel {
            vertices: level.chart.positions_m.len(),
            iterations,
            relative_residual,
        });
        previous_applied = Some(m);
    }
    Ok((
        uv,
        HlscmReport {
            levels,
            collapses: pm.collapses.len(),
            finest_iterations,
            converged,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::super::lscm::{conformal_energy, diameter_pins, flipped_faces};
    use super::super::test_meshes::{hemisphere, noisy_height_field};
    use super::*;

    fn direct_energy(chart: &ChartMesh) -> f64 {
        let topo = chart.validate().expect("disk");
        let pins = diameter_pins(chart, &topo);
        let sys = LscmSystem::assemble(chart, &topo, &pins).expect("assemble");
        let uv = sys.uv_from_solution(&sys.solve_direct().expect("solve"));
        conformal_energy(chart, &uv)
    }

    #[test]
    fn hlscm_matches_direct_energy_within_1e4() {
        for chart in [noisy_height_field(60, 0.3, 4), hemisphere(64, 30)] {
            let topo = chart.validate().expect("disk");
            let pins = diameter_pins(&chart, &topo);
            let options = HlscmOptions {
                coarsest_max_vertices: 300,
                ..HlscmOptions::default()
            };
            let (uv, report) =
                solve_hlscm(&chart, &topo, &pins, &options, &mut |_| ControlFlow::Continue(()))
                    .expect("hlscm");
            assert!(report.levels.len() >= 2, "{report:?}");
            assert!(report.converged, "{report:?}");
            let e = conformal_energy(&chart, &uv);
            let e_direct = direct_energy(&chart);
            assert!(
                (e - e_direct).abs() <= 1e-4 * e_direct,
                "hlscm {e} direct {e_direct} report {report:?}"
            );
            assert!(flipped_faces(&chart, &uv).is_empty());
        }
    }

    #[test]
    fn single_level_when_chart_is_small() {
        let chart = noisy_height_field(8, 0.3, 4);
        let topo = chart.validate().expect("disk");
        let pins = diameter_pins(&chart, &topo);
        let (uv, report) = solve_hlscm(
            &chart,
            &topo,
            &pins,
            &HlscmOptions::default(),
            &mut |_| ControlFlow::Continue(()),
        )
        .expect("hlscm");
        assert_eq!(report.levels.len(), 1);
        let e = conformal_energy(&chart, &uv);
        assert!((e - direct_energy(&chart)).abs() <= 1e-9 * e);
    }
}
