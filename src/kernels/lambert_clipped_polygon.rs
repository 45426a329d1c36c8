//! Certified fast path of [`polygon_form_factor`](super::polygon_form_factor) when the receiver's
//! tangent plane cuts a strictly convex polygon of 4 to 8 vertices and `x` is near the polygon's
//! plane: Lambert's sum over the clipped loop with [`lambert_clipped`](super::lambert_clipped)'s
//! running error bound, and the derivatives of that loop
//! ([`lambert_clipped_derivs`](super::lambert_clipped_derivs)).
//!
//! Near the plane (`x` within 1e-3 of the size) the robust path's exact geometry (validation,
//! exact clip, near-plane split, edge sum) costs 4.5-5.5x the unclipped polygon's Lambert sum;
//! the clipped loop needs only the loop and Lambert's per-edge terms. Measured by callgrind on
//! `benches/kernels_regimes.rs` (instructions per call, value / gradient / Hessian, robust path
//! → this path): quad 1e-6 above the plane 7783 / 10271 / 10867 → 3433 / 4425 / 5235, pentagon
//! 9099 / 9759 / 10355 → 3611 / 4618 / 5429 (docs/kernels.md, "Hard regimes").
//!
//! **What is certified.** The polygon must be one that
//! [`lambert_polygon`](super::lambert_polygon) would take unclipped (strictly convex, planar to a
//! quarter of the robust tolerance, not a sliver, every edge and turn with a 1e-3 margin:
//! `convex_normal`), so that the robust path accepts it and its visible part is one convex loop.
//! Every vertex must be certainly above or below the tangent plane (`|n·r_k|` beyond
//! `16u(|n|·|r_k|)`, as for the triangle) and the vertices above must be one run (exactly two
//! sign changes around the polygon; a planar convex polygon has at most two, so more means the
//! polygon's slight non-planarity decides, and the path declines). The loop is then the run of
//! kept vertices, the crossing of the edge leaving the run, the crossing of the edge entering it
//! and the clip edge between the two: at most `M + 1` points.
//!
//! **The error bound for `M` edges** is the triangle's argument (`lambert_clipped`'s module
//! documentation), which uses nothing of the triangle but these facts, all true here:
//! (i) each loop vertex is the f64 rounding of a point exactly on a polygon edge's line (a vertex
//! `r_k`, or a clip point `R_i + t(R_j − R_i)` formed in double-double from the exact differences
//! `R_k = v_k − x` to ~u²), displaced along that edge by at most `δ ≤ δt‖E‖` from the exact clip
//! point, with `δt` bounded from the heights' error bounds as for the triangle; (ii) each loop edge
//! vector is one rounding of the exact difference of its ends (`v_j − v_i` between two polygon
//! vertices, the double-double difference where an end is a clip point): Lambert's input model,
//! so every ordinary edge's term errs by at most `u(36β + 20|r_a·e|g)` (`lambert.rs`); (iii)
//! exactly two clip points, adjacent in the loop, so there is one clip edge, whose term `±β` and
//! bound `u(6‖e‖/‖r_b‖ + 7 + 2β)` are those of a segment in the tangent plane, and the region the
//! loop bounds differs from the exact visible part by the same two thin triangles along the clip
//! line (`2π|ΔF| ≤ 8δ²/ρ²`) plus the clip edge's tilt (`βθ²/2`, `θ ≤ 2δ/ρ`). Summing the
//! `m ≤ M + 1` terms adds `(m − 1)u Σ|f_k|`, renormalizing `n` and the final scaling `3u Σ|f_k|`:
//! the bound is `u(Σ err_k + (m + 2)Σ|f_k|)` plus the two second-order terms, the triangle's
//! formula with `m` the loop's length, accepted within [`FAST_TOLERANCE`](super::lambert::FAST_TOLERANCE)
//! of the result. The polygon's planarity within `2.5e-9` of its extent does not enter: the loop's
//! edges are the polygon's edges (or parts of them, on their lines) and the clip edge, as the
//! robust path clips them; only the clip line's Hessian term uses a plane, and that of a
//! polygon planar to 2.5e-9 moves it by that relatively at most (far below `δ/ρ`'s effect, and
//! the derivatives' tolerance is 1e-12 relative to their largest entry against the robust
//! path's 1e-8 planarity).
//!
//! **Where it is tried**: as for the triangle (`lambert_clipped::left_to_the_robust_path`), only
//! below 1e-3 of the size from the plane (`|N·r_0| < 1e-3‖N‖ max‖r_k‖`, `N` Newell's normal),
//! not within a sine of 1e-3 of an edge's segment (`β > π/2`, where Lambert's bound grows like
//! `1/sin β`), and not below 1e-4 of the size outside the polygon (the sum cancels: the robust
//! path's near-plane split, which `polygon/near_plane_polygon.rs` replays for the value with the
//! robust bits; the derivative orders there take that value and the derivatives of the route's
//! loop, [`routed_polygon_derivs`]). It declines within ~1e-9 of the clip line and wherever
//! the bound fails.
//!
//! **Derivatives**: those of the same loop, with the triangle's acceptance rules (Lambert's terms
//! down to `sin β = 1/32` with their error growth charged in the cancellation test, the robust
//! path's moments below, the sums cancelling by at most 1e5, the clip points' displacement within
//! 1e-11 of the result): `lambert_clipped_derivs`' argument is per edge and holds for any number
//! of them. The route's clip points are the exact crossings to ~u², so their displacement is their
//! rounding to f64, charged at its bound `u` (the triangle charges `2u` for its 1e-12): over the
//! benchmark's outside mix (`RADDIFF_REGIMES_MIX`, 3000 calls) the robust path then runs for 16
//! calls instead of 30 (the rest cancel beyond 1e5, or move beyond the tolerance even at `u`),
//! and the derivatives agree with the 320-bit reference within 3.0e-12 (gradient; measured
//! over the mix by a temporary test), against the regime's 1e-9 (the worst before was the robust
//! path's 2.8e-12). Where the route found the visible part far-field, the derivative orders take
//! its far-field rule instead ([`deferred_far_piece`](super::polygon::deferred_far_piece)). The
//! value of a derivative order is the certified value, bit for bit (the same loop and sum).

