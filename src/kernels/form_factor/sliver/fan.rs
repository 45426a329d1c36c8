//! Very thin polygons (slivers of 4 to 8 vertices) by the triangles' sliver rule, one fan triangle
//! at a time.
//!
//! The sliver rule ([`sliver`](crate::kernels::form_factor::sliver::rule)) takes triangles only. A
//! polygon thinner than `2·area < 1e-5·extent²` has an edge sum that cancels beyond
//! [`THIN_CANCELLATION_LIMIT`](crate::kernels::form_factor::tolerance::THIN_CANCELLATION_LIMIT),
//! and `evaluate` then bisects it isotropically into up to 256 pieces: two orders of magnitude the
//! cost of a generic quad for a quad 1e-6 wide seen from a length away (docs/kernels.md, "Hard
//! regimes").
//!
//! The clipped form factor is the integral over the polygon of a pointwise integrand (the clip is a
//! pointwise factor), so it is additive over a partition. When every fan triangle `(v_0, v_k,
//! v_{k+1})` has the polygon's orientation, the fan partitions the polygon and its form factor is
//! the sum of the triangles' (each a non-negative number: no cancellation in the value). The
//! decisions of the sliver rule's direct entry
//! ([`direct_sliver`](crate::kernels::form_factor::sliver::direct::direct_sliver)) are taken once
//! for the polygon (not near the plane, nothing clipped, no far-field rule), then each triangle is
//! integrated by the rule ([`sliver_quadrature`], which declines when `x` is not far from the
//! triangle compared with its width); as soon as one triangle is declined, so is the polygon (with
//! `x` near its plane [`fan_of_triangles`] then sums the fan triangles through the triangle kernel,
//! elsewhere the robust path runs). Where the robust path on a fan triangle takes the rule too, the
//! sum has its bits up to the order of the additions. The derivatives are sums too: a triangle's
//! gradient and Hessian are within its own accuracy relative to its largest entry, and the pieces'
//! derivatives can only partly cancel (all pieces are seen under the same small width, from the
//! same side), which `tests/form_factor_polygon_slivers.rs` measures against 320-bit references.
//!
//! Validation once ([`validated`]): the thinness test's Newell normal and extent are the
//! robust path's own (term for term), so `Plane::validated` runs its area and planarity tests on
//! them without recomputing; its O(m²) simplicity test is skipped when the fan is sorted by angle
//! within a half-turn ([`fan_is_star`]), which makes the polygon simple (and runs otherwise).
//!
//! Why not one rule over the whole sliver, with pieces that do not overlap along it (strips
//! between the vertices' abscissae): within the planarity tolerance (1e-8 of the extent, plus
//! the normal's rounding, ~ε/aspect radians) the fan triangles' planes differ by up to ~1e-2 rad
//! for a sliver 1e-6 wide, and the form factor of the loop is the flux through flat pieces that
//! span it. A strip across several fan triangles is not flat: its flux density jumps where it
//! crosses a fan diagonal (a Gauss rule across would not converge), and a ruled strip's
//! Jacobian and height would need the strip's corners on the edges in double-double. Not done;
//! the fan's pieces are each flat, with exact geometry.

use glam::DVec3;

use crate::error::Result;
use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::convex::SLIVER_AREA2;
use crate::kernels::form_factor::orient::oriented;
use crate::kernels::form_factor::plane::{Plane, NEAR_PLANE_HEIGHT};
use crate::kernels::form_factor::quadrature::rules::far_rule_of;
use crate::kernels::form_factor::sliver::rule::sliver_quadrature;
use crate::kernels::form_factor::validate::unit;
use crate::kernels::numeric::dd;
use crate::{Deriv3, Order};

