//! C wrappers for the closed-form derivative kernels.

// C entry points take raw pointers by design: each is NULL-checked (`out_ref`, `in_slice`) and its
// validity for the stated length is the C caller's contract, documented on every function.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use super::common::*;
use crate::kernels;
use crate::kernels::solid_angle::{solid_angle_to, solid_angle_value};
use crate::Order;

/// `exp(-sigma_t |x - y|)` and its derivatives with respect to `x` (see the Rust
/// `kernels::transmittance`). `RADDIFF_ERROR_DEGENERATE` for a gradient at `x == y`.
#[no_mangle]
pub extern "C" fn raddiff_transmittance(
    x: raddiff_vec3,
    y: raddiff_vec3,
    sigma_t: f64,
    order: u32,
    out: *mut raddiff_deriv3,
) -> raddiff_status {
    guard(|| {
        let out = unsafe { out_ref(out, "out")? };
        let order = order_from_c(order)?;
        *out = kernels::transmittance(x.into(), y.into(), sigma_t, order)?.into();
        Ok(())
    })
}

/// Transmittance through a heterogeneous medium from `count >= 1` extinction samples `sigma_t`
/// (and optionally their spatial gradients, `sigma_t_gradient`, NULL when unknown) at the midpoints
/// `t_i = (i + 0.5)/count` of the segment `x -> y`; gradient with respect to `x` (see the Rust
/// `kernels::transmittance_marched` for the exact definition). `order` must be
/// `RADDIFF_ORDER_VALUE` or `RADDIFF_ORDER_GRADIENT`; `RADDIFF_ORDER_HESSIAN`, `count == 0`, a
/// negative or non-finite sample give `RADDIFF_ERROR_INVALID_ARGUMENT`.
/// `sigma_t` must point to `count` doubles and `sigma_t_gradient` to `count` vectors (or be NULL).
#[no_mangle]
pub extern "C" fn raddiff_transmittance_marched(
    x: raddiff_vec3,
    y: raddiff_vec3,
    sigma_t: *const f64,
    sigma_t_gradient: *const raddiff_vec3,
    count: usize,
    order: u32,
    out: *mut raddiff_deriv3,
) -> raddiff_status {
    guard(|| {
        let out = unsafe { out_ref(out, "out")? };
        let order = order_from_c(order)?;
        if count == 0 {
            return Err(crate::Error::InvalidArgument(
                "count must be >= 1 (at least one sigma_t sample)".into(),
            )
            .into());
        }
        let sigma = unsafe { in_slice(sigma_t, count, "sigma_t")? };
        // raddiff_vec3 and glam's DVec3 are both #[repr(C)] { x, y, z: f64 } (checked below), so
        // the caller's array is read in place, without a per-call allocation.
        let gradient = if sigma_t_gradient.is_null() {
            None
        } else {
            let g = sigma_t_gradient.cast::<glam::DVec3>();
            Some(unsafe { in_slice(g, count, "sigma_t_gradient")? })
        };
        *out = kernels::transmittance_marched(x.into(), y.into(), sigma, gradient, order)?.into();
        Ok(())
    })
}

/// Unsigned solid angle (steradians) subtended at `x` by the triangle `(a, b, c)`, with gradient
/// and Hessian with respect to `x` (see the Rust `kernels::triangle_solid_angle`). On the
/// triangle's plane: 2π inside, 0 outside, zero derivatives; `RADDIFF_ERROR_DEGENERATE` on an edge or
/// at a vertex; zero-area triangles give 0.
#[no_mangle]
pub extern "C" fn raddiff_triangle_solid_angle(
    x: raddiff_vec3,
    a: raddiff_vec3,
    b: raddiff_vec3,
    c: raddiff_vec3,
    order: u32,
    out: *mut raddiff_deriv3,
) -> raddiff_status {
    guard(|| {
        let out = unsafe { out_ref(out, "out")? };
        let (x, y) = (x.read(), [a.read(), b.read(), c.read()]);
        match order_from_c(order)? {
            // The value alone, without the derivatives' plumbing (13 numbers through each layer).
            Order::Value => *out = value_only(solid_angle_value(x, y, false)?),
            order => solid_angle_to(x, y, order, false, |d| *out = (*d).into())?,
        }
        Ok(())
    })
}

/// Flatland form factor: the angle subtended at `x` by the segment `(a, b)`, divided by 2π, with
/// gradient and Hessian (row-major 2x2) with respect to `x` (see the Rust
/// `kernels::segment_form_factor_2d`). On the segment's line: 1/2 between the endpoints, 0 beyond,
/// zero derivatives; `RADDIFF_ERROR_DEGENERATE` at an endpoint; a zero-length segment gives 0.
#[no_mangle]
pub extern "C" fn raddiff_segment_form_factor_2d(
    x: raddiff_vec2,
    a: raddiff_vec2,
    b: raddiff_vec2,
    order: u32,
    out: *mut raddiff_deriv2,
) -> raddiff_status {
    guard(|| {
        let out = unsafe { out_ref(out, "out")? };
        let order = order_from_c(order)?;
        *out = kernels::segment_form_factor_2d(x.into(), a.into(), b.into(), order)?.into();
        Ok(())
    })
}

const _: () = {
    assert!(std::mem::size_of::<raddiff_vec3>() == std::mem::size_of::<glam::DVec3>());
    assert!(std::mem::align_of::<raddiff_vec3>() == std::mem::align_of::<glam::DVec3>());
    assert!(std::mem::offset_of!(raddiff_vec3, y) == std::mem::offset_of!(glam::DVec3, y));
    assert!(std::mem::offset_of!(raddiff_vec3, z) == std::mem::offset_of!(glam::DVec3, z));
};
