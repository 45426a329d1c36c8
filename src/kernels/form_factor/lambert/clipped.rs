//! Certified value fast path of the point-to-triangle form factor when the receiver's tangent plane
//! cuts the triangle: Lambert's sum over the clipped polygon, with a running error bound.
//!
//! The robust path clips in exact arithmetic and evaluates every edge with its derivative machinery;
//! near the triangle's plane (`x` within 1e-3 of the size), where it also recomputes the height and
//! the clip points exactly, that costs several unclipped Lambert sums, and the value alone needs
//! only the clipped loop and Lambert's per-edge terms. Further from the plane the robust value is cheap enough that the path
//! is not tried (gradient and Hessian orders replace their value by this one and would pay twice).
//!
//! **The loop.** Each vertex must be certainly above or below the tangent plane: `|n·r_k|` beyond
//! `16u(|n|·|r_k|)`, as in the unclipped path, twice the bound `γ_k = 8u(|n|·|r_k|)` used here for
//! the error of the computed height (which is below `4u(|n|·|r_k|)`); otherwise the path declines.
//! Where an edge `i → j` crosses the plane, `t = d_i/(d_i − d_j)` (`d = n·r`, f64) errs by at most
//! `δt ≤ (γ_i(1 + t) + γ_j t)/|d_i − d_j| + 2ut` (the heights have opposite signs: no
//! cancellation), and the clip point is formed as `R_i + t(R_j − R_i)` in double-double from the
//! exact differences `R_k = r_k + r_lo_k = v_k − x`: a point exactly on the triangle's edge line
//! (to ~u²), displaced from the exact clip point by `δ ≤ δt‖E‖` along the edge `E`. The loop's
//! vertices are the f64 roundings of these points (`r_k` for triangle vertices) and its edge
//! vectors one rounding of the exact differences of their ends (`v_j − v_i` for triangle edges):
//! the input model of Lambert's bound (`lambert/sum.rs`), in which every input is rounded once from
//! exact, consistent data.
//!
//! **The clip edge** lies in the tangent plane, so its plane through `x` is the tangent plane and
//! `n·ŵ = ±1` exactly: its term is `±β`, `β = atan2(s, c)` (`s = ‖r_a × e‖`, `c = r_a·r_b`), with no
//! `1/s` factor. Rounded inputs perturb `β` by at most `(|c|·|δs| + s·|δc|)/P² + 2uβ` with
//! `|δs| ≤ 6uL + 2us`, `|δc| ≤ 5uP` (`L = ‖r_a‖‖e‖`, `P = ‖r_a‖‖r_b‖`), i.e. by
//! `u(6‖e‖/‖r_b‖ + 7 + 2β)`: bounded even as `x` approaches the clip line (`s → 0`), where the
//! generic term's bound grows like `1/sin β`. The sign is taken when `|n·w|` exceeds its rounding
//! bound `6uL + 3us`.
//!
//! **The clip points' displacement** `δ` (along the triangle's edges) has two effects, both
//! bounded. (a) It tilts the clip edge's plane out of the tangent plane by `θ ≤ 2δ/ρ`
//! (`ρ = s/‖e‖`, the distance from `x` to the clip line), so `n·ŵ = cos θ` and `±β` errs by
//! `βθ²/2`. (b) The loop then bounds a region that differs from the exact clipped triangle by two
//! thin triangles along the clip line, each of width `w ≤ δ` and within `δ` of the tangent plane,
//! where the integrand `(n·ω)(N·ω)/(π‖r‖²)` is at most `δ/(π‖r‖³)`; along the line
//! `‖r‖² ≥ ρ² + σ²`, so each contributes at most `δ² ∫ dσ/(π(ρ² + σ²)^{3/2}) = 2δ²/(πρ²)`:
//! `2π·|ΔF| ≤ 8δ²/ρ²` for the two. Both are second order in `δ`; generically `δ` is a few `u‖E‖`, and they reach the
//! tolerance when `x` is within ~1e-9 `‖E‖` of the clip line.
//!
//! The bound is `u(Σ err_k + (m + 2)Σ|f_k|)` (summing `m` terms, renormalizing `n`, scaling) plus
//! (a) and (b); the value is accepted when it is within [`FAST_TOLERANCE`] of the result. It
//! declines near an edge line of the triangle, when the sum cancels (`x` near the triangle's plane
//! outside it: the robust path has a cancellation-free form there), within ~1e-9 of the clip line,
//! and for invalid input.

