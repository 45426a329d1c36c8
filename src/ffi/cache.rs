//! C wrappers for the radiance cache (`raddiff_cache_*`), over `cache::Cache<Vec<f32>>`.

// These are C entry points: every pointer is NULL-checked and the caller's validity contract is
// the header's; marking them `unsafe fn` would change nothing for C callers.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::ffi::{c_char, CStr};
use std::path::PathBuf;

use glam::DVec3;

use super::common::*;
use crate::cache::{Cache, CacheConfig, Cursor, Domain, Extent, Interpolation};
use crate::Error;

/// Records on surfaces: ellipses in the tangent plane, normals compared at lookup.
pub const RADDIFF_DOMAIN_SURFACE: u32 = 0;
/// Records in participating media: ellipsoids, normals ignored.
pub const RADDIFF_DOMAIN_VOLUME: u32 = 1;
/// Largest channel count `raddiff_cache_new` accepts.
pub const RADDIFF_CACHE_MAX_CHANNELS: u32 = 4096;
const _: () = assert!(RADDIFF_CACHE_MAX_CHANNELS as usize == crate::cache::MAX_CHANNELS);

/// Ward-Heckbert first-order extrapolation with Krivanek-Gautron weights 1/(t+rho) - 1.
pub const RADDIFF_INTERP_WARD: u32 = 0;
/// Anisotropic tent weights (1 - t) times the normal tent (Schwarzhaupt eq. 6.10-6.13).
pub const RADDIFF_INTERP_TENT: u32 = 1;
/// Linear-space extrapolation with the cubic kernel 3d^2 - 2d^3, d = 1 - t (Marco et al. eq. 23).
pub const RADDIFF_INTERP_CUBIC: u32 = 2;
/// Log-space extrapolation of Jarosz et al. 2008 with the cubic kernel (Marco et al. eq. 4).
pub const RADDIFF_INTERP_LOG: u32 = 3;
/// Ward-Heckbert extrapolation with Ward's original weights 1/(t+rho) (no fall-off to 0).
pub const RADDIFF_INTERP_WARD_CLASSIC: u32 = 4;
/// Ward-Heckbert extrapolation with Tabellion-Lamorlette weights 1 - (t+rho).
pub const RADDIFF_INTERP_WARD_TABELLION: u32 = 5;
/// Flag OR-ed into `raddiff_cache_config.interpolation`: clamp each record's extrapolated value
/// at 0 per channel before blending, so lookups never return negative values (irradiance and
/// radiance cannot be negative; leave it off for signed quantities). `_LOG` is positive anyway.
/// Saved with the cache and restored by `raddiff_cache_load`.
pub const RADDIFF_INTERP_NON_NEGATIVE: u32 = 0x100;
/// Flag OR-ed into `raddiff_cache_config.interpolation`: create the cache with the gradient
/// (slope) limit c = `RADDIFF_GRADIENT_LIMIT_DEFAULT` (see `raddiff_cache_set_gradient_limit` for
/// the rule and for other values of c). Saved with the cache and restored by `raddiff_cache_load`.
pub const RADDIFF_INTERP_GRADIENT_LIMIT: u32 = 0x200;
/// The gradient limit c that `RADDIFF_INTERP_GRADIENT_LIMIT` selects and
/// `raddiff_irradiance_settings_default` sets: 2, the library's one default (Rust:
/// `cache::irradiance::GRADIENT_LIMIT_DEFAULT`, which documents the measurement it comes from).
/// With c > 1 an extrapolated value may change sign: irradiance caches also set
/// `RADDIFF_INTERP_NON_NEGATIVE`.
pub const RADDIFF_GRADIENT_LIMIT_DEFAULT: f64 = 2.0;
/// The largest lookup radius scale (`raddiff_cache_set_lookup_radius_scale`): a lookup over 8
/// radii already weighs about 64 times the records of one over 1 (Rust:
/// `cache::LOOKUP_RADIUS_SCALE_MAX`).
pub const RADDIFF_LOOKUP_RADIUS_SCALE_MAX: f64 = 8.0;
const _: () = assert!(RADDIFF_LOOKUP_RADIUS_SCALE_MAX == crate::cache::LOOKUP_RADIUS_SCALE_MAX);

/// A thread-safe radiance cache: any number of threads may call `raddiff_cache_lookup` and
/// `raddiff_cache_insert` on the same handle at once (lookups never block).
pub struct raddiff_cache {
    pub(super) inner: Cache<Vec<f32>>,
}