/// Smallest `(u_k × u_{k+1})·N / (‖u_k‖‖u_{k+1}‖‖N‖)` of a fan triangle (and of `(u_1 × u_k)`
/// in [`fan_is_star`]'s half-turn test): its orientation is then
/// certainly the polygon's (the rounded cross product errs by a few ulps of
/// `‖u_k‖‖u_{k+1}‖`), and its area is above the triangles' zero-area limit (1e-13).
const FAN_SINE: f64 = 1e-12;

/// Most vertices taken (the fan's arrays live on the stack).
const MAX_VERTICES: usize = 8;

/// [`polygon_form_factor`](crate::kernels::polygon_form_factor) of a very thin polygon:
/// [`fan_rule`], else [`fan_of_triangles`] with `triangle(a, b, c)` the triangle kernel's
/// result for a fan triangle (the caller's: the polygon kernel passes the triangle kernel);
/// `None` when neither takes it. Polygons that are not thin at all pay one Newell normal here
/// and nothing else.
pub(crate) fn very_thin_polygon_form_factor(
    x: DVec3,
    n: DVec3,
    v: &[DVec3],
    order: Order,
    triangle: impl Fn(DVec3, DVec3, DVec3) -> Result<Deriv3>,
) -> Option<Deriv3> {
    let (u, newell, extent2) = thin_differences(x, v)?;
    thin_polygon_form_factor(x, n, v, (u, newell, extent2), order, triangle)
}

/// [`very_thin_polygon_form_factor`] past the thinness test. Out of line: inlined, its frame
/// would weigh on the polygons that are not thin.
#[inline(never)]
fn thin_polygon_form_factor(
    x: DVec3,
    n: DVec3,
    v: &[DVec3],
    differences: ([DVec3; MAX_VERTICES], DVec3, f64),
    order: Order,
    triangle: impl Fn(DVec3, DVec3, DVec3) -> Result<Deriv3>,
) -> Option<Deriv3> {
    let thin = validated(v.len(), differences)?;
    fan_rule(x, n, v, &thin, order).or_else(|| fan_of_triangles(x, v, &thin, triangle))
}

/// A very thin polygon of 4 to 8 vertices whose fan from `v_0` keeps its orientation, validated
/// as the robust path validates it: what both routes need.
pub(crate) struct ThinPolygon {
    /// `v_k − v_0`.
    u: [DVec3; MAX_VERTICES],
    plane: Plane,
}

/// Whether every fan triangle `(v_0, v_k, v_{k+1})` (from the differences `u_k = v_k − v_0`,
/// `u_0 = 0`) certainly has the orientation of the polygon's unit `normal` ([`FAN_SINE`]): the
/// fan then partitions the polygon. `Some(true)` when besides every `u_k` is certainly on the
/// left of `u_1` (`(u_1 × u_k)·normal > 0`): the vertices are then sorted by angle around `v_0`
/// within a half-turn, so in the projection along `normal` every edge `v_k v_{k+1}` lies in its
/// own wedge `[θ_k, θ_{k+1}]` from `v_0` (convex, less than a half-turn) without touching `v_0`,
/// and the two edges at `v_0` lie on the wedges' outer rays: non-adjacent edges are disjoint, the
/// polygon is simple, and the robust path's O(m²) simplicity test is not needed. `None` when the
/// fan turns over (or for NaN).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails
fn fan_is_star(u: &[DVec3], normal: DVec3) -> Option<bool> {
    let m = u.len();
    let mut length = [0.0f64; MAX_VERTICES];
    for k in 1..m {
        length[k] = u[k].length();
    }
    for k in 1..m - 1 {
        // The rounded cross product errs by a few ulps of ‖u_k‖‖u_{k+1}‖: the margin certifies
        // the sign.
        if !(u[k].cross(u[k + 1]).dot(normal) > FAN_SINE * (length[k] * length[k + 1])) {
            return None;
        }
    }
    Some((3..m).all(|k| u[1].cross(u[k]).dot(normal) > FAN_SINE * (length[1] * length[k])))
}

