//! C wrappers for the near/far decomposition at a reach (`raddiff_gather_near_field`,
//! `raddiff_gather_far_field_radiance`, `raddiff_gather_far_field`; see `gather::near_far`).
// The C functions take raw pointers by contract (documented per argument) and NULL-check them;
// marking them `unsafe fn` would change nothing for C callers.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use super::common::*;
use super::gather::raddiff_gather_layout;
use crate::gather::{far_field_gather, far_field_radiance, near_field, Layout};
use crate::Error;

/// `m*n*channels` for a valid layout, or an error when it overflows.
fn radiance_len(layout: &Layout, channels: u32) -> Result<usize, FfiError> {
    layout
        .len()
        .checked_mul(channels as usize)
        .ok_or_else(|| Error::InvalidArgument("m*n*channels overflows size_t".into()).into())
}

/// The near field at a pixel's point (Arikan et al. 2005): from the directions of `layout`
/// (`raddiff_gather_directions`) traced no farther than `reach` (L, finite and > 0), writes the
/// irradiance of the hits closer than `reach` to `near_irradiance` (`channels` values: `pi/(m*n)`
/// times the sum of their radiance; `4 pi/(m*n)`, fluence, for the sphere layout) and the open
/// fraction to `open_fraction` (the share of the layout's measure whose rays reach at least
/// `reach`: a miss, `INFINITY`, or any distance >= `reach`; in [0, 1]).
///
/// `distance` (m*n) and `radiance` (m*n*channels, index `i*channels + c`) are as in
/// `raddiff_gather_input`. The pixel's irradiance is then `near_irradiance[c] + open_fraction *
/// F[c]`, with F the far field interpolated from records made from `raddiff_gather_far_field`'s
/// (or `raddiff_gather_far_field_radiance`'s) gathers at the same reach.
/// `RADDIFF_ERROR_INVALID_ARGUMENT` for a bad layout, a reach not finite and > 0, `channels` 0,
/// a distance not > 0 (or NaN) or non-finite radiance; nothing is written on failure.
#[no_mangle]
pub extern "C" fn raddiff_gather_near_field(
    layout: *const raddiff_gather_layout,
    distance: *const f64,
    radiance: *const f32,
    channels: u32,
    reach: f64,
    near_irradiance: *mut f64,
    open_fraction: *mut f64,
) -> raddiff_status {
    guard(|| {
        let layout = Layout::try_from(unsafe { in_ref(layout, "layout")? })?;
        let distance = unsafe { in_slice(distance, layout.len(), "distance")? };
        let radiance = unsafe { in_slice(radiance, radiance_len(&layout, channels)?, "radiance")? };
        if near_irradiance.is_null() {
            return Err(FfiError::Null("near_irradiance"));
        }
        let open = unsafe { out_ref(open_fraction, "open_fraction")? };
        let near = near_field(&layout, distance, radiance, channels as usize, reach)?;
        unsafe { std::slice::from_raw_parts_mut(near_irradiance, near.irradiance.len()) }
            .copy_from_slice(&near.irradiance);
        *open = near.open_fraction;
        Ok(())
    })
}

/// Turns a traced gather into its far-field gather at `reach` (L, finite and > 0), in place: the
/// radiance of every direction whose hit is closer than `reach` becomes the mean radiance of the
/// directions that reach at least that far (per channel; 0 when none does). Evaluated as usual
/// (`raddiff_gather_evaluate`, `raddiff_gather_evaluation_new`, the radii), the gather then gives
/// the far field F and its derivatives, which is what the records of a near/far cache hold. Near
/// hits keep their distances. Without a medium F is `(E - E_near) / open_fraction` of the
/// unmodified gather, up to the mean's rounding to float.
///
/// `distance` (m*n) and `radiance` (m*n*channels, read and written) are as in
/// `raddiff_gather_input`; `open_fraction` (nullable) receives the open fraction in [0, 1].
/// `RADDIFF_ERROR_INVALID_ARGUMENT` for a bad layout, a reach not finite and > 0, `channels` 0,
/// a distance not > 0 (or NaN) or non-finite radiance; nothing is written on failure.
#[no_mangle]
pub extern "C" fn raddiff_gather_far_field_radiance(
    layout: *const raddiff_gather_layout,
    distance: *const f64,
    radiance: *mut f32,
    channels: u32,
    reach: f64,
    open_fraction: *mut f64,
) -> raddiff_status {
    guard(|| {
        let layout = Layout::try_from(unsafe { in_ref(layout, "layout")? })?;
        let distance = unsafe { in_slice(distance, layout.len(), "distance")? };
        let radiance =
            unsafe { inout_slice(radiance, radiance_len(&layout, channels)?, "radiance")? };
        let open = far_field_radiance(&layout, distance, radiance, channels as usize, reach)?;
        if let Some(out) = unsafe { open_fraction.as_mut() } {
            *out = open;
        }
        Ok(())
    })
}

/// As `raddiff_gather_far_field_radiance`, and every hit closer than `reach` moves to the reach
/// (`distance[i] = reach`, read and written), as if a surface at the reach showed the far field's
/// mean radiance: the far field's derivatives and radii then see only the far geometry, which is
/// what a near/far cache's records want (the pixels' near fields carry the near geometry). Hit
/// normals given to a metric (the geometric Hessian) should face the gather point for the moved
/// hits. `distance` and `radiance` must not overlap. Errors as
/// `raddiff_gather_far_field_radiance`; nothing is written on failure.
#[no_mangle]
pub extern "C" fn raddiff_gather_far_field(
    layout: *const raddiff_gather_layout,
    distance: *mut f64,
    radiance: *mut f32,
    channels: u32,
    reach: f64,
    open_fraction: *mut f64,
) -> raddiff_status {
    guard(|| {
        let layout = Layout::try_from(unsafe { in_ref(layout, "layout")? })?;
        if !distance.is_null() && std::ptr::eq(distance.cast::<u8>(), radiance.cast::<u8>()) {
            return Err(
                Error::InvalidArgument("distance and radiance are the same array".into()).into(),
            );
        }
        let distance = unsafe { inout_slice(distance, layout.len(), "distance")? };
        let radiance =
            unsafe { inout_slice(radiance, radiance_len(&layout, channels)?, "radiance")? };
        let open = far_field_gather(&layout, distance, radiance, channels as usize, reach)?;
        if let Some(out) = unsafe { open_fraction.as_mut() } {
            *out = open;
        }
        Ok(())
    })
}
