//! Packing figures on generated chart sets: efficiency (Σ UV area / page area) and time, with
//! the independent checker of `texatlas::atlas::pack::test_charts`. Prints one line per case;
//! asserts the stage guarantees. Run: `cargo test --release --test it -- pack_bench:: --nocapture`.

use std::time::Instant;

use texatlas::atlas::pack::test_charts::{
    as_pack_charts, check_packing, mixed_set, realistic_set, OwnedChart,
};
use texatlas::atlas::pack::{pack_charts, PackOptions, TexelDensity};
use texatlas::atlas::{Stage, StageProgress};

fn run(name: &str, charts: &[OwnedChart], options: &PackOptions) {
    let borrowed = as_pack_charts(charts);
    let t = Instant::now();
    let packing =
        pack_charts(&borrowed, options, &mut StageProgress::ignored(Stage::Pack)).expect("packs");
    let ms = t.elapsed().as_secs_f64() * 1e3;
    let check = check_packing(&borrowed, &packing, options);
    println!(
        "{name:28} charts {:5} page {}x{} pad {} rot {:2}: efficiency {:.3} pages {} density {:.4} time {ms:8.1} ms  {:?}",
        charts.len(),
        options.width_texels,
        options.height_texels,
        options.padding_texels,
        options.rotations,
        check.efficiency,
        packing.num_pages,
        packing.texels_per_unit,
        (check.overlap_texels, check.padding_violation_texels, check.edge_violation_texels, check.out_of_range_uvs)
    );
    // One trial: the same packing at the density found.
    let fixed = PackOptions {
        density: TexelDensity::TexelsPerUnit(packing.texels_per_unit),
        ..*options
    };
    let t = Instant::now();
    let one =
        pack_charts(&borrowed, &fixed, &mut StageProgress::ignored(Stage::Pack)).expect("packs");
    println!(
        "{:28} one trial at that density: {:8.1} ms, pages {}",
        "",
        t.elapsed().as_secs_f64() * 1e3,
        one.num_pages
    );
    assert_eq!(
        check.overlap_texels
            + check.padding_violation_texels
            + check.edge_violation_texels
            + check.out_of_range_uvs,
        0
    );
}

#[test]
fn pack_bench_generated_sets() {
    let d = PackOptions::default();
    run("realistic x8", &realistic_set(8), &d);
    run("mixed 60", &mixed_set(60, 3), &d);
    run(
        "mixed 60 rot4",
        &mixed_set(60, 3),
        &PackOptions { rotations: 4, ..d },
    );
    run(
        "mixed 60 rot1",
        &mixed_set(60, 3),
        &PackOptions { rotations: 1, ..d },
    );
    run("mixed 500", &mixed_set(500, 4), &d);
    run("mixed 3000", &mixed_set(3000, 5), &d);
}
