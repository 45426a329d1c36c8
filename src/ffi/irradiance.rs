//! C wrappers for irradiance caching in one call per shading point (`raddiff_cache_irradiance`),
//! its settings and the cache those settings describe.

// These are C entry points: every pointer is NULL-checked and the caller's validity contract is
// the header's; marking them `unsafe fn` would change nothing for C callers.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::ffi::{c_int, c_void};

use glam::DVec3;

use super::cache::raddiff_cache;
use super::common::*;
use crate::cache::irradiance::{
    IrradianceSettings, Metric, NearFieldSettings, RadiusBounds, SeedPolicy,
};
use crate::cache::{Cache, FarFieldReach, LeakGuard, OpenFractionTest};
use crate::gather::{LayoutKind, StrataSmoothing};
use crate::Error;

/// Ward's split sphere: radius a * D, D the harmonic-mean hit distance (accuracy a
/// dimensionless, typically 0.1-0.3). Ward interpolation.
pub const RADDIFF_METRIC_SPLIT_SPHERE: u32 = 0;
/// The split sphere bounded by the gradient: a * min(D, E / |grad E|). Ward interpolation.
pub const RADDIFF_METRIC_BOUNDED_SPLIT_SPHERE: u32 = 1;
/// Jarosz et al. 2008: radius eps * E / |grad E|. Ward interpolation.
pub const RADDIFF_METRIC_GRADIENT: u32 = 2;
/// The occlusion-unaware (radiometric) Hessian, anisotropic records. Needs the hits' normals:
/// mid-level calls only (`raddiff_gather_evaluation_new` with `hit_normals`).
pub const RADDIFF_METRIC_HESSIAN_UNAWARE: u32 = 3;
/// The geometric Hessian (thesis eq. 4.23), anisotropic records. Needs the hits' normals, as
/// `RADDIFF_METRIC_HESSIAN_UNAWARE`.
pub const RADDIFF_METRIC_HESSIAN_GEOMETRIC: u32 = 4;
/// The occlusion-aware Hessian, isotropic (disc) records. Tent interpolation.
pub const RADDIFF_METRIC_HESSIAN_ISOTROPIC: u32 = 5;
/// The occlusion-aware Hessian, anisotropic (ellipse) records: the default. Tent interpolation.
/// Accuracy: the relative error integrated over the record, in L^2 (radii grow as its fourth
/// root).
pub const RADDIFF_METRIC_HESSIAN_ANISOTROPIC: u32 = 6;
/// The occlusion-aware Hessian metric: `RADDIFF_METRIC_HESSIAN_ANISOTROPIC`.
pub const RADDIFF_METRIC_HESSIAN: u32 = 6;

/// Gather jitter hashed from the query point and normal and `seed_salt` (the default): the same
/// record for the same query, whatever the thread or call order.
pub const RADDIFF_SEED_FROM_QUERY: u32 = 0;
/// Every gather direction at its stratum's centre (seed 0).
pub const RADDIFF_SEED_CENTRES: u32 = 1;

const _: () = assert!(
    RADDIFF_METRIC_SPLIT_SPHERE == Metric::SplitSphere as u32
        && RADDIFF_METRIC_BOUNDED_SPLIT_SPHERE == Metric::BoundedSplitSphere as u32
        && RADDIFF_METRIC_GRADIENT == Metric::Gradient as u32
        && RADDIFF_METRIC_HESSIAN_UNAWARE == Metric::HessianUnaware as u32
        && RADDIFF_METRIC_HESSIAN_GEOMETRIC == Metric::HessianGeometric as u32
        && RADDIFF_METRIC_HESSIAN_ISOTROPIC == Metric::HessianIsotropic as u32
        && RADDIFF_METRIC_HESSIAN_ANISOTROPIC == Metric::HessianAnisotropic as u32
);

