//! Volume (media) radiance caching in the room: the indirect in-scattered radiance q (see
//! [`crate::media_gather`]) cached in a `raddiff::cache::Cache` of the volume domain, records from
//! sphere gathers placed along the camera rays, one run per error metric at equal record counts.
//!
//! The camera ray of every pixel is cut into `steps` equal segments up to its surface hit; their
//! midpoints are the *points* where the render needs q (I = Σ q(x_k) T(t_k) Δt) and where records
//! may be placed. A point's gather depends only on the point, so gathers are memoized and shared by
//! every metric and parameter, and a run's CPU time is the sum of its own records' measured costs
//! plus its lookups, as for the surface caches.

use std::sync::OnceLock;

use glam::DVec3;
use raddiff::cache::{metric, Cache, CacheConfig, Extent, Interpolation, Record};
use raddiff::gather::radii::ErrorMode;
use rayon::prelude::*;

use crate::lightmap::LightMap;
use crate::media_gather::{MediaGathered, MediaGatherer};
pub use crate::media_view::MediaView;
use crate::placement::{clamped_extent, level_pixels};
use crate::scene::Scene;
use crate::timing::ThreadTimer;

/// The media metrics compared, by command-line name, each with the interpolation its paper uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MediaMetric {
    /// Ward's split sphere with the harmonic-mean distance to the surfaces around the point: the
    /// baseline that knows nothing of the medium's own light. Ward-Heckbert interpolation.
    SplitSphere,
    /// Jarosz et al. 2008 (Marco et al. eq. 5): R = ε Σ_c q_c / Σ_c |∇q_c| over the RGB channels,
    /// with Jarosz's log-space extrapolation (Marco eq. 4).
    Gradient,
    /// Occlusion-aware Hessian of Marco et al. 2018 (`media_derivatives`), sphere records from
    /// `volume_radii` (eq. 22, anisotropy 1), cubic kernel (eq. 23).
    HessianIsotropic,
    /// The same with ellipsoidal records, anisotropy ≤ 2.
    HessianAnisotropic,
}

impl MediaMetric {
    pub const ALL: [MediaMetric; 4] = [
        MediaMetric::SplitSphere,
        MediaMetric::Gradient,
        MediaMetric::HessianIsotropic,
        MediaMetric::HessianAnisotropic,
    ];

    pub fn name(self) -> &'static str {
        match self {
            MediaMetric::SplitSphere => "split-sphere",
            MediaMetric::Gradient => "gradient",
            MediaMetric::HessianIsotropic => "hessian-isotropic",
            MediaMetric::HessianAnisotropic => "hessian-anisotropic",
        }
    }

    /// The name in the report's CSV, next to the surface metrics.
    pub fn report_name(self) -> &'static str {
        match self {
            MediaMetric::SplitSphere => "media-split-sphere",
            MediaMetric::Gradient => "media-gradient",
            MediaMetric::HessianIsotropic => "media-hessian-isotropic",
            MediaMetric::HessianAnisotropic => "media-hessian-anisotropic",
        }
    }

    pub fn parse(s: &str) -> Option<MediaMetric> {
        MediaMetric::ALL.into_iter().find(|m| m.name() == s)
    }

    pub fn uses_hessian(self) -> bool {
        matches!(
            self,
            MediaMetric::HessianIsotropic | MediaMetric::HessianAnisotropic
        )
    }

    pub fn interpolation(self) -> Interpolation {
        match self {
            MediaMetric::SplitSphere => Interpolation::Ward,
            MediaMetric::Gradient => Interpolation::Log,
            MediaMetric::HessianIsotropic | MediaMetric::HessianAnisotropic => Interpolation::Cubic,
        }
    }

    /// How a record's radius scales with the parameter: as its first power for the
    /// split-sphere and gradient metrics, as its fifth root for the Hessian metrics (they bound
    /// the error integrated over the record's ball, which grows as r⁵).
    pub fn radius_exponent(self) -> f64 {
        if self.uses_hessian() {
            0.2
        } else {
            1.0
        }
    }

    fn initial_parameter(self) -> f64 {
        match self {
            MediaMetric::SplitSphere | MediaMetric::Gradient => 0.2,
            MediaMetric::HessianIsotropic | MediaMetric::HessianAnisotropic => 1e-3,
        }
    }

    /// The record extent this metric gives a gather, before the radius clamps (an error means
    /// unbounded: the largest radius).
    pub fn extent(self, g: &MediaGathered, parameter: f64) -> Result<Extent, raddiff::Error> {
        Ok(match self {
            MediaMetric::SplitSphere => {
                Extent::isotropic(metric::split_sphere(parameter, g.harmonic_mean_distance)?)
            }
            MediaMetric::Gradient => {
                let values = g.value.map(|v| v as f64);
                Extent::isotropic(metric::gradient_metric(
                    parameter,
                    &values,
                    &g.channel_gradients,
                )?)
            }
            MediaMetric::HessianIsotropic | MediaMetric::HessianAnisotropic => {
                let anisotropy = if self == MediaMetric::HessianIsotropic {
                    1.0
                } else {
                    2.0
                };
                metric::hessian_volume(
                    g.hessian,
                    g.luminance.max(1e-12),
                    parameter,
                    ErrorMode::Relative,
                    anisotropy,
                )?
            }
        })
    }
}

