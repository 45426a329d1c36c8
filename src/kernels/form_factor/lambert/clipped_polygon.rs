//! Certified fast path of [`polygon_form_factor`](crate::kernels::form_factor::polygon_form_factor)
//! when the receiver's tangent plane cuts a strictly convex polygon of 4 to 8 vertices and `x` is
//! near the polygon's plane: Lambert's sum over the clipped loop with
//! [`lambert::clipped`](crate::kernels::form_factor::lambert::clipped)'s running error bound, and
//! the derivatives of that loop
//! ([`lambert::clipped_derivs`](crate::kernels::form_factor::lambert::clipped_derivs)).
//!
//! Near the plane (`x` within 1e-3 of the size) the robust path's exact geometry (validation,
//! exact clip, near-plane split, edge sum) costs 4.5-5.5x the unclipped polygon's Lambert sum;
//! the clipped loop needs only the loop and Lambert's per-edge terms (the costs are in
//! docs/kernels.md, "Hard regimes").
//!
//! **What is certified.** The polygon must be one that
//! [`lambert::polygon`](crate::kernels::form_factor::lambert::polygon) would take unclipped
//! (strictly convex, planar to a quarter of the robust tolerance, not a sliver, every edge and turn
//! with a 1e-3 margin: `convex_normal`), so that the robust path accepts it and its visible part is
//! one convex loop. Every vertex must be certainly above or below the tangent plane (`|n·r_k|`
//! beyond `16u(|n|·|r_k|)`, as for the triangle) and the vertices above must be one run (exactly
//! two sign changes around the polygon; a planar convex polygon has at most two, so more means the
//! polygon's slight non-planarity decides, and the path declines). The loop is then the run of kept
//! vertices, the crossing of the edge leaving the run, the crossing of the edge entering it and the
//! clip edge between the two: at most `M + 1` points.
//!
//! **The error bound for `M` edges** is the triangle's argument (`lambert::clipped`'s module
//! documentation), which uses nothing of the triangle but these facts, all true here: (i) each loop
//! vertex is the f64 rounding of a point exactly on a polygon edge's line (a vertex `r_k`, or a
//! clip point `R_i + t(R_j − R_i)` formed in double-double from the exact differences `R_k = v_k −
//! x` to ~u²), displaced along that edge by at most `δ ≤ δt‖E‖` from the exact clip point, with
//! `δt` bounded from the heights' error bounds as for the triangle; (ii) each loop edge vector is
//! one rounding of the exact difference of its ends (`v_j − v_i` between two polygon vertices, the
//! double-double difference where an end is a clip point): Lambert's input model, so every ordinary
//! edge's term errs by at most `u(36β + 20|r_a·e|g)` (`lambert/sum.rs`); (iii) exactly two clip
//! points, adjacent in the loop, so there is one clip edge, whose term `±β` and bound
//! `u(6‖e‖/‖r_b‖ + 7 + 2β)` are those of a segment in the tangent plane, and the region the loop
//! bounds differs from the exact visible part by the same two thin triangles along the clip line
//! (`2π|ΔF| ≤ 8δ²/ρ²`) plus the clip edge's tilt (`βθ²/2`, `θ ≤ 2δ/ρ`). Summing the `m ≤ M + 1`
//! terms adds `(m − 1)u Σ|f_k|`, renormalizing `n` and the final scaling `3u Σ|f_k|`: the bound is
//! `u(Σ err_k + (m + 2)Σ|f_k|)` plus the two second-order terms, the triangle's formula with `m`
//! the loop's length,
//! accepted within [`FAST_TOLERANCE`](crate::kernels::form_factor::tolerance::FAST_TOLERANCE) of
//! the result. The polygon's planarity within `2.5e-9` of its extent does not enter: the loop's
//! edges are the polygon's edges (or parts of them, on their lines) and the clip edge, as the
//! robust path clips them; only the clip line's Hessian term uses a plane, and that of a polygon
//! planar to 2.5e-9 moves it by that relatively at most (far below `δ/ρ`'s effect, and the
//! derivatives' tolerance is 1e-12 relative to their largest entry against the robust path's 1e-8
//! planarity).
//!
//! **Where it is tried**: as for the triangle (`lambert::clipped::left_to_the_robust_path`), only
//! below 1e-3 of the size from the plane (`|N·r_0| < 1e-3‖N‖ max‖r_k‖`, `N` Newell's normal),
//! not within a sine of 1e-3 of an edge's segment (`β > π/2`, where Lambert's bound grows like
//! `1/sin β`), and not below 1e-4 of the size outside the polygon (the sum cancels: the robust
//! path's near-plane split, which `near_plane/polygon.rs` replays for the value with the
//! robust bits; the derivative orders there take that value and the derivatives of the route's
//! loop, [`routed_polygon_derivs`]). It declines within ~1e-9 of the clip line and wherever
//! the bound fails.
//!
//! **Derivatives**: those of the same loop, with the triangle's acceptance rules (Lambert's terms
//! down to `sin β = 1/32` with their error growth charged in the cancellation test, the robust
//! path's moments below, the sums cancelling by at most 1e5, the clip points' displacement within
//! 1e-11 of the result): `lambert::clipped_derivs`' argument is per edge and holds for any number
//! of them. The route's clip points are the exact crossings to ~u², so their displacement is their
//! rounding to f64, charged at its bound `u` (the triangle charges `2u` for its 1e-12): over the
//! benchmark's outside mix (`RADDIFF_REGIMES_MIX`, 3000 calls) the robust path then runs for 16
//! calls instead of 30 (the rest cancel beyond 1e5, or move beyond the tolerance even at `u`),
//! and the derivatives agree with the 320-bit reference within 3.0e-12 (gradient; measured
//! over the mix by a temporary test), against the regime's 1e-9 (the worst before was the robust
//! path's 2.8e-12). Where the route found the visible part far-field, the derivative orders take
//! its far-field rule instead ([`deferred_far_piece`]). The
//! value of a derivative order is the certified value, bit for bit (the same loop and sum).