/// How irradiance records are made (Rust: `cache::irradiance::IrradianceSettings`, whose docs
/// give every field's domain). Start from `raddiff_irradiance_settings_default()` and set
/// fields; the defaults are the library's one set of safeguard defaults.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct raddiff_irradiance_settings {
    /// `RADDIFF_METRIC_*` (default `RADDIFF_METRIC_HESSIAN_ANISOTROPIC`).
    pub metric: u32,
    /// The metric's threshold, > 0 (default 1e-3): a of the split-sphere family and eps of the
    /// gradient metric (dimensionless, 0.1-0.3), or the Hessian metrics' relative error
    /// integrated over the record (L^2). Smaller: more, smaller records.
    pub accuracy: f64,
    /// Floats per record value (default 3).
    pub channels: u32,
    /// Nullable: `channels` weights of the scalar the metrics measure (>= 0, not all 0). NULL:
    /// Rec. 709 luminance (0.2126, 0.7152, 0.0722) for 3 channels, the mean otherwise. Read
    /// during each call that takes the settings; not kept.
    pub channel_weights: *const f64,
    /// `RADDIFF_LAYOUT_COSINE_POLAR` (default) or `RADDIFF_LAYOUT_CONCENTRIC`.
    pub gather_kind: u32,
    /// Gather strata along theta (default 32).
    pub gather_m: u32,
    /// Gather strata along phi (default 128; the occlusion-aware Hessian needs >= 6).
    pub gather_n: u32,
    /// `RADDIFF_SEED_FROM_QUERY` (default) or `RADDIFF_SEED_CENTRES`.
    pub seed_policy: u32,
    /// Mixed into every seed of `RADDIFF_SEED_FROM_QUERY` (default 0).
    pub seed_salt: u64,
    /// Smallest radius in L (default 0).
    pub world_radius_min: f64,
    /// Largest radius in L (default INFINITY: none).
    pub world_radius_max: f64,
    /// Smallest radius in pixels, applied with the query's footprint (default 1).
    pub pixel_radius_min: f64,
    /// Largest radius in pixels, applied with the query's footprint (default 150: the thesis'
    /// clamp at 1800 pixels; scale it with your resolution). A record's bounds are
    /// [max(world_min, pixel_min * footprint), min(world_max, pixel_max * footprint)], the pixel
    /// terms only for footprint > 0; the maximum must come out finite.
    pub pixel_radius_max: f64,
    /// Largest axis ratio of the anisotropic Hessian metrics, >= 1 (default 2).
    pub max_anisotropy: f64,
    /// Weight kappa of the Hessian metrics' curvature floor kappa |E| / D^2, >= 0 (default
    /// `RADDIFF_CURVATURE_FLOOR_WEIGHT`; 0: off).
    pub curvature_floor: f64,
    /// The cache's gradient limit c, > 0 (default `RADDIFF_GRADIENT_LIMIT_DEFAULT`; INFINITY:
    /// off).
    pub gradient_limit: f64,
    /// The cache's leak guard, relative tolerance >= 0 (default INFINITY: off; see
    /// `raddiff_cache_set_leak_guard`).
    pub leak_guard_relative: f64,
    /// The leak guard's absolute tolerance in L, >= 0 (default 0).
    pub leak_guard_absolute: f64,
    /// The near/far decomposition's reach in L, >= 0 (default 0). With either reach > 0 the
    /// records hold far fields (cache state, saved with the cache) and the cache is queried with
    /// `raddiff_cache_irradiance_near_far`; the reach at a query is
    /// max(near_field_reach_world, near_field_reach_pixels * footprint).
    pub near_field_reach_world: f64,
    /// The reach in pixel footprints, >= 0 (default 0; the real-scene benchmark used 8).
    pub near_field_reach_pixels: f64,
    /// Near rays per query along theta, in the gather's layout kind (default 32).
    pub near_field_m: u32,
    /// Near rays per query along phi (default 32).
    pub near_field_n: u32,
    /// The cache's open-fraction test, tolerance >= 0 (default INFINITY: off; see
    /// `raddiff_cache_set_open_fraction_tolerance`). With it on,
    /// `raddiff_cache_irradiance_near_far` traces a query's near rays before its lookup and
    /// its records keep their open fractions. The test's coverage tolerance is the cache's
    /// choice (`raddiff_cache_set_open_fraction_coverage_tolerance`), not the settings'.
    pub near_field_open_fraction_tolerance: f64,
    /// How far the cache reads records, in multiples of their radii, in
    /// [1, `RADDIFF_LOOKUP_RADIUS_SCALE_MAX`] (default 1; see
    /// `raddiff_cache_set_lookup_radius_scale`): records are made where they would be at 1, and
    /// each value blends more of them. `raddiff_irradiance_cache_new` gives the cache this scale;
    /// the query calls only check its range, as every field's (the cache's own scale applies).
    pub lookup_radius_scale: f64,
    /// Passes of the [1 2 1] / 4 filter over each stratum's azimuthal neighbours (the ring wraps;
    /// the concentric layout's second square axis) before the gather's derivatives are taken,
    /// 0..=`RADDIFF_STRATA_SMOOTHING_MAX_PASSES` (default 0: off). The records' gradients and
    /// radii then come from the smoothed strata, their values from the strata as traced: for
    /// noisy hit radiance (the real-scene benchmark's 2 and 1 passes lowered every metric's
    /// error by 2-10%); on noise-free radiance it only blurs.
    pub derivative_smoothing_azimuthal: u32,
    /// Passes over each stratum's polar neighbours (the first square axis), after the azimuthal
    /// ones, 0..=`RADDIFF_STRATA_SMOOTHING_MAX_PASSES` (default 0).
    pub derivative_smoothing_polar: u32,
}

