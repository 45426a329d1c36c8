//! Point-to-edge, point-to-triangle and point-to-polygon form factors: the public entry points
//! and the ladder of paths behind them.
//!
//! The form factor from a differential area at `x` with unit normal `n` to a polygon is Lambert's
//! sum of per-edge terms (`edge`), with the part below the tangent plane clipped away. Evaluated
//! as written it fails where its terms cancel or are near-singular: far away (terms ~size/d, sum
//! ~(size/d)²), near the polygon's plane (the clip line passes within ~`h_P` of `x`), near an
//! edge's line, for slivers. Each such configuration has its own path below, and the generic
//! configurations, which are most calls, take the cheapest path that can certify its result.
//!
//! # The ladder
//!
//! Each entry point tries its rungs in order; the first that answers returns. Every rung meets
//! the accuracy contract (1e-12 / 1e-12 / 1e-10 relative to the largest entry in generic
//! configurations, 1e-10 / 1e-9 / 1e-8 in the hard regimes). *Certified* rungs return a result
//! only when its running error bound is within `tolerance::FAST_TOLERANCE` (5e-13); *replays*
//! repeat the robust path's decisions from a few certain f64 tests and then its f64 operations, so
//! they return its bits. The value never depends on the order asked for: where the derivative
//! orders end on another rung than the value order, they take the value order's value.
//!
//! **[`triangle_form_factor`], value** (also `triangle_form_factor_value`, the C ABI's):
//! 1. Very thin (`2·area < 1e-5·extent²`): the sliver rule's direct entry (`sliver::direct`), else
//!    the robust path (the polygon ladder when the differences need rescaling).
//! 2. Every vertex certainly above the tangent plane: Lambert's sum, certified (`lambert::sum`),
//!    or its cancellation-free far form when every edge is small against its distance
//!    (`lambert::far`).
//! 3. Clipped, `x` within 1e-3 of the size from the plane: Lambert's sum over the clipped loop,
//!    certified (`lambert::clipped`).
//! 4. `x` near the plane outside the visible part: the robust near-plane split, replayed on fixed
//!    arrays (`near_plane::triangle`).
//! 5. Far field (centroid beyond 16 radii): the robust far-field rule, replayed (`replay`).
//! 6. Robust decisions all trivial: the robust edge sum, replayed (`replay`).
//! 7. The robust path (`robust`), without the rescaling when the differences are in range.
//!
//! **[`triangle_form_factor`], gradient and Hessian:**
//! 1. Very thin: as for the value.
//! 2. Far field: the far-field rule, replayed (`replay`), with Lambert's value where certified.
//! 3. Lambert's analytic derivatives, certified (`lambert::sum`): `sin β ≥ 1/32` on every edge,
//!    neither sum cancelling beyond 100x once each edge below `sin β = 1/4` is charged with the
//!    growth of its rounding errors (the common case a few sizes away, where some edge is seen
//!    under a small angle).
//! 4. Clipped near the plane: the derivatives of the clipped loop (`lambert::clipped_derivs`),
//!    built once (`lambert::clipped`) on the certified loop or on the near-plane route's clip
//!    points (`near_plane::route_loop`).
//! 5. Rungs 6 and 7 of the value.
//!
//! **[`polygon_form_factor`]** (rungs 1 to 3 take 4 to 8 vertices; the certified ones strictly
//! convex polygons planar to a quarter of the robust tolerance, not slivers, `convex`):
//! 1. Value: Lambert's sum or far form (`lambert::polygon`); derivatives: the far-field rule
//!    replayed on any valid polygon (`replay`), then Lambert's derivatives.
//! 2. Clipped near the plane: the clipped loop's value and derivatives
//!    (`lambert::clipped_polygon`).
//! 3. Value, `x` near the plane outside: the near-plane split, replayed (`near_plane::polygon`).
//! 4. Very thin (4 to 8 vertices): the sum over its fan triangles of the sliver rule
//!    (`sliver::fan`).
//! 5. The robust path (`robust`).
//!
//! **[`edge_form_factor`]:** Lambert's certified term (`lambert::sum`), the robust term replayed
//! (`replay`), the robust term on exactly rescaled differences (`edge`).
//!
//! **The robust path** (`robust::evaluate`, every valid input): the polygon's plane is validated
//! (`plane`: area, planarity, simplicity) and the differences rescaled by a power of two
//! (`scaled`); `x` in the plane gives 0 (derivatives `Degenerate`); near the plane its height is
//! recomputed exactly; the polygon is clipped (`clip`, clip points in double-double). Then, on the
//! visible part: far field → the tensor Gauss rule (`quadrature`); very thin → the anisotropic
//! sliver rule (`sliver`); otherwise the edge sum (`edge`), whose value near the plane outside
//! the visible part is the cancellation-free near-plane split (`near_plane::split`), and which,
//! where it still cancels beyond `tolerance::cancellation_limit`, gives way to the sliver rule or
//! subdivided quadrature. A clipped polygon's Hessian adds the moving clip line's term
//! (`clip_line`); the sign follows the side of the plane and the value is clamped to `[0, 1]`
//! (`orient`).
//!
//! # Layers
//!
//! Modules import only from the ones before them in this list (checked for cycles by
//! `tests/module_graph.rs`): `validate`, `edge`, `clip`, `orient`, `convex` and
//! `quadrature::rules` import nothing of the form factor; then `scaled`, `plane`, `tolerance`,
//! `near_plane::split`, `quadrature::tensor`, `sliver::geometry`, `lambert::far`; then the
//! rules and sums built on them (`quadrature`, `clip_line`, `lambert::sum`, `replay`,
//! `sliver::rule`); the routes and direct entries (`near_plane`, `sliver`), `robust`; the
//! clipped Lambert paths (`lambert::clipped*`, `lambert::polygon`); this module last.