/// The differences `u_k = v_k − v_0`, the Newell sum and the squared extent of a polygon of 4 to
/// 8 finite vertices seen from a finite `x` when it is thin at all: exactly the complement of the
/// Lambert fast paths' test (the same rounded Newell normal and extent), so that they never took
/// it; `None` otherwise (the other polygons that reach the robust path pay only this test here).
/// The Newell sum and extent are `Plane::new`'s, term for term (its first term, `u_0 × u_1`, is
/// zero).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn thin_differences(x: DVec3, v: &[DVec3]) -> Option<([DVec3; MAX_VERTICES], DVec3, f64)> {
    let m = v.len();
    if !(4..=MAX_VERTICES).contains(&m) || !x.is_finite() || !v.iter().all(|p| p.is_finite()) {
        return None;
    }
    let mut u = [DVec3::ZERO; MAX_VERTICES];
    for k in 1..m {
        u[k] = v[k] - v[0];
    }
    let mut newell = DVec3::ZERO;
    let mut extent2 = 0.0f64;
    for k in 1..m {
        newell += u[k].cross(u[(k + 1) % m]);
        extent2 = extent2.max(u[k].length_squared());
    }
    (newell.length_squared() < SLIVER_AREA2 * extent2 * extent2).then_some((u, newell, extent2))
}

/// The [`ThinPolygon`] of the `m`-gon whose [`thin_differences`] are given: with a fan that keeps
/// its orientation, valid (the robust path's area, planarity and simplicity tests on the same
/// normal and extent, the simplicity certified by [`fan_is_star`] where it can) and very thin by
/// the robust path's threshold; `None` otherwise.
#[inline(always)]
pub(crate) fn validated(
    m: usize,
    (u, newell, extent2): ([DVec3; MAX_VERTICES], DVec3, f64),
) -> Option<ThinPolygon> {
    let normal = newell / newell.length();
    let star = fan_is_star(&u[..m], normal)?;
    // sqrt is monotone and correctly rounded: the root of the max is the max of the roots.
    let plane = Plane::validated(&u[..m], newell, extent2.sqrt(), !star).ok()?;
    plane.is_very_thin().then_some(ThinPolygon { u, plane })
}

/// [`polygon_form_factor`](crate::kernels::polygon_form_factor) of a valid polygon of 4 to 8
/// vertices that is very thin (`2·area < 1e-5·extent²`) with a consistently oriented fan from
/// `v_0` ([`ThinPolygon`]), as the sum of the fan triangles' sliver rules; `None` when any
/// condition fails or a triangle is declined (module documentation). Coordinates differences
/// must be within (1e-30, 1e30), where no rescaling is needed.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn fan_rule(x: DVec3, n: DVec3, v: &[DVec3], thin: &ThinPolygon, order: Order) -> Option<Deriv3> {
    let m = v.len();
    let u = &thin.u;
    let mut r = [DVec3::ZERO; MAX_VERTICES];
    let mut r_lo = [DVec3::ZERO; MAX_VERTICES];
    let mut r2 = [0.0f64; MAX_VERTICES];
    let mut largest = 0.0f64;
    let err = |a: f64, b: f64| dd::two_sum(a, -b).1;
    for k in 0..m {
        r[k] = v[k] - x;
        r_lo[k] = DVec3::new(err(v[k].x, x.x), err(v[k].y, x.y), err(v[k].z, x.z));
        r2[k] = r[k].length_squared();
        largest = largest.max(u[k].abs().max_element().max(r[k].abs().max_element()));
    }
    if !(largest > 1e-30 && largest < 1e30) {
        return None;
    }
    let n = unit(n)?;
    // The decisions the sliver rule's direct entry takes per triangle, once for the polygon:
    // x not near the plane (so the side it is on is certain, the same for every fan triangle),
    // no far-field rule (the robust path's far field takes the polygon), and every vertex above
    // the tangent plane by more than the rounding of `n·r` (nothing clipped).
    let h_p = near_field_height(&r[..m], &r2[..m], &thin.plane)?;
    if !(0..m).all(|k| {
        let h = n.dot(r[k]);
        h > 0.0 && h * h > 1e-26 * r2[k]
    }) {
        return None;
    }
    let vertex = |k: usize| ClipVertex {
        u: u[k],
        r: r[k],
        r_lo: r_lo[k],
        on_line: false,
    };
    let mut sum = Deriv3::constant(0.0);
    for k in 1..m - 1 {
        let d = sliver_quadrature(&[vertex(0), vertex(k), vertex(k + 1)], n, order)?;
        sum.value += d.value;
        sum.gradient += d.gradient;
        sum.hessian += d.hessian;
    }
    oriented(sum, h_p)
}