use glam::DVec3;

use crate::kernels::form_factor::edge::INV_2PI;
use crate::kernels::form_factor::lambert::sum::edge_and_angle;
use crate::kernels::form_factor::near_plane;
use crate::kernels::form_factor::near_plane::route_loop::RouteLoop;
use crate::kernels::form_factor::tolerance::FAST_TOLERANCE;
use crate::kernels::form_factor::validate::{in_range, unit};
use crate::kernels::numeric::dd::{two_sum, Dd, Dd3};

const U: f64 = 0.5 * f64::EPSILON;

/// A vertex of the clipped loop: the exact point `exact` (double-double, relative to `x`), its f64
/// rounding `hi`, the triangle vertex it is (`None` for a clip point), and for a clip point the
/// bound on its displacement along the triangle's edge.
#[derive(Clone, Copy)]
pub(crate) struct LoopVertex {
    pub(crate) exact: Dd3,
    pub(crate) hi: DVec3,
    pub(crate) vertex: Option<usize>,
    pub(crate) displacement: f64,
}

/// The value a loop's unused point entries hold (nothing reads past `count`): a constant, not a
/// copy of point 0.
const LOOP_VERTEX_ZERO: LoopVertex = LoopVertex {
    exact: Dd3 {
        x: Dd { hi: 0.0, lo: 0.0 },
        y: Dd { hi: 0.0, lo: 0.0 },
        z: Dd { hi: 0.0, lo: 0.0 },
    },
    hi: DVec3::ZERO,
    vertex: None,
    displacement: 0.0,
};

/// The clipped loop of a certified [`triangle_value`], for the derivative path
/// ([`lambert::clipped_derivs`](crate::kernels::form_factor::lambert::clipped_derivs)): the unit
/// normal, the loop's vertices (`count` of them), its edge vectors (`edges[k]` from vertex `k` to
/// the next, each one rounding of the exact difference), the ordinary edges' angles `β` where the
/// value computed them (NaN otherwise) and `2π` times the signed certified sum. `N` is the
/// capacity: 4 for a triangle, `M + 1` for a convex polygon of `M` vertices
/// ([`lambert::clipped_polygon`](crate::kernels::form_factor::lambert::clipped_polygon)).
#[derive(Clone)]
pub(crate) struct ClippedLoop<const N: usize = 4> {
    pub(crate) n: DVec3,
    pub(crate) points: [LoopVertex; N],
    pub(crate) edges: [DVec3; N],
    pub(crate) angles: [f64; N],
    pub(crate) count: usize,
    pub(crate) sum: f64,
}

/// `hi + lo` as a double-double vector, for `lo` the exact rounding error of `hi` (already
/// normalized: no renormalization needed).
// Always inlined (also below): called from two modules, they were left out of line.
#[inline(always)]
pub(crate) fn from_parts(hi: DVec3, lo: DVec3) -> Dd3 {
    let dd = |hi: f64, lo: f64| Dd { hi, lo };
    Dd3 {
        x: dd(hi.x, lo.x),
        y: dd(hi.y, lo.y),
        z: dd(hi.z, lo.z),
    }
}

/// The rounding error of `v − x` per component (`(v − x) − fl(v − x)`, exact by two-sum).
#[inline(always)]
pub(crate) fn difference_error(v: DVec3, x: DVec3) -> DVec3 {
    DVec3::new(
        two_sum(v.x, -x.x).1,
        two_sum(v.y, -x.y).1,
        two_sum(v.z, -x.z).1,
    )
}