use glam::DVec3;

use crate::kernels::form_factor::convex::convex_normal;
use crate::kernels::form_factor::lambert::clipped::{
    certify, difference_error, edge_vector, from_parts, ClippedLoop, LoopVertex,
};
use crate::kernels::form_factor::lambert::clipped_derivs::{loop_derivs, loop_derivs_charging};
use crate::kernels::form_factor::near_plane;
use crate::kernels::form_factor::near_plane::far_piece::deferred_far_piece;
use crate::kernels::form_factor::near_plane::route_loop::RouteLoop;
use crate::kernels::form_factor::validate::{in_range, unit};
use crate::kernels::numeric::dd::Dd;
use crate::{Deriv3, Order};

const U: f64 = 0.5 * f64::EPSILON;

/// The computed heights' error bound, `4.01u(|n|·|r_k|)`, as a fraction of the sign test's
/// `16u(|n|·|r_k|)` (module documentation, "The clip points").
const HEIGHT_ERROR: f64 = 4.01 / 16.0;

/// The tangent plane's cut of the polygon: the unit normal, `r_k = v_k − x`, the heights
/// `n·r_k` with their error bounds (twice the computed heights' error) and which vertices are
/// certainly above.
struct Cut<const M: usize> {
    n: DVec3,
    r: [DVec3; M],
    heights: [f64; M],
    height_error: [f64; M],
    above: [bool; M],
}

/// The cut, from the unit normal and `r_k = v_k − x` (each in range); `None`
/// when a height's sign is uncertain, or unless the vertices above form one run (two sign
/// changes: something clipped, something kept).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn cut<const M: usize>(n: DVec3, r: &[DVec3; M]) -> Option<Cut<M>> {
    let heights: [f64; M] = std::array::from_fn(|k| n.dot(r[k]));
    // The computed heights err by less than a quarter of this (module documentation).
    let height_error: [f64; M] =
        std::array::from_fn(|k| 8.0 * f64::EPSILON * n.abs().dot(r[k].abs()));
    let mut above = [false; M];
    for k in 0..M {
        if heights[k] > height_error[k] {
            above[k] = true;
        } else if !(heights[k] < -height_error[k]) {
            return None;
        }
    }
    let changes = (0..M)
        .filter(|&i| above[i] != above[if i + 1 == M { 0 } else { i + 1 }])
        .count();
    (changes == 2).then_some(Cut {
        n,
        r: *r,
        heights,
        height_error,
        above,
    })
}

/// Newell's normal `Σ d_k × d_{k+1}` (`d_k = v_k − v_0`), as
/// [`convex_normal`] forms it (the same operations), for the decisions before the validation.
#[inline(always)]
pub(crate) fn newell<const M: usize>(v: &[DVec3; M]) -> DVec3 {
    let mut normal = DVec3::ZERO;
    for k in 1..M - 1 {
        normal += (v[k] - v[0]).cross(v[k + 1] - v[0]);
    }
    normal
}

