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
use raddiff::cache::{metric, Cache, CacheConfig, Extent, Interpolation, Record};
use raddiff::gather::radii::{surface_radii, surface_radii_floored, CurvatureFloor, ErrorMode};
use rayon::prelude::*;

use crate::derivs::{Gathered, Gatherer, Hessians};
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
    /// The gradient limit at c = 2: it stops gradients estimated a hair's breadth from a
    /// junction (|grad E| R / E up to 132) and leaves sane ones alone (c = 1, which keeps every
    /// value's sign, trimmed the split sphere's legitimately steep gradients: +9% error).
    /// Neighbour clamping off: at equal record counts it raised every metric's error here (see
    /// `docs/demo.md`).
    fn default() -> Self {
        Safeguards {
            gradient_limit: 2.0,
            neighbour_clamp: false,
        }
    }
}

/// The metrics compared, by command-line name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    /// Ward's split sphere: radius a·R with R the harmonic-mean hit distance.
    SplitSphere,
    /// The split sphere bounded by the measured gradient (Ward-Heckbert, Křivánek): a·min(R, E/|∇E|).
    BoundedSplitSphere,
    /// Jarosz et al. 2008: radius ε·E/|∇E| from the gradient alone.
    Gradient,
    /// Occlusion-unaware (radiometric) Hessian (thesis ch. 4), anisotropic records like the last.
    HessianUnaware,
    /// Geometric Hessian (thesis eq. 4.23: radiance held at its largest), anisotropic records.
    HessianGeometric,
    /// Occlusion-aware Hessian (Schwarzhaupt et al.), isotropic (disc) records.
    HessianIsotropic,
    /// Occlusion-aware Hessian, anisotropic (ellipse) records, anisotropy ≤ 2.
    HessianAnisotropic,
}