/// The value of [`triangle_form_factor`](crate::kernels::form_factor::triangle_form_factor) by
/// Lambert's sum over the clipped triangle when its tangent plane certainly cuts it and the error
/// bound (module documentation) is within [`FAST_TOLERANCE`] of the result; `None` otherwise,
/// including when nothing is clipped (the unclipped path's case) and for invalid input.
// Out of line, with the loop built in place inside: inlined into the kernel, the loop's frame
// would weigh on the value order's other paths; returned by value, it would be copied.
#[inline(never)]
pub(crate) fn triangle_value(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<f64> {
    with_certified_loop(x, n, v, ClippedLoop::value)
}

impl<const N: usize> ClippedLoop<N> {
    /// The form factor: the sum's sign is the triangle's orientation as seen from x, and the form
    /// factor is two-sided.
    pub(crate) fn value(&self) -> f64 {
        (self.sum.abs() * INV_2PI).min(1.0)
    }
}

/// The tangent plane's cut of the triangle: the unit normal, `r_k = v_k − x`, the heights
/// `n·r_k` with their error bounds, and which vertices are certainly above; `None` when a height's
/// sign is uncertain, nothing or everything is clipped, or for invalid input.
struct Cut {
    n: DVec3,
    r: [DVec3; 3],
    heights: [f64; 3],
    height_error: [f64; 3],
    above: [bool; 3],
}

#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn cut(x: DVec3, n: DVec3, v: &[DVec3; 3]) -> Option<Cut> {
    // Written out (here and below): array maps were left out of line.
    let r = [v[0] - x, v[1] - x, v[2] - x];
    if !r.iter().all(|rk| in_range(*rk)) {
        return None;
    }
    let n = unit(n)?;
    let heights = [n.dot(r[0]), n.dot(r[1]), n.dot(r[2])];
    // The computed heights err by less than half of this (see the module documentation).
    let error = |rk: DVec3| 8.0 * f64::EPSILON * n.abs().dot(rk.abs());
    let height_error = [error(r[0]), error(r[1]), error(r[2])];
    let mut above = [false; 3];
    for k in 0..3 {
        if heights[k] > height_error[k] {
            above[k] = true;
        } else if !(heights[k] < -height_error[k]) {
            return None;
        }
    }
    let kept = above.iter().filter(|&&a| a).count();
    if kept == 0 || kept == 3 {
        return None;
    }
    Some(Cut {
        n,
        r,
        heights,
        height_error,
        above,
    })
}

/// Whether `route` lists the same loop as `cut` would build: the kept vertices and the clip
/// points in the same order (for `i` in 0..3: vertex `i` when kept, then the crossing of edge
/// `i`). The route clips on exact heights, which have the signs `cut` certified, so it always
/// does; checked (a few comparisons) rather than assumed.
#[inline(always)]
fn same_loop(route: &RouteLoop, cut: &Cut) -> bool {
    let mut k = 0;
    for i in 0..3 {
        let j = (i + 1) % 3;
        if cut.above[i] {
            if k >= route.count() || route.is_clip_point(k) {
                return false;
            }
            debug_assert_eq!(route.point(k).0, cut.r[i]);
            k += 1;
        }
        if cut.above[i] != cut.above[j] {
            if k >= route.count() || !route.is_clip_point(k) {
                return false;
            }
            k += 1;
        }
    }
    k == route.count()
}

