//! Irradiance caching with one error metric: records placed coarse to fine over the image, the
//! metric's free parameter tuned to a record count, and the cached image compared with the
//! reference.
//!
//! Gathers depend only on the pixel they are computed at, so they are computed once (in parallel)
//! and shared by every metric and threshold; each record's measured costs (ray casting, raddiff's
//! gradient evaluation, raddiff's Hessian) are summed into a metric's CPU time, so the comparison
//! does not depend on the machine's load while it runs.

use std::sync::OnceLock;

use glam::DVec3;
pub use raddiff::cache::irradiance::Metric;
use raddiff::cache::irradiance::{
    Hessians, IrradianceSettings, RadiusBounds, GRADIENT_LIMIT_DEFAULT,
};
use raddiff::cache::{Cache, CacheConfig, Record};
use rayon::prelude::*;

use crate::derivs::{Gathered, Gatherer};
use crate::lightmap::LightMap;
use crate::placement::{clamped_extent_to, level_pixels, RADIUS_MAX, RADIUS_MIN};
use crate::render::GBuffer;
use crate::scene::Scene;
use crate::timing::ThreadTimer;

/// How records are placed and what the metrics get: the two settings the demo reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Baseline {
    /// Coarse-to-fine placement (an overture over pixel grids of step 16 to 1), gradients for
    /// every metric, the cache's gradient limit, two-sided neighbour clamping, the curvature
    /// floor for the Hessian metrics, radii clamped to [0.004, 0.25] x the scene size.
    Production,
    /// The thesis' comparison (sec. 6.4): lazy placement in one scanline pass, Ward 1988's split
    /// sphere without gradients, a one-pixel minimum radius, the bounded split sphere capped at
    /// 150 px of an 1800 px image (scaled to this resolution), no maximum for Hessian records
    /// (the curvature floor, the working form of the thesis' robustness term, keeps them finite).
    Thesis,
}

impl Baseline {
    pub const ALL: [Baseline; 2] = [Baseline::Production, Baseline::Thesis];

    pub fn name(self) -> &'static str {
        match self {
            Baseline::Production => "production",
            Baseline::Thesis => "thesis",
        }
    }

    pub fn parse(s: &str) -> Option<Baseline> {
        Baseline::ALL.into_iter().find(|b| b.name() == s)
    }

    /// One line for the report.
    pub fn summary(self, safeguards: Safeguards) -> String {
        match self {
            Baseline::Production => {
                let limit = if safeguards.gradient_limit.is_finite() {
                    format!("gradient limit c = {}", safeguards.gradient_limit)
                } else {
                    "no gradient limit".to_string()
                };
                let clamp = if safeguards.neighbour_clamp {
                    "two-sided neighbour clamping"
                } else {
                    "no neighbour clamping"
                };
                format!(
                    "overture placement, gradients for every metric, {limit}, {clamp}, curvature \
                     floor for the Hessian metrics, radii in [0.004, 0.25] x scene size"
                )
            }
            Baseline::Thesis => "lazy scanline placement, Ward 1988 split sphere without \
                                 gradients, one-pixel minimum radius, bounded split sphere capped \
                                 at 150 px of 1800, no maximum radius for Hessian records, \
                                 curvature floor for the Hessian metrics"
                .to_string(),
        }
    }
}

/// Rounds of the finest level that end with the two-sided neighbour clamp (each can uncover
/// pixels next to the small records the round inserted); one more round then only fills.
const CLAMP_ROUNDS: usize = 3;

/// The production baseline's safeguards (command-line options).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Safeguards {
    /// `CacheConfig::gradient_limit`: over its extent a record's first-order extrapolation moves
    /// a channel by at most this times its value (∞: off).
    pub gradient_limit: f64,
    /// Two-sided neighbour clamping (Křivánek et al. 2006): each record clamped to its stored
    /// neighbours before it is inserted, and `Cache::clamp_neighbours` after every level.
    pub neighbour_clamp: bool,
}