/// Gathers computed so far, one slot per march point, shared by every metric.
pub struct MediaStore<'a> {
    pub scene: &'a Scene,
    pub lightmap: &'a LightMap,
    pub view: &'a MediaView,
    pub gatherer: MediaGatherer,
    slots: Vec<OnceLock<Option<MediaGathered>>>,
}

impl<'a> MediaStore<'a> {
    pub fn new(
        scene: &'a Scene,
        lightmap: &'a LightMap,
        view: &'a MediaView,
        gatherer: MediaGatherer,
    ) -> Self {
        MediaStore {
            scene,
            lightmap,
            view,
            gatherer,
            slots: (0..view.points()).map(|_| OnceLock::new()).collect(),
        }
    }

    pub fn get(&self, id: usize) -> Option<&MediaGathered> {
        self.slots[id]
            .get_or_init(|| {
                if !self.view.in_medium(id / self.view.steps) {
                    return None;
                }
                self.gatherer
                    .gather(
                        self.scene,
                        self.lightmap,
                        self.view.point(id),
                        1 + id as u64,
                    )
                    .ok()
            })
            .as_ref()
    }

    /// Every gather computed so far, with its point id.
    pub fn computed(&self) -> impl Iterator<Item = (usize, &MediaGathered)> {
        self.slots
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.get().and_then(|g| g.as_ref()).map(|g| (i, g)))
    }

    /// Relative RMS difference (luminance) between the gathers' own q and the reference q at their
    /// points: the noise floor under every media cache.
    pub fn gather_noise(&self, reference: &[DVec3]) -> f64 {
        let (mut e2, mut r2) = (0.0, 0.0);
        for (i, g) in self.computed() {
            let r = crate::image::luminance(reference[i]);
            e2 += (g.luminance - r) * (g.luminance - r);
            r2 += r * r;
        }
        (e2 / r2.max(1e-300)).sqrt()
    }
}

/// One media cache built with one metric at one parameter, and its image.
pub struct MediaRun {
    pub metric: MediaMetric,
    pub parameter: f64,
    pub records: Vec<Record<[f32; 3]>>,
    /// q from the cache at every point (what the render integrates: [`MediaRun::image`]).
    pub points: Vec<DVec3>,
    pub trace_seconds: f64,
    pub raddiff_seconds: f64,
    pub cache_seconds: f64,
    pub uncovered: usize,
}

impl MediaRun {
    /// The cached term reaching the camera per pixel.
    pub fn image(&self, view: &MediaView) -> Vec<DVec3> {
        view.integrate(&self.points)
    }
}

/// Candidates are gathered in parallel in fixed chunks of this many, then inserted in order: the
/// records do not depend on the thread count, and gathers a record of the same chunk makes
/// unnecessary are bounded by the chunk.
const CHUNK: usize = 256;

/// March indices coarse to fine: the middle first, then the quarters, … (for 8 steps: 4, 2, 6, 1,
/// 3, 5, 7, 0), so that records spread along a ray before they crowd.
fn depth_order(steps: usize) -> Vec<usize> {
    let mut seen = vec![false; steps];
    let mut order = Vec::with_capacity(steps);
    let mut ds = steps.next_power_of_two();
    while ds >= 1 {
        let mut k = ds / 2;
        while k < steps {
            if !seen[k] {
                seen[k] = true;
                order.push(k);
            }
            k += ds.max(1);
        }
        ds /= 2;
    }
    order
}

