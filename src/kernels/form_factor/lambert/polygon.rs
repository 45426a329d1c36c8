//! Certified value fast path of
//! [`polygon_form_factor`](crate::kernels::form_factor::polygon_form_factor) for 4 to 8 vertices:
//! Lambert's sum (or its far-field form) with the running bound of
//! [`lambert::sum`](crate::kernels::form_factor::lambert::sum), for convex polygons that the robust
//! path certainly accepts.
//!
//! The robust path validates area, planarity (1e-8 of the extent) and simplicity (an O(m²)
//! segment test) before it evaluates; Lambert's sum needs none of it, but the fast path must keep
//! that contract, so it accepts only polygons the robust checks pass by a wide margin, with a few
//! products per vertex (`d_k = v_k − v_0`, `e_i = v_{i+1} − v_i`, `N` Newell's normal
//! `Σ d_k × d_{k+1}`, `X = max ‖d_k‖` the robust path's extent):
//!
//! * area: `‖N‖² ≥ 1.01e-10·X⁴`, i.e. `‖N‖ ≳ 1e-5·X²` (the robust limit is 1e-13; thinner
//!   polygons are slivers, whose sum cancels: `sliver/fan.rs`);
//! * planarity: `|d_k·N| ≤ 0.25·1e-8·X‖N‖` (a quarter of the robust tolerance);
//! * strictly convex, winding once: every edge `‖e_i‖ ≥ 1e-3 X`, every turn
//!   `(e_{i−1} × e_i)·N ≥ 1e-3 ‖e_{i−1}‖‖e_i‖‖N‖` (a sine of 1e-3), the fan from `v_0` monotone
//!   (`(d_k × d_{k+1})·N > 0`) and inside the half-plane left of `d_1` (`(d_1 × d_k)·N > 0`): the
//!   vertices are sorted by angle around `v_0` within less than π, so the polygon is simple (star-
//!   shaped from `v_0`), and the margins keep every vertex at least ~1e-6 X from the line of any
//!   edge it is not on, far beyond the rounding of the robust path's orientation tests.
//!
//! The derivative fast path
//! ([`polygon_derivs`](crate::kernels::form_factor::lambert::clipped_polygon::polygon_derivs))
//! takes the same validation and then the analytic per-edge derivatives of Lambert's sum with the
//! triangle's certificate generalized to `m` edges ([`certified_derivs`]).
//!
//! Anything else (non-convex, nearly degenerate, non-planar or self-intersecting polygons, more
//! than 8 vertices) goes to the robust path, which gives the errors.

use glam::DVec3;

use crate::kernels::form_factor::convex::convex_and_valid;
use crate::kernels::form_factor::edge::INV_2PI;
use crate::kernels::form_factor::lambert::sum::{certified_derivs, certified_sum, unclipped};
use crate::{Deriv3, Order};

#[inline(always)]
pub(crate) fn value<const M: usize>(x: DVec3, n: DVec3, v: &[DVec3; M]) -> Option<f64> {
    value_or(x, n, v, || None)
}

/// [`value`], or `clipped()` where the polygon is not certainly unclipped (a vertex below the
/// tangent plane or within rounding of it, or input the unclipped test refuses: the clipped path
/// refuses it too). The unclipped test's differences are not handed over: that would cost the
/// common unclipped path more than it saves the clipped one.
#[inline(always)]
pub(crate) fn value_or<const M: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
    clipped: impl FnOnce() -> Option<f64>,
) -> Option<f64> {
    let Some((n, r, r2)) = unclipped(x, n, v) else {
        return clipped();
    };
    if !convex_and_valid(v) {
        return None;
    }
    let sum = certified_sum(n, v, &r, &r2)?;
    Some((sum.abs() * INV_2PI).min(1.0))
}

/// The value of [`polygon_form_factor`](crate::kernels::form_factor::polygon_form_factor) for a
/// strictly convex polygon of 4 to 8 vertices, every vertex certainly above the tangent plane, when
/// the certified sum is within the fast-path tolerance; `None` otherwise (including invalid input,
/// which the robust path reports).
pub(crate) fn polygon_value(x: DVec3, n: DVec3, v: &[DVec3]) -> Option<f64> {
    match v.len() {
        4 => value::<4>(x, n, v.try_into().ok()?),
        5 => value::<5>(x, n, v.try_into().ok()?),
        6 => value::<6>(x, n, v.try_into().ok()?),
        7 => value::<7>(x, n, v.try_into().ok()?),
        8 => value::<8>(x, n, v.try_into().ok()?),
        _ => None,
    }
}

/// `derivs`, or `clipped()` where the polygon is not certainly unclipped (as [`value_or`]).
#[inline(always)]
pub(crate) fn derivs_or<const M: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
    order: Order,
    clipped: impl FnOnce() -> Option<Deriv3>,
) -> Option<Deriv3> {
    let Some((n, r, r2)) = unclipped(x, n, v) else {
        return clipped();
    };
    if !convex_and_valid(v) {
        return None;
    }
    certified_derivs(n, v, &r, &r2, order)
}

#[cfg(test)]
mod tests;