impl Default for Safeguards {
    /// The library's gradient limit ([`GRADIENT_LIMIT_DEFAULT`], chosen from this demo's
    /// measurements). Neighbour clamping off: at equal record counts it raised every metric's
    /// error here (see `docs/demo.md`).
    fn default() -> Self {
        Safeguards {
            gradient_limit: GRADIENT_LIMIT_DEFAULT,
            neighbour_clamp: false,
        }
    }
}

/// What the demo adds to the library's metrics: where its tuning starts, how radii scale with
/// the parameter, and where a metric is defined.
pub trait MetricTuning {
    /// A starting value of the metric's parameter (accuracy a, ε, or relative error).
    fn initial_parameter(self) -> f64;
    /// How a record's radius scales with the parameter: as its first power for the
    /// split-sphere and gradient metrics, as its fourth root for the Hessian metrics (they bound
    /// the error integrated over the record's disc, which grows as r⁴).
    fn radius_exponent(self) -> f64;
    /// Whether the metric is defined only on surfaces outside a medium (its Hessian needs the
    /// hits' normals and ignores attenuation).
    fn surfaces_only(self) -> bool;
}

impl MetricTuning for Metric {
    fn initial_parameter(self) -> f64 {
        match self.hessian() {
            None => 0.2,
            Some(_) => 1e-3,
        }
    }

    fn radius_exponent(self) -> f64 {
        match self.hessian() {
            None => 1.0,
            Some(_) => 0.25,
        }
    }

    fn surfaces_only(self) -> bool {
        self.needs_hit_normals()
    }
}

/// The library's settings for `metric` at `parameter` in the production baseline: luminance as
/// the metrics' scalar, radii in [`RADIUS_MIN`, `RADIUS_MAX`] x the scene size, the curvature
/// floor and anisotropy 2 (the library's defaults), the gradient limit of `safeguards`.
fn production_settings(
    metric: Metric,
    parameter: f64,
    size: f64,
    safeguards: Safeguards,
) -> IrradianceSettings {
    IrradianceSettings {
        metric,
        accuracy: parameter,
        radius_bounds: RadiusBounds::world(RADIUS_MIN * size, RADIUS_MAX * size),
        gradient_limit: safeguards.gradient_limit,
        ..IrradianceSettings::new(3)
    }
}

/// Gathers computed so far, one slot per pixel, shared by every metric.
pub struct GatherStore<'a> {
    scene: &'a Scene,
    lightmap: &'a LightMap,
    gbuffer: &'a GBuffer,
    gatherer: Gatherer,
    slots: Vec<OnceLock<Option<Gathered>>>,
}

impl<'a> GatherStore<'a> {
    pub fn new(
        scene: &'a Scene,
        lightmap: &'a LightMap,
        gbuffer: &'a GBuffer,
        m: usize,
        n: usize,
        hessians: Hessians,
    ) -> Result<Self, raddiff::Error> {
        Ok(GatherStore {
            scene,
            lightmap,
            gbuffer,
            gatherer: Gatherer::new(m, n, hessians)?,
            slots: (0..gbuffer.pixels.len()).map(|_| OnceLock::new()).collect(),
        })
    }

    pub fn get(&self, pixel: usize) -> Option<&Gathered> {
        self.slots[pixel]
            .get_or_init(|| {
                let sp = self.gbuffer.pixels[pixel].shaded()?;
                self.gatherer
                    .gather(
                        self.scene,
                        self.lightmap,
                        sp.position,
                        sp.normal,
                        1 + pixel as u64,
                    )
                    .ok()
            })
            .as_ref()
    }

    /// Every gather computed so far.
    pub fn computed(&self) -> impl Iterator<Item = &Gathered> {
        self.slots
            .iter()
            .filter_map(|s| s.get().and_then(|g| g.as_ref()))
    }