/// [`fast_decisions`](crate::kernels::form_factor::replay::fast_decisions) for [`fan_rule`], which
/// declines a far-field rule: the signed height `h_P` of x when x is not near the plane and the far
/// field does not apply, `None` otherwise. The same decisions from the same rounded quantities
/// (unit-tested), with the squared distances `r2` computed once for them and for the clip test.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn near_field_height(r: &[DVec3], r2: &[f64], plane: &Plane) -> Option<f64> {
    let (mut nearest, mut r2_max) = (0, 0.0f64);
    for k in 0..r.len() {
        // `min_by` keeps the first of equal elements.
        if r2[k] < r2[nearest] {
            nearest = k;
        }
        r2_max = r2_max.max(r2[k]);
    }
    let h_p = plane.normal.dot(r[nearest]);
    if !(h_p.abs() >= NEAR_PLANE_HEIGHT * r2_max.sqrt()) {
        return None;
    }
    far_rule_of(r).is_none().then_some(h_p)
}

/// [`polygon_form_factor`](crate::kernels::polygon_form_factor) of the polygons
/// [`fan_rule`] takes up to its per-triangle decisions (valid, 4 to 8 vertices, very
/// thin, a fan from `v_0` with the polygon's orientation) with `x` within 1e-3 of its largest
/// distance to a vertex from the plane: the sum
/// of the fan triangles' [`triangle_form_factor`](crate::kernels::triangle_form_factor) (`triangle`), whose
/// very-thin branch handles `x` near the sliver, near its plane and clipping (the clipped
/// integrand is pointwise, so additive over the fan). `None` when any condition fails or a
/// triangle reports an error (the robust path then runs, and reports).
///
/// The value is a sum of non-negative pieces, each within the triangles' sliver accuracy of its
/// own value: the sum is within that accuracy of its value. The derivatives' pieces can partly
/// cancel: each is within its accuracy of its own largest entry, so the sum's error relative to
/// its largest entry is bounded by that accuracy times `Σ|piece| / |sum|` (per entry);
/// `tests/form_factor_polygon_slivers.rs` measures that ratio.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn fan_of_triangles(
    x: DVec3,
    v: &[DVec3],
    thin: &ThinPolygon,
    triangle: impl Fn(DVec3, DVec3, DVec3) -> Result<Deriv3>,
) -> Option<Deriv3> {
    let m = v.len();
    // Only near the plane (the robust path's own `NEAR_PLANE_HEIGHT` switch, on rounded
    // heights: a decision, not a value); farther, the robust path (which takes clipped slivers to
    // the clipped sliver rule) is kept.
    let (mut h_min, mut r_max) = (f64::INFINITY, 0.0f64);
    for p in v {
        let r = *p - x;
        h_min = h_min.min(thin.plane.normal.dot(r).abs());
        r_max = r_max.max(r.length());
    }
    if !(h_min < 1e-3 * r_max) {
        return None;
    }
    let mut sum = Deriv3::constant(0.0);
    for k in 1..m - 1 {
        let d = triangle(v[0], v[k], v[k + 1]).ok()?;
        sum.value += d.value;
        sum.gradient += d.gradient;
        sum.hessian += d.hessian;
    }
    Some(sum)
}

#[cfg(test)]
mod tests;
