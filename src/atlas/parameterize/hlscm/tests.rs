//! Tests of the hierarchy and the cascadic solve against the direct solve.
use super::super::lscm::{conformal_energy, diameter_pins, flipped_faces};
use super::super::test_meshes::{hemisphere, noisy_height_field};
use super::*;
use crate::atlas::progress::Stage;

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
        let hierarchy = build_hierarchy(&chart, &topo, &pins, &options).expect("hierarchy");
        let sizes = hierarchy.level_sizes();
        assert_eq!(sizes.last(), Some(&chart.positions_m.len()));
        // About `level_ratio` = 10 times more vertices per level (the paper's schedule).
        for w in sizes.windows(2) {
            let ratio = w[1] as f64 / w[0] as f64;
            assert!((7.0..=13.0).contains(&ratio), "{sizes:?}");
        }
        let (uv, report) = hierarchy
            .solve(&options, &mut StageProgress::ignored(Stage::Parameterize))
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
fn paper_jacobi_relaxation_also_converges_to_the_minimum() {
    let chart = hemisphere(24, 10);
    let topo = chart.validate().expect("disk");
    let pins = diameter_pins(&chart, &topo);
    let options = HlscmOptions {
        coarsest_max_vertices: 30,
        smoother: HlscmSmoother::Jacobi,
        final_max_iterations: 20_000,
        final_energy_tolerance: 0.0,
        final_tolerance: 1e-10,
        ..HlscmOptions::default()
    };
    let (uv, report) = solve_hlscm(
        &chart,
        &topo,
        &pins,
        &options,
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("hlscm");
    assert!(report.levels.len() >= 2 && report.converged, "{report:?}");
    let (e, e_direct) = (conformal_energy(&chart, &uv), direct_energy(&chart));
    // The direct solution is the minimum: HLSCM can only be above it, and close.
    assert!(
        e >= e_direct * (1.0 - 1e-12) && e <= e_direct * (1.0 + 1e-6),
        "{e} {e_direct}"
    );
}

#[test]
fn block_mat_vecs_give_the_scalar_csr_bits() {
    let chart = noisy_height_field(40, 0.4, 7);
    let topo = chart.validate().expect("disk");
    let pins = diameter_pins(&chart, &topo);
    let sys = LscmSystem::assemble(&chart, &topo, &pins).expect("assemble");
    let blocks = ComplexBlockMatrix::from_normal_matrix(sys.matrix()).expect("blocks");
    let n = sys.unknowns();
    let mut seed = 99u64;
    let mut next = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let x: Vec<f64> = (0..n).map(|_| next()).collect();
    let mut y = vec![0.0; n];
    blocks.mul_vec_into(&x, &mut y).expect("block mat-vec");
    let expected = sys.matrix().mul_vec(&x).expect("csr mat-vec");
    assert_eq!(
        y.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        expected.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    // A hierarchy's interpolation against its scalar (P ⊗ I₂) CSR form and transpose.
    let options = HlscmOptions {
        coarsest_max_vertices: 200,
        ..HlscmOptions::default()
    };
    let hierarchy = build_hierarchy(&chart, &topo, &pins, &options).expect("hierarchy");
    let fine = hierarchy.levels.last().expect("levels");
    let (p, pt) = fine.prolongation.as_ref().expect("prolongation");
    let mut row_ptr = vec![0usize];
    let (mut cols, mut vals) = (Vec::new(), Vec::new());
    for r in 0..p.rows() {
        for c in 0..2u32 {
            for k in p.row_ptr[r]..p.row_ptr[r + 1] {
                cols.push(2 * p.col[k] + c);
                vals.push(p.weight[k]);
            }
            row_ptr.push(cols.len());
        }
    }
    let scalar =
        CsrMatrix::from_csr_parts(2 * p.rows(), 2 * p.cols, row_ptr, cols, vals).expect("csr");
    let xc: Vec<f64> = (0..2 * p.cols).map(|_| next()).collect();
    let xf: Vec<f64> = (0..2 * p.rows()).map(|_| next()).collect();
    let (mut yf, mut yc) = (vec![0.0; 2 * p.rows()], vec![0.0; 2 * p.cols]);
    p.mul_vec_into(&xc, &mut yf).expect("P");
    pt.mul_vec_into(&xf, &mut yc).expect("Pt");
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&yf), bits(&scalar.mul_vec(&xc).expect("csr P")));
    assert_eq!(
        bits(&yc),
        bits(&scalar.transpose().mul_vec(&xf).expect("csr Pt"))
    );
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
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("hlscm");
    assert_eq!(report.levels.len(), 1);
    let e = conformal_energy(&chart, &uv);
    assert!((e - direct_energy(&chart)).abs() <= 1e-9 * e);
}