/// The clipped loop (module documentation): its vertices (the first `count`: kept triangle
/// vertices and clip points, in the triangle's order) and edge vectors, without angles or sum
/// (NaN and 0). With `route` (the value order's route's loop for the same configuration, see
/// [`with_valued_derivative_loop`]) the points are the route's (the clip points in
/// double-double) instead of this loop's own; their displacement bounds stay those of this
/// loop's f64 `t`. Handed to `f` in place: the loop is ~560 bytes, and a returned loop is copied.
#[inline(always)]
fn with_loop<R>(
    x: DVec3,
    v: &[DVec3; 3],
    cut: &Cut,
    route: Option<&RouteLoop>,
    f: impl FnOnce(&mut ClippedLoop) -> R,
) -> R {
    let Cut {
        r,
        heights,
        height_error,
        above,
        ..
    } = cut;
    // Not `Option::filter`: left out of line.
    let route = match route {
        Some(route) if same_loop(route, cut) => Some(route),
        _ => None,
    };
    // The route's points are these differences' double-double parts already.
    let exact: [Dd3; 3] = match route {
        Some(_) => [from_parts(DVec3::ZERO, DVec3::ZERO); 3],
        // Written out: `from_fn` was left out of line.
        None => {
            let exact = |k: usize| from_parts(r[k], difference_error(v[k], x));
            [exact(0), exact(1), exact(2)]
        }
    };
    let from_route = |route: &RouteLoop, k: usize| {
        let (hi, lo) = route.point(k);
        // Already normalized: `hi` is the rounding of `hi + lo`.
        (from_parts(hi, lo), hi)
    };
    // Filled in place (returned into the caller's frame): a local array moved into the loop was
    // copied.
    let mut l = ClippedLoop {
        n: cut.n,
        // Overwritten up to `count`, never read beyond: zeros (stored by vector registers) rather
        // than copies of a point.
        points: [LOOP_VERTEX_ZERO; 4],
        edges: [DVec3::ZERO; 4],
        // The route's angles are those of the same edges (the same ends, to their rounding).
        angles: match route {
            Some(route) => route.angles(),
            None => [f64::NAN; 4],
        },
        count: 0,
        sum: 0.0,
    };
    let mut count = 0;
    for i in 0..3 {
        let j = (i + 1) % 3;
        if above[i] {
            l.points[count] = LoopVertex {
                exact: match route {
                    Some(route) => from_route(route, count).0,
                    None => exact[i],
                },
                hi: r[i],
                vertex: Some(i),
                displacement: 0.0,
            };
            count += 1;
        }
        if above[i] != above[j] {
            let total = heights[i] - heights[j];
            let edge = (v[j] - v[i]).length();
            let (point, hi, displacement) = match route {
                Some(route) => {
                    // The route's clip point, from the double-double heights: within a few u²
                    // of the exact crossing, bounded as `lambert::clipped_polygon`'s loop bounds
                    // the same points (the heights by `U·height_error`, `t` by their errors over
                    // `|total|` and a few u², the point by a few u² of its ends' size).
                    let (point, hi) = from_route(route, count);
                    let dt =
                        2.0 * U * (height_error[i] + height_error[j]) / total.abs() + 16.0 * U * U;
                    let size = 16.0 * U * U * (r[i].length() + r[j].length());
                    (point, hi, dt * edge + size)
                }
                None => {
                    let t = heights[i] / total;
                    // |t − t_exact| from the heights' errors (half of `height_error`), the
                    // subtraction and the division, with a 2x margin for the bound's own
                    // rounding.
                    let (gi, gj) = (0.5 * height_error[i], 0.5 * height_error[j]);
                    let dt = 2.0 * ((gi * (1.0 + t) + gj * t) / total.abs() + 2.0 * U * t);
                    let p = exact[i].add(&exact[j].sub(&exact[i]).scale(Dd { hi: t, lo: 0.0 }));
                    (p, p.to_dvec3(), dt * edge)
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
        l.edges[k] = match route {
            // The route's vector of an edge with a clip point at an end is this one's: the
            // same rounding of the same double-double difference.
            Some(route) if a.vertex.is_none() || b.vertex.is_none() => route.edge(k),
            _ => edge_vector(v, a, b),
        };
    }
    f(&mut l)
}

/// The loop's edge vector from `a` to `b`: one rounding of the exact difference of its ends.
#[inline]
pub(crate) fn edge_vector<const M: usize>(v: &[DVec3; M], a: &LoopVertex, b: &LoopVertex) -> DVec3 {
    match (a.vertex, b.vertex) {
        (Some(i), Some(j)) => v[j] - v[i],
        _ => b.exact.sub(&a.exact).to_dvec3(),
    }
}

/// What decides, before the loop is built, which loop the configuration gets: the triangle's
/// (unnormalized) normal `N = (v_1 − v_0) × (v_2 − v_0)` and the quantities both decisions share.
struct Screen {
    /// `N·r_0`: `x`'s height over the triangle's plane times `‖N‖`, signed.
    side: f64,
    scale: f64,
    r_max: f64,
    r0_length: f64,
    /// `x` within a sine of 1e-3 of a triangle edge's segment, as [`left_to_the_robust_path`] tests
    /// it (`s < 1e-3‖r_i‖‖r_j‖`) and as [`with_valued_derivative_loop`] does (squared): the two
    /// roundings may differ at the threshold, and each decision keeps its own.
    near_edge: bool,
    near_edge_squared: bool,
    inside: bool,
}

#[inline(always)]
fn screen(v: &[DVec3; 3], r: &[DVec3; 3]) -> Screen {
    let normal = (v[1] - v[0]).cross(v[2] - v[0]);
    let length = [r[0].length(), r[1].length(), r[2].length()];
    let r_max = length.iter().fold(0.0f64, |m, &l| m.max(l));
    let mut sides = [0.0; 3];
    let (mut near_edge, mut near_edge_squared) = (false, false);
    for i in 0..3 {
        let j = (i + 1) % 3;
        let w = r[i].cross(r[j]);
        sides[i] = normal.dot(w);
        if r[i].dot(r[j]) < 0.0 {
            let (li2, lj2) = (r[i].length_squared(), r[j].length_squared());
            near_edge |= w.length() < 1e-3 * length[i] * length[j];
            near_edge_squared |= w.length_squared() < 1e-6 * li2 * lj2;
        }
    }
    Screen {
        side: normal.dot(r[0]),
        scale: normal.length(),
        r_max,
        r0_length: length[0],
        near_edge,
        near_edge_squared,
        inside: sides.iter().all(|&t| t > 0.0) || sides.iter().all(|&t| t < 0.0),
    }
}

impl Screen {
    /// [`left_to_the_robust_path`]'s decision, with its operations (kept separate there: the value
    /// order returns early, before the cross products, away from the plane).
    fn left_to_the_robust_path(&self) -> bool {
        let height = self.side.abs();
        height >= 1e-3 * self.scale * self.r_max
            || self.near_edge
            || (height < 1e-4 * self.scale * self.r_max && !self.inside)
    }

    /// Whether [`with_valued_derivative_loop`] builds its loop. The rounded normal and `r_0` are
    /// within 4u and u of exact relatively: 8u with a margin. Taken only near the plane (below 1e-3
    /// of the size, as [`left_to_the_robust_path`]), where the robust path's exact geometry makes
    /// its derivatives several times dearer. Within a sine of 1e-3 of a triangle edge's segment the
    /// clip point on it is within ~1e-3 of the size from x, where the derivatives decline on its
    /// displacement: without the loop.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
    fn uncertified(&self) -> bool {
        let height = self.side.abs();
        height > 8.0 * f64::EPSILON * self.scale * self.r0_length
            && height < 1e-3 * self.scale * self.r_max
            && !self.near_edge_squared
    }
}

/// `f` of [`triangle_value`]'s loop and signed sum (times `2π`) when it certifies the value, in
/// place (`certified_loop` for the tests).
#[inline(always)]
fn with_certified_loop<R>(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    f: impl FnOnce(&ClippedLoop) -> R,
) -> Option<R> {
    let cut = cut(x, n, &v)?;
    if left_to_the_robust_path(&v, &cut.r) {
        return None;
    }
    with_loop(
        x,
        &v,
        &cut,
        None,
        #[inline(always)]
        |l| {
            l.sum = certify(l)?;
            Some(f(l))
        },
    )
}

/// Where the derivative orders' loop ([`with_valued_derivative_loop`]) takes its value from.
#[derive(Clone, Copy)]
pub(crate) enum LoopValue<'a> {
    /// The certified loop: [`ClippedLoop::value`].
    Certified,
    /// The uncertified loop on the clip points of the value order's near-plane route
    /// ([`near_plane::triangle::clipped_triangle_value_and_loop`]), with that route's value: the
    /// value order's bits.
    Route(f64),
    /// The uncertified loop, its value to be taken from the value order's paths; `route_tried`
    /// when the near-plane route was tried here and declined (the caller need not try it again).
    Elsewhere { route_tried: bool },
    /// The near-plane route took the robust path's far-field rule on its loop (a far-field visible
    /// part) and left its value to the derivatives, the same rule's
    /// ([`deferred_far_piece`](crate::kernels::form_factor::near_plane::far_piece::deferred_far_piece)),
    /// which the loop's do not replace; where that value is not finite the route declined, as
    /// `Elsewhere { route_tried: true }`.
    Far(&'a RouteLoop),
}

/// The loop of the derivative orders, handed to `f` in place (no copy of the loop): the
/// certified loop ([`with_certified_loop`]) when it certifies (`f(loop, Certified)`), else the
/// uncertified loop (`uncertified_loop` for the tests),
/// both from one cut and one built loop (the lists of points and edges are the same); `None`
/// where neither is built. `fma`: the CPU has AVX2 and FMA (checked by the caller), for the
/// route's FMA build.
///
/// Outside the triangle near its plane (the certificate is not tried: Lambert's sum cancels) the
/// value is the value order's near-plane route's, which clips the triangle in double-double too:
/// the route runs first and the loop takes its clip points (`f(loop, Route(value))`) instead of
/// clipping a second time. Its points are on the triangle's edge lines and at the exact crossings
/// to ~u² (double-double `t` and point), so within the displacement bound each point carries (that
/// of this loop's own f64 `t`, kept so that the derivatives' accept and decline tests are computed
/// the same way);
/// [`lambert::clipped_derivs`](crate::kernels::form_factor::lambert::clipped_derivs)' accuracy
/// argument needs only that bound and the points on the edge lines to O(u). Where the route
/// declines, the loop's own points (`f(loop, Elsewhere { route_tried: true })`).
#[inline(always)]
pub(crate) fn with_valued_derivative_loop<R>(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    fma: bool,
    f: impl FnOnce(&ClippedLoop, LoopValue<'_>) -> R,
) -> Option<R> {
    let cut = cut(x, n, &v)?;
    let screen = screen(&v, &cut.r);
    // Outside the triangle near its plane the certified sum cancels and declines: not tried.
    let try_certified = !screen.left_to_the_robust_path();
    let uncertified = screen.uncertified();
    if !try_certified && !uncertified {
        return None;
    }
    if !try_certified {
        let side = screen.side.signum();
        let _ = fma; // Read on x86-64 only.
        #[cfg(target_arch = "x86_64")]
        if fma {
            // SAFETY: the caller checked that the CPU has AVX2 and FMA.
            return Some(unsafe { routed_loop_fma(x, v, &cut, side, f) });
        }
        return Some(routed_loop(x, v, &cut, side, f));
    }
    with_loop(
        x,
        &v,
        &cut,
        None,
        #[inline(always)]
        |l| {
            if let Some(sum) = certify(l) {
                l.sum = sum;
                return Some(f(l, LoopValue::Certified));
            }
            if !uncertified {
                return None;
            }
            // A declined certificate may have set some angles.
            l.angles = [f64::NAN; 4];
            l.sum = screen.side.signum();
            Some(f(l, LoopValue::Elsewhere { route_tried: false }))
        },
    )
}

/// [`with_valued_derivative_loop`] outside the triangle: the value order's near-plane route,
/// then the loop on its clip points (or on the loop's own where it declines), oriented by
/// `side`. Out of line, in a portable and an FMA build (the route's double-double products; the
/// same bits, see [`near_plane::triangle::triangle_value`]): inlined, its frame and registers
/// would weigh on the certified loop's other callers.
#[inline(always)]
fn routed_loop_body<R>(
    x: DVec3,
    v: [DVec3; 3],
    cut: &Cut,
    side: f64,
    f: impl FnOnce(&ClippedLoop, LoopValue<'_>) -> R,
) -> R {
    let mut route = RouteLoop::new();
    // The far-field rule's value is summed with its derivatives (`LoopValue::Far`).
    route.defer_far = true;
    let value = near_plane::triangle::clipped_triangle_value_and_loop(x, cut.n, v, &mut route);
    with_loop(
        x,
        &v,
        cut,
        // A far-field route computed neither edge vectors nor angles: the loop's own then.
        (value.is_some() && !route.is_far()).then_some(&route),
        #[inline(always)]
        |l| {
            l.sum = side;
            let value = match value {
                Some(_) if route.is_far() => LoopValue::Far(&route),
                Some(value) => LoopValue::Route(value),
                None => LoopValue::Elsewhere { route_tried: true },
            };
            f(l, value)
        },
    )
}

#[inline(never)]
fn routed_loop<R>(
    x: DVec3,
    v: [DVec3; 3],
    cut: &Cut,
    side: f64,
    f: impl FnOnce(&ClippedLoop, LoopValue<'_>) -> R,
) -> R {
    routed_loop_body(x, v, cut, side, f)
}

/// [`routed_loop`] compiled with FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn routed_loop_fma<R>(
    x: DVec3,
    v: [DVec3; 3],
    cut: &Cut,
    side: f64,
    f: impl FnOnce(&ClippedLoop, LoopValue<'_>) -> R,
) -> R {
    routed_loop_body(x, v, cut, side, f)
}

/// The certified signed sum (times `2π`) over the loop, setting its ordinary edges' angles;
/// `None` when the bound exceeds [`FAST_TOLERANCE`] (some angles may then be set).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn certify<const N: usize>(l: &mut ClippedLoop<N>) -> Option<f64> {
    let (mut sum, mut magnitude, mut err) = (0.0, 0.0, 0.0);
    let (n, count) = (l.n, l.count);
    for k in 0..count {
        let next = if k + 1 == count { 0 } else { k + 1 };
        let (a, b) = (&l.points[k], &l.points[next]);
        let e = l.edges[k];
        let (f, e_k) = if a.vertex.is_none() && b.vertex.is_none() {
            clip_edge(n, a.hi, b.hi, e, a.displacement.max(b.displacement))?
        } else {
            let (f, err, beta) = edge_and_angle(n, a.hi, b.hi, e, a.hi.length_squared());
            l.angles[k] = beta;
            (f, err)
        };
        sum += f;
        magnitude += f.abs();
        err += e_k;
        // |sum| ≤ 2π: past this the final test cannot pass.
        if U * err > FAST_TOLERANCE * std::f64::consts::TAU {
            return None;
        }
    }
    let err = U * (err + (count as f64 + 2.0) * magnitude);
    if !(err <= FAST_TOLERANCE * sum.abs()) {
        return None;
    }
    Some(sum)
}

/// Whether this path leaves the configuration to the robust one before the exact clip points and
/// the arctangents. It is taken only near the triangle's plane (`|h_P|` below 1e-3 of the largest
/// `‖r_k‖`, the robust path's near-plane regime, where its exact geometry makes the value several
/// times dearer than this sum): elsewhere the robust value is cheap enough, and gradient and
/// Hessian orders, which replace their value by this one, would pay for a second value. It also
/// declines where its final test is bound to fail: `x` within a sine of 1e-3 of a triangle
/// edge's segment (`β > π/2`: Lambert's bound grows like `1/sin β`), and `x` within 1e-4 of the
/// size from the plane outside the triangle (the sum cancels by about size/height).
fn left_to_the_robust_path(v: &[DVec3; 3], r: &[DVec3; 3]) -> bool {
    let normal = (v[1] - v[0]).cross(v[2] - v[0]);
    let r_max = r.iter().fold(0.0f64, |m, rk| m.max(rk.length()));
    let height = normal.dot(r[0]).abs();
    let scale = normal.length();
    if height >= 1e-3 * scale * r_max {
        return true;
    }
    let mut sides = [0.0; 3];
    for i in 0..3 {
        let j = (i + 1) % 3;
        let w = r[i].cross(r[j]);
        sides[i] = normal.dot(w);
        let (c, s) = (r[i].dot(r[j]), w.length());
        if c < 0.0 && s < 1e-3 * r[i].length() * r[j].length() {
            return true;
        }
    }
    let inside = sides.iter().all(|&t| t > 0.0) || sides.iter().all(|&t| t < 0.0);
    height < 1e-4 * scale * r_max && !inside
}

/// The clip edge's term times 2π, `±β`, and its error bound times 2π / u (module documentation),
/// for displacements of its ends up to `delta` along the triangle's edges; `None` when the sign is
/// uncertain (`x` on or within rounding of the clip line).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn clip_edge(
    n: DVec3,
    ra: DVec3,
    rb: DVec3,
    e: DVec3,
    delta: f64,
) -> Option<(f64, f64)> {
    let w = ra.cross(e);
    let s = w.length();
    let c = ra.dot(rb);
    let beta = s.atan2(c);
    let (len_a, len_b, len_e) = (ra.length(), rb.length(), e.length());
    let nw = n.dot(w);
    // 1 % margin on every bound for the rounding of the bound itself.
    let sign_bound = 1.01 * U * (6.0 * len_a * len_e + 3.0 * s);
    if !(nw.abs() > sign_bound) {
        return None;
    }
    let rounding = 1.01 * (6.0 * len_e / len_b + 7.0 + 2.0 * beta);
    // Distance from x to the clip line, and the two second-order displacement terms (in units of u).
    let rho = s / len_e;
    let tilt = 2.0 * delta / rho;
    let displaced = 1.01 * (0.5 * beta * tilt * tilt + 8.0 * (delta / rho).powi(2)) / U;
    Some((beta.copysign(nw), rounding + displaced))
}

#[cfg(test)]
pub(crate) mod tests;
