//! Derivative fast path of the point-to-triangle form factor when the receiver's tangent plane cuts
//! the triangle near its plane: the gradient and Hessian of Lambert's sum over the clipped loop
//! that [`lambert::clipped`](crate::kernels::form_factor::lambert::clipped) builds for the value.
//!
//! **The derivatives of a clipped form factor.** `F(x) = ∫_{T(x)} K(x, y) dA_y` over the part
//! `T(x)` of the triangle above the tangent plane, with `K ∝ (n·(y − x))(N·(x − y))/‖y − x‖⁴`. `K`
//! vanishes on the clip line, so moving the line adds nothing to the gradient: `∇F` is the gradient
//! of Lambert's sum over the loop with its vertices held fixed, edge by edge. The Hessian gains the
//! line's motion, `n nᵀ |h_P| ∫ dl/(π‖n_t‖‖y − x‖⁴)` along the clip edge (`∂K/∂x = −n (N·(x −
//! y))/(π‖y − x‖⁴)` there), which cancels the `1/h_P²` part of the clip edge's fixed-end Hessian;
//! [`clip_edge_derivs`] has the sum in closed form for an edge lying in the tangent plane, with no
//! division by `x`'s distance `ρ` to the clip line. The other edges of the loop (triangle edges,
//! possibly shortened to a clip point) are ordinary edges: Lambert's analytic terms
//! ([`lambert::sum::edge_derivatives`](crate::kernels::form_factor::lambert::sum::edge_derivatives))
//! down to `sin β = 1/32` ([`MIN_SINE`]; below 1/4 with their error growth paid for in the
//! cancellation test), the robust path's moments below ([`robust_edge_term`]: a short edge far
//! away, or `x` near an edge's line). Neither derivative sum may cancel by more than
//! [`LOOP_CANCELLATION`] (1e5, against Lambert's unclipped 100: this loop serves the near-plane
//! regime, whose contract is the hard regimes'). Their error is then a few ulps of the largest
//! (weighted) term, at most 1e5 times the result's size.
//!
//! **Rounded clip points.** The loop's clip points are the f64 roundings of points on the
//! triangle's edges within `δ` (a few `u‖E‖`) of the exact clip points. The line through them
//! is tilted out of the tangent plane by `θ ~ δ/ρ`, and Lambert's fixed-end derivative of that edge
//! would err by `β∇(n·ŵ) ~ θ/ρ = δ/ρ²` (`1e-4` at `ρ = 1e-6`): that is why the clip edge's term is
//! not Lambert's but [`clip_edge_derivs`]' closed form *for an edge in the tangent plane*, whose
//! inputs (`ê`, `s_a`, `s_b`, `ρ`, the foot vector `p`) move by `O(δ)` and whose output is a
//! polynomial in them over `‖r_a‖²‖r_b‖²` (no `1/ρ`): it moves by `O(δ)` relative to its size.
//! The ordinary edges' terms are smooth in their ends at distances `O(‖r‖)` from `x`, so they move
//! by `O(δ/‖r‖)` relatively, which is the displacement test: the sum over edges of each term's size
//! times the relative displacement `δ/‖r‖` of its clip-point ends, times 4 (the terms are
//! homogeneous of degree −1 and −2 in the distances), must stay within [`MOVED_TOLERANCE`] of the
//! result. A clip point's rounding to f64 (within `u‖r‖`) counts as displacement too: at twice
//! its bound for the triangle ([`loop_derivs`]), whose derivatives keep the generic 1e-12 outside
//! near the plane, at its bound for the polygon route ([`loop_derivs_charging`] from
//! `lambert::clipped_polygon::routed_polygon_derivs`), whose contract is the regime's 1e-9.
//! Measured against the 320-bit reference (`tests/form_factor_clipped_derivs.rs`, `h_P` down
//! to 1e-12 of the size): worst 2e-15 (gradient) and 4e-15 (Hessian) over the interior, 1.1e-14
//! and 3.7e-15 outside; 1.8e-12 and 4.2e-12 with `x` near a vertex.
//!
//! The value does not depend on the order. Where
//! [`lambert::clipped`](crate::kernels::form_factor::lambert::clipped) certifies it (near the
//! plane, `|h_P|` below 1e-3 of the size, over the clipped triangle's interior, not within ~1e-9 of
//! the clip line nor near a triangle edge's line) the value is that one, bit for bit, from the same
//! loop. Elsewhere below 1e-3 of the size (outside the triangle, where Lambert's sum cancels, and
//! next to the clip line) the loop is built without the certificate
//! ([`with_valued_derivative_loop`](crate::kernels::form_factor::lambert::clipped::with_valued_derivative_loop)),
//! and the value is the value order's own. Outside the triangle that is the near-plane route's
//! (`near_plane::triangle`), which runs first: the loop takes its double-double clip points (closer
//! to the exact ones than the loop's own, within the same displacement bounds), its
//! vertex-to-clip-point edge vectors (the same rounding of the same difference) and, where well
//! conditioned, its edges' angles, instead of a second clip and an `atan2` per edge.

