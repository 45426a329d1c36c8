//! Irradiance caching with one call per shading point, and the pieces it is made of.
//!
//! [`Cache::irradiance`](crate::cache::Cache::irradiance) looks a shading point up and, on a
//! miss, lays out a gather, has the renderer trace it in one batch through a closure, evaluates
//! it, builds the record under the [`IrradianceSettings`] (error metric, threshold, radius bounds
//! in world units and pixels, safeguards) and inserts it:
//!
//! ```
//! use raddiff::cache::irradiance::{IrradianceSettings, RadiusBounds};
//! use raddiff::cache::Cache;
//! use raddiff::glam::DVec3;
//!
//! let mut settings = IrradianceSettings::new(1);
//! settings.gather_m = 8;
//! settings.gather_n = 24;
//! settings.radius_bounds = RadiusBounds::world(0.01, 1.0);
//! let cache: Cache<f32> = Cache::new(settings.cache_config())?;
//! // a floor under a ceiling of radiance 1 at height 2, beyond which there is nothing
//! let trace = |_origin: DVec3, directions: &[DVec3], distance: &mut [f64], radiance: &mut [f32]| {
//!     for (i, w) in directions.iter().enumerate() {
//!         distance[i] = 2.0 / w.z.max(1e-9);
//!         radiance[i] = 1.0;
//!     }
//!     Ok::<(), String>(())
//! };
//! let e = cache.irradiance(&settings, DVec3::ZERO, DVec3::Z, 0.0, trace)?;
//! assert!((e.value - std::f32::consts::PI).abs() < 1e-4);
//! assert_eq!(cache.len(), 1);
//! # Ok::<(), raddiff::Error>(())
//! ```
//!
//! With a near-field reach ([`IrradianceSettings::near_field`]) the records hold far fields and
//! [`Cache::irradiance_near_far`](crate::cache::Cache::irradiance_near_far) gives each shading
//! point its own near field (short rays, traced through the same kind of closure, which then
//! also takes a maximum distance) plus the interpolated far field ([`NearFarLookup`]).
//!
//! Renderers that share one gather between several metrics or thresholds (benchmarks, parameter
//! sweeps) use the pieces: a [`TracedGather`] evaluated once into a [`GatherEvaluation`] (with the
//! [`Hessians`] every metric of interest needs), then [`IrradianceSettings::record`] per metric
//! and threshold. `Cache::irradiance` is exactly these steps.
//!
//! The safeguards and their defaults (one per safeguard, used by the C ABI, the demo and the
//! Embree example alike; `docs/cache.md` has the table):
//! * gradient limit c = [`GRADIENT_LIMIT_DEFAULT`] (cache state, applied at insert);
//! * curvature floor κ = [`CURVATURE_FLOOR_WEIGHT`](crate::gather::radii::CURVATURE_FLOOR_WEIGHT)
//!   for the Hessian metrics;
//! * anisotropy at most [`MAX_ANISOTROPY_DEFAULT`];
//! * radius bounds from one pixel to 150 pixels ([`RadiusBounds::default`]);
//! * leak guard off ([`LeakGuard::OFF`](crate::cache::LeakGuard::OFF); cache state, applied at
//!   lookup);
//! * extrapolation clamped at zero (cache state, [`IrradianceSettings::cache_config`]).

mod bounds;
mod evaluation;
mod metric;
mod near_far;
mod query;
mod record;
mod seed;
mod settings;
mod traced;

pub use bounds::RadiusBounds;
pub use evaluation::{GatherEvaluation, Hessians};
pub use metric::{HessianKind, Metric};
pub use near_far::NearFarLookup;
pub use seed::SeedPolicy;
pub use settings::{
    IrradianceSettings, NearFieldSettings, GRADIENT_LIMIT_DEFAULT, LUMINANCE_WEIGHTS,
    MAX_ANISOTROPY_DEFAULT,
};
pub use traced::TracedGather;

#[cfg(test)]
mod smoothing_tests;
#[cfg(test)]
mod tests;