/// How a cache is created.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct raddiff_cache_config {
    /// Floats per record value (1..=4096).
    pub channels: u32,
    /// `RADDIFF_DOMAIN_SURFACE` or `RADDIFF_DOMAIN_VOLUME`.
    pub domain: u32,
    /// `RADDIFF_INTERP_WARD`, `_TENT`, `_CUBIC`, `_LOG` (or `_WARD_CLASSIC`, `_WARD_TABELLION`),
    /// optionally OR-ed with `RADDIFF_INTERP_NON_NEGATIVE` and `RADDIFF_INTERP_GRADIENT_LIMIT`.
    pub interpolation: u32,
    /// Radians in (0, pi]: largest normal deviation for a record to be used (surface domain;
    /// ignored in volumes). 0.2 is a good default.
    pub max_normal_deviation: f64,
}

/// A record to insert.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct raddiff_cache_record {
    /// Where the gather was computed.
    pub position: raddiff_vec3,
    /// Surface normal (need not be unit length); ignored in the volume domain.
    pub normal: raddiff_vec3,
    /// `channels` floats.
    pub value: *const f32,
    /// Nullable: 3*channels floats, translational gradient, channel-major (`gradient[3*c + k]`
    /// is the derivative of channel c along world axis k).
    pub gradient: *const f32,
    /// Nullable: 3*channels floats, rotational gradient (derivative with respect to the rotation
    /// vector of the normal, Ward-Heckbert convention), channel-major; surface domain only.
    pub rotation_gradient: *const f32,
    /// Surface: `radii[0..1]` along `axes[0]` (projected to the tangent plane) and `normal x axes[0]`;
    /// `radii[2]` unused. Volume: ellipsoid radii along `axes[0..2]`. Each in 1e-30..=1e30.
    pub radii: [f64; 3],
    /// Principal axes (need not be unit; may be zero for isotropic radii).
    pub axes: [raddiff_vec3; 3],
    /// Nullable: the open fraction of a far-field record's gather, in [0, 1] (the share of its
    /// measure whose rays reach at least the reach), for the open-fraction test
    /// (`raddiff_cache_set_open_fraction_tolerance`). NULL: none (the test never refuses the
    /// record; what a zero-initialized record has). Read during the call; stored to within 2^-31.
    pub open_fraction: *const f64,
}

fn config_from_c(c: &raddiff_cache_config) -> Result<CacheConfig, FfiError> {
    let flags = RADDIFF_INTERP_NON_NEGATIVE | RADDIFF_INTERP_GRADIENT_LIMIT;
    Ok(CacheConfig {
        channels: c.channels as usize,
        domain: Domain::try_from(c.domain)?,
        interpolation: Interpolation::try_from(c.interpolation & !flags)?,
        max_normal_deviation: c.max_normal_deviation,
        non_negative: c.interpolation & RADDIFF_INTERP_NON_NEGATIVE != 0,
        gradient_limit: if c.interpolation & RADDIFF_INTERP_GRADIENT_LIMIT != 0 {
            RADDIFF_GRADIENT_LIMIT_DEFAULT
        } else {
            f64::INFINITY
        },
        leak_guard: crate::cache::LeakGuard::OFF,
        far_field: crate::cache::FarFieldReach::OFF,
        open_fraction_test: crate::cache::OpenFractionTest::OFF,
        lookup_radius_scale: 1.0,
    })
}

unsafe fn path_from_c(path: *const c_char) -> Result<PathBuf, FfiError> {
    let c = CStr::from_ptr(in_ref(path, "path")?);
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        Ok(PathBuf::from(std::ffi::OsStr::from_bytes(c.to_bytes())))
    }
    #[cfg(not(unix))]
    {
        c.to_str()
            .map(PathBuf::from)
            .map_err(|_| Error::InvalidArgument("path is not valid UTF-8".into()).into())
    }
}

/// Creates an empty cache, or returns NULL (with `raddiff_last_error`) for a NULL or invalid
/// configuration. Free it with `raddiff_cache_free`.
#[no_mangle]
pub extern "C" fn raddiff_cache_new(config: *const raddiff_cache_config) -> *mut raddiff_cache {
    guard_ptr(|| {
        let config = config_from_c(unsafe { in_ref(config, "config")? })?;
        let inner = Cache::new(config)?;
        Ok(Box::into_raw(Box::new(raddiff_cache { inner })))
    })
}

