//! The sliver rule's direct entry for a triangle: the robust path's sliver branch without the
//! robust path's set-up, with its bits.

use glam::DVec3;

use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::orient::oriented;
use crate::kernels::form_factor::plane::{plane_height, triangle_plane};
use crate::kernels::form_factor::quadrature::rules::far_rule_of;
use crate::kernels::form_factor::sliver::clipped::clipped_sliver;
use crate::kernels::form_factor::sliver::rule::sliver_quadrature;
use crate::{Deriv3, Order};

/// [`evaluate`](crate::kernels::form_factor::robust::evaluate)'s sliver branch for a triangle given
/// by `u` (relative to its first vertex), `r` (relative to x) and `r_lo` (`r + r_lo` exact),
/// without the set-up that branch does not use: the same decisions from the same rounded quantities
/// (plane, height, far-field switch), so the result has the robust path's bits. Every vertex above
/// the tangent plane by more than the rounding of `n·r` certifies that the clip keeps the triangle
/// as it is (the uncut rule); otherwise the triangle is clipped as `evaluate` clips it and the
/// visible part takes
/// [`clipped_sliver_quadrature`](crate::kernels::form_factor::sliver::clipped::clipped_sliver_quadrature)
/// and the clip line's Hessian term
/// ([`sliver::clipped`](crate::kernels::form_factor::sliver::clipped)). `None` whenever the robust
/// path would do anything else (x near the plane or near the sliver, a zero-area triangle, an uncut
/// far-field sliver, a non-finite result); the caller then takes that path.
pub(crate) fn direct_sliver(
    u: &[DVec3; 3],
    r: &[DVec3; 3],
    r_lo: &[DVec3; 3],
    n: DVec3,
    order: Order,
) -> Option<Deriv3> {
    let plane = triangle_plane(u)?;
    if !plane.is_very_thin() {
        return None;
    }
    // x not near the plane (so not in it either).
    let h_p = plane_height(r, &plane)?;
    // `clip` compares the exact heights n·(r + r_lo) with zero; the rounded n·r is within
    // ~4ε‖r‖ of them (‖n‖ = 1 + O(ε)), so a margin of 1e-13‖r‖ certifies every sign.
    let above = |v: &DVec3| {
        let h = n.dot(*v);
        h > 0.0 && h * h > 1e-26 * v.length_squared()
    };
    if !r.iter().all(above) {
        // Cut, `evaluate` takes the rule whatever the far-field switch says.
        return clipped_sliver(u, r, r_lo, n, order, &plane, h_p);
    }
    // Uncut, a far-field rule goes to `evaluate`.
    if far_rule_of(r).is_some() {
        return None;
    }
    let verts = [0, 1, 2].map(|k| ClipVertex {
        u: u[k],
        r: r[k],
        r_lo: r_lo[k],
        on_line: false,
    });
    // As `evaluate` finishes: the sign of the height, then the clamp of the value.
    oriented(sliver_quadrature(&verts, n, order)?, h_p)
}
