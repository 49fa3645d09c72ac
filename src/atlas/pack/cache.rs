//! Work kept between packings of mostly the same charts: the packing-aware cuts pack an atlas
//! again and again with one chart cut in two, each try at the density of the gain it needs,
//! so every other chart's prepared data ([`place::prepare_chart`]) and its footprints at that
//! density ([`place::orientations`]) are those of the try before.
//!
//! A chart is known by its content (UVs, triangles and area, compared exactly, not only by
//! hash), so a chart rebuilt by the caller for the next try is found again. Prepared data is
//! kept for every chart seen; footprints only at the density [`PackCache::pin`] names (a
//! density search tries a new density each trial, and footprints are the bulk of a
//! packing's memory: one density's worth at most). Whatever is found is what would be
//! computed, so a packing is the same with or without a cache.

use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex, MutexGuard};

use super::place::{self, Orientation, PreparedChart};
use super::{chart_rotations, Context, PackChart, PackError};

/// Prepared charts and footprints kept between packings ([`super::pack_charts_cached`],
/// [`super::pack_one_page`]). Deterministic: it changes how much is computed, never a
/// result.
#[derive(Debug, Default)]
pub struct PackCache {
    inner: Mutex<Inner>,
}

#[derive(Debug, Default)]
struct Inner {
    /// The density whose footprints are kept (its bits).
    pinned: Option<u64>,
    /// Every chart seen, by content hash: its content and its id.
    charts: HashMap<u64, Vec<(Arc<Content>, usize)>>,
    /// Charts seen so far (the next id).
    count: usize,
    prepared: HashMap<usize, PreparedChart>,
    footprints: HashMap<(usize, FootprintKey), Arc<Vec<Orientation>>>,
}

/// A chart's content, compared exactly.
#[derive(Debug, PartialEq)]
struct Content {
    uv_bits: Vec<[u64; 2]>,
    triangles: Vec<[u32; 3]>,
    area_bits: u64,
}

impl Content {
    fn of(chart: &PackChart<'_>) -> Self {
        Self {
            uv_bits: chart
                .uv
                .iter()
                .map(|p| [p[0].to_bits(), p[1].to_bits()])
                .collect(),
            triangles: chart.triangles.to_vec(),
            area_bits: chart.area_m2.to_bits(),
        }
    }

    fn hash(&self) -> u64 {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        self.uv_bits.hash(&mut h);
        self.triangles.hash(&mut h);
        self.area_bits.hash(&mut h);
        h.finish()
    }
}

/// Everything a chart's footprints depend on besides the chart: the arguments of
/// [`place::orientations`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct FootprintKey {
    texels_per_unit_bits: u64,
    rotations: u32,
    padding_texels: u32,
    page_texels: [u32; 2],
    padded_bits: bool,
}

impl PackCache {
    /// An empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// From now on, keeps the footprints made at `texels_per_unit` (and drops those kept at
    /// another density).
    pub fn pin(&self, texels_per_unit: f64) {
        let mut inner = self.lock();
        let bits = texels_per_unit.to_bits();
        if inner.pinned != Some(bits) {
            inner.pinned = Some(bits);
            inner.footprints.clear();
        }
    }

    /// What it holds: the charts whose prepared data it keeps, and the footprint sets (one per
    /// chart and set of orientation arguments) at the pinned density. A diagnostic.
    pub fn kept(&self) -> (usize, usize) {
        let inner = self.lock();
        (inner.prepared.len(), inner.footprints.len())
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        // A panic elsewhere cannot leave the maps half-written (each insert is one call).
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The id of each chart's content (the same id for the same content, in any packing).
    fn ids(&self, charts: &[PackChart<'_>]) -> Vec<usize> {
        use rayon::prelude::*;
        let contents: Vec<(Content, u64)> = charts
            .par_iter()
            .map(|c| {
                let content = Content::of(c);
                let hash = content.hash();
                (content, hash)
            })
            .collect();
        let mut inner = self.lock();
        contents
            .into_iter()
            .map(|(content, hash)| {
                let known = inner
                    .charts
                    .get(&hash)
                    .and_then(|v| v.iter().find(|(c, _)| **c == content).map(|e| e.1));
                known.unwrap_or_else(|| {
                    let id = inner.count;
                    inner.count += 1;
                    inner
                        .charts
                        .entry(hash)
                        .or_default()
                        .push((Arc::new(content), id));
                    id
                })
            })
            .collect()
    }
}

/// [`super::prepare_all`] through `cache`: each chart's prepared data, computed (in parallel)
/// only for contents not seen before, and the charts' ids in the cache.
pub(super) fn prepare_cached(
    charts: &[PackChart<'_>],
    cache: &PackCache,
) -> Result<(Vec<PreparedChart>, Vec<usize>), PackError> {
    use rayon::prelude::*;
    let ids = cache.ids(charts);
    let known: Vec<Option<PreparedChart>> = {
        let inner = cache.lock();
        ids.iter()
            .map(|id| inner.prepared.get(id).cloned())
            .collect()
    };
    let prepared: Vec<PreparedChart> = known
        .into_par_iter()
        .enumerate()
        .map(|(i, p)| match p {
            Some(p) => Ok(p),
            None => place::prepare_chart(i, &charts[i]),
        })
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<_, _>>()?;
    let mut inner = cache.lock();
    for (id, p) in ids.iter().zip(&prepared) {
        inner.prepared.entry(*id).or_insert_with(|| p.clone());
    }
    Ok((prepared, ids))
}

impl Context<'_, '_> {
    /// The orientations of charts `js` at `texels_per_unit` ([`place::orientations`], with
    /// [`chart_rotations`]), made in parallel; with a cache, those kept at a pinned density
    /// are taken from it and those made there are kept. The same whatever the thread count.
    pub(super) fn footprints(
        &self,
        js: &[usize],
        texels_per_unit: f64,
    ) -> Vec<Arc<Vec<Orientation>>> {
        use rayon::prelude::*;
        let o = self.options;
        let page = self.page();
        let key = |j: usize| FootprintKey {
            texels_per_unit_bits: texels_per_unit.to_bits(),
            rotations: chart_rotations(
                &self.prepared[j],
                texels_per_unit,
                o.rotations,
                self.holes,
                self.scored,
                page,
            ),
            padding_texels: o.padding_texels,
            page_texels: page,
            padded_bits: self.scored,
        };
        let make = |j: usize| {
            let k = key(j);
            Arc::new(place::orientations(
                &self.charts[j],
                &self.prepared[j],
                texels_per_unit,
                k.rotations,
                k.padding_texels,
                k.page_texels,
                k.padded_bits,
            ))
        };
        let Some((cache, ids)) = self.cache else {
            return js.par_iter().map(|&j| make(j)).collect();
        };
        let pinned = cache.lock().pinned == Some(texels_per_unit.to_bits());
        if !pinned {
            return js.par_iter().map(|&j| make(j)).collect();
        }
        let mut got: Vec<Option<Arc<Vec<Orientation>>>> = {
            let inner = cache.lock();
            js.iter()
                .map(|&j| inner.footprints.get(&(ids[j], key(j))).cloned())
                .collect()
        };
        let missing: Vec<usize> = (0..js.len()).filter(|&i| got[i].is_none()).collect();
        let made: Vec<Arc<Vec<Orientation>>> = missing.par_iter().map(|&i| make(js[i])).collect();
        let mut inner = cache.lock();
        for (i, m) in missing.into_iter().zip(made) {
            inner
                .footprints
                .insert((ids[js[i]], key(js[i])), Arc::clone(&m));
            got[i] = Some(m);
        }
        got.into_iter().flatten().collect()
    }
}