use glam::{DMat3, DVec3};

use crate::kernels::form_factor::edge::{
    clip_edge_derivs, frame_term, EdgeFrame, ExactEnds, INV_2PI,
};
use crate::kernels::form_factor::lambert::clipped::{ClippedLoop, LoopVertex};
use crate::kernels::form_factor::lambert::sum::edge_derivatives;
use crate::{Deriv3, Order};

const U: f64 = 0.5 * f64::EPSILON;

/// Largest accepted error, relative to the largest entry of the gradient (Hessian), from the
/// clip points' displacement (module documentation): 1/100 of the near-plane regime's gradient
/// contract (1e-9), and of the order of what [`LOOP_CANCELLATION`] accepts from the terms' own
/// rounding (the displacement of a route's clip point is its rounding to f64, `u` relative, so
/// this test is that one for the clip point's edges, charged at `2u` for the triangle, `u` for
/// the polygon route: module documentation).
const MOVED_TOLERANCE: f64 = 1e-11;

/// Smallest `sin β` of an ordinary edge of the loop at which the path is taken. Lambert's
/// derivative path takes edges down to `sin β = 1/4`
/// ([`lambert::sum::triangle_derivs`](crate::kernels::form_factor::lambert::sum::triangle_derivs));
/// the clipped loop's edges shortened to a clip point near a vertex are often below (the
/// benchmarked "1e-6 above the plane" has one at 0.076), so here an edge below 1/4 is taken with
/// its magnitude in the cancellation tests multiplied by the growth of its rounding errors relative
/// to 1/4, `1/sin²β` for the gradient and `1/sin³β` for the Hessian (see
/// [`lambert::sum::edge_derivatives`](crate::kernels::form_factor::lambert::sum::edge_derivatives)'s
/// terms): the same accepted error as Lambert's rule, with this floor.
const MIN_SINE: f64 = 1.0 / 32.0;

/// Largest ratio of the summed (weighted) magnitudes of the edge terms' gradient (Hessian) to the
/// largest entry of their sum. Each term errs by a few ulps of its weighted size, so the sum keeps
/// a few `u` times this ratio, ~1e-11 relative to its largest entry: 100x under the gradient and
/// Hessian contract of the near-plane regime this loop serves (`|h_P|` below 1e-3 of the size: 1e-9
/// / 1e-8, the hard regimes'). Seen from outside, near the plane, the sums cancel by the visible
/// part's smallness against its distance: over a spread of such configurations
/// (`benches/kernels_regimes.rs`, `RADDIFF_REGIMES_MIX`) by 25x at the median, 860x at the 90th
/// percentile and 4.7e4 at the 99th. Lambert's unclipped limit
/// ([`lambert::sum::CANCELLATION`](crate::kernels::form_factor::lambert::sum::CANCELLATION), 100,
/// set for the generic 1e-12 contract) sent a quarter of them to the robust path, which takes the
/// same edge sums at any cancellation there while its near-plane split cancels by less than 1e3,
/// and integrates by quadrature beyond. Measured against the 320-bit reference over that spread
/// (`tests/form_factor_near_plane.rs`): worst 1.1e-12 / 4.4e-14.
const LOOP_CANCELLATION: f64 = 1e5;

