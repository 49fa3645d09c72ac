//! Stretch (Sander, Snyder, Gortler, Hoppe 2001, "Texture mapping progressive meshes" §3, with
//! the symmetric L∞ of Zhou, Snyder, Guo, Shum 2004, "Iso-charts" §4), angle and area
//! distortion, and texel density, with the evaluator's global normalisation `k = Σ|A2| / ΣA3`.
//!
//! Per used face: `Ss = (e1·dt2 - e2·dt1) / (2 A2)`, `St = (e2·ds1 - e1·ds2) / (2 A2)` (the
//! Jacobian columns of the map from texture to surface), `a, b, c` its metric tensor scaled by
//! `k`, Γ/γ its singular values. Percentiles follow numpy: linear interpolation unweighted,
//! inverted weighted CDF (stable sort, sequential cumulative sum, first index reaching `q·Σw`)
//! weighted.
//!
//! Units: stretch and ratios dimensionless; angles in degrees (`_deg`, as the evaluator).
//! Cost: one pass over the faces plus three sorts of the used faces' values (percentiles).
use super::geometry::{uv64, FaceGeometry};
use super::numpy::{
    dot3_einsum, np_mean, np_mean_weighted, np_sum, percentile_linear, percentile_weighted,
    stable_order,
};
use super::{finite, AngleDistortion, AreaDistortion, StretchReport, TexelDensityReport};
use crate::mesh::vector::sub;
use crate::mesh::{FaceId, TriangleMesh};

/// Per-chart stretch figures (global `k`).
#[derive(Debug, Clone, Default)]
pub(super) struct ChartStretch {
    pub area_3d_m2: f64,
    pub uv_area: f64,
    pub l2: Option<f64>,
    pub linf: Option<f64>,
    pub texel_density: Option<f64>,
}

pub(super) struct StretchResult {
    pub stretch: StretchReport,
    pub angle: Option<AngleDistortion>,
    pub area: Option<AreaDistortion>,
    pub density: Option<TexelDensityReport>,
    pub per_chart: Vec<ChartStretch>,
}

/// One used face's metric: `a, b, c` (the metric tensor of the map from texture to surface,
/// scaled by `k`) and its singular values Γ (`big`) and γ (`small`).
pub(crate) struct FaceMetric {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub big: f64,
    pub small: f64,
}

/// The report's [`FaceMetric`] of a face with 3-D corners `p` and UV corners `uv`; `two_a2` is
/// twice its signed UV area (non-zero), `k` the atlas's `Σ|A2| / ΣA3`. The one definition of
/// the report's per-face stretch (the pipeline's last line of defence reads it too).
pub(crate) fn face_metric(p: [[f64; 3]; 3], uv: &[[f32; 2]; 3], two_a2: f64, k: f64) -> FaceMetric {
    let e1 = sub(p[1], p[0]);
    let e2 = sub(p[2], p[0]);
    let [s0, t0] = uv64(uv[0]);
    let [s1, t1] = uv64(uv[1]);
    let [s2, t2] = uv64(uv[2]);
    let (ds1, dt1, ds2, dt2) = (s1 - s0, t1 - t0, s2 - s0, t2 - t0);
    let ss: [f64; 3] = std::array::from_fn(|i| (e1[i] * dt2 - e2[i] * dt1) / two_a2);
    let st: [f64; 3] = std::array::from_fn(|i| (-e1[i] * ds2 + e2[i] * ds1) / two_a2);
    let a = dot3_einsum(ss, ss) * k;
    let b = dot3_einsum(ss, st) * k;
    let c = dot3_einsum(st, st) * k;
    let root = ((a - c) * (a - c) + 4.0 * b * b).sqrt();
    FaceMetric {
        a,
        b,
        c,
        big: (0.5 * ((a + c) + root)).sqrt(),
        small: (0.5 * ((a + c) - root)).max(0.0).sqrt(),
    }
}