impl Metric {
    pub const ALL: [Metric; 7] = [
        Metric::SplitSphere,
        Metric::BoundedSplitSphere,
        Metric::Gradient,
        Metric::HessianUnaware,
        Metric::HessianGeometric,
        Metric::HessianIsotropic,
        Metric::HessianAnisotropic,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Metric::SplitSphere => "split-sphere",
            Metric::BoundedSplitSphere => "bounded-split-sphere",
            Metric::Gradient => "gradient",
            Metric::HessianUnaware => "hessian-unaware",
            Metric::HessianGeometric => "hessian-geometric",
            Metric::HessianIsotropic => "hessian-isotropic",
            Metric::HessianAnisotropic => "hessian-anisotropic",
        }
    }

    pub fn parse(s: &str) -> Option<Metric> {
        Metric::ALL.into_iter().find(|m| m.name() == s)
    }

    /// The Hessians the gathers must compute for `metrics`.
    pub fn hessians(metrics: &[Metric]) -> Hessians {
        let any = |wanted: &[Metric]| metrics.iter().any(|m| wanted.contains(m));
        Hessians {
            aware: any(&[Metric::HessianIsotropic, Metric::HessianAnisotropic]),
            unaware: any(&[Metric::HessianUnaware]),
            geometric: any(&[Metric::HessianGeometric]),
        }
    }

    /// Whether the metric is defined only on surfaces outside a medium (its Hessian needs the
    /// hits' normals and ignores attenuation).
    pub fn surfaces_only(self) -> bool {
        matches!(self, Metric::HessianUnaware | Metric::HessianGeometric)
    }

    pub fn uses_hessian(self) -> bool {
        matches!(
            self,
            Metric::HessianUnaware
                | Metric::HessianGeometric
                | Metric::HessianIsotropic
                | Metric::HessianAnisotropic
        )
    }

    /// A starting value of the metric's parameter (accuracy a, ε, or relative error).
    fn initial_parameter(self) -> f64 {
        match self {
            Metric::SplitSphere | Metric::BoundedSplitSphere | Metric::Gradient => 0.2,
            _ => 1e-3,
        }
    }

    /// How a record's radius scales with the parameter: as its first power for the
    /// split-sphere and gradient metrics, as its fourth root for the Hessian metrics (they bound
    /// the error integrated over the record's disc, which grows as r⁴).
    pub fn radius_exponent(self) -> f64 {
        if self.uses_hessian() {
            0.25
        } else {
            1.0
        }
    }

    fn interpolation(self) -> Interpolation {
        if self.uses_hessian() {
            Interpolation::Tent
        } else {
            Interpolation::Ward
        }
    }

    /// The record extent this metric gives a gather, before the radius clamps.
    fn extent(self, g: &Gathered, parameter: f64) -> Result<Extent, raddiff::Error> {
        self.extent_floored(g, parameter, true)
    }

    /// [`Metric::extent`], the Hessian metrics' radii with or without the curvature floor.
    pub fn extent_floored(
        self,
        g: &Gathered,
        parameter: f64,
        curvature_floor: bool,
    ) -> Result<Extent, raddiff::Error> {
        let lum = g.luminance.max(1e-12);
        Ok(match self {
            Metric::SplitSphere => {
                Extent::isotropic(metric::split_sphere(parameter, g.harmonic_mean_distance)?)
            }
            Metric::BoundedSplitSphere => Extent::isotropic(metric::split_sphere_bounded(
                parameter,
                g.harmonic_mean_distance,
                lum,
                g.luminance_gradient,
            )?),
            Metric::Gradient => {
                let norm = g.luminance_gradient.length();
                let r = if norm > 0.0 {
                    parameter * lum / norm
                } else {
                    f64::INFINITY
                };
                Extent::isotropic(r)
            }
            Metric::HessianUnaware
            | Metric::HessianGeometric
            | Metric::HessianIsotropic
            | Metric::HessianAnisotropic => {
                let anisotropy = if self == Metric::HessianIsotropic {
                    1.0
                } else {
                    2.0
                };
                let hessian = match self {
                    Metric::HessianUnaware => g.unaware_hessian.ok_or_else(|| {
                        raddiff::Error::Degenerate("no occlusion-unaware Hessian in media".into())
                    })?,
                    Metric::HessianGeometric => g.geometric_hessian.ok_or_else(|| {
                        raddiff::Error::Degenerate("no geometric Hessian in media".into())
                    })?,
                    _ => g.hessian,
                };
                // the floor's distance: Ward's harmonic mean (infinite when every ray missed)
                let distance = g.harmonic_mean_distance;
                let r = if curvature_floor && distance.is_finite() {
                    surface_radii_floored(
                        hessian,
                        g.normal,
                        g.luminance,
                        parameter,
                        ErrorMode::Relative,
                        anisotropy,
                        CurvatureFloor::new(distance),
                    )?
                } else {
                    surface_radii(
                        hessian,
                        g.normal,
                        lum,
                        parameter,
                        ErrorMode::Relative,
                        anisotropy,
                    )?
                };
                Extent {
                    radii: [r.radii[0], r.radii[1], r.radii[0].min(r.radii[1])],
                    axes: [r.axes[0], r.axes[1], DVec3::ZERO],
                }
            }
        })
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
                e2 += (g.luminance - lr) * (g.luminance - lr);
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
    let config = CacheConfig::surface(3).with_interpolation(metric.interpolation());
    let Filled {
        cache,
        record_pixels,
        seconds: placement_seconds,
    } = match baseline {
        Baseline::Production => fill_production(store, metric, parameter, config, safeguards)?,
        Baseline::Thesis => fill_thesis(store, metric, parameter, config)?,
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
        raddiff_seconds += match metric {
            Metric::HessianUnaware => g.unaware_seconds,
            Metric::HessianGeometric => g.geometric_seconds,
            Metric::HessianIsotropic | Metric::HessianAnisotropic => g.hessian_seconds,
            _ => 0.0,
        };
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

/// The record of gather `g` with `extent`, with its gradients or (Ward 1988) without.
fn record_of(g: &Gathered, extent: Extent, gradients: bool) -> Record<[f32; 3]> {
    let mut record = Record::new(g.position, g.normal, g.value, extent);
    if gradients {
        record.gradient = Some(g.gradient);
        record.rotation_gradient = Some(g.rotation_gradient);
    }
    record
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
    metric: Metric,
    parameter: f64,
    config: CacheConfig,
    safeguards: Safeguards,
) -> Result<Filled, raddiff::Error> {
    let gb = store.gbuffer;
    let (w, h) = (gb.width, gb.height);
    let size = store.scene.size;
    let mut cache: Cache<[f32; 3]> =
        Cache::new(config.with_gradient_limit(safeguards.gradient_limit))?;
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
            let extent = clamped_extent_to(
                metric.extent(g, parameter).ok(),
                RADIUS_MIN * size,
                RADIUS_MAX * size,
            );
            let extent = if clamp {
                cache.clamp_to_neighbours(g.position, &extent)?
            } else {
                extent
            };
            cache.insert(&record_of(g, extent, true))?;
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
    metric: Metric,
    parameter: f64,
    config: CacheConfig,
) -> Result<Filled, raddiff::Error> {
    let gb = store.gbuffer;
    let camera = &store.scene.camera;
    let size = store.scene.size;
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
            let depth = (g.position - camera.position).dot(camera.forward);
            let pixel = 2.0 * depth * camera.tan_half_fov / gb.height as f64;
            let max = match metric {
                Metric::BoundedSplitSphere => pixel * 150.0 / 1800.0 * gb.height as f64,
                Metric::SplitSphere | Metric::Gradient => RADIUS_MAX * size,
                _ => raddiff::cache::RADIUS_MAX,
            };
            let extent = clamped_extent_to(metric.extent(g, parameter).ok(), pixel, max);
            cache.insert(&record_of(g, extent, metric != Metric::SplitSphere))?;
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