/// Frees a cache (NULL is ignored). No other thread may be using it.
#[no_mangle]
pub extern "C" fn raddiff_cache_free(cache: *mut raddiff_cache) {
    if !cache.is_null() {
        // SAFETY: `cache` came from `raddiff_cache_new` / `raddiff_cache_load` and is freed once.
        drop(unsafe { Box::from_raw(cache) });
    }
}

/// Inserts a record (thread-safe). Inserting a record identical to a stored one is a no-op that
/// succeeds. `RADDIFF_ERROR_INVALID_ARGUMENT` for non-finite input, radii out of range, a zero
/// surface normal, degenerate axes with anisotropic radii, or an open fraction outside [0, 1].
#[no_mangle]
pub extern "C" fn raddiff_cache_insert(
    cache: *mut raddiff_cache,
    record: *const raddiff_cache_record,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        let r = unsafe { in_ref(record, "record")? };
        let channels = cache.inner.config().channels;
        let value = unsafe { in_slice(r.value, channels, "record->value")? };
        let gradient = (!r.gradient.is_null())
            .then(|| unsafe { in_slice(r.gradient, 3 * channels, "record->gradient") })
            .transpose()?;
        let rotation = (!r.rotation_gradient.is_null())
            .then(|| unsafe {
                in_slice(
                    r.rotation_gradient,
                    3 * channels,
                    "record->rotation_gradient",
                )
            })
            .transpose()?;
        // SAFETY: NULL or one readable double (the header's contract).
        let open_fraction = unsafe { r.open_fraction.as_ref() }.copied();
        cache.inner.insert_flat(&crate::cache::RecordInput {
            position: r.position.into(),
            normal: r.normal.into(),
            value,
            gradient,
            rotation,
            extent: Extent {
                radii: r.radii,
                axes: r.axes.map(DVec3::from),
            },
            open_fraction,
        })?;
        Ok(())
    })
}

/// Interpolates the cache at `position` with surface normal `normal` (ignored in volumes) into
/// `value` (`channels` floats) and, if `weight_sum` is not NULL, the sum of the weights used.
/// `RADDIFF_ERROR_NOT_FOUND` when no record covers the point (outputs untouched). Thread-safe and
/// lock-free; the result depends only on the set of records covering the point. Each calling
/// thread keeps a cursor for each of the last four caches it looked up in, so that nearby
/// successive queries skip the spatial index (see `raddiff_cache_lookup_with`).
#[no_mangle]
pub extern "C" fn raddiff_cache_lookup(
    cache: *const raddiff_cache,
    position: raddiff_vec3,
    normal: raddiff_vec3,
    value: *mut f32,
    weight_sum: *mut f64,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        lookup_to_c(cache, value, weight_sum, |out| {
            cache.inner.lookup_into(position.into(), normal.into(), out)
        })
    })
}

/// Per-thread state for spatially coherent lookups (pixels of a tile, steps along a ray): it
/// remembers the records around recent queries so that nearby lookups skip the spatial index.
/// Not thread-safe: one per thread. It holds no reference to a cache and may be used with any.
pub struct raddiff_cache_cursor {
    inner: Cursor,
}

/// A new cursor for `raddiff_cache_lookup_with`; free it with `raddiff_cache_cursor_free`.
#[no_mangle]
pub extern "C" fn raddiff_cache_cursor_new() -> *mut raddiff_cache_cursor {
    guard_ptr(|| {
        Ok(Box::into_raw(Box::new(raddiff_cache_cursor {
            inner: Cursor::new(),
        })))
    })
}

/// Frees a cursor (NULL is ignored).
#[no_mangle]
pub extern "C" fn raddiff_cache_cursor_free(cursor: *mut raddiff_cache_cursor) {
    if !cursor.is_null() {
        // SAFETY: `cursor` came from `raddiff_cache_cursor_new` and is freed once.
        drop(unsafe { Box::from_raw(cursor) });
    }
}

