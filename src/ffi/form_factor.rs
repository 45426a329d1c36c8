//! C wrappers for the point-to-triangle and point-to-polygon form factors.

use glam::DVec3;
use smallvec::SmallVec;

use super::common::*;
use crate::kernels;
use crate::kernels::form_factor::triangle_form_factor_value;
use crate::Order;

/// Form factor from a differential area at `x` with unit normal `n` to the triangle `(a, b, c)`:
/// `(1/pi)` times the integral of `n . w` over the triangle's solid angle, with the part below the
/// tangent plane clipped away; value, gradient and Hessian with respect to `x` (`n` fixed). The
/// triangle is two-sided (either vertex order). See the Rust `kernels::triangle_form_factor`.
///
/// `RADDIFF_ERROR_INVALID_ARGUMENT`: non-finite input, `n` not unit length within 1e-6, bad `order`.
/// `RADDIFF_ERROR_DEGENERATE`: zero-area triangle, or a gradient/Hessian with `x` in the triangle's
/// plane (the value there is 0).
///
/// # Safety
/// `out` must be NULL or valid for writing one `raddiff_deriv3`.
#[no_mangle]
pub unsafe extern "C" fn raddiff_triangle_form_factor(
    x: raddiff_vec3,
    n: raddiff_vec3,
    a: raddiff_vec3,
    b: raddiff_vec3,
    c: raddiff_vec3,
    order: u32,
    out: *mut raddiff_deriv3,
) -> raddiff_status {
    guard(|| {
        let out = unsafe { out_ref(out, "out")? };
        *out = match order_from_c(order)? {
            // The value alone, inlined here, without the derivatives' plumbing.
            Order::Value => {
                let v = [a.read(), b.read(), c.read()];
                value_only(triangle_form_factor_value(x.read(), n.read(), v)?)
            }
            order => {
                let (x, n, a, b, c) = (x.into(), n.into(), a.into(), b.into(), c.into());
                kernels::triangle_form_factor(x, n, a, b, c, order)?.into()
            }
        };
        Ok(())
    })
}

/// The same as `raddiff_triangle_form_factor` for a planar simple polygon of `count >= 3`
/// vertices (either orientation). See the Rust `kernels::polygon_form_factor`.
///
/// `RADDIFF_ERROR_INVALID_ARGUMENT` also for `count < 3`, a non-planar (beyond 1e-8 of its extent
/// plus the rounding of its normal, which matters only for slivers) or self-intersecting polygon.
///
/// # Safety
/// `vertices` must be NULL or valid for reading `count` `raddiff_vec3`; `out` must be NULL or valid
/// for writing one `raddiff_deriv3`.
#[no_mangle]
pub unsafe extern "C" fn raddiff_polygon_form_factor(
    x: raddiff_vec3,
    n: raddiff_vec3,
    vertices: *const raddiff_vec3,
    count: usize,
    order: u32,
    out: *mut raddiff_deriv3,
) -> raddiff_status {
    guard(|| {
        let out = unsafe { out_ref(out, "out")? };
        let vertices = unsafe { in_slice(vertices, count, "vertices")? };
        let order = order_from_c(order)?;
        let vertices: SmallVec<[DVec3; 8]> = vertices.iter().map(|v| DVec3::from(*v)).collect();
        *out = kernels::polygon_form_factor(x.into(), n.into(), &vertices, order)?.into();
        Ok(())
    })
}