    /// Relative RMS difference between the gathers' own irradiance and the reference at their
    /// pixels: the noise floor of any cache built from these gathers.
    pub fn gather_noise(&self, reference: &[DVec3]) -> f64 {
        let (mut e2, mut r2) = (0.0, 0.0);
        for (slot, r) in self.slots.iter().zip(reference) {
            if let Some(Some(g)) = slot.get() {
                let lr = crate::image::luminance(*r);
                let l = g.evaluation.scalar;
                e2 += (l - lr) * (l - lr);
                r2 += lr * lr;
            }
        }
        (e2 / r2.max(1e-300)).sqrt()
    }

    pub fn rays_per_gather(&self) -> usize {
        (self.gatherer.m * self.gatherer.n) as usize
    }
}

/// One cache built with one metric at one parameter, and its image.
pub struct Run {
    pub metric: Metric,
    pub parameter: f64,
    pub records: Vec<Record<[f32; 3]>>,
    /// Indirect irradiance per pixel from the cache.
    pub image: Vec<DVec3>,
    /// CPU seconds: ray casting of the records' gathers, raddiff's gradient and Hessian work for
    /// them (Hessian only for the Hessian metrics), placement and rendering lookups.
    pub trace_seconds: f64,
    pub raddiff_seconds: f64,
    pub cache_seconds: f64,
    pub uncovered: usize,
}

/// Builds a cache with `metric` at `parameter` under `baseline`, renders every pixel from it and
/// sums the records' measured costs. Deterministic for any thread count.
pub fn run(
    store: &GatherStore,
    metric: Metric,
    parameter: f64,
    baseline: Baseline,
    safeguards: Safeguards,
) -> Result<Run, raddiff::Error> {
    let settings = production_settings(metric, parameter, store.scene.size, safeguards);
    let Filled {
        cache,
        record_pixels,
        seconds: placement_seconds,
    } = match baseline {
        Baseline::Production => fill_production(store, &settings, safeguards)?,
        Baseline::Thesis => fill_thesis(store, &settings)?,
    };
    let (image, uncovered, render_seconds) = render(&cache, store.gbuffer);
    // The records' measured costs.
    let (mut trace_seconds, mut raddiff_seconds) = (0.0, 0.0);
    for &i in &record_pixels {
        let g = store
            .get(i)
            .expect("every record comes from a stored gather");
        trace_seconds += g.trace_seconds;
        raddiff_seconds += g.gradient_seconds;
        raddiff_seconds += metric.hessian().map_or(0.0, |kind| g.hessian_seconds(kind));
    }
    Ok(Run {
        metric,
        parameter,
        records: cache.records(),
        image,
        trace_seconds,
        raddiff_seconds,
        cache_seconds: placement_seconds + render_seconds,
        uncovered,
    })
}

/// A filled cache, the pixels whose gathers made its records, and the placement's CPU seconds.
struct Filled {
    cache: Cache<[f32; 3]>,
    record_pixels: Vec<usize>,
    seconds: f64,
}

/// Whether a record covers pixel `i` (pixels that show no indirect light count as covered).
fn covered(cache: &Cache<[f32; 3]>, gb: &GBuffer, i: usize) -> bool {
    match gb.pixels[i].shaded() {
        Some(sp) => cache.lookup(sp.position, sp.normal).is_ok(),
        None => true,
    }
}