/// `raddiff_cache_lookup` through this thread's `cursor`: the same results bit for bit, faster
/// when successive queries are close to each other. The cache may be shared by threads as with
/// `raddiff_cache_lookup`; the cursor may not. `raddiff_cache_lookup` already keeps a cursor per
/// thread and cache; an explicit one helps a thread that interleaves more than four caches, or
/// several coherent query streams in one cache (one cursor each).
#[no_mangle]
pub extern "C" fn raddiff_cache_lookup_with(
    cache: *const raddiff_cache,
    cursor: *mut raddiff_cache_cursor,
    position: raddiff_vec3,
    normal: raddiff_vec3,
    value: *mut f32,
    weight_sum: *mut f64,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        // SAFETY: NULL or a live cursor used by this thread only (the header's contract).
        let cursor = unsafe { out_ref(cursor, "cursor")? };
        lookup_to_c(cache, value, weight_sum, |out| {
            cache
                .inner
                .lookup_into_with(&mut cursor.inner, position.into(), normal.into(), out)
        })
    })
}

/// `raddiff_cache_lookup` (`cursor` NULL) or `raddiff_cache_lookup_with` (`cursor` not NULL) for a
/// query whose open fraction is `open_fraction` (in [0, 1]; the near field's, see
/// `raddiff_gather_near_field`): the cache's open-fraction test refuses every record whose open
/// fraction differs from it by more than the tolerance
/// (`raddiff_cache_set_open_fraction_tolerance`; records inserted without an open fraction are
/// never refused). With the test off, the result of `raddiff_cache_lookup` bit for bit.
/// `RADDIFF_ERROR_NOT_FOUND` when no admitted record covers the point;
/// `RADDIFF_ERROR_INVALID_ARGUMENT` for an open fraction outside [0, 1] (NaN included). Thread-safe
/// as `raddiff_cache_lookup`; a cursor is used by one thread only.
#[no_mangle]
pub extern "C" fn raddiff_cache_lookup_open(
    cache: *const raddiff_cache,
    cursor: *mut raddiff_cache_cursor,
    position: raddiff_vec3,
    normal: raddiff_vec3,
    open_fraction: f64,
    value: *mut f32,
    weight_sum: *mut f64,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        // SAFETY: NULL or a live cursor used by this thread only (the header's contract).
        let cursor = unsafe { cursor.as_mut() };
        let (p, n) = (position.into(), normal.into());
        lookup_to_c(cache, value, weight_sum, |out| match cursor {
            Some(c) => cache
                .inner
                .lookup_into_with_open(&mut c.inner, p, n, open_fraction, out),
            None => cache.inner.lookup_into_open(p, n, open_fraction, out),
        })
    })
}

/// Runs a lookup into a stack buffer (heap beyond 32 channels) and copies it to the caller.
fn lookup_to_c(
    cache: &raddiff_cache,
    value: *mut f32,
    weight_sum: *mut f64,
    lookup: impl FnOnce(&mut [f32]) -> crate::Result<(f64, usize)>,
) -> Result<(), FfiError> {
    if value.is_null() {
        return Err(FfiError::Null("value"));
    }
    let channels = cache.inner.config().channels;
    let mut stack = [0.0f32; 32];
    let mut heap = Vec::new();
    let tmp: &mut [f32] = if channels <= stack.len() {
        &mut stack[..channels]
    } else {
        heap.resize(channels, 0.0);
        &mut heap
    };
    let (sum, _) = lookup(tmp)?;
    // SAFETY: the caller provides `channels` writable floats at `value`.
    unsafe { std::ptr::copy_nonoverlapping(tmp.as_ptr(), value, channels) };
    if let Some(w) = unsafe { weight_sum.as_mut() } {
        *w = sum;
    }
    Ok(())
}

/// Prepares a cache for a lookup-only phase: frees memory kept for concurrent readers while it
/// was filled and stores its records in index order (faster lookups). Changes no result.
/// **Not thread-safe**: no other thread may use the cache during the call.
#[no_mangle]
pub extern "C" fn raddiff_cache_compact(cache: *mut raddiff_cache) -> raddiff_status {
    guard(|| {
        // SAFETY: NULL or a live handle that, per the contract, nobody else uses right now.
        let cache = unsafe { out_ref(cache, "cache")? };
        cache.inner.compact();
        Ok(())
    })
}