/// The largest number of smoothing passes along either axis of a gather
/// (`derivative_smoothing_azimuthal`, `derivative_smoothing_polar`).
pub const RADDIFF_STRATA_SMOOTHING_MAX_PASSES: u32 = 64;

const _: () = assert!(RADDIFF_STRATA_SMOOTHING_MAX_PASSES == StrataSmoothing::MAX_PASSES);

/// The default settings (3 channels, the anisotropic occlusion-aware Hessian, a 32 x 128
/// cosine-polar gather, 1 to 150 pixel radii, the default safeguards, leak guard off, no near
/// field, no smoothing of the strata).
#[no_mangle]
pub extern "C" fn raddiff_irradiance_settings_default() -> raddiff_irradiance_settings {
    settings_to_c(&IrradianceSettings::default())
}

fn settings_to_c(s: &IrradianceSettings) -> raddiff_irradiance_settings {
    let (seed_policy, seed_salt) = match s.seed {
        SeedPolicy::Query { salt } => (RADDIFF_SEED_FROM_QUERY, salt),
        SeedPolicy::Centres => (RADDIFF_SEED_CENTRES, 0),
    };
    raddiff_irradiance_settings {
        metric: s.metric as u32,
        accuracy: s.accuracy,
        channels: s.channels as u32,
        channel_weights: std::ptr::null(),
        gather_kind: s.gather_kind as u32,
        gather_m: s.gather_m,
        gather_n: s.gather_n,
        seed_policy,
        seed_salt,
        world_radius_min: s.radius_bounds.world_min,
        world_radius_max: s.radius_bounds.world_max,
        pixel_radius_min: s.radius_bounds.pixel_min,
        pixel_radius_max: s.radius_bounds.pixel_max,
        max_anisotropy: s.max_anisotropy,
        curvature_floor: s.curvature_floor,
        gradient_limit: s.gradient_limit,
        leak_guard_relative: s.leak_guard.relative,
        leak_guard_absolute: s.leak_guard.absolute,
        near_field_reach_world: s.near_field.reach.world,
        near_field_reach_pixels: s.near_field.reach.pixels,
        near_field_m: s.near_field.m,
        near_field_n: s.near_field.n,
        near_field_open_fraction_tolerance: s.near_field.open_fraction_test.tolerance,
        lookup_radius_scale: s.lookup_radius_scale,
        derivative_smoothing_azimuthal: s.derivative_smoothing.azimuthal_passes,
        derivative_smoothing_polar: s.derivative_smoothing.polar_passes,
    }
}

