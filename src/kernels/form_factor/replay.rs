//! Replays of the robust path: where its decisions are certain from a few f64 tests, the same f64
//! operations without its rescaling and exact-difference set-up, so the result is its bits.

use glam::DVec3;

use crate::kernels::form_factor::edge::{frame_term, EdgeFrame, NEAR_LINE_SINE};
use crate::kernels::form_factor::orient::oriented;
use crate::kernels::form_factor::plane::{plane_height, triangle_plane, Plane};
use crate::kernels::form_factor::quadrature::rules::{far_rule_of, Rule};
use crate::kernels::form_factor::quadrature::tensor::triangle_rule;
use crate::kernels::form_factor::tolerance::cancellation_limit;
use crate::kernels::form_factor::validate::{in_fast_range, unit};
use crate::{Deriv3, Order};

/// The edge's frame as the robust path builds it, `None` when the robust path would recompute the
/// cross product from the exact endpoints ([`EdgeFrame::with_exact_ends`]: x near the edge's line,
/// the same comparison on the same values) or the edge has zero length.
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn fast_frame(r_a: DVec3, e: DVec3) -> Option<EdgeFrame> {
    let f = EdgeFrame::new(r_a, e)?;
    let bound = NEAR_LINE_SINE * f.len;
    if !(f.w.length_squared() >= bound * bound * r_a.length_squared()) {
        return None;
    }
    Some(f)
}

/// The fast evaluation of [`edge_form_factor`](crate::kernels::form_factor::edge_form_factor):
/// `None` when the inputs are invalid or out of
/// [`FAST_RANGE`](crate::kernels::form_factor::validate::FAST_RANGE), or `x` is near the edge's
/// line (where the robust path switches to double-double cross products). Elsewhere the robust path
/// evaluates exactly these f64 operations on inputs rescaled by a power of two, which changes no
/// rounding: the result is bit-for-bit the robust one, so it carries the robust path's accuracy,
/// without its rescaling and exact-difference setup.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn edge_form_factor_fast(
    x: DVec3,
    n: DVec3,
    a: DVec3,
    b: DVec3,
    order: Order,
) -> Option<Deriv3> {
    let (r_a, e) = (a - x, b - a);
    in_fast_range(&[r_a, b - x, e])?;
    let d = frame_term(&fast_frame(r_a, e)?, unit(n)?, order).ok()?;
    d.is_finite().then_some(d)
}

/// A cheap necessary condition for the robust path's far-field decision (vertex centroid at least
/// [`FAR_FIELD_RATIO`](crate::kernels::form_factor::quadrature::rules::FAR_FIELD_RATIO) radii `R`
/// from x): then `‖v_0 − x‖ ≥ 15 R` and every vertex is within `2R` of `v_0`, so `‖v_0 − x‖_∞ ≥
/// ‖v_0 − x‖/√3 ≥ 4.3 max_k ‖v_k − v_0‖_∞`; 4 leaves room for rounding. Max-norms keep it to a few
/// instructions on the generic path. It only decides whether [`far_field_fast`] is tried first,
/// which replays the exact decision.
#[inline(always)]
pub(crate) fn maybe_far<const M: usize>(v: &[DVec3; M], x: DVec3) -> bool {
    let mut edges = (v[1] - v[0]).abs();
    for vk in &v[2..] {
        edges = edges.max((*vk - v[0]).abs());
    }
    (v[0] - x).abs().max_element() >= 4.0 * edges.max_element()
}

