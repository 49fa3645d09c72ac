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
use super::geometry::{dot3, sub3, uv64, FaceGeometry};
use super::{finite, AngleDistortion, AreaDistortion, StretchReport, TexelDensityReport};
use crate::mesh::{FaceId, TriangleMesh};

/// Neumaier-compensated sum: long sums agree with numpy's pairwise sums to ~1e-16 relative.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Sum {
    sum: f64,
    compensation: f64,
}

impl Sum {
    pub(super) fn add(&mut self, x: f64) {
        let t = self.sum + x;
        if self.sum.abs() >= x.abs() {
            self.compensation += (self.sum - t) + x;
        } else {
            self.compensation += (x - t) + self.sum;
        }
        self.sum = t;
    }
    pub(super) fn value(&self) -> f64 {
        self.sum + self.compensation
    }
}

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

/// numpy `percentile(x, q)` with the default linear method; `sorted` ascending.
pub(super) fn percentile_linear(sorted: &[f64], q: f64) -> Option<f64> {
    let n = sorted.len();
    if n == 0 {
        return None;
    }
    let quantile = q / 100.0;
    // numpy's `_compute_virtual_index` with alpha = beta = 1.
    let virtual_index = n as f64 * quantile + (1.0 + quantile * -1.0) - 1.0;
    let below = virtual_index.floor().clamp(0.0, (n - 1) as f64);
    let gamma = virtual_index - below;
    let i = below as usize;
    let (a, b) = (sorted[i], sorted[(i + 1).min(n - 1)]);
    // numpy's `_lerp`: exact at both ends.
    let diff = b - a;
    let x = if gamma >= 0.5 {
        b - diff * (1.0 - gamma)
    } else {
        a + diff * gamma
    };
    finite(x)
}

/// The evaluator's weighted percentile: inverted CDF over `order` (indices of `x` stably
/// sorted ascending), weights `w`.
pub(super) fn percentile_weighted(x: &[f64], w: &[f64], order: &[u32], q: f64) -> Option<f64> {
    if order.is_empty() {
        return None;
    }
    let total = order.iter().fold(0.0, |s, &i| s + w[i as usize]);
    if total <= 0.0 || total.is_nan() {
        return None;
    }
    let target = q / 100.0 * total;
    let mut cum = 0.0;
    let mut k = order.len() - 1;
    for (j, &i) in order.iter().enumerate() {
        cum += w[i as usize];
        if cum >= target {
            k = j;
            break;
        }
    }
    finite(x[order[k] as usize])
}

/// Indices of `x` stably sorted ascending.
pub(super) fn stable_order(x: &[f64]) -> Vec<u32> {
    let mut o: Vec<u32> = (0..x.len() as u32).collect();
    o.sort_by(|&a, &b| x[a as usize].total_cmp(&x[b as usize]));
    o
}

fn mean(x: &[f64]) -> Option<f64> {
    if x.is_empty() {
        return None;
    }
    let mut s = Sum::default();
    x.iter().for_each(|&v| s.add(v));
    finite(s.value() / x.len() as f64)
}

fn mean_weighted(x: &[f64], w: &[f64]) -> Option<f64> {
    if x.is_empty() {
        return None;
    }
    let (mut sxw, mut sw) = (Sum::default(), Sum::default());
    for (&v, &wi) in x.iter().zip(w) {
        sxw.add(v * wi);
        sw.add(wi);
    }
    (sw.value() > 0.0)
        .then(|| sxw.value() / sw.value())
        .and_then(finite)
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
    let (mut sa2, mut sa3) = (Sum::default(), Sum::default());
    for f in (0..nf).filter(|&f| used[f]) {
        sa2.add(geo.signed_uv_area[f].abs());
        sa3.add(geo.area_3d_m2[f]);
    }
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
    let k = sa2.value() / sa3.value();
    report.uv_area_over_3d_area = finite(k);

    let mut dev = Vec::with_capacity(num_used);
    let mut conf = Vec::with_capacity(num_used);
    let mut ratio = Vec::with_capacity(num_used);
    let mut weight = Vec::with_capacity(num_used);
    let (mut l2_num, mut l2_den) = (Sum::default(), Sum::default());
    let (mut max_gamma, mut max_inv_gamma) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    // Per chart: Σ (a+c)/2·A3 and max(Γ, 1/γ); plain sequential sums (as numpy's bincount).
    let mut chart_l2_num = vec![0.0f64; num_charts];
    let mut chart_a3 = vec![0.0f64; num_charts];
    let mut chart_a2 = vec![0.0f64; num_charts];
    let mut chart_linf = vec![f64::NEG_INFINITY; num_charts];
    for f in (0..nf).filter(|&f| used[f]) {
        let p = mesh.face_positions(FaceId(f as u32));
        let e1 = sub3(p[1], p[0]);
        let e2 = sub3(p[2], p[0]);
        let uv = &corner_uvs[f];
        let [s0, t0] = uv64(uv[0]);
        let [s1, t1] = uv64(uv[1]);
        let [s2, t2] = uv64(uv[2]);
        let (ds1, dt1, ds2, dt2) = (s1 - s0, t1 - t0, s2 - s0, t2 - t0);
        let a2 = geo.signed_uv_area[f];
        let a3 = geo.area_3d_m2[f];
        let two_a2 = 2.0 * a2;
        let ss: [f64; 3] = std::array::from_fn(|i| (e1[i] * dt2 - e2[i] * dt1) / two_a2);
        let st: [f64; 3] = std::array::from_fn(|i| (-e1[i] * ds2 + e2[i] * ds1) / two_a2);
        let a = dot3(ss, ss) * k;
        let b = dot3(ss, st) * k;
        let c = dot3(st, st) * k;
        let root = ((a - c) * (a - c) + 4.0 * b * b).sqrt();
        let big = (0.5 * ((a + c) + root)).sqrt();
        let small = (0.5 * ((a + c) - root)).max(0.0).sqrt();
        let inv_small = if small > 0.0 {
            1.0 / small
        } else {
            f64::INFINITY
        };
        let term = (a + c) / 2.0 * a3;
        l2_num.add(term);
        l2_den.add(a3);
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
    report.l2 = finite((l2_num.value() / l2_den.value()).sqrt());
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
        angle_deviation_deg_mean: mean(&dev),
        angle_deviation_deg_p95: percentile_linear(&dev_sorted, 95.0),
        angle_deviation_deg_mean_aw: mean_weighted(&dev, &weight),
        angle_deviation_deg_p95_aw: percentile_weighted(&dev, &weight, &dev_order, 95.0),
        conformal_ratio_mean: mean(&conf_finite),
        conformal_ratio_p95: percentile_linear(&conf_sorted, 95.0),
        conformal_ratio_mean_aw: mean_weighted(&conf_finite, &w_finite),
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
        let mu = mean(&dens).unwrap_or(f64::NAN);
        let var: Vec<f64> = dens.iter().map(|&d| (d - mu) * (d - mu)).collect();
        let std = mean(&var).unwrap_or(f64::NAN).sqrt();
        let mu_w = mean_weighted(&dens, &dens_w).unwrap_or(f64::NAN);
        let var_w = mean_weighted(&var_about(&dens, mu_w), &dens_w).unwrap_or(f64::NAN);
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