/// The Rust settings of a C settings struct (enum values checked; the domains of the numbers are
/// checked where the settings are used).
///
/// # Safety
/// `settings.channel_weights` is NULL or valid for `settings.channels` reads.
pub(crate) unsafe fn settings_from_c(
    settings: &raddiff_irradiance_settings,
) -> Result<IrradianceSettings, FfiError> {
    let channels = settings.channels as usize;
    let channel_weights = (!settings.channel_weights.is_null())
        .then(|| {
            in_slice(
                settings.channel_weights,
                channels,
                "settings->channel_weights",
            )
        })
        .transpose()?
        .map(<[f64]>::to_vec);
    let seed = match settings.seed_policy {
        RADDIFF_SEED_FROM_QUERY => SeedPolicy::Query {
            salt: settings.seed_salt,
        },
        RADDIFF_SEED_CENTRES => SeedPolicy::Centres,
        other => {
            return Err(Error::InvalidArgument(format!(
                "seed_policy {other} is not RADDIFF_SEED_FROM_QUERY (0) or RADDIFF_SEED_CENTRES (1)"
            ))
            .into())
        }
    };
    Ok(IrradianceSettings {
        metric: Metric::try_from(settings.metric)?,
        accuracy: settings.accuracy,
        channels,
        channel_weights,
        gather_kind: LayoutKind::try_from(settings.gather_kind)?,
        gather_m: settings.gather_m,
        gather_n: settings.gather_n,
        seed,
        radius_bounds: RadiusBounds {
            world_min: settings.world_radius_min,
            world_max: settings.world_radius_max,
            pixel_min: settings.pixel_radius_min,
            pixel_max: settings.pixel_radius_max,
        },
        max_anisotropy: settings.max_anisotropy,
        curvature_floor: settings.curvature_floor,
        gradient_limit: settings.gradient_limit,
        leak_guard: LeakGuard {
            relative: settings.leak_guard_relative,
            absolute: settings.leak_guard_absolute,
        },
        near_field: NearFieldSettings {
            reach: FarFieldReach {
                world: settings.near_field_reach_world,
                pixels: settings.near_field_reach_pixels,
            },
            m: settings.near_field_m,
            n: settings.near_field_n,
            open_fraction_test: OpenFractionTest::new(settings.near_field_open_fraction_tolerance),
        },
        lookup_radius_scale: settings.lookup_radius_scale,
        derivative_smoothing: StrataSmoothing {
            azimuthal_passes: settings.derivative_smoothing_azimuthal,
            polar_passes: settings.derivative_smoothing_polar,
        },
    })
}

/// A cache for the records `settings` make: surface domain, the settings' channels, the
/// metric's interpolation (`RADDIFF_INTERP_WARD` for the split-sphere family and the gradient
/// metric, `RADDIFF_INTERP_TENT` for the Hessian metrics), values clamped at zero
/// (`RADDIFF_INTERP_NON_NEGATIVE`), the settings' gradient limit, leak guard, near-field
/// reach (records then hold far fields), open-fraction tolerance and lookup radius scale,
/// maximum normal deviation 0.2 rad. NULL (with
/// `raddiff_last_error`) for NULL or invalid settings. Free it with `raddiff_cache_free`.
#[no_mangle]
pub extern "C" fn raddiff_irradiance_cache_new(
    settings: *const raddiff_irradiance_settings,
) -> *mut raddiff_cache {
    guard_ptr(|| {
        let settings = unsafe { settings_from_c(in_ref(settings, "settings")?)? };
        settings.validate()?;
        let inner = Cache::new(settings.cache_config())?;
        Ok(Box::into_raw(Box::new(raddiff_cache { inner })))
    })
}

/// Traces `count` rays from `origin` along the unit `directions` (world space); writes each ray's
/// hit distance to `distance[i]` (INFINITY for a miss) and the radiance arriving at `origin`
/// along it to `radiance[i*channels + c]` (`channels` floats per ray, interleaved). Returns 0 on
/// success; anything else abandons the request (`RADDIFF_ERROR_CALLBACK`, nothing inserted).
/// `user` is the pointer given to `raddiff_cache_irradiance`. Called at most once per call, on
/// the calling thread; it must not unwind (C++: catch every exception, as
/// `raddiff::IrradianceCache` does) and may call raddiff functions (other caches' lookups too).
pub type raddiff_trace_fn = Option<
    unsafe extern "C" fn(
        user: *mut c_void,
        origin: raddiff_vec3,
        directions: *const raddiff_vec3,
        count: usize,
        distance: *mut f64,
        radiance: *mut f32,
    ) -> c_int,