/// The far-field evaluation of
/// [`triangle_form_factor`](crate::kernels::form_factor::triangle_form_factor) when the robust
/// path's decisions are certain: inputs valid and in
/// [`FAST_RANGE`](crate::kernels::form_factor::validate::FAST_RANGE), every vertex above the
/// tangent plane by more than the rounding bound of its height (nothing clipped), not near the
/// plane, not a sliver (whose fan geometry the robust path takes from exact differences), and in
/// the far field. Then the robust path integrates the one fan triangle with the rule
/// [`replay::fast_decisions`](crate::kernels::form_factor::replay::fast_decisions) picks, on the
/// same f64 differences up to its exact power-of-two rescaling: the result is bit-for-bit the
/// robust one. Returned with the smallest ratio (distance over radius) of the rule's range; `None`
/// otherwise.
// Not inlined: the generic path only pays the call's test, not this function's frame.
#[inline(never)]
pub(crate) fn triangle_far_field_fast(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    order: Order,
) -> Option<(Deriv3, f64)> {
    far_field_fast(x, n, v, triangle_plane, order)
}

/// [`triangle_far_field_fast`] for a polygon of 4 to 8 vertices (`None` for other counts): the
/// robust path's validation ([`Plane::new`](crate::kernels::form_factor::plane::Plane::new), so
/// invalid polygons are declined and left to the robust path's errors) and decisions, then its
/// far-field rule on the fan triangles from `v_0`, on the same f64 differences: bit-for-bit the
/// robust result.
// Inlined up to the distance test, which declines every nearby polygon: a declined call then pays
// neither the rule's frame nor a copy of the vertices.
#[inline(always)]
pub(crate) fn polygon_far_field_fast(
    x: DVec3,
    n: DVec3,
    v: &[DVec3],
    order: Order,
) -> Option<(Deriv3, f64)> {
    #[inline(always)]
    fn at<const M: usize>(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Option<(Deriv3, f64)> {
        let v: &[DVec3; M] = v.try_into().ok()?;
        if !maybe_far(v, x) {
            return None;
        }
        polygon_far_rule(x, n, *v, order)
    }
    match v.len() {
        4 => at::<4>(x, n, v, order),
        5 => at::<5>(x, n, v, order),
        6 => at::<6>(x, n, v, order),
        7 => at::<7>(x, n, v, order),
        8 => at::<8>(x, n, v, order),
        _ => None,
    }
}

/// [`polygon_far_field_fast`] past its distance test.
#[inline(never)]
fn polygon_far_rule<const M: usize>(
    x: DVec3,
    n: DVec3,
    v: [DVec3; M],
    order: Order,
) -> Option<(Deriv3, f64)> {
    far_field_fast(x, n, v, |u| Plane::new(u).ok(), order)
}

/// The far-field replay shared by [`triangle_far_field_fast`] and [`polygon_far_field_fast`]
/// (`plane_of` validates the polygon given relative to `v_0` as the robust path does).
#[inline(always)]
fn far_field_fast<const M: usize>(
    x: DVec3,
    n: DVec3,
    v: [DVec3; M],
    plane_of: impl FnOnce(&[DVec3; M]) -> Option<Plane>,
    order: Order,
) -> Option<(Deriv3, f64)> {
    let FastSetup {
        r,
        u,
        n,
        plane,
        far: rule,
        h_p,
    } = fast_setup(x, n, v, plane_of)?;
    if plane.is_thin() {
        return None;
    }
    let rule = rule?;
    // The robust path's non-exact fan geometry of (v_0, v_k, v_{k+1}) (its u_0 is exactly zero)
    // and its triangle rule, accumulated from zero in the same order.
    let mut sum = Deriv3::constant(0.0);
    for k in 1..M - 1 {
        let normal = u[k].cross(u[k + 1]);
        let geometry = (normal, normal.dot(r[0]));
        let d = triangle_rule(r[0], u[k], u[k + 1] - u[k], n, order, geometry, rule);
        sum.value += d.value;
        sum.gradient += d.gradient;
        sum.hessian += d.hessian;
    }
    Some((oriented(sum, h_p)?, rule.min_ratio()))
}

/// The fast evaluation of
/// [`triangle_form_factor`](crate::kernels::form_factor::triangle_form_factor) when the robust
/// path's decisions are certain: every vertex strictly above the tangent plane by more than the
/// rounding bound of its height (so nothing is clipped), not near the plane, no edge line near `x`,
/// the triangle not in the far field and the edge sum not cancelling beyond [`cancellation_limit`]
/// (where the robust path integrates by quadrature instead). `None` otherwise, or for invalid or
/// out-of-range inputs. Accepted results are bit-for-bit those of the robust path (same f64
/// operations; its power-of-two rescaling changes no rounding).
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn triangle_form_factor_fast(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    order: Order,
) -> Option<Deriv3> {
    let FastSetup {
        r,
        u,
        n,
        plane,
        far,
        h_p,
    } = fast_setup(x, n, v, triangle_plane)?;
    if far.is_some() {
        return None;
    }
    let mut sum = Deriv3::constant(0.0);
    let mut magnitude = 0.0;
    for i in 0..3 {
        let j = (i + 1) % 3;
        let t = frame_term(&fast_frame(r[i], u[j] - u[i])?, n, order).ok()?;
        magnitude += t.value.abs();
        sum.value += t.value;
        sum.gradient += t.gradient;
        sum.hessian += t.hessian;
    }
    // Neither near the plane nor clipped (both checked above).
    if !(magnitude <= cancellation_limit(&plane, false) * sum.value.abs()) {
        return None;
    }
    oriented(sum, h_p)
}

/// What the replays of the robust path ([`triangle_form_factor_fast`], [`far_field_fast`]) decide
/// first, with the robust path's own operations.
pub(crate) struct FastSetup<const M: usize> {
    /// `v_i − x`.
    pub(crate) r: [DVec3; M],
    /// Positions relative to the first vertex, as the robust path forms them (its edge vectors
    /// are differences of these).
    pub(crate) u: [DVec3; M],
    /// The unit receiver normal.
    pub(crate) n: DVec3,
    pub(crate) plane: Plane,
    /// The far-field rule, when the robust path would integrate by quadrature.
    pub(crate) far: Option<Rule>,
    /// Signed height of `x` over the triangle's plane.
    pub(crate) h_p: f64,
}

/// `None` when the robust path would rescale, clip, or treat `x` as near the polygon's plane, when
/// `plane_of` (the robust path's plane and validation for the positions relative to `v_0`)
/// declines, or for invalid input.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn fast_setup<const M: usize>(
    x: DVec3,
    n: DVec3,
    v: [DVec3; M],
    plane_of: impl FnOnce(&[DVec3; M]) -> Option<Plane>,
) -> Option<FastSetup<M>> {
    let r = v.map(|vk| vk - x);
    let u: [DVec3; M] = std::array::from_fn(|k| if k == 0 { DVec3::ZERO } else { v[k] - v[0] });
    in_fast_range(r.iter().chain(&u[1..]))?;
    let n = unit(n)?;
    // Heights over the tangent plane: the f64 dot product errs by less than 4u·(|n|·|r|) (one
    // rounding in r, three in the dot product), so above 8u·(|n|·|r|) the exact height is positive
    // and the robust clip keeps every vertex without cutting.
    for rk in &r {
        if !(n.dot(*rk) > 8.0 * f64::EPSILON * n.abs().dot(rk.abs())) {
            return None;
        }
    }
    let plane = plane_of(&u)?;
    let (far, h_p) = fast_decisions(&r, &plane)?;
    Some(FastSetup {
        r,
        u,
        n,
        plane,
        far,
        h_p,
    })
}

/// The decisions [`evaluate`](crate::kernels::form_factor::robust::evaluate) takes before its edge
/// sum, for an unclipped polygon given relative to `x`: `None` when `x` is in or near the polygon's
/// plane (where it recomputes the height exactly), otherwise the far-field rule if the quadrature
/// applies and the signed height `h_P`.
pub(crate) fn fast_decisions(r: &[DVec3], plane: &Plane) -> Option<(Option<Rule>, f64)> {
    let h_p = plane_height(r, plane)?;
    Some((far_rule_of(r), h_p))
}

#[cfg(test)]
mod tests;