use glam::DVec3;

use crate::error::{ensure_finite3, Result};
use crate::{Deriv3, Order};
use edge::edge_term_exact;
use lambert::clipped::{with_valued_derivative_loop, LoopValue};
use lambert::clipped_derivs::loop_derivs;
use lambert::clipped_polygon::clipped_polygon_derivs;
use lambert::polygon::{derivs_or, value_or};
use lambert::sum::{edge_derivs_checked, edge_value};
use near_plane::far_piece::deferred_far_piece;
use plane::is_very_thin_triangle;
use replay::{
    edge_form_factor_fast, maybe_far, polygon_far_field_fast, triangle_far_field_fast,
    triangle_form_factor_fast,
};
use robust::{
    form_factor, polygon_form_factor_in_range, triangle_form_factor_in_range,
    very_thin_triangle_form_factor_in_range,
};
use scaled::Scaled;
use sliver::fan::very_thin_polygon_form_factor;
use validate::unit_normal;

pub(crate) mod clip;
pub(crate) mod clip_line;
pub(crate) mod convex;
pub(crate) mod edge;
pub(crate) mod lambert;
pub(crate) mod near_plane;
pub(crate) mod orient;
pub(crate) mod plane;
pub(crate) mod quadrature;
pub(crate) mod replay;
pub(crate) mod robust;
pub(crate) mod scaled;
pub(crate) mod sliver;
pub(crate) mod tolerance;
pub(crate) mod validate;