/// Production placement: coarse to fine (pixel grids of step 16, 8, …, 1). At every level the
/// pixels no record covers get a gather, and their records are inserted in pixel order, each
/// clamped to its stored neighbours and skipped when a record inserted earlier at the same level
/// already covers it; then the two-sided neighbour clamp runs over the whole cache. Clamping
/// can uncover pixels, so the finest level repeats over every pixel, the last round only
/// filling, until every pixel is covered.
fn fill_production(
    store: &GatherStore,
    settings: &IrradianceSettings,
    safeguards: Safeguards,
) -> Result<Filled, raddiff::Error> {
    let gb = store.gbuffer;
    let (w, h) = (gb.width, gb.height);
    // the figures of docs/demo.md were measured without the zero clamp of irradiance caches
    let mut cache: Cache<[f32; 3]> = Cache::new(settings.cache_config().with_non_negative(false))?;
    let clamp = safeguards.neighbour_clamp;
    let mut record_pixels = Vec::new();
    let mut seconds = 0.0;
    let mut step = 16;
    let mut final_rounds = 0;
    loop {
        // the repeated finest rounds revisit every pixel: the clamp can uncover any of them
        let level = if final_rounds == 0 {
            level_pixels(w, h, step)
        } else {
            (0..w * h).collect()
        };
        // Lookups run on this thread so that the thread clock measures them (they cost
        // microseconds; the gathers below are what needs the threads).
        let start = ThreadTimer::start();
        let wanted: Vec<usize> = level
            .iter()
            .copied()
            .filter(|&i| !covered(&cache, gb, i))
            .collect();
        seconds += start.seconds();
        wanted.par_iter().for_each(|&i| {
            store.get(i);
        });
        let start = ThreadTimer::start();
        for &i in &wanted {
            if covered(&cache, gb, i) {
                continue;
            }
            let Some(g) = store.get(i) else { continue };
            let mut record = settings.record(&g.evaluation, 0.0)?;
            if clamp {
                record.extent = cache.clamp_to_neighbours(record.position, &record.extent)?;
            }
            cache.insert(&record)?;
            record_pixels.push(i);
        }
        // the last round only fills: every pixel it inserts a record for stays covered
        let last_round = step == 1 && final_rounds == CLAMP_ROUNDS;
        if clamp && !last_round {
            cache.clamp_neighbours();
        }
        seconds += start.seconds();
        if step > 1 {
            step /= 2;
            continue;
        }
        if wanted.is_empty() || last_round {
            break;
        }
        final_rounds += 1;
    }
    Ok(Filled {
        cache,
        record_pixels,
        seconds,
    })
}

/// Thesis placement: one pass in scanline order, a record wherever no record covers the pixel
/// (lazy placement while rendering). Gathers are computed ahead in small parallel batches of the
/// next uncovered pixels (some of them then turn out covered and are not used: only the used
/// ones count in the CPU time), so the wall time stays low without changing any result.
fn fill_thesis(
    store: &GatherStore,
    settings: &IrradianceSettings,
) -> Result<Filled, raddiff::Error> {
    let gb = store.gbuffer;
    let camera = &store.scene.camera;
    let size = store.scene.size;
    let metric = settings.metric;
    let config = CacheConfig::surface(3).with_interpolation(metric.interpolation());
    let cache: Cache<[f32; 3]> = Cache::new(config)?;
    let mut record_pixels = Vec::new();
    let mut seconds = 0.0;
    let batch = rayon::current_num_threads();
    let mut next = 0;
    while next < gb.pixels.len() {
        let start = ThreadTimer::start();
        let mut ahead = Vec::with_capacity(batch);
        let mut i = next;
        while i < gb.pixels.len() && ahead.len() < batch {
            if !covered(&cache, gb, i) {
                ahead.push(i);
            }
            i += 1;
        }
        seconds += start.seconds();
        ahead.par_iter().for_each(|&i| {
            store.get(i);
        });
        let start = ThreadTimer::start();
        for p in next..i {
            if covered(&cache, gb, p) {
                continue;
            }
            let Some(g) = store.get(p) else { continue };
            // one pixel's footprint at the record's depth
            let depth = (g.evaluation.position - camera.position).dot(camera.forward);
            let pixel = 2.0 * depth * camera.tan_half_fov / gb.height as f64;
            let max = match metric {
                Metric::BoundedSplitSphere => pixel * 150.0 / 1800.0 * gb.height as f64,
                Metric::SplitSphere | Metric::Gradient => RADIUS_MAX * size,
                _ => raddiff::cache::RADIUS_MAX,
            };
            let extent = clamped_extent_to(settings.extent(&g.evaluation).ok(), pixel, max);
            let mut record: Record<[f32; 3]> = g.evaluation.record(extent)?;
            if metric == Metric::SplitSphere {
                // Ward 1988: no gradients
                record.gradient = None;
                record.rotation_gradient = None;
            }
            cache.insert(&record)?;
            record_pixels.push(p);
        }
        seconds += start.seconds();
        next = i;
    }
    Ok(Filled {
        cache,
        record_pixels,
        seconds,
    })
}