/// The stretch, distortion and density figures. `page_texels_area` = `W · H`.
pub(super) fn stretch(
    mesh: &TriangleMesh,
    corner_uvs: &[[[f32; 2]; 3]],
    geo: &FaceGeometry,
    chart_of_face: &[u32],
    num_charts: usize,
    page_texels_area: f64,
) -> StretchResult {
    let nf = corner_uvs.len();
    let used: Vec<bool> = (0..nf)
        .map(|f| !geo.uv_degenerate[f] && !geo.degenerate_3d[f])
        .collect();
    let used_a2: Vec<f64> = (0..nf)
        .filter(|&f| used[f])
        .map(|f| geo.signed_uv_area[f].abs())
        .collect();
    let used_a3: Vec<f64> = (0..nf)
        .filter(|&f| used[f])
        .map(|f| geo.area_3d_m2[f])
        .collect();
    let num_used = used.iter().filter(|&&u| u).count();
    let excluded_uv = (0..nf)
        .filter(|&f| geo.uv_degenerate[f] && !geo.degenerate_3d[f])
        .count();
    let mut report = StretchReport {
        triangles_used: num_used,
        excluded_uv_degenerate: excluded_uv,
        excluded_3d_degenerate: geo.degenerate_3d.iter().filter(|&&d| d).count(),
        strict_infinite: excluded_uv > 0,
        ..StretchReport::default()
    };
    let mut per_chart = vec![ChartStretch::default(); num_charts];
    if num_used == 0 {
        return StretchResult {
            stretch: report,
            angle: None,
            area: None,
            density: None,
            per_chart,
        };
    }
    let k = np_sum(&used_a2) / np_sum(&used_a3);
    report.uv_area_over_3d_area = finite(k);

    let mut dev = Vec::with_capacity(num_used);
    let mut conf = Vec::with_capacity(num_used);
    let mut ratio = Vec::with_capacity(num_used);
    let mut weight = Vec::with_capacity(num_used);
    let mut l2_terms = Vec::with_capacity(num_used);
    let (mut max_gamma, mut max_inv_gamma) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    // Per chart: Σ (a+c)/2·A3 and max(Γ, 1/γ); plain sequential sums (as numpy's bincount).
    let mut chart_l2_num = vec![0.0f64; num_charts];
    let mut chart_a3 = vec![0.0f64; num_charts];
    let mut chart_a2 = vec![0.0f64; num_charts];
    let mut chart_linf = vec![f64::NEG_INFINITY; num_charts];
    for f in (0..nf).filter(|&f| used[f]) {
        let p = mesh.face_positions(FaceId(f as u32));
        let a2 = geo.signed_uv_area[f];
        let a3 = geo.area_3d_m2[f];
        let FaceMetric {
            a,
            b,
            c,
            big,
            small,
        } = face_metric(p, &corner_uvs[f], 2.0 * a2, k);
        let inv_small = if small > 0.0 {
            1.0 / small
        } else {
            f64::INFINITY
        };
        let term = (a + c) / 2.0 * a3;
        l2_terms.push(term);
        max_gamma = max_gamma.max(big);
        max_inv_gamma = max_inv_gamma.max(inv_small);
        let cos = (b / (a * c).sqrt()).clamp(-1.0, 1.0);
        let d = (cos.acos().to_degrees() - 90.0).abs();
        dev.push(if d.is_nan() { 90.0 } else { d });
        conf.push(if small > 0.0 {
            big / small
        } else {
            f64::INFINITY
        });
        ratio.push((a2.abs() / a3) / k);
        weight.push(a3);
        let ch = chart_of_face[f] as usize;
        chart_l2_num[ch] += term;
        chart_a3[ch] += a3;
        chart_a2[ch] += a2.abs();
        chart_linf[ch] = chart_linf[ch].max(big.max(inv_small));
    }
    report.l2 = finite((np_sum(&l2_terms) / np_sum(&used_a3)).sqrt());
    report.linf = finite(max_gamma.max(max_inv_gamma));
    report.linf_sander = finite(max_gamma);

    // Angle distortion.
    let dev_order = stable_order(&dev);
    let dev_sorted: Vec<f64> = dev_order.iter().map(|&i| dev[i as usize]).collect();
    let conf_order = stable_order(&conf);
    let conf_sorted: Vec<f64> = conf_order.iter().map(|&i| conf[i as usize]).collect();
    let (conf_finite, w_finite): (Vec<f64>, Vec<f64>) = conf
        .iter()
        .zip(&weight)
        .filter(|(c, _)| c.is_finite())
        .map(|(&c, &w)| (c, w))
        .unzip();
    let angle = AngleDistortion {
        angle_deviation_deg_mean: np_mean(&dev),
        angle_deviation_deg_p95: percentile_linear(&dev_sorted, 95.0),
        angle_deviation_deg_mean_aw: np_mean_weighted(&dev, &weight),
        angle_deviation_deg_p95_aw: percentile_weighted(&dev, &weight, &dev_order, 95.0),
        conformal_ratio_mean: np_mean(&conf_finite),
        conformal_ratio_p95: percentile_linear(&conf_sorted, 95.0),
        conformal_ratio_mean_aw: np_mean_weighted(&conf_finite, &w_finite),
        conformal_ratio_p95_aw: percentile_weighted(&conf, &weight, &conf_order, 95.0),
    };
    // Area distortion.
    let r_order = stable_order(&ratio);
    let r_sorted: Vec<f64> = r_order.iter().map(|&i| ratio[i as usize]).collect();
    let area = AreaDistortion {
        p5: percentile_linear(&r_sorted, 5.0),
        p50: percentile_linear(&r_sorted, 50.0),
        p95: percentile_linear(&r_sorted, 95.0),
        p5_aw: percentile_weighted(&ratio, &weight, &r_order, 5.0),
        p50_aw: percentile_weighted(&ratio, &weight, &r_order, 50.0),
        p95_aw: percentile_weighted(&ratio, &weight, &r_order, 95.0),
    };

    // Per chart and texel density.
    let (mut dens, mut dens_w) = (Vec::new(), Vec::new());
    for (ch, cs) in per_chart.iter_mut().enumerate() {
        cs.area_3d_m2 = chart_a3[ch];
        cs.uv_area = chart_a2[ch];
        if chart_a3[ch] > 0.0 {
            cs.l2 = finite((chart_l2_num[ch] / chart_a3[ch]).sqrt());
            cs.linf = finite(chart_linf[ch]);
            let d = (chart_a2[ch] / chart_a3[ch]).sqrt();
            cs.texel_density = finite(d);
            dens.push(d);
            dens_w.push(chart_a3[ch]);
        }
    }
    let density = (!dens.is_empty()).then(|| {
        let min = dens.iter().copied().fold(f64::INFINITY, f64::min);
        let max = dens.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mu = np_mean(&dens).unwrap_or(f64::NAN);
        let var: Vec<f64> = dens.iter().map(|&d| (d - mu) * (d - mu)).collect();
        let std = np_mean(&var).unwrap_or(f64::NAN).sqrt();
        let mu_w = np_mean_weighted(&dens, &dens_w).unwrap_or(f64::NAN);
        let var_w = np_mean_weighted(&var_about(&dens, mu_w), &dens_w).unwrap_or(f64::NAN);
        TexelDensityReport {
            charts_measured: dens.len(),
            min,
            max,
            max_over_min: (min > 0.0).then(|| max / min).and_then(finite),
            cv: (mu > 0.0).then(|| std / mu).and_then(finite),
            cv_aw: (mu_w > 0.0).then(|| var_w.sqrt() / mu_w).and_then(finite),
            texels_per_unit: finite(k.sqrt() * page_texels_area.sqrt()),
        }
    });
    StretchResult {
        stretch: report,
        angle: Some(angle),
        area: Some(area),
        density,
        per_chart,
    }
}

fn var_about(x: &[f64], mu: f64) -> Vec<f64> {
    x.iter().map(|&d| (d - mu) * (d - mu)).collect()
}