/// The per-edge term of the point-to-polygon form factor, with gradient and Hessian w.r.t. `x`:
///
/// ```text
/// f(x) = (1/2π) β n·(r_a × r_b)/‖r_a × r_b‖,   r_a = a − x, r_b = b − x,
/// β = atan2(‖r_a × r_b‖, r_a·r_b) ∈ [0, π].
/// ```
///
/// **Sign convention.** `f` is positive when the triangle `(x, a, b)`, oriented `x → a → b`, has its
/// right-hand normal `(a − x) × (b − x)` in the half-space of `n`, i.e. when the edge `a → b` runs
/// counter-clockwise about `n` as seen from the tip of `n`. The term is odd in the edge direction:
/// `edge_form_factor(x, n, b, a) = −edge_form_factor(x, n, a, b)`. Summing it over the edges of a
/// polygon whose vertices run clockwise when seen from `x` (equivalently, whose right-hand normal
/// points away from `x`) gives the polygon's unclipped form factor; the opposite orientation gives
/// its negative. Summing over all edges of a closed mesh counts every shared edge twice with
/// opposite signs, which is why a caller weighting by the radiance difference of the two adjacent
/// triangles gets the occlusion-aware derivatives from one term per shared edge.
///
/// No clipping is applied: the term is the flux of the "vector form factor" through the edge's
/// wedge, also below the tangent plane.
///
/// * `n` must be unit length within a relative 1e-6 (it is renormalized); otherwise
///   [`Error::InvalidArgument`](crate::Error::InvalidArgument). `x`, `a`, `b` must be finite.
/// * Units: dimensionless value, gradient per L, Hessian per L².
/// * Limits: `a == b` gives 0 with zero derivatives. For `x` on the edge's line but outside the
///   segment the term and its derivatives are finite (their continuous limit; `β = 0`). For `x` on
///   the closed segment `[a, b]` the term is undefined:
///   [`Error::Degenerate`](crate::Error::Degenerate). If derivatives would overflow (for example
///   `x` within ~1e-100 of the segment) [`Error::Degenerate`](crate::Error::Degenerate).
///
/// ```
/// use glam::DVec3;
/// use raddiff::{kernels, Order};
/// // The four edges of a unit square 1 above x, clockwise as seen from below, sum to the square's
/// // form factor.
/// let v = [DVec3::new(0., 0., 1.), DVec3::new(1., 0., 1.), DVec3::new(1., 1., 1.), DVec3::new(0., 1., 1.)];
/// let x = DVec3::new(0.3, 0.4, 0.0);
/// let mut sum = 0.0;
/// for i in 0..4 {
///     sum += kernels::edge_form_factor(x, DVec3::Z, v[i], v[(i + 1) % 4], Order::Value)?.value;
/// }
/// let f = kernels::polygon_form_factor(x, DVec3::Z, &v, Order::Value)?.value;
/// assert!((sum - f).abs() < 1e-15);
/// # Ok::<(), raddiff::Error>(())
/// ```
pub fn edge_form_factor(x: DVec3, n: DVec3, a: DVec3, b: DVec3, order: Order) -> Result<Deriv3> {
    if order == Order::Value {
        if let Some(f) = edge_value(x, n, a, b) {
            return Ok(Deriv3::constant(f));
        }
    } else if let Some(d) = edge_derivs_checked(x, n, a, b, order) {
        return Ok(d);
    }
    let d = edge_form_factor_slow(x, n, a, b, order)?;
    // The value must not depend on the order asked for: where Lambert's value is certified but
    // its derivatives are not, the derivatives come from the paths below and the value from it.
    Ok(with_lambert_value(d, order, || edge_value(x, n, a, b)))
}

/// The value a fast Lambert call would have given for `Order::Value`, put into `d`.
#[inline]
fn with_lambert_value(mut d: Deriv3, order: Order, value: impl FnOnce() -> Option<f64>) -> Deriv3 {
    if order != Order::Value {
        if let Some(f) = value() {
            d.value = f;
        }
    }
    d
}

/// [`edge_form_factor`] without the Lambert fast path.
fn edge_form_factor_slow(x: DVec3, n: DVec3, a: DVec3, b: DVec3, order: Order) -> Result<Deriv3> {
    if let Some(d) = edge_form_factor_fast(x, n, a, b, order) {
        return Ok(d);
    }
    ensure_finite3(x, "x")?;
    ensure_finite3(a, "a")?;
    ensure_finite3(b, "b")?;
    let n = unit_normal(n)?;
    let scaled = Scaled::new(x, &[a, b])?;
    let ends = scaled.exact_ends(0, 1);
    let d = edge_term_exact(
        scaled.r[0],
        scaled.u[1] - scaled.u[0],
        n,
        order,
        Some(&ends),
    )?;
    scaled.finish(d, order)
}