>;

/// The irradiance at the shading point `x` with normal `n` (any non-zero length): looked up in
/// `cache`, or, when no record covers `x`, computed from a new record: the gather's directions
/// are laid out (seeded from the query), traced through one call of `trace` (the whole gather in
/// one batch), evaluated with the Hessian the metric needs, the record's radii built under the
/// settings' metric, bounds and safeguards, and the record inserted. `out` (`channels` floats)
/// receives the cache's interpolation at `x`. Thread-safe: any number of threads may call it on
/// one cache; threads that miss at the same point insert its record once.
///
/// `x` is the gather point: pull it back from the surface as your rays need (e.g. 1e-4 of the
/// camera ray's hit distance towards the camera). `footprint` is the world-space size of one
/// pixel at `x`, for the settings' pixel radius bounds (0 when unknown: world bounds only).
///
/// `RADDIFF_ERROR_NULL_POINTER` for a NULL `cache`, `settings`, `trace` or `out`;
/// `RADDIFF_ERROR_INVALID_ARGUMENT` for non-finite `x`, `n` or `footprint`, a zero `n`, a
/// negative footprint, settings with a near-field reach or a cache of far fields (query those
/// with `raddiff_cache_irradiance_near_far`), invalid settings or settings that disagree with the
/// cache (create it with `raddiff_irradiance_cache_new`), no finite maximum radius, a metric that needs hit normals,
/// or traced values the gather refuses (distance <= 0 or NaN, non-finite radiance);
/// `RADDIFF_ERROR_CALLBACK` when `trace` returns non-zero; `RADDIFF_ERROR_DEGENERATE` when the
/// evaluation overflows. On any error nothing is inserted and `out` is untouched.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn raddiff_cache_irradiance(
    cache: *mut raddiff_cache,
    settings: *const raddiff_irradiance_settings,
    x: raddiff_vec3,
    n: raddiff_vec3,
    footprint: f64,
    trace: raddiff_trace_fn,
    user: *mut c_void,
    out: *mut f32,
) -> raddiff_status {
    guard(|| {
        let (cache, settings) = unsafe { query_args(cache, settings, out)? };
        let trace = trace.ok_or(FfiError::Null("trace"))?;
        let found = cache.inner.irradiance(
            &settings,
            DVec3::from(x),
            DVec3::from(n),
            footprint,
            |origin, directions, distance, radiance| {
                // SAFETY: the arrays hold `count` directions and distances and
                // `count * channels` radiances, as the callback's contract says.
                let status = unsafe {
                    trace(
                        user,
                        origin.into(),
                        directions.as_ptr().cast(),
                        directions.len(),
                        distance.as_mut_ptr(),
                        radiance.as_mut_ptr(),
                    )
                };
                callback_result(status)
            },
        )?;
        // SAFETY: the caller provides `channels` writable floats at `out`.
        unsafe { std::ptr::copy_nonoverlapping(found.value.as_ptr(), out, found.value.len()) };
        Ok(())
    })
}

/// What both one-call queries check first: the cache, the settings (converted) and a non-NULL
/// `out`.
///
/// # Safety
/// The pointers are NULL or valid as the queries' contracts say.
pub(super) unsafe fn query_args<'a>(
    cache: *mut raddiff_cache,
    settings: *const raddiff_irradiance_settings,
    out: *mut f32,
) -> Result<(&'a raddiff_cache, IrradianceSettings), FfiError> {
    let cache = in_ref(cache, "cache")?;
    let settings = settings_from_c(in_ref(settings, "settings")?)?;
    if out.is_null() {
        return Err(FfiError::Null("out"));
    }
    Ok((cache, settings))
}

/// A trace callback's return value as the tracing closure's result.
pub(super) fn callback_result(status: c_int) -> Result<(), String> {
    match status {
        0 => Ok(()),
        s => Err(format!("the trace callback returned {s}")),
    }
}