/// Sets the gradient (slope) limit c for the records inserted from now on; stored records keep
/// their gradients. Rule, applied by `raddiff_cache_insert` to each channel k with value E_k: with
/// R the record's largest radius, s_t = |gradient_k| * R and s_r = |rotation_gradient_k| *
/// sin(min(max_normal_deviation, pi/2)) (0 in the volume domain), if s_t + s_r > c * |E_k| both
/// gradients of channel k are scaled by c * |E_k| / (s_t + s_r) (a channel with E_k = 0 loses its
/// gradients). Then every lookup within the record's extent extrapolates channel k by at most
/// c * |E_k| (up to binary16 rounding): with c <= 1 extrapolation never flips a value's sign.
/// c = INFINITY turns the limit off; `RADDIFF_ERROR_INVALID_ARGUMENT` (no change) for c <= 0 or
/// NaN. Saved with the cache and restored by `raddiff_cache_load`; `raddiff_cache_merge` copies
/// records as stored. **Not thread-safe**: no other thread may use the cache during the call.
#[no_mangle]
pub extern "C" fn raddiff_cache_set_gradient_limit(
    cache: *mut raddiff_cache,
    c: f64,
) -> raddiff_status {
    guard(|| {
        // SAFETY: NULL or a live handle that, per the contract, nobody else uses right now.
        let cache = unsafe { out_ref(cache, "cache")? };
        cache.inner.set_gradient_limit(c)?;
        Ok(())
    })
}

/// Writes the cache's gradient limit c to `*limit` (INFINITY when off).
#[no_mangle]
pub extern "C" fn raddiff_cache_get_gradient_limit(
    cache: *const raddiff_cache,
    limit: *mut f64,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        let limit = unsafe { out_ref(limit, "limit")? };
        *limit = cache.inner.config().gradient_limit;
        Ok(())
    })
}

/// Sets the leak guard ("record in front of the query" test of Ward's cache, Radiance, pbrt-v2
/// and Mitsuba) for every lookup from now on: a record i is not used at a query x with unit
/// normal n when (x - x_i) . (n + n_i) / 2 < -(relative * R_i + absolute), R_i the record's radius
/// along its normal (the smaller tangent radius). The height is 0 on planes and spheres, so
/// curvature alone never trips it; `relative` is in units of the record's own radius
/// (scale-free), `absolute` in L (for ray epsilons and pull-backs). Off (the default) while
/// either tolerance is INFINITY; for an absolute tolerance alone pass relative 0. Surface domain
/// only. `RADDIFF_ERROR_INVALID_ARGUMENT` (no change) for a NaN or negative tolerance. Saved with
/// the cache and restored by `raddiff_cache_load` (files written before it load with it off).
/// **Not thread-safe**: no other thread may use the cache during the call.
#[no_mangle]
pub extern "C" fn raddiff_cache_set_leak_guard(
    cache: *mut raddiff_cache,
    relative: f64,
    absolute: f64,
) -> raddiff_status {
    guard(|| {
        // SAFETY: NULL or a live handle that, per the contract, nobody else uses right now.
        let cache = unsafe { out_ref(cache, "cache")? };
        cache
            .inner
            .set_leak_guard(crate::cache::LeakGuard { relative, absolute })?;
        Ok(())
    })
}

/// Writes the cache's leak guard tolerances to `*relative` and `*absolute` (relative INFINITY
/// when off).
#[no_mangle]
pub extern "C" fn raddiff_cache_get_leak_guard(
    cache: *const raddiff_cache,
    relative: *mut f64,
    absolute: *mut f64,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        let relative = unsafe { out_ref(relative, "relative")? };
        let absolute = unsafe { out_ref(absolute, "absolute")? };
        let g = cache.inner.config().leak_guard;
        *relative = g.relative;
        *absolute = g.absolute;
        Ok(())
    })
}

/// Sets the open-fraction test of a far-field cache for every lookup from now on: a record with
/// open fraction V_i (`raddiff_cache_record.open_fraction`) is not used at a query of open
/// fraction V (`raddiff_cache_lookup_open`, `raddiff_cache_irradiance_near_far`) when
/// |V_i - V| > `tolerance`. A record's far field is the mean over the directions its gather found
/// open; a query whose hemisphere is open elsewhere (under a ledge, at the foot of a step) would
/// take the wrong mean. The tolerance is dimensionless (0.1-0.2 suits gathers of a thousand rays
/// or more, whose open fractions have a noise of at most 0.5/sqrt(rays)); INFINITY (the default)
/// turns the test off. `RADDIFF_ERROR_INVALID_ARGUMENT` (no change) for a NaN or negative
/// tolerance. Saved with the cache and restored by `raddiff_cache_load` (files written before it
/// load with it off). Keeps the test's coverage tolerance
/// (`raddiff_cache_set_open_fraction_coverage_tolerance`). **Not thread-safe**: no other thread may
/// use the cache during the call.
#[no_mangle]
pub extern "C" fn raddiff_cache_set_open_fraction_tolerance(
    cache: *mut raddiff_cache,
    tolerance: f64,
) -> raddiff_status {
    guard(|| {
        // SAFETY: NULL or a live handle that, per the contract, nobody else uses right now.
        let cache = unsafe { out_ref(cache, "cache")? };
        let test = crate::cache::OpenFractionTest {
            tolerance,
            ..cache.inner.config().open_fraction_test
        };
        cache.inner.set_open_fraction_test(test)?;
        Ok(())
    })
}