/// The indirect irradiance of every pixel from the cache, in scanline order through a cursor
/// (the same results as plain lookups, faster for neighbouring pixels); uncovered pixels are
/// zero. Returns the image, the uncovered count and the CPU seconds.
fn render(cache: &Cache<[f32; 3]>, gb: &GBuffer) -> (Vec<DVec3>, usize, f64) {
    let start = ThreadTimer::start();
    let mut cursor = raddiff::cache::Cursor::new();
    let image: Vec<Option<DVec3>> = gb
        .pixels
        .iter()
        .map(|p| match p.shaded() {
            Some(sp) => cache
                .lookup_with(&mut cursor, sp.position, sp.normal)
                .ok()
                .map(|l| DVec3::new(l.value[0] as f64, l.value[1] as f64, l.value[2] as f64)),
            None => Some(DVec3::ZERO),
        })
        .collect();
    let seconds = start.seconds();
    let uncovered = image.iter().filter(|v| v.is_none()).count();
    let image = image
        .into_iter()
        .map(|v| v.unwrap_or(DVec3::ZERO))
        .collect();
    (image, uncovered, seconds)
}

/// Tunes the metric's parameter (bisection in log space) until the record count is within 3% of
/// `target` (or 24 steps), then returns that run.
pub fn tune(
    store: &GatherStore,
    metric: Metric,
    target: usize,
    baseline: Baseline,
    safeguards: Safeguards,
) -> Result<Run, raddiff::Error> {
    let count = |p: f64| run(store, metric, p, baseline, safeguards);
    let mut p = metric.initial_parameter();
    let mut current = count(p)?;
    // Bracket: records decrease as the parameter grows.
    let (mut lo, mut hi) = (p, p);
    let mut steps = 0;
    while current.records.len() > target && steps < 24 {
        lo = p;
        p *= 2.0;
        hi = p;
        current = count(p)?;
        steps += 1;
    }
    while current.records.len() < target && steps < 24 {
        hi = p;
        p *= 0.5;
        lo = p;
        current = count(p)?;
        steps += 1;
    }
    let mut best = current;
    let close = |n: usize| (n as f64 - target as f64).abs() <= 0.03 * target as f64;
    while !close(best.records.len()) && steps < 24 {
        let mid = (lo * hi).sqrt();
        let r = count(mid)?;
        if r.records.len() > target {
            lo = mid;
        } else {
            hi = mid;
        }
        if (r.records.len() as f64 - target as f64).abs()
            < (best.records.len() as f64 - target as f64).abs()
        {
            best = r;
        }
        steps += 1;
    }
    Ok(best)
}

/// RMS error of luminance over the shaded pixels (see [`crate::render::Pixel::shaded`]), and that divided by the RMS of the reference.
pub fn rms_error(image: &[DVec3], reference: &[DVec3], gbuffer: &GBuffer) -> (f64, f64) {
    let (mut e2, mut r2, mut n) = (0.0, 0.0, 0usize);
    for ((v, r), p) in image.iter().zip(reference).zip(&gbuffer.pixels) {
        if p.shaded().is_none() {
            continue;
        }
        let (lv, lr) = (crate::image::luminance(*v), crate::image::luminance(*r));
        e2 += (lv - lr) * (lv - lr);
        r2 += lr * lr;
        n += 1;
    }
    let n = n.max(1) as f64;
    ((e2 / n).sqrt(), (e2 / r2.max(1e-300)).sqrt())
}
