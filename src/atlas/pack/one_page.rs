//! One page at a fixed density, as a yes-or-no test with its packing: the packing-aware cuts'
//! cheap test of a candidate before a full density search.
use std::ops::ControlFlow;

use super::{
    largest_first, padded_box_order, prepare_all, Context, PackCache, PackChart, PackError,
    PackOptions, Packing, Steps, TexelDensity,
};

/// One page at the fixed density `texels_per_unit`, if it holds every chart: the horizons'
/// packing, else the packing with hole filling by the plain first fit (the searches of one
/// trial of the fit-to-page density search, [`super::pack_charts`], but never the
/// contact-scored hole search, which costs several times more; `options.density` is
/// ignored). `Ok(None)` when neither places every chart. A cheaper test than
/// [`super::pack_charts`] at that density, which opens more pages for what does not fit: each
/// trial stops at its first chart that does not fit. Same guarantees as
/// [`super::pack_charts`] for the packing returned. Through `cache` when given
/// ([`PackCache`]; its footprints are used and kept when `texels_per_unit` is its pinned
/// density).
///
/// Errors: [`PackError::InvalidOption`], [`PackError::InvalidChart`].
pub fn pack_one_page(
    charts: &[PackChart<'_>],
    options: &PackOptions,
    texels_per_unit: f64,
    cache: Option<&PackCache>,
) -> Result<Option<Packing>, PackError> {
    one_page(charts, options, texels_per_unit, cache, true)
}

/// [`pack_one_page`] with the horizons alone: `Ok(None)` when they do not place every chart,
/// without the hole filling after them: a test that fails costs one trial instead of two.
pub fn pack_one_page_horizons(
    charts: &[PackChart<'_>],
    options: &PackOptions,
    texels_per_unit: f64,
    cache: Option<&PackCache>,
) -> Result<Option<Packing>, PackError> {
    one_page(charts, options, texels_per_unit, cache, false)
}

fn one_page(
    charts: &[PackChart<'_>],
    options: &PackOptions,
    texels_per_unit: f64,
    cache: Option<&PackCache>,
    holes_too: bool,
) -> Result<Option<Packing>, PackError> {
    let options = &PackOptions {
        density: TexelDensity::TexelsPerUnit(texels_per_unit),
        ..*options
    };
    options.check()?;
    let (prepared, ids) = prepare_all(charts, cache)?;
    let order = largest_first(&prepared);
    let mut ctx = Context::new(charts, &prepared, &order, options);
    ctx.cache = cache.zip(ids.as_deref());
    ctx.first_miss_stops = true;
    let mut ignore = |_: (usize, usize)| ControlFlow::Continue(());
    let t = ctx.run(
        texels_per_unit,
        false,
        &mut Steps::new(&mut ignore, order.len()),
    )?;
    if t.unplaced == 0 {
        return Ok(Some(ctx.output(&t)));
    }
    if !holes_too {
        return Ok(None);
    }
    let total_area_m2: f64 = order.iter().map(|&i| prepared[i].area_m2).sum();
    let hole_order = padded_box_order(charts, &prepared, &order, options, total_area_m2);
    ctx.holes = true;
    ctx.scored = false;
    ctx.order = &hole_order;
    let t = ctx.run(
        texels_per_unit,
        false,
        &mut Steps::new(&mut ignore, order.len()),
    )?;
    Ok((t.unplaced == 0).then(|| ctx.output(&t)))
}