/// Writes the cache's open-fraction tolerance to `*tolerance` (INFINITY when the test is off).
#[no_mangle]
pub extern "C" fn raddiff_cache_get_open_fraction_tolerance(
    cache: *const raddiff_cache,
    tolerance: *mut f64,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        let tolerance = unsafe { out_ref(tolerance, "tolerance")? };
        *tolerance = cache.inner.config().open_fraction_test.tolerance;
        Ok(())
    })
}

/// Sets the open-fraction test's coverage tolerance: a query whose covering records the test all
/// refuses reads those whose open fraction is within `coverage_tolerance` of its own (as with the
/// test at that tolerance; the leak guard still applies), and returns
/// `RADDIFF_ERROR_NOT_FOUND` only when none is. So the test makes a renderer add a record only
/// where the open fraction changes by more than the coverage tolerance (the foot of a wall, the
/// edge of a ledge), not where it changes by a little more than the tolerance; at a fixed record
/// budget the open regions keep more, smaller records. INFINITY keeps all coverage (the test then
/// only chooses among the records covering a query; also
/// `raddiff_cache_set_open_fraction_keeps_coverage`); 0 (the default), or any value not above
/// the tolerance, keeps none. On the real-scene benchmark at tolerance 0.1 (512 px) a coverage
/// tolerance of 0.25 came within 1.06x of the best of 0.15, 0.2, 0.25, 0.3 and INFINITY from
/// 4,000 to 14,000 records; 0.3 or more did better below about one record per 65 pixels.
/// Dimensionless. Acts only while the test is on (a finite tolerance), and is kept when the
/// tolerance changes. `RADDIFF_ERROR_INVALID_ARGUMENT` (no change) for a NaN or negative value.
/// Saved with the cache (files written before it load with 0, or with INFINITY where they kept
/// coverage). **Not thread-safe**: no other thread may use the cache during the call.
#[no_mangle]
pub extern "C" fn raddiff_cache_set_open_fraction_coverage_tolerance(
    cache: *mut raddiff_cache,
    coverage_tolerance: f64,
) -> raddiff_status {
    guard(|| {
        // SAFETY: NULL or a live handle that, per the contract, nobody else uses right now.
        let cache = unsafe { out_ref(cache, "cache")? };
        set_coverage_tolerance(cache, coverage_tolerance)?;
        Ok(())
    })
}

/// Sets the cache's open-fraction coverage tolerance, its tolerance kept.
fn set_coverage_tolerance(cache: &mut raddiff_cache, coverage_tolerance: f64) -> crate::Result<()> {
    let test = cache
        .inner
        .config()
        .open_fraction_test
        .with_coverage_tolerance(coverage_tolerance);
    cache.inner.set_open_fraction_test(test)
}

/// Writes the open-fraction test's coverage tolerance to `*coverage_tolerance` (see
/// `raddiff_cache_set_open_fraction_coverage_tolerance`; INFINITY when it keeps all coverage).
#[no_mangle]
pub extern "C" fn raddiff_cache_get_open_fraction_coverage_tolerance(
    cache: *const raddiff_cache,
    coverage_tolerance: *mut f64,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        let coverage_tolerance = unsafe { out_ref(coverage_tolerance, "coverage_tolerance")? };
        *coverage_tolerance = cache.inner.config().open_fraction_test.coverage_tolerance;
        Ok(())
    })
}