/// Whether the configuration is left to the robust path (module documentation, "Where it is
/// tried"), for the polygon's Newell normal `normal` and `r_k = v_k − x`; squared, without square
/// roots (a decision on where to try, not part of the certificate; NaN input passes it, to be
/// refused next), and outside the polygon near its plane (the robust path's case) returning at
/// the first edge that sees `x` on the other side.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that a NaN side counts as outside
fn left_to_the_robust_path<const M: usize>(normal: DVec3, r: &[DVec3; M]) -> bool {
    let length2: [f64; M] = std::array::from_fn(|k| r[k].length_squared());
    let r_max2 = length2.iter().fold(0.0f64, |m, &l| m.max(l));
    let height = normal.dot(r[0]);
    let height2 = height * height;
    let scale2 = normal.length_squared();
    if height2 >= 1e-6 * scale2 * r_max2 {
        return true;
    }
    // Below 1e-4 of the size, x's foot must be inside: every edge sees it on the same side.
    // Tested first, returning at the first edge that disagrees (the outside case pays for two).
    if height2 < 1e-8 * scale2 * r_max2 {
        let first = normal.dot(r[M - 1].cross(r[0]));
        for i in 0..M - 1 {
            if !(normal.dot(r[i].cross(r[i + 1])) * first > 0.0) {
                return true;
            }
        }
    }
    (0..M).any(|i| {
        let j = if i + 1 == M { 0 } else { i + 1 };
        r[i].dot(r[j]) < 0.0 && r[i].cross(r[j]).length_squared() < 1e-6 * length2[i] * length2[j]
    })
}

/// The clipped loop of `cut` (`N ≥ M + 1`; the run of kept vertices, then the two clip points),
/// its edge vectors, without sum (0), handed to `f` in place. With `route`, the near-plane
/// route's loop of the same cut (the caller checks [`same_loop`]): its clip points, placed from
/// the double-double heights (as the robust path's clip places them) rather than from the f64
/// ones, which moves them from the exact crossing by ~u² instead of ~u of the size (the routed
/// derivatives' accept test on that displacement fails by a few times with the f64 points where
/// the derivative sums cancel outside the polygon), its edge vectors from a kept vertex to a
/// clip point (or back) and of the clip edge (the same rounding of the same double-double
/// difference) and its angles
/// (those of the same edges, the same ends to their rounding); without, NaN angles.
#[inline(always)]
fn with_loop<const M: usize, const N: usize, const R: usize, T>(
    x: DVec3,
    v: &[DVec3; M],
    cut: &Cut<M>,
    route: Option<&RouteLoop<R>>,
    f: impl FnOnce(&mut ClippedLoop<N>) -> T,
) -> T {
    let Cut {
        r,
        heights,
        height_error,
        above,
        ..
    } = cut;
    let exact = |k: usize| from_parts(r[k], difference_error(v[k], x));
    let mut l = ClippedLoop {
        n: cut.n,
        points: [LoopVertex {
            exact: from_parts(DVec3::ZERO, DVec3::ZERO),
            hi: r[0],
            vertex: Some(0),
            displacement: 0.0,
        }; N],
        edges: [DVec3::ZERO; N],
        angles: [f64::NAN; N],
        count: 0,
        sum: 0.0,
    };
    let mut count = 0;
    for i in 0..M {
        let j = if i + 1 == M { 0 } else { i + 1 };
        if above[i] {
            // Every vertex keeps its exact difference: a vertex next to a clip point for the edge
            // vector between them, every one for the robust terms of edges below `MIN_SINE`
            // (`lambert::clipped_derivs::robust_edge_term`), exact near the edge's line.
            l.points[count] = LoopVertex {
                exact: match route {
                    // The route's point is these parts.
                    Some(route) => {
                        let (hi, lo) = route.point(count);
                        from_parts(hi, lo)
                    }
                    None => exact(i),
                },
                hi: r[i],
                vertex: Some(i),
                displacement: 0.0,
            };
            count += 1;
        }
        if above[i] != above[j] {
            let total = heights[i] - heights[j];
            let t = heights[i] / total;
            // |t − t_exact| (module documentation, "The clip points"), 1 % for the rounding of
            // the bound itself.
            let (gi, gj) = (
                HEIGHT_ERROR * height_error[i],
                HEIGHT_ERROR * height_error[j],
            );
            let dt = 1.01 * ((gi * (1.0 - t) + gj * t) / (total.abs() - gi - gj) + 2.0 * U * t);
            let (point, hi, displacement) = match route {
                Some(route) => {
                    // Each double-double operation errs by a few u² relative: the heights by
                    // `8u²(|n|·|r_k|)` (`U·height_error` is twice that), `t` (no cancellation:
                    // the heights have opposite signs) by their errors over `|total|` and a few
                    // u², the point by a few u² of its ends' size; bounded here with margins of
                    // 2x or more.
                    let (hi, lo) = route.point(count);
                    let dt =
                        2.0 * U * (height_error[i] + height_error[j]) / total.abs() + 16.0 * U * U;
                    let size = 16.0 * U * U * (r[i].length() + r[j].length());
                    (from_parts(hi, lo), hi, dt * (v[j] - v[i]).length() + size)
                }
                None => {
                    let (ei, ej) = (exact(i), exact(j));
                    let point = ei.add(&ej.sub(&ei).scale(Dd { hi: t, lo: 0.0 }));
                    (point, point.to_dvec3(), dt * (v[j] - v[i]).length())
                }
            };
            l.points[count] = LoopVertex {
                exact: point,
                hi,
                vertex: None,
                displacement: 1.01 * displacement,
            };
            count += 1;
        }
    }
    l.count = count;
    for k in 0..count {
        let next = if k + 1 == count { 0 } else { k + 1 };
        let (a, b) = (&l.points[k], &l.points[next]);
        l.edges[k] = match (route, a.vertex, b.vertex) {
            // `edge_vector`'s first case, written out: both ends are vertices.
            (_, Some(i), Some(j)) => v[j] - v[i],
            // The route's double-double difference of the same ends, rounded once.
            (Some(route), ..) => route.edge(k),
            _ => edge_vector(v, a, b),
        };
        if let Some(route) = route {
            l.angles[k] = route.angle(k);
        }
    }
    f(&mut l)
}