/// Form factor from a differential area at `x` with unit normal `n` to the triangle `(a, b, c)`:
/// `(1/π) ∫ n·ω dω` over the triangle's solid angle, with the part of the triangle below the tangent
/// plane (`n·(v − x) < 0`) clipped away. Value, gradient and Hessian with respect to `x` (`n` fixed).
///
/// This is [`polygon_form_factor`] for three vertices (no simplicity check is needed); see there for
/// conventions, accuracy and limits.
pub fn triangle_form_factor(
    x: DVec3,
    n: DVec3,
    a: DVec3,
    b: DVec3,
    c: DVec3,
    order: Order,
) -> Result<Deriv3> {
    if is_very_thin_triangle([a, b, c]) {
        return very_thin_triangle(x, n, [a, b, c], order);
    }
    if order == Order::Value {
        return triangle_value(x, n, [a, b, c]);
    }
    let lambert_value = || triangle_lambert_value(x, n, [a, b, c]);
    // Far away Lambert's derivatives would be computed only to be declined (their sums
    // cancel): the far-field quadrature first. Its value is replaced by Lambert's where that is
    // certified (its cancellation-free far form reaches any distance), so that the value is
    // the same for every order.
    if maybe_far(&[a, b, c], x) {
        if let Some((d, _)) = triangle_far_field_fast(x, n, [a, b, c], order) {
            return Ok(with_lambert_value(d, order, lambert_value));
        }
    }
    if let Some(d) = lambert::sum::triangle_derivs(x, n, [a, b, c], order) {
        return Ok(d);
    }
    // Near the plane with the tangent plane cutting the triangle: the derivatives of the certified
    // clipped loop, whose value is `lambert_value`'s, or outside the triangle (the sum cancels) or
    // on the clip line those of the uncertified loop, with the value order's value (no Lambert
    // value there: clipped, uncertified). One cut and one loop for both, used in place; a certified
    // value is kept for the robust path below.
    let clipped = clipped_derivs(x, n, [a, b, c], order);
    let certified_value = match clipped {
        Some(ClippedDerivs::Done(d)) => return Ok(d),
        Some(ClippedDerivs::ValueElsewhere(d, route_tried)) => {
            let value = value_past_route(x, n, [a, b, c], !route_tried)?.value;
            return Ok(Deriv3 { value, ..d });
        }
        Some(ClippedDerivs::Declined(value)) => value,
        None => None,
    };
    let d = robust_triangle(x, n, [a, b, c], order)?;
    Ok(with_lambert_value(d, order, || {
        lambert::sum::triangle_value(x, n, [a, b, c]).or(certified_value)
    }))
}

