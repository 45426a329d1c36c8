//! C wrappers for irradiance caching with the near/far decomposition
//! (`raddiff_cache_irradiance_near_far`) and the cache's far-field marker.

// These are C entry points: every pointer is NULL-checked and the caller's validity contract is
// the header's; marking them `unsafe fn` would change nothing for C callers.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::ffi::{c_int, c_void};

use glam::DVec3;

use super::cache::raddiff_cache;
use super::common::*;
use super::irradiance::{callback_result, query_args, raddiff_irradiance_settings};

/// Traces `count` rays from `origin` along the unit `directions` (world space), none farther
/// than `max_distance` (INFINITY: as far as they go); writes each ray's hit distance to
/// `distance[i]` and the radiance arriving at `origin` along it to `radiance[i*channels + c]`.
/// A ray that finds nothing closer than `max_distance` gets INFINITY (or any distance >=
/// `max_distance`) and its radiance may be left as it is (zeros; not read). Returns 0 on success;
/// anything else abandons the request (`RADDIFF_ERROR_CALLBACK`, nothing inserted). `user` is the
/// pointer given to `raddiff_cache_irradiance_near_far`. Called once per call that passes the
/// argument checks (never after a refusal), twice on a miss with the open-fraction test on (see
/// `raddiff_cache_irradiance_near_far`), on the calling thread; it must not unwind and may call
/// raddiff functions.
pub type raddiff_trace_bounded_fn = Option<
    unsafe extern "C" fn(
        user: *mut c_void,
        origin: raddiff_vec3,
        directions: *const raddiff_vec3,
        count: usize,
        max_distance: f64,
        distance: *mut f64,
        radiance: *mut f32,
    ) -> c_int,
>;

/// The irradiance at the shading point `x` with normal `n` as the near/far decomposition gives
/// it (Arikan et al. 2005): `E_near + V * F`, with the near field `E_near` and open fraction `V`
/// from the query's own short rays and the far field `F` from `cache`, or from a new record when
/// none covers `x`. `settings` must have a near-field reach and `cache` must be made from them
/// (`raddiff_irradiance_cache_new`): its records hold far fields. The reach at this query is
/// rho = max(near_field_reach_world, near_field_reach_pixels * footprint).
///
/// `trace` is called once (unless the arguments are refused first): when a record covers `x`,
/// with the `near_field_m * near_field_n` near rays and `max_distance` = rho; on a miss, with the
/// record's `gather_m * gather_n` gather and `max_distance` = INFINITY, whose rays give both the
/// near field and, split at rho (near hits moved to the reach with the far field's mean
/// radiance, as `raddiff_gather_far_field`), the new record. With the settings'
/// `near_field_open_fraction_tolerance` finite (the open-fraction test, see
/// `raddiff_cache_set_open_fraction_tolerance`), the near rays come first and the lookup admits
/// only records whose open fraction is within the tolerance of theirs; a miss then also traces
/// the gather, whose open fraction the new record keeps. `out` (`channels` floats) receives
/// `E_near + V * F`. Thread-safe as `raddiff_cache_irradiance`.
///
/// `x`, `n`, `footprint` and the errors are as `raddiff_cache_irradiance`'s, and
/// `RADDIFF_ERROR_INVALID_ARGUMENT` when the settings have no near-field reach or disagree with
/// the cache's, the reach comes out 0 (a reach in pixels with footprint 0), the near-ray layout
/// is invalid, or the near rays' values are refused; `RADDIFF_ERROR_DEGENERATE` when the sum
/// overflows a float. On any error `out` is untouched and nothing is inserted, with one exception:
/// on a miss whose own gather's sum fits a float but whose interpolated far field (blended with
/// other records) makes it overflow, `RADDIFF_ERROR_DEGENERATE` comes with the new record kept.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn raddiff_cache_irradiance_near_far(
    cache: *mut raddiff_cache,
    settings: *const raddiff_irradiance_settings,
    x: raddiff_vec3,
    n: raddiff_vec3,
    footprint: f64,
    trace: raddiff_trace_bounded_fn,
    user: *mut c_void,
    out: *mut f32,
) -> raddiff_status {
    raddiff_cache_irradiance_near_far_parts(
        cache,
        settings,
        x,
        n,
        footprint,
        trace,
        user,
        out,
        std::ptr::null_mut(),
        std::ptr::null_mut(),
    )
}

