//! The packer's input, built from the validated charts: per chart, its triangles in the
//! numbering of its map, its 3-D area and whether it is degenerate. One builder, so that the
//! packing-aware cuts and the pack stage pack the same charts.

use super::error::AtlasError;
use super::pack::PackChart;
use super::parameterize::{self, ChartDefect};
use crate::mesh::{TriangleMesh, VertexId};

/// What the packer needs of validated charts, per chart: triangles in the numbering of the
/// chart's map, 3-D area (model units²), and whether every face is degenerate (such charts are
/// not packed, see [`generate`](super::generate)).
pub(super) struct PackInputs {
    pub(super) triangles: Vec<Vec<[u32; 3]>>,
    pub(super) area_m2: Vec<f64>,
    pub(super) degenerate: Vec<bool>,
}

/// [`PackInputs`] of `v`; the one builder of packer input, so that the packing of
/// `cut_for_packing` and the pack stage see the same charts. Errors when a chart has no map.
pub(super) fn pack_inputs(
    mesh: &TriangleMesh,
    v: &parameterize::ParameterizedCharts,
) -> Result<PackInputs, AtlasError> {
    let charts = &v.segmentation.charts;
    let mut local_of = vec![u32::MAX; mesh.num_vertices()];
    let mut out = PackInputs {
        triangles: Vec::with_capacity(charts.len()),
        area_m2: Vec::with_capacity(charts.len()),
        degenerate: Vec::with_capacity(charts.len()),
    };
    for (i, faces) in charts.iter().enumerate() {
        let Some((map, global)) = v.maps[i].as_ref() else {
            // The parameterizer's own reason when validation recorded one.
            let detail = v
                .unresolved
                .iter()
                .find_map(|(c, d)| match d {
                    ChartDefect::Unparameterizable(e) if *c == i => Some(e.to_string()),
                    _ => None,
                })
                .unwrap_or_else(|| "no map was produced".into());
            return Err(AtlasError::Unparameterizable {
                chart: i,
                faces: faces.len(),
                detail,
            });
        };
        for (l, g) in global.iter().enumerate() {
            local_of[g.index()] = l as u32;
        }
        let mut tris = Vec::with_capacity(faces.len());
        let mut area = 0.0;
        for &f in faces {
            let t = mesh.face_vertices(f).map(|g: VertexId| local_of[g.index()]);
            debug_assert!(t.iter().all(|&l| (l as usize) < map.uv.len()));
            tris.push(t);
            area += mesh.face_area_m2(f);
        }
        for g in global {
            local_of[g.index()] = u32::MAX;
        }
        out.triangles.push(tris);
        out.area_m2.push(area);
        out.degenerate
            .push(faces.iter().all(|&f| mesh.face_degeneracy(f).is_some()));
    }
    Ok(out)
}

/// The packer's view of the charts `packed` of `v` (see [`pack_inputs`]).
pub(super) fn pack_charts_of<'a>(
    v: &'a parameterize::ParameterizedCharts,
    packed: &[usize],
    triangles: &'a [Vec<[u32; 3]>],
    area_m2: &[f64],
) -> Vec<PackChart<'a>> {
    packed
        .iter()
        .map(|&i| PackChart {
            uv: v.maps[i].as_ref().map_or(&[][..], |(m, _)| &m.uv),
            triangles: &triangles[i],
            area_m2: area_m2[i],
        })
        .collect()
}