/// The value of [`triangle_form_factor`] alone, inlined into the caller down to the paths' calls
/// (the C ABI's value order: no derivative plumbing). The same bits as the value of every order.
#[inline]
pub(crate) fn triangle_form_factor_value(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Result<f64> {
    if is_very_thin_triangle(v) {
        return very_thin_triangle(x, n, v, Order::Value).map(|d| d.value);
    }
    // The ladder of `triangle_value`, with Lambert's unclipped sum inlined and the rest cold and
    // out of line: the arguments then stay in registers (as loaded from the C caller's memory)
    // on the common path, rather than go through copies made for calls.
    match lambert::sum::triangle_value_inlined(x, n, v) {
        Some(f) => Ok(f),
        None => value_past_unclipped_lambert(x, n, v),
    }
}

/// [`triangle_form_factor_value`] where Lambert's unclipped sum declines: the clipped sum, else
/// the paths past Lambert.
#[cold]
#[inline(never)]
fn value_past_unclipped_lambert(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Result<f64> {
    match lambert::clipped::triangle_value(x, n, v) {
        Some(f) => Ok(f),
        None => value_past_lambert(x, n, v).map(|d| d.value),
    }
}

/// A triangle thin enough that Lambert's sum and the replay would cancel and be declined:
/// straight to the sliver rule (`polygon_form_factor` has no fast path for three vertices).
fn very_thin_triangle(x: DVec3, n: DVec3, v: [DVec3; 3], order: Order) -> Result<Deriv3> {
    match very_thin_triangle_form_factor_in_range(x, n, v, order) {
        Some(d) => d,
        None => polygon_form_factor(x, n, &v, order),
    }
}

/// [`triangle_form_factor`]'s value order past the thinness test: Lambert's certified sum, else
/// the paths past it.
#[inline(always)]
fn triangle_value(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Result<Deriv3> {
    match triangle_lambert_value(x, n, v) {
        Some(f) => Ok(Deriv3::constant(f)),
        None => value_past_lambert(x, n, v),
    }
}

/// Lambert's sum, over the clipped triangle when the tangent plane cuts it.
#[inline(always)]
fn triangle_lambert_value(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<f64> {
    lambert::sum::triangle_value(x, n, v).or_else(|| lambert::clipped::triangle_value(x, n, v))
}

/// The clipped loop's part of [`triangle_form_factor`]'s derivative orders; out of line, so
/// that the loop's stack frame is not set up on the kernel's other paths.
#[inline(never)]
fn clipped_derivs(x: DVec3, n: DVec3, v: [DVec3; 3], order: Order) -> Option<ClippedDerivs> {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2_fma() {
        // SAFETY: `simd::avx2_fma` checked that the CPU has AVX2 and FMA.
        return unsafe { clipped_derivs_fma(x, n, v, order) };
    }
    clipped_derivs_with(x, n, v, order, false)
}

/// [`clipped_derivs`] compiled with FMA, as `near_plane::triangle` does for the value:
/// the loop's double-double clip points and edge vectors use fused products instead of calls to
/// `fma`, with the same bits (the fused product is correctly rounded either way and Rust fuses
/// nothing else).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn clipped_derivs_fma(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    order: Order,
) -> Option<ClippedDerivs> {
    clipped_derivs_with(x, n, v, order, true)
}

/// [`clipped_derivs`]' body; `fma` when the CPU has AVX2 and FMA, for the parts compiled out of
/// line twice (see `lambert::clipped::with_valued_derivative_loop`).
#[inline(always)]
fn clipped_derivs_with(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    order: Order,
    fma: bool,
) -> Option<ClippedDerivs> {
    with_valued_derivative_loop(
        x,
        n,
        v,
        fma,
        #[inline(always)]
        |l, value| match value {
            LoopValue::Certified => {
                let value = l.value();
                match loop_derivs(l, value, order) {
                    Some(d) => ClippedDerivs::Done(d),
                    None => ClippedDerivs::Declined(Some(value)),
                }
            }
            // The value order's own value (its near-plane route's bits).
            LoopValue::Route(value) => match loop_derivs(l, value, order) {
                Some(d) => ClippedDerivs::Done(d),
                None => ClippedDerivs::Declined(None),
            },
            LoopValue::Far(route) => match deferred_far_piece(route, order) {
                Some(Ok(d)) => ClippedDerivs::Done(d),
                Some(Err(_)) => ClippedDerivs::Declined(None),
                // The route's value was not finite: it declined (the loop is the loop's own).
                None => match loop_derivs(l, 0.0, order) {
                    Some(d) => ClippedDerivs::ValueElsewhere(d, true),
                    None => ClippedDerivs::Declined(None),
                },
            },
            LoopValue::Elsewhere { route_tried } => match loop_derivs(l, 0.0, order) {
                Some(d) => ClippedDerivs::ValueElsewhere(d, route_tried),
                None => ClippedDerivs::Declined(None),
            },
        },
    )
}

/// What the derivative orders take from the clipped loop.
enum ClippedDerivs {
    /// The certified loop's derivatives and value.
    Done(Deriv3),
    /// The uncertified loop's derivatives: the value is the value order's (whose near-plane
    /// route was already tried and declined when the flag is set).
    ValueElsewhere(Deriv3, bool),
    /// Declined, with the certified value when there is one.
    Declined(Option<f64>),
}

/// The value order's result where Lambert's value is not certified: with `x` near the plane
/// outside the visible part the robust path's near-plane split (its bits) without the robust
/// path's set-up, far away the far-field path, else the robust path.
fn value_past_lambert(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Result<Deriv3> {
    value_past_route(x, n, v, true)
}

/// [`value_past_lambert`], without trying the near-plane route unless `try_route` (the caller
/// knows it declines).
fn value_past_route(x: DVec3, n: DVec3, v: [DVec3; 3], try_route: bool) -> Result<Deriv3> {
    if try_route {
        if let Some(f) = near_plane::triangle::triangle_value(x, n, v) {
            return Ok(Deriv3::constant(f));
        }
    }
    if maybe_far(&v, x) {
        if let Some((d, _)) = triangle_far_field_fast(x, n, v, Order::Value) {
            return Ok(d);
        }
    }
    robust_triangle(x, n, v, Order::Value)
}

/// The triangle's form factor past the Lambert and far-field paths.
fn robust_triangle(x: DVec3, n: DVec3, v: [DVec3; 3], order: Order) -> Result<Deriv3> {
    Ok(match triangle_form_factor_fast(x, n, v, order) {
        Some(d) => d,
        None => match triangle_form_factor_in_range(x, n, v, order) {
            Some(d) => d?,
            None => form_factor(x, n, &v, order)?,
        },
    })
}

/// Form factor from a differential area at `x` with unit normal `n` to a planar simple polygon:
/// `F(x) = (1/π) ∫ n·ω dω` over the polygon's solid angle as seen from `x`, i.e.
/// `∫_P cosθ_x cosθ_y / (π ‖y − x‖²) dA_y`. The part of the polygon below the tangent plane
/// (`n·(v − x) < 0`) is clipped away, so `0 ≤ F ≤ 1`. Value, gradient and Hessian with respect to
/// `x` (`n` fixed).
///
/// * **Orientation-free.** The vertices may run either way; the polygon is two-sided (it is seen from
///   whichever side `x` is on).
/// * **Clipping.** The derivatives are those of the true clipped function: the clip line moves with
///   `x`. The integrand vanishes on the clip line, so the gradient equals that of the clipped polygon
///   held fixed, while the Hessian gains `n nᵀ (|h_P| / (π ‖n_t‖)) ∫_{P∩ℓ} ds/‖y − x‖⁴` (ℓ the clip
///   line, `h_P` the distance from `x` to the polygon's plane, `n_t` the part of `n` in that plane).
/// * **Accuracy.** Near `x` the edge sum of [`edge_form_factor`] is evaluated in a cancellation-free
///   form. Far away (distance from the visible part's vertex centroid above 16 times its radius) the
///   edge sum cancels (terms ~size/d, sum ~(size/d)²), so the kernel integrates the smooth integrand
///   instead with an n x n Gauss-Legendre rule per fan triangle (Duffy map), n = 8 from 16 radii,
///   6 from 100, 5 from 280, 4 from 1500 and 3 from 36000 (an a-priori bound keeps the rule's
///   relative error below 1e-14 for value and gradient, 1e-12 for the Hessian); both sides of
///   every switch meet 1e-12. When the edge sum cancels by more than 100x for another reason
///   (`x` near the plane, a thin visible part; for slivers, `2·area < 1e-2·extent²`, only beyond
///   1e4x: their edge terms are accurate to a few ulps, so the sum keeps a few ulps times the
///   cancellation, within the hard-regime contract), the fan triangles are
///   bisected until each is 16 radii away and integrated the same way (at most 256 pieces).
///   Slivers thinner than that (`2·area < 1e-5·extent²`, 4 to 8 vertices, every fan triangle from
///   the first vertex oriented as the polygon, nothing clipped, x not near the plane, x far from
///   each fan triangle compared with its width) are instead the sum of their fan triangles, each
///   by the anisotropic sliver rule of the triangle kernel.
///   With `x` near the plane, outside the (clipped) polygon, the value comes from a near-plane
///   split without cancellation (exact winding number, small per-edge terms, the clip edges in
///   closed form) and the derivatives from the edge sum; only where that split's own parts cancel
///   (the clip line cutting a tiny corner off) does the quadrature run, with up to 4096 pieces
///   (~1 ms). Near-singular quantities (the cross product `r_a × r_b` near an edge's line, the
///   height over the plane near it, a sliver's normal, the clip points) are computed in
///   double-double from the exact differences `v − x`, only when needed. Measured worst errors per
///   regime are in `docs/kernels.md`.
/// * **Fast path.** For [`Order::Value`], a strictly convex polygon of 4 to 8 vertices entirely
///   above the tangent plane, which passes the validation below by a wide margin, is evaluated by
///   Lambert's sum (or its cancellation-free far-field form) with a running error bound, accepted
///   within 5e-13; the other orders return that same value when it is certified. Gradient and
///   Hessian of such a polygon come from the analytic derivatives of Lambert's per-edge terms when
///   its value is certified, no edge's line passes near `x` (the angle each edge subtends has
///   `sin β ≥ 1/4`) and neither derivative sum cancels by more than 100x; otherwise from the
///   robust path below. The same polygons with the tangent plane certainly cutting them and `x`
///   within 1e-3 of the size from their plane, over their interior, take Lambert's sum over the
///   clipped loop with its own running bound (clip points formed in double-double on the edges;
///   declined within ~1e-9 of the clip line, near an edge's segment and where the sum cancels)
///   and that loop's derivatives, at every order with the same value.
/// * **Validation.** `x`, `n` and every vertex must be finite; `n` unit length within a relative
///   1e-6 (it is renormalized); at least 3 vertices; planar within 1e-8 of the polygon's extent
///   plus twice the rounding of its Newell normal (`(4 + count)·count·ε·extent²/(2·area)` of the
///   extent: negligible unless the polygon is a sliver, ~1e-4 for a quad 1e-10 wide), so that thin
///   planar polygons are accepted (4 or more vertices: a triangle is planar however thin);
///   simple (no two non-adjacent edges touch; checked in O(count²) for count > 3). Violations give
///   [`Error::InvalidArgument`](crate::Error::InvalidArgument).
/// * **Limits.** A polygon with (numerically) zero area (`2·area ≤ 1e-13 extent²`, the extent being
///   the largest distance from the first vertex) gives
///   [`Error::Degenerate`](crate::Error::Degenerate). For `x` in the polygon's plane (within 4 ulps
///   of the coordinates) the value is 0 (the polygon is seen edge-on) and the gradient is undefined
///   (the two-sided form factor has a crease there): orders above [`Order::Value`] give
///   [`Error::Degenerate`](crate::Error::Degenerate). A polygon entirely below the tangent plane
///   gives 0 with zero derivatives. Derivatives that overflow `f64` give
///   [`Error::Degenerate`](crate::Error::Degenerate); NaN or Inf never come out.
/// * **Head-on receivers near the plane.** With `n` within ~1e-6 rad of the polygon's normal and
///   `x` near the plane, the value keeps the hard-regime accuracy but the gradient's relative error
///   grows like `6u/tilt` (`u` the unit roundoff: 4e-9 at 2.5e-7 rad, 4e-7 at 2e-9 rad); the value
///   there moves by up to 1e-7 relative per ulp of `n`, so `n` should be as exact as the caller has
///   it (docs/kernels.md, "Grazing receivers").
///
/// ```
/// use glam::DVec3;
/// use raddiff::{kernels, Order};
/// // A disc-like square far above: F ≈ area cos² / (π d²).
/// let s = 0.01;
/// let v = [DVec3::new(-s, -s, 1.), DVec3::new(s, -s, 1.), DVec3::new(s, s, 1.), DVec3::new(-s, s, 1.)];
/// let d = kernels::polygon_form_factor(DVec3::ZERO, DVec3::Z, &v, Order::Hessian)?;
/// assert!((d.value - 4.0 * s * s / std::f64::consts::PI).abs() < 1e-7);
/// assert!(d.gradient.z > 0.0); // moving towards the square increases F
/// # Ok::<(), raddiff::Error>(())
/// ```
pub fn polygon_form_factor(x: DVec3, n: DVec3, vertices: &[DVec3], order: Order) -> Result<Deriv3> {
    // The certified value of a convex polygon clipped near its plane, when the derivative
    // orders' clipped loop certified it and its derivatives declined.
    let mut clipped_value = None;
    if order == Order::Value {
        if let Some(f) = polygon_lambert_value(x, n, vertices) {
            return Ok(Deriv3::constant(f));
        }
    } else {
        // As for triangles: far away the replay of the robust far-field rule first (Lambert's
        // derivative sums would cancel and be declined), with the certified value.
        if let Some((d, _)) = polygon_far_field_fast(x, n, vertices, order) {
            return Ok(with_lambert_value(d, order, || {
                polygon_lambert_value(x, n, vertices)
            }));
        }
        // Unclipped, Lambert's derivatives; clipped near the plane, those of the certified
        // clipped loop, with its value.
        if let Some(d) = polygon_derivs_or_clipped(x, n, vertices, order, &mut clipped_value) {
            return Ok(d);
        }
    }
    // A sliver: the fan triangles' sliver rules instead of the robust path's isotropic subdivision,
    // or, declined with x near the sliver's plane, the fan triangles through the triangle kernel's
    // sliver handling (`tests/form_factor_polygon_slivers.rs`). Lambert's paths decline every
    // polygon these take (`convex::SLIVER_AREA2`): their value is the value order's as it
    // is.
    let fan_triangle = |a, b, c| triangle_form_factor(x, n, a, b, c, order);
    if let Some(d) = very_thin_polygon_form_factor(x, n, vertices, order, fan_triangle) {
        return Ok(d);
    }
    let d = match polygon_form_factor_in_range(x, n, vertices, order) {
        Some(d) => d?,
        None => form_factor(x, n, vertices, order)?,
    };
    // The clipped loop's value and Lambert's unclipped one exclude each other (a vertex below
    // the tangent plane, or none).
    Ok(with_lambert_value(d, order, || {
        lambert::polygon::polygon_value(x, n, vertices).or(clipped_value)
    }))
}

/// Lambert's certified sum for a polygon, over the clipped loop when the tangent plane cuts it:
/// the value order's fast paths, in their order.
#[inline(always)]
fn polygon_lambert_value(x: DVec3, n: DVec3, vertices: &[DVec3]) -> Option<f64> {
    polygon_value_or_clipped(x, n, vertices)
}

/// [`lambert::polygon::polygon_value`], or where the tangent plane cuts the polygon near its plane,
/// Lambert's sum over the clipped loop ([`lambert::clipped_polygon::polygon_value`]): the value
/// order's fast paths, sharing the unclipped test (a polygon that fails it for a vertex below the
/// tangent plane is the clipped path's; slivers and other polygons that pass it are left alone).
/// Where the clipped loop declines (outside the polygon near its plane, where its sum cancels), the
/// replay of the robust path's near-plane split
/// ([`near_plane::polygon::polygon_value`]:
/// the robust bits).
pub(crate) fn polygon_value_or_clipped(x: DVec3, n: DVec3, v: &[DVec3]) -> Option<f64> {
    use lambert::clipped_polygon::polygon_value as clipped;
    use near_plane::polygon::polygon_value as route;
    match v.len() {
        4 => {
            let v = v.try_into().ok()?;
            value_or::<4>(x, n, v, || {
                clipped::<4, 5>(x, n, v).or_else(|| route::<4, 8>(x, n, v))
            })
        }
        5 => {
            let v = v.try_into().ok()?;
            value_or::<5>(x, n, v, || {
                clipped::<5, 6>(x, n, v).or_else(|| route::<5, 10>(x, n, v))
            })
        }
        6 => {
            let v = v.try_into().ok()?;
            value_or::<6>(x, n, v, || {
                clipped::<6, 7>(x, n, v).or_else(|| route::<6, 12>(x, n, v))
            })
        }
        7 => {
            let v = v.try_into().ok()?;
            value_or::<7>(x, n, v, || {
                clipped::<7, 8>(x, n, v).or_else(|| route::<7, 14>(x, n, v))
            })
        }
        8 => {
            let v = v.try_into().ok()?;
            value_or::<8>(x, n, v, || {
                clipped::<8, 9>(x, n, v).or_else(|| route::<8, 16>(x, n, v))
            })
        }
        _ => None,
    }
}

/// `polygon_derivs`, or where the tangent plane cuts the polygon near its plane, the derivatives of
/// the clipped loop ([`lambert::clipped_polygon::polygon_derivs`]), or where that loop is not
/// certified (outside near the plane), those of the loop with the value of the robust path's
/// near-plane split ([`lambert::clipped_polygon::routed_polygon_derivs`], the value order's bits
/// there); `None` where neither accepts, with `*clipped_value` the clipped loop's certified value
/// where that is.
pub(crate) fn polygon_derivs_or_clipped(
    x: DVec3,
    n: DVec3,
    v: &[DVec3],
    order: Order,
    clipped_value: &mut Option<f64>,
) -> Option<Deriv3> {
    let mut clipped = |d: Option<std::result::Result<Deriv3, f64>>| match d? {
        Ok(d) => Some(d),
        Err(value) => {
            *clipped_value = Some(value);
            None
        }
    };
    use clipped_polygon_derivs as derivs;
    match v.len() {
        4 => {
            let v = v.try_into().ok()?;
            derivs_or::<4>(x, n, v, order, || {
                clipped(derivs::<4, 5, 8>(x, n, v, order))
            })
        }
        5 => {
            let v = v.try_into().ok()?;
            derivs_or::<5>(x, n, v, order, || {
                clipped(derivs::<5, 6, 10>(x, n, v, order))
            })
        }
        6 => {
            let v = v.try_into().ok()?;
            derivs_or::<6>(x, n, v, order, || {
                clipped(derivs::<6, 7, 12>(x, n, v, order))
            })
        }
        7 => {
            let v = v.try_into().ok()?;
            derivs_or::<7>(x, n, v, order, || {
                clipped(derivs::<7, 8, 14>(x, n, v, order))
            })
        }
        8 => {
            let v = v.try_into().ok()?;
            derivs_or::<8>(x, n, v, order, || {
                clipped(derivs::<8, 9, 16>(x, n, v, order))
            })
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests;