/// `raddiff_cache_irradiance_near_far`, which also writes the query's near field: its near
/// irradiance `E_near` to `near_irradiance` (`channels` doubles) and its open fraction `V` (in
/// [0, 1]) to `*open_fraction`. Either may be NULL (not wanted). Both are written only on
/// success, with `out`.
///
/// They let a renderer shade a pixel once while it fills the cache and again, without tracing,
/// once the cache is complete: keep `E_near` and `V` from the call that visited the pixel, then
/// show `E_near + V * F` with the far field `F` from `raddiff_cache_lookup` (or
/// `raddiff_cache_lookup_with`, or `raddiff_cache_lookup_open` with `V` when the cache has the
/// open-fraction test) on the finished cache. On a miss the near field comes from the new
/// record's gather (its rays closer than the reach), on a hit from the near rays.
///
/// Arguments, callback and errors as `raddiff_cache_irradiance_near_far`'s.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn raddiff_cache_irradiance_near_far_parts(
    cache: *mut raddiff_cache,
    settings: *const raddiff_irradiance_settings,
    x: raddiff_vec3,
    n: raddiff_vec3,
    footprint: f64,
    trace: raddiff_trace_bounded_fn,
    user: *mut c_void,
    out: *mut f32,
    near_irradiance: *mut f64,
    open_fraction: *mut f64,
) -> raddiff_status {
    guard(|| {
        let (cache, settings) = unsafe { query_args(cache, settings, out)? };
        let trace = trace.ok_or(FfiError::Null("trace"))?;
        let found = cache.inner.irradiance_near_far(
            &settings,
            DVec3::from(x),
            DVec3::from(n),
            footprint,
            |origin, directions, max_distance, distance, radiance| {
                // SAFETY: the arrays hold `count` directions and distances and
                // `count * channels` radiances, as the callback's contract says.
                let status = unsafe {
                    trace(
                        user,
                        origin.into(),
                        directions.as_ptr().cast(),
                        directions.len(),
                        max_distance,
                        distance.as_mut_ptr(),
                        radiance.as_mut_ptr(),
                    )
                };
                callback_result(status)
            },
        )?;
        // SAFETY: the caller provides `channels` writable floats at `out`, and `channels`
        // writable doubles at `near_irradiance` unless it is NULL.
        unsafe {
            std::ptr::copy_nonoverlapping(found.value.as_ptr(), out, found.value.len());
            if !near_irradiance.is_null() {
                let near = &found.near.irradiance;
                std::ptr::copy_nonoverlapping(near.as_ptr(), near_irradiance, near.len());
            }
            if let Some(v) = open_fraction.as_mut() {
                *v = found.near.open_fraction;
            }
        }
        Ok(())
    })
}

/// Writes the cache's far-field reach to `*world` (L) and `*pixels` (pixel footprints): both 0
/// when its records hold irradiance, not far fields. Set when the cache is made
/// (`raddiff_irradiance_cache_new` with a near-field reach), saved with it and restored by
/// `raddiff_cache_load` (files written before it load with both 0).
#[no_mangle]
pub extern "C" fn raddiff_cache_get_far_field(
    cache: *const raddiff_cache,
    world: *mut f64,
    pixels: *mut f64,
) -> raddiff_status {
    guard(|| {
        let cache = unsafe { in_ref(cache, "cache")? };
        let world = unsafe { out_ref(world, "world")? };
        let pixels = unsafe { out_ref(pixels, "pixels")? };
        let reach = cache.inner.config().far_field;
        *world = reach.world;
        *pixels = reach.pixels;
        Ok(())
    })
}