/// Whether the route's loop has the points of `l` (built on it by [`with_loop`]): the same
/// count, clip points where `l` has them. The route clips on the signs of the double-double
/// heights, which agree with the cut's certain f64 signs, so this holds but for a defect.
#[inline(always)]
fn same_loop<const N: usize, const R: usize>(l: &ClippedLoop<N>, route: &RouteLoop<R>) -> bool {
    l.count == route.count()
        && (0..l.count).all(|k| route.is_clip_point(k) == l.points[k].vertex.is_none())
}

/// `f` of the certified loop (its `sum` set), `None` where the path is not tried or the value is
/// not certified.
#[inline(always)]
fn with_certified_loop<const M: usize, const N: usize, R>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
    f: impl FnOnce(&ClippedLoop<N>) -> R,
) -> Option<R> {
    debug_assert!(N > M);
    // The cheap decisions first: outside near the plane (the robust path's near-plane split) they
    // decline before the range checks, the cut and the validation.
    let r: [DVec3; M] = std::array::from_fn(|k| v[k] - x);
    if left_to_the_robust_path(newell(v), &r) {
        return None;
    }
    let (n, r) = differences(x, n, v)?;
    let cut = cut(n, &r)?;
    convex_normal(v)?;
    with_loop(
        x,
        v,
        &cut,
        None::<&RouteLoop<0>>,
        #[inline(always)]
        |l: &mut ClippedLoop<N>| {
            l.sum = certify(l)?;
            Some(f(l))
        },
    )
}

/// The value of [`polygon_form_factor`](crate::kernels::form_factor::polygon_form_factor) by
/// Lambert's sum over the clipped loop (module documentation) when the tangent plane certainly cuts
/// a strictly convex polygon of `M` (4 to 8) vertices, `x` is near its plane (below 1e-3 of the
/// size) and the error bound is within
/// [`FAST_TOLERANCE`](crate::kernels::form_factor::tolerance::FAST_TOLERANCE) of the result; `None`
/// otherwise, including when nothing is clipped and for invalid polygons (the robust path reports
/// them). `N = M + 1`, the loop's capacity. Called by
/// [`lambert::polygon`](crate::kernels::form_factor::lambert::polygon)'s entries where the polygon
/// is not certainly unclipped.
// Out of line: the loop's frame (~1 KB) stays off the kernel's other paths.
#[inline(never)]
pub(crate) fn polygon_value<const M: usize, const N: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
) -> Option<f64> {
    with_certified_loop::<M, N, _>(x, n, v, ClippedLoop::value)
}

/// What the derivative orders get from the certified loop: its derivatives (value included), or
/// only its value where the derivatives decline.
pub(crate) type Derivs = Result<Deriv3, f64>;