/// Sets whether the open-fraction test keeps all coverage (`keeps` 1: a coverage tolerance of
/// INFINITY) or none (0: a coverage tolerance of 0, the default); see
/// `raddiff_cache_set_open_fraction_coverage_tolerance`. With it, a query whose covering records
/// the test all refuses reads them (as with the test off; the leak guard still applies) instead
/// of returning `RADDIFF_ERROR_NOT_FOUND`, so the test chooses among the records covering a query
/// and never makes a renderer add a record. Without it the refusals make records where the open
/// fraction changes, which at a fixed record budget leaves the open regions fewer, larger records
/// (the real-scene benchmark: keeping all coverage had the lower error below 5,000 to 8,000
/// records at 512 px, keeping none above). Acts only while the test is on (a finite tolerance).
/// `RADDIFF_ERROR_INVALID_ARGUMENT` (no change) for `keeps` other than 0 or 1. Saved with the
/// cache (files written before it load without it). **Not thread-safe**: no other thread may use
/// the cache during the call.
#[no_mangle]
pub extern "C" fn raddiff_cache_set_open_fraction_keeps_coverage(
    cache: *mut raddiff_cache,
    keeps: u32,
) -> raddiff_status {
    guard(|| {
        // SAFETY: NULL or a live handle that, per the contract, nobody else uses right now.
        let cache = unsafe { out_ref(cache, "cache")? };
        let coverage_tolerance = match keeps {
            0 => 0.0,
            1 => f64::INFINITY,
            _ => {
                return Err(
                    Error::InvalidArgument(format!("keeps must be 0 or 1, got {keeps}")).into(),
                )
            }
        };
        set_coverage_tolerance(cache, coverage_tolerance)?;
        Ok(())
    })
}

/// Writes whether the open-fraction test keeps all coverage to `*keeps`: 1 when its coverage
/// tolerance is INFINITY, else 0 (see `raddiff_cache_set_open_fraction_keeps_coverage`; a
/// finite coverage tolerance reads as 0: `raddiff_cache_get_open_fraction_coverage_tolerance`
/// gives it).
#[no_mangle]
pub extern "C" fn raddiff_cache_get_open_fraction_keeps_coverage(
    cache: *const raddiff_cache,
    keeps: *mut u32,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        let keeps = unsafe { out_ref(keeps, "keeps")? };
        let coverage = cache.inner.config().open_fraction_test.coverage_tolerance;
        *keeps = u32::from(coverage == f64::INFINITY);
        Ok(())
    })
}

/// Sets how far records are read, in multiples of their radii, for every lookup from now on
/// (default 1). A lookup then blends every record within `scale` times its radii (the leak
/// guard's radius scaled alike), while a query still counts as covered only where some record
/// covers it at its own radii: `raddiff_cache_lookup` returns `RADDIFF_ERROR_NOT_FOUND`, and
/// `raddiff_cache_irradiance` makes a record, exactly where they would at 1. So records are
/// placed as before and each value blends about scale^2 more of them (surfaces): less of the
/// gathers' noise, more bias where the value curves (the real-scene benchmark: 1.5 lowers every
/// error metric's error by 3-13%). `RADDIFF_ERROR_INVALID_ARGUMENT` (no change) unless `scale`
/// is in [1, `RADDIFF_LOOKUP_RADIUS_SCALE_MAX`]. The index is rebuilt. Saved with the cache and
/// restored by `raddiff_cache_load` (files written before it load with 1). **Not thread-safe**:
/// no other thread may use the cache during the call.
#[no_mangle]
pub extern "C" fn raddiff_cache_set_lookup_radius_scale(
    cache: *mut raddiff_cache,
    scale: f64,
) -> raddiff_status {
    guard(|| {
        // SAFETY: NULL or a live handle that, per the contract, nobody else uses right now.
        let cache = unsafe { out_ref(cache, "cache")? };
        cache.inner.set_lookup_radius_scale(scale)?;
        Ok(())
    })
}

/// Writes the cache's lookup radius scale to `*scale` (1 unless set).
#[no_mangle]
pub extern "C" fn raddiff_cache_get_lookup_radius_scale(
    cache: *const raddiff_cache,
    scale: *mut f64,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        let scale = unsafe { out_ref(scale, "scale")? };
        *scale = cache.inner.config().lookup_radius_scale;
        Ok(())
    })
}

