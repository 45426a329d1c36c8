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
use raddiff::gather::radii::{surface_radii, ErrorMode};
use rayon::prelude::*;

use crate::derivs::{Gathered, Gatherer, Hessians};
use crate::lightmap::LightMap;
use crate::placement::{clamped_extent, level_pixels};
use crate::render::GBuffer;
use crate::scene::Scene;
use crate::timing::ThreadTimer;

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
                let r = surface_radii(
                    hessian,
                    g.normal,
                    lum,
                    parameter,
                    ErrorMode::Relative,
                    anisotropy,
                )?;
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

/// Places records coarse to fine (pixel grids of step 16, 8, …, 1): at every level the pixels no
/// record covers get a gather, and their records are inserted in pixel order, skipping those that
/// a record inserted earlier at the same level already covers. Deterministic for any thread count.
pub fn run(store: &GatherStore, metric: Metric, parameter: f64) -> Result<Run, raddiff::Error> {
    let gb = store.gbuffer;
    let (w, h) = (gb.width, gb.height);
    let cache: Cache<[f32; 3]> =
        Cache::new(CacheConfig::surface(3).with_interpolation(metric.interpolation()))?;
    let size = store.scene.size;
    let mut records = Vec::new();
    let mut record_pixels = Vec::new();
    let mut cache_seconds = 0.0;
    let covered = |cache: &Cache<[f32; 3]>, i: usize| match gb.pixels[i].shaded() {
        Some(sp) => cache.lookup(sp.position, sp.normal).is_ok(),
        None => true,
    };
    let mut step = 16;
    loop {
        let level = level_pixels(w, h, step);
        // Lookups run on this thread so that the thread clock measures them (they cost
        // microseconds; the gathers below are what needs the threads).
        let start = ThreadTimer::start();
        let wanted: Vec<usize> = level
            .iter()
            .copied()
            .filter(|&i| !covered(&cache, i))
            .collect();
        cache_seconds += start.seconds();
        wanted.par_iter().for_each(|&i| {
            store.get(i);
        });
        let start = ThreadTimer::start();
        for &i in &wanted {
            if covered(&cache, i) {
                continue;
            }
            let Some(g) = store.get(i) else { continue };
            let extent = clamped_extent(metric.extent(g, parameter).ok(), size);
            let mut record = Record::new(g.position, g.normal, g.value, extent);
            record.gradient = Some(g.gradient);
            record.rotation_gradient = Some(g.rotation_gradient);
            cache.insert(&record)?;
            records.push(record);
            record_pixels.push(i);
        }
        cache_seconds += start.seconds();
        if step == 1 {
            break;
        }
        step /= 2;
    }
    // Render the indirect irradiance from the cache, in scanline order through a cursor (the
    // same results as plain lookups, faster for neighbouring pixels).
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
    cache_seconds += start.seconds();
    let uncovered = image.iter().filter(|v| v.is_none()).count();
    let image = image
        .into_iter()
        .map(|v| v.unwrap_or(DVec3::ZERO))
        .collect();
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
        records,
        image,
        trace_seconds,
        raddiff_seconds,
        cache_seconds,
        uncovered,
    })
}

/// Tunes the metric's parameter (bisection in log space) until the record count is within 3% of
/// `target` (or 24 steps), then returns that run.
pub fn tune(store: &GatherStore, metric: Metric, target: usize) -> Result<Run, raddiff::Error> {
    let count = |p: f64| run(store, metric, p);
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