/// Gradient (per unit length) and Hessian (per squared length, at [`Order::Hessian`]) of
/// [`polygon_form_factor`](crate::kernels::form_factor::polygon_form_factor) over
/// [`polygon_value`]'s loop, for `order` above [`Order::Value`]: `Some(Ok(d))` with `d.value`
/// [`polygon_value`]'s bits, `Some(Err(value))` where the value is certified but the derivatives
/// decline (an ordinary edge of the loop below `sin β = 1/32`, a cancelling derivative sum, a clip
/// point too close to `x` for its displacement), `None` where [`polygon_value`] declines. Arguments
/// as there.
// Inlined into `clipped_polygon_derivs`, out of line, whose frame holds the loop: outside near the
// plane (the routed derivatives' regime) the decision where to try declines without a call of its
// own.
#[inline(always)]
pub(crate) fn polygon_derivs<const M: usize, const N: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
    order: Order,
) -> Option<Derivs> {
    with_certified_loop::<M, N, _>(x, n, v, |l| {
        let value = l.value();
        loop_derivs(l, value, order).ok_or(value)
    })
}

/// [`polygon_derivs`], or where it is not tried or its value declines, [`routed_polygon_derivs`]:
/// the derivative orders' clipped paths, in their order. Out of line, so that the caller's
/// unclipped path keeps its own frame.
#[inline(never)]
pub(crate) fn clipped_polygon_derivs<const M: usize, const N: usize, const R: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
    order: Order,
) -> Option<Derivs> {
    polygon_derivs::<M, N>(x, n, v, order)
        .or_else(|| routed_polygon_derivs::<M, N, R>(x, n, v, order))
}

/// [`polygon_derivs`] where the certified loop is not built: outside the polygon near its plane,
/// where Lambert's sum cancels and the value order takes the robust path's near-plane split
/// ([`near_plane::polygon::polygon_value`],
/// the robust bits). With that route's value (so the value order's bits), the derivatives of the
/// loop [`with_loop`] builds on the same cut as the certified path, with the route's double-double
/// clip points, edge vectors and angles (the loop's points on the polygon's edge lines with their
/// displacement bounds; the derivatives' accuracy argument, `lambert::clipped_derivs`, needs only
/// these, not the certified value), oriented by the sign of the route's exact height `h_P` as the
/// robust edge sum is. `Some(Err(value))` where the derivatives decline (or no vertex is certainly
/// below the tangent plane), `None` where the route declines. `N = M + 1` (the loop), `R = 2M` (the
/// route's clipped loop).
#[inline(never)]
pub(crate) fn routed_polygon_derivs<const M: usize, const N: usize, const R: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
    order: Order,
) -> Option<Derivs> {
    let mut route = RouteLoop::<R>::new();
    // The far-field rule's value is summed with its derivatives (`deferred_far_piece`; where
    // that value is not finite the route declined before, and does here).
    route.defer_far = true;
    let (value, h_p, n, r) =
        near_plane::polygon::clipped_polygon_value_and_loop::<M, R>(x, n, v, &mut route)?;
    if route.is_far() {
        return deferred_far_piece(&route, order);
    }
    // The route's unit normal and differences are those `differences` forms; their range is
    // checked as there.
    if !r.iter().all(|rk| in_range(*rk)) {
        return Some(Err(value));
    }
    let (Some(cut), false) = (cut(n, &r), h_p == 0.0) else {
        return Some(Err(value));
    };
    Some(with_loop(
        x,
        v,
        &cut,
        Some(&route),
        #[inline(always)]
        |l: &mut ClippedLoop<N>| {
            if !same_loop(l, &route) {
                return Err(value);
            }
            l.sum = h_p.signum();
            // The route's clip points are the exact crossings to ~u²: their displacement is
            // their rounding to f64, charged at its bound `u` (module documentation,
            // "Derivatives").
            loop_derivs_charging(l, value, order, U).ok_or(value)
        },
    ))
}

/// The unit normal and the differences `r_k = v_k − x`, each in
/// [`validate::in_range`](crate::kernels::form_factor::validate::in_range), as
/// [`lambert::sum::unclipped`](crate::kernels::form_factor::lambert::sum::unclipped) checks them;
/// `None` otherwise.
#[inline(always)]
pub(crate) fn differences<const M: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
) -> Option<(DVec3, [DVec3; M])> {
    let r: [DVec3; M] = std::array::from_fn(|k| v[k] - x);
    if !r.iter().all(|rk| in_range(*rk)) {
        return None;
    }
    Some((unit(n)?, r))
}

#[cfg(test)]
mod tests;