/// Neighbour clamping (Krivanek et al. 2006) of a record about to be inserted: shrinks
/// `record->radii` in place so that the record's largest radius R (surface: of `radii[0..1]`) is at
/// most R_j + d_j for every stored record j at distance d_j = |position - x_j| < R (R_j its largest
/// radius). All radii are scaled by one factor (anisotropy and axes kept) and the largest becomes
/// the largest float at most the tightest bound, so that the inserted record meets every bound
/// exactly. Only `position` and `radii` are read (and `radii` written); untouched when no bound
/// binds or on error. One-sided: stored records are not shrunk (see
/// `raddiff_cache_clamp_neighbours`). `RADDIFF_ERROR_INVALID_ARGUMENT` for a non-finite position or
/// radius, or a negative one among those the domain uses. Thread-safe, like `raddiff_cache_lookup`.
#[no_mangle]
pub extern "C" fn raddiff_cache_clamp_record(
    cache: *const raddiff_cache,
    record: *mut raddiff_cache_record,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        // SAFETY: NULL or a record the caller lets us modify.
        let record = unsafe { out_ref(record, "record")? };
        let extent = Extent {
            radii: record.radii,
            axes: record.axes.map(DVec3::from),
        };
        let clamped = cache
            .inner
            .clamp_to_neighbours(record.position.into(), &extent)?;
        record.radii = clamped.radii;
        Ok(())
    })
}

/// Two-sided neighbour clamping of every stored record: each record's largest radius R_i becomes
/// min(R_i, min_j (R_j + d_ij)) from the current radii, which is the fixed point of the
/// constraints R_i <= R_j + d_ij (independent of record and thread order; a second call shrinks
/// nothing); a shrinking record's radii are all scaled by one factor. Records that become
/// identical are stored once. If `shrunk` is not NULL, the number of records that shrank is
/// written to it. **Not thread-safe**: no other thread may use the cache during the call (it
/// rebuilds the index and compacts the cache like `raddiff_cache_compact`).
#[no_mangle]
pub extern "C" fn raddiff_cache_clamp_neighbours(
    cache: *mut raddiff_cache,
    shrunk: *mut usize,
) -> raddiff_status {
    guard(|| {
        // SAFETY: NULL or a live handle that, per the contract, nobody else uses right now.
        let cache = unsafe { out_ref(cache, "cache")? };
        let count = cache.inner.clamp_neighbours();
        if let Some(s) = unsafe { shrunk.as_mut() } {
            *s = count;
        }
        Ok(())
    })
}

/// Number of records (0 for NULL).
#[no_mangle]
pub extern "C" fn raddiff_cache_len(cache: *const raddiff_cache) -> usize {
    // SAFETY: NULL or a live handle.
    unsafe { cache.as_ref() }.map_or(0, |c| c.inner.len())
}

/// Writes the cache to `path` atomically (temporary file in the same directory, fsync, rename):
/// a crash never leaves a damaged file. `RADDIFF_ERROR_IO` on failure.
#[no_mangle]
pub extern "C" fn raddiff_cache_save(
    cache: *const raddiff_cache,
    path: *const c_char,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        let path = unsafe { path_from_c(path)? };
        cache.inner.save(path)?;
        Ok(())
    })
}

/// Loads a cache saved by `raddiff_cache_save` (channels, domain, interpolation, its flags, the
/// gradient limit, the leak guard, the far-field reach, the open-fraction tolerance and coverage
/// tolerance and the lookup radius scale come from the file; files of format version 2 have no
/// gradient limit, those of versions 2 and 3 no leak guard, 2 to 4 no far field, 2 to 5 no
/// open-fraction test, 2 to 6 a lookup radius scale of 1, 2 to 7 a coverage tolerance of 0,
/// version 8 one of 0 or INFINITY). Returns
/// NULL with a `RADDIFF_ERROR_IO` or `RADDIFF_ERROR_CORRUPT` message in `raddiff_last_error` for
/// unreadable, truncated, damaged or wrong-version files.
#[no_mangle]
pub extern "C" fn raddiff_cache_load(path: *const c_char) -> *mut raddiff_cache {
    guard_ptr(|| {
        let path = unsafe { path_from_c(path)? };
        let inner = Cache::load(path)?;
        Ok(Box::into_raw(Box::new(raddiff_cache { inner })))
    })
}

/// Adds to `into` every record of `from` it does not hold yet (identical records, e.g. the same
/// gather saved by two render nodes, are detected and skipped). Both caches need the same channel
/// count and domain (`RADDIFF_ERROR_INVALID_ARGUMENT` otherwise). `from` may equal `into`.
#[no_mangle]
pub extern "C" fn raddiff_cache_merge(
    into: *mut raddiff_cache,
    from: *const raddiff_cache,
) -> raddiff_status {
    guard(|| {
        let into = unsafe { in_ref(into, "into")? };
        let from = unsafe { in_ref(from, "from")? };
        into.inner.merge(&from.inner)?;
        Ok(())
    })
}