use glam::DVec3;

use super::lambert;
use super::lambert_clipped::{
    certify, difference_error, edge_vector, from_parts, ClippedLoop, LoopVertex,
};
use super::lambert_clipped_derivs::{loop_derivs, loop_derivs_charging};
use super::lambert_polygon::convex_normal;
use super::numeric::dd::Dd;
use super::polygon::{deferred_far_piece, near_plane_clipped_polygon_value_and_loop, RouteLoop};
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
fn newell<const M: usize>(v: &[DVec3; M]) -> DVec3 {
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
            // (`lambert_clipped_derivs::robust_edge_term`), exact near the edge's line.
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
            // Written out: the call (`edge_vector`'s first case) cost ~40 instructions per edge.
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
    // The cheap decisions first: outside near the plane (the robust path's near-plane split)
    // they decline before the range checks, the cut and the validation (~50, ~150 and ~300
    // instructions for a quad).
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

/// The value of [`polygon_form_factor`](super::polygon_form_factor) by Lambert's sum over the
/// clipped loop (module documentation) when the tangent plane certainly cuts a strictly convex
/// polygon of `M` (4 to 8) vertices, `x` is near its plane (below 1e-3 of the size) and the
/// error bound is within [`FAST_TOLERANCE`](super::lambert::FAST_TOLERANCE) of the result;
/// `None` otherwise, including when nothing is clipped and for invalid polygons (the robust path
/// reports them). `N = M + 1`, the loop's capacity. Called by
/// [`lambert_polygon`](super::lambert_polygon)'s entries where the polygon is not certainly
/// unclipped.
// Out of line: the loop's frame (~1 KB) stays off the kernel's other paths.
#[inline(never)]
pub(super) fn polygon_value<const M: usize, const N: usize>(
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
/// [`polygon_form_factor`](super::polygon_form_factor) over [`polygon_value`]'s loop, for `order`
/// above [`Order::Value`]: `Some(Ok(d))` with `d.value` [`polygon_value`]'s bits,
/// `Some(Err(value))` where the value is certified but the derivatives decline (an ordinary edge
/// of the loop below `sin β = 1/32`, a cancelling derivative sum, a clip point too close to `x`
/// for its displacement), `None` where [`polygon_value`] declines. Arguments as there.
// Inlined into `clipped_polygon_derivs`, out of line, whose frame holds the loop: outside near
// the plane (the routed derivatives' regime) the decision where to try declines without a call
// of its own (~30 instructions).
#[inline(always)]
pub(super) fn polygon_derivs<const M: usize, const N: usize>(
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

/// [`polygon_derivs`], or where it is not tried or its value declines,
/// [`routed_polygon_derivs`]: the derivative orders' clipped paths, in their order. Out of line,
/// so that the caller's unclipped path keeps its own frame (with the certified loop's decision
/// inlined there the generic mix cost ~25 instructions more per call, callgrind).
#[inline(never)]
pub(super) fn clipped_polygon_derivs<const M: usize, const N: usize, const R: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
    order: Order,
) -> Option<Derivs> {
    polygon_derivs::<M, N>(x, n, v, order)
        .or_else(|| routed_polygon_derivs::<M, N, R>(x, n, v, order))
}

/// [`polygon_derivs`] where the certified loop is not built: outside the polygon near its
/// plane, where Lambert's sum cancels and the value order takes the robust path's near-plane
/// split ([`near_plane_polygon_value`](super::polygon::near_plane_polygon_value), the robust
/// bits). With that route's value (so the value order's bits), the derivatives of the loop
/// [`with_loop`] builds on the same cut as the certified path, with the route's double-double
/// clip points, edge vectors and angles (the loop's points on the polygon's edge
/// lines with their displacement bounds; the derivatives' accuracy argument,
/// `lambert_clipped_derivs`, needs only these, not the certified value), oriented by the sign of
/// the route's exact height `h_P` as the robust edge sum is. `Some(Err(value))` where the
/// derivatives decline (or no vertex is certainly below the tangent plane), `None` where the
/// route declines. `N = M + 1` (the loop), `R = 2M` (the route's clipped loop).
#[inline(never)]
pub(super) fn routed_polygon_derivs<const M: usize, const N: usize, const R: usize>(
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
        near_plane_clipped_polygon_value_and_loop::<M, R>(x, n, v, &mut route)?;
    if route.is_far() {
        return deferred_far_piece(&route, order);
    }
    // The route's unit normal and differences are those `differences` forms; their range is
    // checked as there.
    if !r.iter().all(|rk| lambert::in_range(*rk)) {
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

/// The unit normal and the differences `r_k = v_k − x`, each in [`lambert::in_range`], as
/// [`lambert::unclipped`] checks them; `None` otherwise.
#[inline(always)]
fn differences<const M: usize>(x: DVec3, n: DVec3, v: &[DVec3; M]) -> Option<(DVec3, [DVec3; M])> {
    let r: [DVec3; M] = std::array::from_fn(|k| v[k] - x);
    if !r.iter().all(|rk| lambert::in_range(*rk)) {
        return None;
    }
    Some((lambert::unit(n)?, r))
}

/// [`polygon_value`] for 4 to 8 vertices from `x`, `n` and the vertices (the tests' entry).
#[cfg(test)]
fn value_of(x: DVec3, n: DVec3, v: &[DVec3]) -> Option<f64> {
    fn at<const M: usize, const N: usize>(x: DVec3, n: DVec3, v: &[DVec3]) -> Option<f64> {
        polygon_value::<M, N>(x, n, v.try_into().ok()?)
    }
    match v.len() {
        4 => at::<4, 5>(x, n, v),
        5 => at::<5, 6>(x, n, v),
        6 => at::<6, 7>(x, n, v),
        7 => at::<7, 8>(x, n, v),
        8 => at::<8, 9>(x, n, v),
        _ => None,
    }
}

/// [`polygon_derivs`] for 4 to 8 vertices (the tests' entry).
#[cfg(test)]
fn derivs_of(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Option<Derivs> {
    fn at<const M: usize, const N: usize>(
        x: DVec3,
        n: DVec3,
        v: &[DVec3],
        order: Order,
    ) -> Option<Derivs> {
        polygon_derivs::<M, N>(x, n, v.try_into().ok()?, order)
    }
    match v.len() {
        4 => at::<4, 5>(x, n, v, order),
        5 => at::<5, 6>(x, n, v, order),
        6 => at::<6, 7>(x, n, v, order),
        7 => at::<7, 8>(x, n, v, order),
        8 => at::<8, 9>(x, n, v, order),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::{polygon, polygon_form_factor};
    use crate::test_rng::lcg;
    use glam::DMat3;

    /// A random strictly convex polygon of `m` vertices and size `scale`: jittered angles on an
    /// ellipse (axes 0.5-1) in a plane tilted up to ~17° from z = 0.3·scale; its unit normal.
    fn random_convex(state: &mut u64, m: usize, scale: f64) -> (Vec<DVec3>, DVec3) {
        let tilt = DVec3::new(0.6 * (lcg(state) - 0.5), 0.6 * (lcg(state) - 0.5), 1.0);
        let normal = tilt.normalize();
        let u = normal.any_orthonormal_vector();
        let w = normal.cross(u);
        let (a, b) = (0.5 + 0.5 * lcg(state), 0.5 + 0.5 * lcg(state));
        let centre = DVec3::new(lcg(state) - 0.5, lcg(state) - 0.5, 0.3) * scale;
        let v = (0..m)
            .map(|k| {
                let phi = std::f64::consts::TAU * (k as f64 + 0.6 * (lcg(state) - 0.5)) / m as f64;
                centre + (u * (a * phi.cos()) + w * (b * phi.sin())) * scale
            })
            .collect();
        (v, normal)
    }

    /// A receiver normal tilted 10°-80° from `plane_n` (on `x`'s side), about a random axis.
    fn tilted(state: &mut u64, plane_n: DVec3) -> DVec3 {
        let tilt = (10.0 + 70.0 * lcg(state)).to_radians();
        let t = plane_n.any_orthonormal_vector();
        let phi = 6.3 * lcg(state);
        let t = t * phi.cos() + plane_n.cross(t) * phi.sin();
        (plane_n * tilt.cos() + t * tilt.sin()).normalize()
    }

    fn robust(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Deriv3 {
        polygon::form_factor(x, n, v, order).unwrap()
    }

    /// Max-norm errors of the gradient and Hessian, each relative to the reference's largest entry.
    fn rel(d: &Deriv3, r: &Deriv3) -> (f64, f64) {
        let hm = |m: DMat3| m.to_cols_array().iter().fold(0.0f64, |s, e| s.max(e.abs()));
        (
            (d.gradient - r.gradient).abs().max_element() / r.gradient.abs().max_element(),
            hm(d.hessian - r.hessian) / hm(r.hessian),
        )
    }

    /// Random clipped convex quads, pentagons, hexagons and octagons of sizes 1e-3 to 1e3, `x` 1 to
    /// 1e-9 sizes above or below a point of the polygon (or of its plane within 0.3 of the size
    /// beyond it): wherever the value is certified it agrees with the robust (exact-clip) path
    /// within 1e-12, wherever the derivatives are accepted they agree within 1e-12 (gradient) and
    /// 1e-10 (Hessian) of their largest entry, and the public kernel returns exactly these, the
    /// value order's bits at every order. At least 95 % of the configurations 1e-7 to 1e-4 sizes
    /// above the interior (away from the edges, `F > 0.05`) are certified, and at least 60 % of
    /// those have their derivatives accepted.
    #[test]
    fn clipped_convex_polygons_agree_with_the_robust_path() {
        let mut state = 3;
        let (mut tried, mut certified, mut derived) = (0, 0, 0);
        let (mut worst, mut worst_g, mut worst_h) = (0.0f64, 0.0f64, 0.0f64);
        for k in 0..6000 {
            let scale = [1e-3, 1.0, 1e3][k % 3];
            let m = [4, 5, 6, 8][(k / 3) % 4];
            let (v, plane_n) = random_convex(&mut state, m, scale);
            let centroid = v.iter().sum::<DVec3>() / m as f64;
            // Inside (towards the centroid from a vertex) or up to 0.3 beyond it.
            let (p, q) = (lcg(&mut state), 1.3 * lcg(&mut state));
            let foot = centroid + (v[(k / 12) % m] - centroid) * q * (0.2 + 0.8 * p);
            let side = if lcg(&mut state) < 0.5 { 1.0 } else { -1.0 };
            let height = scale * 10f64.powf(-9.0 * lcg(&mut state));
            let x = foot + plane_n * (side * height);
            let n = tilted(&mut state, plane_n * side);
            if !v.iter().any(|vk| n.dot(*vk - x) < 0.0) {
                continue;
            }
            let away = q * (0.2 + 0.8 * p) < 0.8
                && height >= 1e-7 * scale
                && height < 1e-4 * scale
                && robust(x, n, &v, Order::Value).value > 0.05;
            tried += usize::from(away);
            let Some(f) = value_of(x, n, &v) else {
                assert!(derivs_of(x, n, &v, Order::Hessian).is_none());
                continue;
            };
            certified += usize::from(away);
            let want = robust(x, n, &v, Order::Value).value;
            let e = (f - want).abs() / want;
            worst = worst.max(e);
            assert!(e <= 1e-12, "{k}: {f:e} vs {want:e} at {x:?} {n:?} {v:?}");
            assert_eq!(
                polygon_form_factor(x, n, &v, Order::Value).unwrap().value,
                f
            );
            for order in [Order::Gradient, Order::Hessian] {
                let public = polygon_form_factor(x, n, &v, order).unwrap();
                assert_eq!(public.value.to_bits(), f.to_bits(), "{k} {order:?}");
                match derivs_of(x, n, &v, order) {
                    Some(Ok(d)) => {
                        assert_eq!(public, d, "{k} {order:?}");
                        let (g, h) = rel(&d, &robust(x, n, &v, order));
                        let h = if order.hessian() { h } else { 0.0 };
                        worst_g = worst_g.max(g);
                        worst_h = worst_h.max(h);
                        assert!(
                            g < 1e-11 && h < 1e-10,
                            "{k}: {g:e} {h:e} at {x:?} {n:?} {v:?}"
                        );
                        derived += usize::from(away && order.hessian());
                    }
                    Some(Err(value)) => assert_eq!(value.to_bits(), f.to_bits()),
                    None => panic!("{k}: the value is certified, the derivative loop is not"),
                }
            }
        }
        println!(
            "clipped polygons 1e-7 to 1e-4 sizes above the interior: {certified} of {tried} \
             certified, {derived} with derivatives; worst vs robust: value {worst:e}, gradient \
             {worst_g:e}, Hessian {worst_h:e}"
        );
        assert!(tried > 500, "{tried}");
        assert!(certified * 100 >= tried * 95, "{certified} of {tried}");
        assert!(derived * 10 >= certified * 6, "{derived} of {certified}");
    }

    /// The quad and pentagon of `benches/kernels_regimes.rs`, 1e-6 above the plane: taken at every
    /// order.
    #[test]
    fn the_benchmarked_cases_are_taken() {
        let quad: Vec<DVec3> = [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
            .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
            .to_vec();
        let pentagon: Vec<DVec3> = (0..5)
            .map(|i| {
                let phi = std::f64::consts::TAU * i as f64 / 5.0;
                DVec3::new(phi.cos(), phi.sin(), 1.2 + 0.3 * phi.sin())
            })
            .collect();
        for v in [quad, pentagon] {
            let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            let x = v.iter().sum::<DVec3>() / v.len() as f64 - plane_n * 1e-6;
            let n = DVec3::new(0.1, -0.2, 1.0).normalize();
            assert!(v.iter().any(|vk| n.dot(*vk - x) < 0.0));
            let f = value_of(x, n, &v).expect("value declined");
            for order in [Order::Gradient, Order::Hessian] {
                let d = derivs_of(x, n, &v, order).unwrap().expect("declined");
                assert_eq!(d.value, f);
                let (g, h) = rel(&d, &robust(x, n, &v, order));
                let h = if order.hessian() { h } else { 0.0 };
                assert!(g < 1e-13 && h < 1e-12, "{g:e} {h:e}");
            }
        }
    }

    /// Central differences (Richardson-extrapolated, steps 1e-3 and 5e-4 of the height) of the
    /// certified value and of the fast gradient, `x` 1e-3.5 sizes above a clipped quad and
    /// hexagon: within 1e-7 of the largest entry (truncation ~(step/height)⁴).
    #[test]
    fn derivatives_agree_with_central_differences() {
        let mut state = 17;
        for m in [4, 6] {
            let (v, plane_n) = random_convex(&mut state, m, 1.0);
            let centroid = v.iter().sum::<DVec3>() / m as f64;
            let height = 10f64.powf(-3.5);
            let x = centroid + (v[0] - centroid) * 0.3 + plane_n * height;
            let n = (plane_n + plane_n.any_orthonormal_vector()).normalize();
            let d = derivs_of(x, n, &v, Order::Hessian).unwrap().unwrap();
            let f = |p: DVec3| value_of(p, n, &v).unwrap();
            let g = |p: DVec3| derivs_of(p, n, &v, Order::Gradient).unwrap().unwrap();
            let central = |h: f64, i: usize| {
                let dx = DVec3::AXES[i] * h;
                let df = (f(x + dx) - f(x - dx)) / (2.0 * h);
                let dg = (g(x + dx).gradient - g(x - dx).gradient) / (2.0 * h);
                (df, dg)
            };
            let g_scale = d.gradient.abs().max_element();
            let h_scale = d
                .hessian
                .to_cols_array()
                .iter()
                .fold(0.0f64, |s, e| s.max(e.abs()));
            for i in 0..3 {
                let (f1, g1) = central(1e-3 * height, i);
                let (f2, g2) = central(5e-4 * height, i);
                let fd = (4.0 * f2 - f1) / 3.0;
                let col = (g2 * 4.0 - g1) / 3.0;
                let eg = (fd - d.gradient[i]).abs() / g_scale;
                let eh = (col - d.hessian.col(i)).abs().max_element() / h_scale;
                assert!(eg < 1e-7 && eh < 1e-7, "m = {m}, axis {i}: {eg:e} {eh:e}");
            }
        }
    }

    /// [`routed_polygon_derivs`] for 4 to 8 vertices (the tests' entry).
    fn routed_of(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Option<Derivs> {
        fn at<const M: usize, const N: usize, const R: usize>(
            x: DVec3,
            n: DVec3,
            v: &[DVec3],
            order: Order,
        ) -> Option<Derivs> {
            routed_polygon_derivs::<M, N, R>(x, n, v.try_into().ok()?, order)
        }
        match v.len() {
            4 => at::<4, 5, 8>(x, n, v, order),
            5 => at::<5, 6, 10>(x, n, v, order),
            6 => at::<6, 7, 12>(x, n, v, order),
            8 => at::<8, 9, 16>(x, n, v, order),
            _ => None,
        }
    }

    /// Random clipped convex quads, pentagons, hexagons and octagons of sizes 1e-3 to 1e3, `x`
    /// 1e-3 to 1e-9 sizes from the plane over a point 0.1-1 sizes beyond a vertex (outside):
    /// wherever the routed loop's derivatives are accepted they agree with the robust path within
    /// 1e-11 (gradient) and 1e-10 (Hessian) of its largest entry (the loop keeps a few `u` times its
    /// sums' cancellation, up to `LOOP_CANCELLATION` = 1e5: ~1e-11), their value is the value order's
    /// bits, and the public kernel returns exactly them; they are accepted in at least half of the
    /// configurations where the route answers.
    #[test]
    fn routed_derivatives_agree_with_the_robust_path() {
        let mut state = 11;
        let (mut routed, mut derived) = (0, 0);
        let (mut worst_g, mut worst_h) = (0.0f64, 0.0f64);
        for k in 0..6000 {
            let scale = [1e-3, 1.0, 1e3][k % 3];
            let m = [4, 5, 6, 8][(k / 3) % 4];
            let (v, plane_n) = random_convex(&mut state, m, scale);
            let centroid = v.iter().sum::<DVec3>() / m as f64;
            let beyond = 1.1 + lcg(&mut state);
            let foot = centroid + (v[(k / 12) % m] - centroid) * beyond;
            let side = if lcg(&mut state) < 0.5 { 1.0 } else { -1.0 };
            let height = scale * 10f64.powf(-3.0 - 6.0 * lcg(&mut state));
            let x = foot + plane_n * (side * height);
            let n = tilted(&mut state, plane_n * side);
            let value = polygon_form_factor(x, n, &v, Order::Value).unwrap().value;
            for order in [Order::Gradient, Order::Hessian] {
                let Some(d) = routed_of(x, n, &v, order) else {
                    continue;
                };
                routed += usize::from(order.hessian());
                let public = polygon_form_factor(x, n, &v, order).unwrap();
                assert_eq!(public.value.to_bits(), value.to_bits(), "{k} {order:?}");
                match d {
                    Ok(d) => {
                        assert_eq!(public, d, "{k} {order:?}");
                        let (g, h) = rel(&d, &robust(x, n, &v, order));
                        let h = if order.hessian() { h } else { 0.0 };
                        worst_g = worst_g.max(g);
                        worst_h = worst_h.max(h);
                        assert!(
                            g < 1e-11 && h < 1e-10,
                            "{k}: {g:e} {h:e} at {x:?} {n:?} {v:?}"
                        );
                        derived += usize::from(order.hessian());
                    }
                    Err(f) => assert_eq!(f.to_bits(), value.to_bits(), "{k}"),
                }
            }
        }
        println!(
            "outside near the plane: route {routed}, derivatives {derived}; worst vs robust: \
             gradient {worst_g:e}, Hessian {worst_h:e}"
        );
        assert!(routed > 1000, "{routed}");
        assert!(derived * 2 >= routed, "{derived} of {routed}");
    }

    /// The quad and pentagon of `benches/kernels_regimes.rs` 1e-6 from the plane outside: the
    /// routed derivatives are taken, agree with the robust path, and with central differences
    /// (Richardson-extrapolated, steps 1e-3 and 5e-4 of the height) of the value order and of
    /// their own gradient within 1e-6 of the largest entry.
    #[test]
    fn the_benchmarked_outside_cases_are_routed() {
        let quad: Vec<DVec3> = [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
            .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
            .to_vec();
        let pentagon: Vec<DVec3> = (0..5)
            .map(|i| {
                let phi = std::f64::consts::TAU * i as f64 / 5.0;
                DVec3::new(phi.cos(), phi.sin(), 1.2 + 0.3 * phi.sin())
            })
            .collect();
        for (v, edge) in [(quad, 0), (pentagon, 1)] {
            let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            let centroid = v.iter().sum::<DVec3>() / v.len() as f64;
            let mid = (v[edge] + v[(edge + 1) % v.len()]) * 0.5;
            let height = 1e-6;
            let x = mid + (mid - centroid) * 0.2 - plane_n * height;
            let normal = DVec3::new(0.1, -0.2, 1.0).normalize();
            let n = if (v[0] - x).dot(normal) > 0.0 {
                normal
            } else {
                -normal
            };
            let d = routed_of(x, n, &v, Order::Hessian)
                .unwrap()
                .expect("declined");
            let (g, h) = rel(&d, &robust(x, n, &v, Order::Hessian));
            assert!(g < 1e-12 && h < 1e-10, "{g:e} {h:e}");
            let f = |p: DVec3| polygon_form_factor(p, n, &v, Order::Value).unwrap().value;
            let grad = |p: DVec3| routed_of(p, n, &v, Order::Gradient).unwrap().unwrap();
            let central = |step: f64, i: usize| {
                let dx = DVec3::AXES[i] * step;
                let df = (f(x + dx) - f(x - dx)) / (2.0 * step);
                let dg = (grad(x + dx).gradient - grad(x - dx).gradient) / (2.0 * step);
                (df, dg)
            };
            let g_scale = d.gradient.abs().max_element();
            let h_scale = d
                .hessian
                .to_cols_array()
                .iter()
                .fold(0.0f64, |s, e| s.max(e.abs()));
            for i in 0..3 {
                let (f1, g1) = central(1e-3 * height, i);
                let (f2, g2) = central(5e-4 * height, i);
                let eg = ((4.0 * f2 - f1) / 3.0 - d.gradient[i]).abs() / g_scale;
                let eh = ((g2 * 4.0 - g1) / 3.0 - d.hessian.col(i))
                    .abs()
                    .max_element()
                    / h_scale;
                assert!(eg < 1e-6 && eh < 1e-6, "axis {i}: {eg:e} {eh:e}");
            }
        }
    }

    /// Outside-near-plane configurations whose visible part is far-field against its size (a
    /// small corner cut off, seen from 1.05-3 radii), triangles, quads and pentagons: the route
    /// takes the robust path's far-field rule on its loop for the value and the derivative orders
    /// its derivatives, the robust bits (value) and within 1e-14 of them (derivatives; the robust
    /// path works on coordinates scaled by a power of two), at every order, through the public
    /// entries.
    #[test]
    fn far_field_corners_take_the_rule_on_the_route() {
        let mut state = 5;
        let mut far = [0; 3];
        let mut tried = 0;
        while far.iter().any(|&f| f < 30) {
            tried += 1;
            assert!(tried < 200_000, "{far:?} far corners");
            let m = 3 + (lcg(&mut state) * 3.0) as usize;
            let v: Vec<DVec3> = (0..m)
                .map(|k| {
                    let a = (k as f64 + 0.3 * lcg(&mut state)) / m as f64 * std::f64::consts::TAU;
                    DVec3::new(a.cos(), a.sin(), 0.0)
                })
                .collect();
            let angle = lcg(&mut state) * std::f64::consts::TAU;
            let distance = 1.05 + 2.0 * lcg(&mut state);
            let h = if lcg(&mut state) < 0.5 { 1e-6 } else { -1e-6 };
            let x = DVec3::new(distance * angle.cos(), distance * angle.sin(), h);
            let n = DVec3::new(
                lcg(&mut state) - 0.5,
                lcg(&mut state) - 0.5,
                lcg(&mut state) - 0.5,
            )
            .normalize();
            let value = match m {
                3 => {
                    let mut route = RouteLoop::<4>::new();
                    let t = [v[0], v[1], v[2]];
                    // The triangle route takes the unit normal as `lambert::unit` divides it.
                    let unit = lambert::unit(n).unwrap();
                    crate::kernels::polygon::near_plane_clipped_triangle_value_and_loop(
                        x, unit, t, &mut route,
                    )
                    .filter(|_| route.is_far())
                }
                _ => {
                    let mut route = RouteLoop::<10>::new();
                    let value = match m {
                        4 => near_plane_clipped_polygon_value_and_loop::<4, 10>(
                            x,
                            n,
                            v[..].try_into().unwrap(),
                            &mut route,
                        )
                        .map(|(value, ..)| value),
                        _ => near_plane_clipped_polygon_value_and_loop::<5, 10>(
                            x,
                            n,
                            v[..].try_into().unwrap(),
                            &mut route,
                        )
                        .map(|(value, ..)| value),
                    };
                    value.filter(|_| route.is_far())
                }
            };
            let Some(value) = value else {
                continue;
            };
            far[m - 3] += 1;
            for order in [Order::Value, Order::Gradient, Order::Hessian] {
                let got = match m {
                    3 => crate::kernels::triangle_form_factor(x, n, v[0], v[1], v[2], order),
                    _ => polygon_form_factor(x, n, &v, order),
                }
                .unwrap();
                let want = robust(x, n, &v, order);
                assert_eq!(got.value.to_bits(), value.to_bits(), "{order:?}");
                assert_eq!(got.value.to_bits(), want.value.to_bits(), "{order:?}");
                if order != Order::Value {
                    if m > 3 {
                        assert_eq!(routed_of(x, n, &v, order).unwrap(), Ok(got));
                    }
                    let (g, eh) = rel(&got, &want);
                    let eh = if order.hessian() { eh } else { 0.0 };
                    assert!(g < 1e-14 && eh < 1e-14, "{m} {order:?}: {g:e} {eh:e}");
                }
            }
        }
        println!("{far:?} far-field corners (3, 4, 5 vertices) in {tried} configurations");
    }

    /// `x` outside a unit square `h` from its plane and `t` from the line of its edge (0,0)→(1,0),
    /// beyond the edge's end: the edge subtends `sin β ≈ 1.3 t`, below the loop's floor for
    /// Lambert's terms (`MIN_SINE` = 1/32) from `t` = 2e-2 down, so its term is the robust path's
    /// (from the ends' exact differences below `t` ≈ 5e-3): the derivatives are taken (the route
    /// answers down to `t` = 10 `h`, below which the near-plane split declines), agree with the
    /// robust path, and with central differences of the value order.
    #[test]
    fn edges_below_the_sine_floor_take_the_robust_term() {
        const MIN_SINE_OF_THE_LOOP: f64 = 1.0 / 32.0;
        let square = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
            .map(|(x, y)| DVec3::new(x, y, 0.0))
            .to_vec();
        let mut worst = (0.0f64, 0.0f64);
        for (t, h) in [(2e-2, 1e-6), (1e-3, 1e-6), (1e-4, 1e-6), (1e-7, 1e-9)] {
            for side in [1.0, -1.0] {
                let x = DVec3::new(-0.5, t, side * h);
                // The tangent plane cuts the edges at x = 0 and x = 1: (0,0)→(1,0) is an ordinary
                // edge of the loop.
                let n = DVec3::new(0.3, -1.0, 0.2 * side).normalize();
                let (ra, rb) = (square[0] - x, square[1] - x);
                let sine = ra.cross(rb).length() / (ra.length() * rb.length());
                assert!(sine < MIN_SINE_OF_THE_LOOP, "{t:e}: {sine}");
                for order in [Order::Gradient, Order::Hessian] {
                    let d = routed_of(x, n, &square, order)
                        .unwrap_or_else(|| panic!("not routed at {t:e} {side}"))
                        .unwrap_or_else(|_| panic!("declined at {t:e} {side} {order:?}"));
                    assert_eq!(polygon_form_factor(x, n, &square, order).unwrap(), d);
                    let (g, eh) = rel(&d, &robust(x, n, &square, order));
                    let eh = if order.hessian() { eh } else { 0.0 };
                    worst = (worst.0.max(g), worst.1.max(eh));
                    assert!(g < 1e-13 && eh < 1e-13, "{t:e} {side}: {g:e} {eh:e}");
                    let f = |p: DVec3| polygon_form_factor(p, n, &square, Order::Value).unwrap();
                    let step = 1e-3 * h;
                    for i in 0..3 {
                        let dx = DVec3::AXES[i] * step;
                        let central = (f(x + dx).value - f(x - dx).value) / (2.0 * step);
                        let e = (central - d.gradient[i]).abs() / d.gradient.abs().max_element();
                        assert!(e < 1e-5, "{t:e} {side} axis {i}: {e:e}");
                    }
                }
            }
        }
        println!(
            "edges below the sine floor: worst vs robust {:e} / {:e}",
            worst.0, worst.1
        );
    }

    /// Declines what the robust path must judge or where the bound fails: far from the plane, on
    /// and near the clip line, outside near the plane (the sum cancels), near an edge's line,
    /// non-convex or non-planar polygons, a clip line through a vertex's rounding, everything or
    /// nothing clipped, invalid input.
    #[test]
    fn declines_outside_its_regime() {
        let quad: Vec<DVec3> = [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
            .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
            .to_vec();
        let plane_n = (quad[1] - quad[0]).cross(quad[2] - quad[0]).normalize();
        let centroid = quad.iter().sum::<DVec3>() / 4.0;
        let n = (plane_n + plane_n.any_orthonormal_vector()).normalize();
        let above = |h: f64| centroid + plane_n * h;
        assert!(value_of(above(1e-6), n, &quad).is_some());
        // Walking x onto the clip line (through x's foot): certified near, declined from some
        // distance on, never certified again.
        let (mut certified, mut declined) = (false, false);
        for k in 4..=18 {
            let x = above(10f64.powi(-k));
            match value_of(x, n, &quad) {
                Some(f) => {
                    assert!(!declined, "certified again at 1e-{k}");
                    certified = true;
                    let want = robust(x, n, &quad, Order::Value).value;
                    assert!((f - want).abs() <= 1e-12 * want, "1e-{k}");
                }
                None => declined = true,
            }
        }
        assert!(certified && declined);
        // Far from the plane: the robust path's.
        assert_eq!(value_of(above(1e-2), n, &quad), None);
        // Outside near the plane, the clip line running into the polygon: the sum cancels.
        let outside = quad[0] + (quad[0] - centroid) * 0.5;
        let towards = (centroid - outside).normalize();
        let n_out = (plane_n + towards.cross(plane_n)).normalize();
        let x = outside + plane_n * 1e-6;
        assert!(quad.iter().any(|vk| n_out.dot(*vk - x) < 0.0));
        assert!(quad.iter().any(|vk| n_out.dot(*vk - x) > 0.0));
        assert_eq!(value_of(x, n_out, &quad), None);
        // Near an edge's segment (1e-4 of the size inside edge 0-1).
        let mid = (quad[0] + quad[1]) * 0.5;
        let near_edge = mid + (centroid - mid) * 1e-4 + plane_n * 1e-7;
        assert_eq!(value_of(near_edge, n, &quad), None);
        // Non-convex (an arrowhead) and non-planar beyond a quarter of the robust tolerance.
        let arrow: Vec<DVec3> = [(0.0, 0.0), (1.0, 0.5), (0.0, 1.0), (0.3, 0.5)]
            .map(|(x, y)| DVec3::new(x, y, 1.0))
            .to_vec();
        let x_arrow = DVec3::new(0.2, 0.5, 1.0 + 1e-6);
        let n_arrow = DVec3::new(0.0, 0.7, 0.7).normalize();
        assert!(arrow.iter().any(|vk| n_arrow.dot(*vk - x_arrow) < 0.0));
        assert_eq!(value_of(x_arrow, n_arrow, &arrow), None);
        let mut bent = quad.clone();
        bent[2] += plane_n * 3e-8;
        assert!(value_of(above(1e-6), n, &bent).is_none());
        // The tangent plane through a vertex (y = 0.6 exactly, n = ŷ: its height is 0), and a
        // control 0.3 beside it.
        let on_vertex = |dy: f64| {
            let (px, py) = (0.7 * quad[2].x + 0.3 * centroid.x, quad[2].y - dy);
            DVec3::new(px, py, 1.0 + 0.1 * px + 0.1 * py + 1e-6)
        };
        assert_eq!(DVec3::Y.dot(quad[2] - on_vertex(0.0)), 0.0);
        assert_eq!(value_of(on_vertex(0.0), DVec3::Y, &quad), None);
        assert!(value_of(on_vertex(0.3), DVec3::Y, &quad).is_some());
        // Nothing clipped, everything clipped, an invalid normal, NaN, a triangle.
        assert_eq!(value_of(above(1e-6), plane_n, &quad), None);
        assert_eq!(value_of(above(1e-6), -plane_n, &quad), None);
        assert_eq!(value_of(above(1e-6), n * 2.0, &quad), None);
        assert_eq!(value_of(above(1e-6) + DVec3::NAN, n, &quad), None);
        let mut nan = quad.clone();
        nan[1].y = f64::NAN;
        assert_eq!(value_of(above(1e-6), n, &nan), None);
        assert_eq!(value_of(above(1e-6), n, &quad[..3]), None);
        for order in [Order::Gradient, Order::Hessian] {
            assert!(derivs_of(above(1e-2), n, &quad, order).is_none());
            assert!(derivs_of(x, n_out, &quad, order).is_none());
        }
    }
}