/// Builds the media cache of `metric` at `parameter`: pixel grids of step 16, 8, …, 1 as for the
/// surfaces, every new pixel's march points in [`depth_order`]; an uncovered point gets a gather and
/// a record unless one inserted before it (same chunk) covers it by then.
pub fn run(
    store: &MediaStore,
    metric: MediaMetric,
    parameter: f64,
) -> Result<MediaRun, raddiff::Error> {
    let view = store.view;
    let (w, h, k) = (view.width, view.height, view.steps);
    let cache: Cache<[f32; 3]> =
        Cache::new(CacheConfig::volume(3).with_interpolation(metric.interpolation()))?;
    let size = store.scene.size;
    let covered = |cache: &Cache<[f32; 3]>, id: usize| {
        !view.in_medium(id / k) || cache.lookup(view.point(id), DVec3::Y).is_ok()
    };
    let depth = depth_order(k);
    let mut records = Vec::new();
    let mut record_ids = Vec::new();
    let mut cache_seconds = 0.0;
    let mut step = 16;
    loop {
        let pixels = level_pixels(w, h, step);
        let candidates: Vec<usize> = depth
            .iter()
            .flat_map(|&d| pixels.iter().map(move |&p| p * k + d))
            .collect();
        for chunk in candidates.chunks(CHUNK) {
            let start = ThreadTimer::start();
            let wanted: Vec<usize> = chunk
                .iter()
                .copied()
                .filter(|&id| !covered(&cache, id))
                .collect();
            cache_seconds += start.seconds();
            wanted.par_iter().for_each(|&id| {
                store.get(id);
            });
            let start = ThreadTimer::start();
            for &id in &wanted {
                if covered(&cache, id) {
                    continue;
                }
                let Some(g) = store.get(id) else { continue };
                let extent = clamped_extent(metric.extent(g, parameter).ok(), size);
                let mut record = Record::new(g.position, DVec3::Y, g.value, extent);
                record.gradient = Some(g.gradient);
                cache.insert(&record)?;
                records.push(record);
                record_ids.push(id);
            }
            cache_seconds += start.seconds();
        }
        if step == 1 {
            break;
        }
        step /= 2;
    }
    // q at every point from the cache (first-order extrapolation may undershoot: q ≥ 0).
    let start = ThreadTimer::start();
    let mut uncovered = 0;
    // successive points are steps along one camera ray: a cursor serves them (same results)
    let mut cursor = raddiff::cache::Cursor::new();
    let points: Vec<DVec3> = (0..view.points())
        .map(|id| {
            if !view.in_medium(id / k) {
                return DVec3::ZERO;
            }
            match cache.lookup_with(&mut cursor, view.point(id), DVec3::Y) {
                Ok(l) => DVec3::new(l.value[0] as f64, l.value[1] as f64, l.value[2] as f64)
                    .max(DVec3::ZERO),
                Err(_) => {
                    uncovered += 1;
                    DVec3::ZERO
                }
            }
        })
        .collect();
    cache_seconds += start.seconds();
    let (mut trace_seconds, mut raddiff_seconds) = (0.0, 0.0);
    for &id in &record_ids {
        let g = store
            .get(id)
            .expect("every record comes from a stored gather");
        trace_seconds += g.trace_seconds;
        raddiff_seconds += g.gradient_seconds;
        if metric.uses_hessian() {
            raddiff_seconds += g.hessian_seconds;
        }
    }
    Ok(MediaRun {
        metric,
        parameter,
        records,
        points,
        trace_seconds,
        raddiff_seconds,
        cache_seconds,
        uncovered,
    })
}

/// Bisects the metric's parameter in log space until the record count is within 3% of `target`
/// (or 24 runs), as for the surface caches.
pub fn tune(
    store: &MediaStore,
    metric: MediaMetric,
    target: usize,
) -> Result<MediaRun, raddiff::Error> {
    let distance = |r: &MediaRun| (r.records.len() as f64 - target as f64).abs();
    let mut p = metric.initial_parameter();
    let mut current = run(store, metric, p)?;
    let (mut lo, mut hi) = (p, p);
    let mut steps = 0;
    while current.records.len() > target && steps < 24 {
        lo = p;
        p *= 2.0;
        hi = p;
        current = run(store, metric, p)?;
        steps += 1;
    }
    while current.records.len() < target && steps < 24 {
        hi = p;
        p *= 0.5;
        lo = p;
        current = run(store, metric, p)?;
        steps += 1;
    }
    let mut best = current;
    while distance(&best) > 0.03 * target as f64 && steps < 24 {
        let mid = (lo * hi).sqrt();
        let r = run(store, metric, mid)?;
        if r.records.len() > target {
            lo = mid;
        } else {
            hi = mid;
        }
        if distance(&r) < distance(&best) {
            best = r;
        }
        steps += 1;
    }
    Ok(best)
}

/// The reference q at every point: an `m`×`n` jittered sphere gather per point (seeds disjoint
/// from the records'), the same integrand as the records', so that a cache's difference from it is
/// interpolation error plus the records' own gather noise.
pub fn reference(
    store: &MediaStore,
    m: usize,
    n: usize,
    progress: &indicatif::ProgressBar,
) -> Vec<DVec3> {
    let view = store.view;
    progress.set_length(view.points() as u64);
    (0..view.points())
        .into_par_iter()
        .map(|id| {
            progress.inc(1);
            if !view.in_medium(id / view.steps) {
                return DVec3::ZERO;
            }
            store
                .gatherer
                .value(
                    store.scene,
                    store.lightmap,
                    view.point(id),
                    m as u32,
                    n as u32,
                    0x5EED_0000_0000 + id as u64,
                )
                .unwrap_or(DVec3::ZERO)
        })
        .collect()
}

/// RMS of the luminance error over the pixels whose camera ray crosses the medium, and that divided
/// by the RMS of the reference.
pub fn rms_error(image: &[DVec3], reference: &[DVec3], view: &MediaView) -> (f64, f64) {
    let (mut e2, mut r2, mut n) = (0.0, 0.0, 0usize);
    for (p, (v, r)) in image.iter().zip(reference).enumerate() {
        if !view.in_medium(p) {
            continue;
        }
        let (lv, lr) = (crate::image::luminance(*v), crate::image::luminance(*r));
        e2 += (lv - lr) * (lv - lr);
        r2 += lr * lr;
        n += 1;
    }
    ((e2 / n.max(1) as f64).sqrt(), (e2 / r2.max(1e-300)).sqrt())
}