/// The derivatives of `triangle_derivs` from a loop (certified, or uncertified from
/// [`with_valued_derivative_loop`](crate::kernels::form_factor::lambert::clipped::with_valued_derivative_loop):
/// the derivatives need only its orientation), with `value` as the value.
pub(crate) fn loop_derivs<const N: usize>(
    clipped: &ClippedLoop<N>,
    value: f64,
    order: Order,
) -> Option<Deriv3> {
    loop_derivs_charging(clipped, value, order, CLIP_ROUNDING)
}

/// The clip points' rounding to f64 charged by the displacement test (relative to the point):
/// twice its bound `u`, the margin the triangle's derivatives keep for their generic 1e-12
/// accuracy outside near the plane (`tests/form_factor_clipped_derivs.rs`).
const CLIP_ROUNDING: f64 = 2.0 * U;

/// [`loop_derivs`] with the clip points' rounding charged at `rounding` (relative to the point,
/// at least its bound `u`) in the displacement test (module documentation, "Rounded clip
/// points").
pub(crate) fn loop_derivs_charging<const N: usize>(
    clipped: &ClippedLoop<N>,
    value: f64,
    order: Order,
    rounding: f64,
) -> Option<Deriv3> {
    debug_assert!(rounding >= U);
    // One copy per order, so that the order tests fold away in the inlined edge terms.
    let d = match order {
        Order::Value => None,
        Order::Gradient => derivs_at(clipped, Order::Gradient, rounding),
        Order::Hessian => derivs_at(clipped, Order::Hessian, rounding),
    };
    d.map(|d| Deriv3 { value, ..d })
}

/// Max-norm of a Hessian's six distinct entries.
#[inline(always)]
fn max6(h: &[f64; 6]) -> f64 {
    h.iter().fold(0.0f64, |m, e| m.max(e.abs()))
}

#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn derivs_at<const N: usize>(
    clipped: &ClippedLoop<N>,
    order: Order,
    rounding: f64,
) -> Option<Deriv3> {
    let n = clipped.n;
    let (mut gradient, mut hessian) = (DVec3::ZERO, [0.0; 6]);
    let (mut g_mag, mut h_mag) = (0.0, 0.0);
    // Σ over edges of the term's size times the relative displacement of its clip-point ends.
    let (mut moved, mut h_moved) = (0.0, 0.0);
    let shift = |p: &LoopVertex| match p.vertex {
        Some(_) => 0.0,
        // The displacement along the triangle's edge and the rounding of the point.
        None => (p.displacement + rounding * p.hi.length()) / p.hi.length(),
    };
    // Once per point (one square root and division, not three): read by the test below and by
    // both of the point's edges.
    let mut shifts = [0.0; N];
    for (s, p) in shifts.iter_mut().zip(&clipped.points[..clipped.count]) {
        *s = shift(p);
    }
    // A clip point that close to x (relative to its displacement) fails the displacement test
    // below unless its edges' terms are tiny: declined before the edge terms.
    if !shifts.iter().all(|&s| s <= MOVED_TOLERANCE) {
        return None;
    }
    for k in 0..clipped.count {
        let next = if k + 1 == clipped.count { 0 } else { k + 1 };
        let (a, b) = (&clipped.points[k], &clipped.points[next]);
        let e = clipped.edges[k];
        let shifted = shifts[k] + shifts[next];
        // The growth of an edge's rounding errors below sin β = 1/4, relative to there.
        let (g, h, growth) = if a.vertex.is_none() && b.vertex.is_none() {
            let (g, h) = clip_term(n, a.hi, b.hi, e, order);
            (g, h, 1.0)
        } else {
            let (g, h, sin2) = edge_derivatives(n, a.hi, b.hi, e, clipped.angles[k], order);
            if sin2 >= MIN_SINE * MIN_SINE {
                (g, h, (1.0 / (16.0 * sin2)).max(1.0))
            } else {
                let (g, h) = robust_edge_term(n, a, b, e, order)?;
                (g, h, 1.0)
            }
        };
        gradient += g;
        let g_size = g.abs().max_element();
        g_mag += growth * g_size;
        moved += g_size * shifted;
        if order.hessian() {
            for (s, t) in hessian.iter_mut().zip(&h) {
                *s += t;
            }
            let h_size = max6(&h);
            h_mag += growth * growth.sqrt() * h_size;
            h_moved += h_size * shifted;
        }
    }
    // An edge term's gradient (Hessian) is homogeneous of degree −1 (−2) in the distances, and
    // moves by about its degree plus one times its size per unit relative displacement of an
    // end: 4 covers both with a margin.
    let g_total = gradient.abs().max_element();
    if !(g_mag <= LOOP_CANCELLATION * g_total && 4.0 * moved <= MOVED_TOLERANCE * g_total) {
        return None;
    }
    let h_total = max6(&hessian);
    if order.hessian()
        && !(h_mag <= LOOP_CANCELLATION * h_total && 4.0 * h_moved <= MOVED_TOLERANCE * h_total)
    {
        return None;
    }
    // Products by zero are NaN exactly for a NaN or infinite entry.
    let z = gradient.dot(DVec3::ZERO) + hessian.iter().fold(0.0, |s, e| s + e * 0.0);
    if z != 0.0 {
        return None;
    }
    // Orientation as seen from x: the form factor is two-sided.
    let scale = INV_2PI.copysign(clipped.sum);
    let h = hessian.map(|e| e * scale);
    Some(Deriv3 {
        value: 0.0,
        gradient: gradient * scale,
        hessian: DMat3::from_cols(
            DVec3::new(h[0], h[3], h[4]),
            DVec3::new(h[3], h[1], h[5]),
            DVec3::new(h[4], h[5], h[2]),
        ),
    })
}

