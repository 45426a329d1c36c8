//! The near-plane routes' far-field piece: where the visible part is far-field against its size,
//! the robust path integrates it by its far-field rule, and so do the routes.

use glam::DVec3;

use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::clip_line::clip_line_hessian;
use crate::kernels::form_factor::near_plane::route_loop::{FarPiece, RouteLoop};
use crate::kernels::form_factor::orient::visible_value;
use crate::kernels::form_factor::quadrature::rules::Rule;
use crate::kernels::form_factor::quadrature::tensor::far_field;
use crate::{Deriv3, Order};

/// The near-plane routes' branch where the visible part `verts` (their clipped loop) is
/// far-field against its size: `evaluate`'s far-field branch (its `exact` set near the plane),
/// which it takes before the split. Records the rule in `far`; returns its value as
/// [`visible_value`] makes it from the exact height `h_p`, or with `defer` NaN, the value being
/// left to [`deferred_far_piece`] (which sums the rule once for the value and the derivatives).
/// `None` for a non-finite value.
pub(crate) fn far_piece_value(
    verts: &[ClipVertex],
    n: DVec3,
    plane_normal: DVec3,
    h_p: f64,
    rule: Rule,
    far: &mut Option<FarPiece>,
    defer: bool,
) -> Option<f64> {
    *far = Some(FarPiece {
        rule,
        n,
        plane_normal,
        h_p,
    });
    if defer {
        return Some(f64::NAN);
    }
    visible_value(far_field(verts, n, Order::Value, true, rule).value, h_p)
}

/// Value, gradient and (at [`Order::Hessian`]) Hessian of the far-field rule on a near-plane
/// route's loop where the route took it and left its value to the derivative order
/// ([`RouteLoop::defer_far`](crate::kernels::form_factor::near_plane::route_loop::RouteLoop)): the
/// rule summed once, for the value and the derivatives, the derivatives as `evaluate` has them (the
/// clip line's Hessian term included). The value is [`far_piece_value`]'s bits: `triangle_rule`
/// sums the value's `q0` and `RuleSums::assemble` forms it by the same operations at every order,
/// and it is signed and clamped here as there ([`visible_value`]). `None` where that value is not
/// finite (where [`far_piece_value`] declines, and the route with it) or `route.far` is not set;
/// `Err(value)` where the derivatives overflow. Per unit length (per squared length), in the units
/// of the vertices.
pub(crate) fn deferred_far_piece<const N: usize>(
    route: &RouteLoop<N>,
    order: Order,
) -> Option<std::result::Result<Deriv3, f64>> {
    let far = route.far?;
    let verts = &route.points[..route.count];
    let mut d = far_field(verts, far.n, order, true, far.rule);
    let value = visible_value(d.value, far.h_p)?;
    if far.h_p < 0.0 {
        d.gradient = -d.gradient;
        d.hessian = -d.hessian;
    }
    if order.hessian() {
        match clip_line_hessian(verts, far.n, far.plane_normal, far.h_p, false, false) {
            Ok(h) => d.hessian += h,
            Err(_) => return Some(Err(value)),
        }
    }
    d.value = value;
    Some(d.is_finite().then_some(d).ok_or(value))
}