/// `2π` times an ordinary edge's gradient and Hessian (six entries) as the robust path has them
/// ([`frame_term`]: its moments keep a few ulps of the term at any `β`, by series where the edge
/// is short against its distance and from the ends' exact differences where `x` is near its
/// line), for the edges below [`MIN_SINE`], where Lambert's analytic terms lose `1/sin²β`
/// (`1/sin³β`); `None` where the moments fail (the derivatives decline). Out of line: a few edges
/// in a hundred take it.
#[inline(never)]
fn robust_edge_term(
    n: DVec3,
    a: &LoopVertex,
    b: &LoopVertex,
    e: DVec3,
    order: Order,
) -> Option<(DVec3, [f64; 6])> {
    let (a_parts, b_parts) = (a.exact.split(), b.exact.split());
    let ends = ExactEnds {
        a: [a_parts.0, a_parts.1],
        b: [b_parts.0, b_parts.1],
    };
    let Some(frame) = EdgeFrame::with_exact_ends(a.hi, e, Some(&ends)) else {
        // A zero-length edge adds nothing.
        return Some((DVec3::ZERO, [0.0; 6]));
    };
    let t = frame_term(&frame, n, order).ok()?;
    let tau = std::f64::consts::TAU;
    Some((t.gradient * tau, six_entries(t.hessian * tau)))
}

/// The six distinct entries `[xx, yy, zz, xy, xz, yz]` of a symmetric matrix, the loop's layout.
#[inline(always)]
fn six_entries(h: DMat3) -> [f64; 6] {
    [
        h.x_axis.x, h.y_axis.y, h.z_axis.z, h.y_axis.x, h.z_axis.x, h.z_axis.y,
    ]
}

/// `2π` times the clip edge's gradient and Hessian (six entries), clip-line motion included, from
/// its rounded ends `r_a`, `r_b` and edge vector `e` (module documentation: `O(δ)` in their
/// errors). The loop's clip edge is never shorter than a few ulps of its ends (the clip points
/// are certainly on two different triangle edges), so `‖e‖ > 0`.
#[inline(always)]
fn clip_term(n: DVec3, ra: DVec3, rb: DVec3, e: DVec3, order: Order) -> (DVec3, [f64; 6]) {
    let len = e.length();
    let e_hat = e / len;
    let w = ra.cross(e);
    let sa = ra.dot(e_hat);
    let frame = EdgeFrame {
        e_hat,
        len,
        p: ra - sa * e_hat,
        w,
        h: w.length() / len,
        sa,
        sb: rb.dot(e_hat),
    };
    let (g, h) = clip_edge_derivs(&frame, n, order.hessian());
    (g, six_entries(h))
}

#[cfg(test)]
mod tests;
