//! Point-to-polygon form factors (the Lambert / Holzschuch-Sillion edge sum) with gradient and
//! Hessian with respect to the receiving point.
//!
//! For a differential area at `x` with unit normal `n` and a polygon with vertices `v_i`
//! (`r_i = v_i − x`), the form factor is
//!
//! ```text
//! F(x) = (1/π) ∫_{Ω(P)} n·ω dω = (1/2π) Σ_i β_i n·(r_i × r_{i+1}) / ‖r_i × r_{i+1}‖,
//! ```
//!
//! `β_i` the angle between `r_i` and `r_{i+1}`. Each edge term is rewritten as a line integral
//! (Holzschuch and Sillion): with `e = v_{i+1} − v_i`, `w = r_i × e` (= `r_i × r_{i+1}`),
//! `I(x) = ∫₀¹ dt / ‖r_i + t e‖²` (= `β_i / ‖w‖`),
//!
//! ```text
//! f_i = (1/2π) (n·w) I,   ∇f_i = (1/2π) [(n × e) I + (n·w) ∇I],
//! Hf_i = (1/2π) [(n × e) ∇Iᵀ + ∇I (n × e)ᵀ + (n·w) HI],
//! ∇I = 2 ∫ r/‖r‖⁴ dt,   HI = −2 (∫ dt/‖r‖⁴) 𝟙 + 8 ∫ r rᵀ/‖r‖⁶ dt.
//! ```
//!
//! (This re-derives the thesis' eq. 6.5-6.6, whose printed form is garbled: the leading
//! "−(−1/2π)" and "norm γ_i" are extraction errors for 1/2π and the edge angle β_i.)
//! The integrals are evaluated in the edge's own frame (foot point `p`, direction `ê`, abscissae
//! `s_a`, `s_b`, distance `h` to the edge's line) with closed forms arranged to avoid cancellation,
//! and with convergent series when `x` lies near the extension of the edge's line.

use glam::{DMat3, DVec3};

use crate::error::{ensure_finite3, Error, Result};
use crate::{Deriv3, Order};

use super::lambert;
use super::lambert_clipped::{self, LoopValue};
use super::lambert_clipped_derivs;
use super::lambert_polygon;
use super::numeric::dd;
use super::polygon;

const INV_2PI: f64 = 0.5 * std::f64::consts::FRAC_1_PI;

/// Below this ratio `h / min(|s_a|, |s_b|)` (x near the extension of the edge's line, both
/// endpoints on the same side) the moments use series in `(h/s)²` instead of recurrences that
/// divide by `h²`. At the boundary the recurrences lose at most a factor `(1/0.25)⁴ = 256` in
/// relative precision; the series converge like `0.0625^k`.
const AXIAL_RATIO: f64 = 0.25;

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
///   [`Error::InvalidArgument`]. `x`, `a`, `b` must be finite.
/// * Units: dimensionless value, gradient per L, Hessian per L².
/// * Limits: `a == b` gives 0 with zero derivatives. For `x` on the edge's line but outside the
///   segment the term and its derivatives are finite (their continuous limit; `β = 0`). For `x` on
///   the closed segment `[a, b]` the term is undefined: [`Error::Degenerate`]. If derivatives would
///   overflow (for example `x` within ~1e-100 of the segment) [`Error::Degenerate`].
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
        if let Some(f) = lambert::edge_value(x, n, a, b) {
            return Ok(Deriv3::constant(f));
        }
    } else if let Some(d) = lambert::edge_derivs_checked(x, n, a, b, order) {
        return Ok(d);
    }
    let d = edge_form_factor_slow(x, n, a, b, order)?;
    // The value must not depend on the order asked for: where Lambert's value is certified but
    // its derivatives are not, the derivatives come from the paths below and the value from it.
    Ok(with_lambert_value(d, order, || {
        lambert::edge_value(x, n, a, b)
    }))
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
    let n = polygon::unit_normal(n)?;
    let scaled = polygon::Scaled::new(x, &[a, b])?;
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
    // Lambert's sum and the replay would cancel and be declined: straight to the sliver rule
    // (`polygon_form_factor` has no fast path for three vertices).
    if polygon::is_very_thin_triangle([a, b, c]) {
        return match polygon::very_thin_triangle_form_factor_in_range(x, n, [a, b, c], order) {
            Some(d) => d,
            None => polygon_form_factor(x, n, &[a, b, c], order),
        };
    }
    let lambert_value = || triangle_lambert_value(x, n, [a, b, c]);
    if order == Order::Value {
        return match triangle_lambert_value(x, n, [a, b, c]) {
            Some(f) => Ok(Deriv3::constant(f)),
            None => value_past_lambert(x, n, [a, b, c]),
        };
    }
    // Far away Lambert's derivatives would be computed only to be declined (their sums
    // cancel): the far-field quadrature first. Its value is replaced by Lambert's where that is
    // certified (its cancellation-free far form reaches any distance), so that the value is
    // the same for every order.
    if maybe_far(&[a, b, c], x) {
        if let Some((d, _)) = triangle_far_field_fast(x, n, [a, b, c], order) {
            return Ok(with_lambert_value(d, order, lambert_value));
        }
    }
    if let Some(d) = lambert::triangle_derivs(x, n, [a, b, c], order) {
        return Ok(d);
    }
    // Near the plane with the tangent plane cutting the triangle: the derivatives of the
    // certified clipped loop, whose value is `lambert_value`'s, or outside the triangle (the sum
    // cancels) or on the clip line those of the uncertified loop, with the value order's value
    // (no Lambert value there: clipped, uncertified). One cut and one loop for both, used in
    // place; a certified value is kept for the robust path below (computing it twice cost ~400
    // instructions where the derivatives decline).
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
        lambert::triangle_value(x, n, [a, b, c]).or(certified_value)
    }))
}

/// Lambert's sum, over the clipped triangle when the tangent plane cuts it (inlined: a closure
/// here was left out of line, ~40 instructions on the value order's every call).
#[inline(always)]
fn triangle_lambert_value(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<f64> {
    lambert::triangle_value(x, n, v).or_else(|| lambert_clipped::triangle_value(x, n, v))
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

/// [`clipped_derivs`] compiled with FMA, as `polygon::near_plane_triangle` does for the value:
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
/// line twice (see `lambert_clipped::with_valued_derivative_loop`).
#[inline(always)]
fn clipped_derivs_with(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    order: Order,
    fma: bool,
) -> Option<ClippedDerivs> {
    lambert_clipped::with_valued_derivative_loop(
        x,
        n,
        v,
        fma,
        #[inline(always)]
        |l, value| match value {
            LoopValue::Certified => {
                let value = l.value();
                match lambert_clipped_derivs::loop_derivs(l, value, order) {
                    Some(d) => ClippedDerivs::Done(d),
                    None => ClippedDerivs::Declined(Some(value)),
                }
            }
            // The value order's own value (its near-plane route's bits).
            LoopValue::Route(value) => match lambert_clipped_derivs::loop_derivs(l, value, order) {
                Some(d) => ClippedDerivs::Done(d),
                None => ClippedDerivs::Declined(None),
            },
            LoopValue::Far(route) => match polygon::deferred_far_piece(route, order) {
                Some(Ok(d)) => ClippedDerivs::Done(d),
                Some(Err(_)) => ClippedDerivs::Declined(None),
                // The route's value was not finite: it declined (the loop is the loop's own).
                None => match lambert_clipped_derivs::loop_derivs(l, 0.0, order) {
                    Some(d) => ClippedDerivs::ValueElsewhere(d, true),
                    None => ClippedDerivs::Declined(None),
                },
            },
            LoopValue::Elsewhere { route_tried } => {
                match lambert_clipped_derivs::loop_derivs(l, 0.0, order) {
                    Some(d) => ClippedDerivs::ValueElsewhere(d, route_tried),
                    None => ClippedDerivs::Declined(None),
                }
            }
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
        if let Some(f) = polygon::near_plane_triangle_value(x, n, v) {
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
        None => match polygon::triangle_form_factor_in_range(x, n, v, order) {
            Some(d) => d?,
            None => polygon::form_factor(x, n, &v, order)?,
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
///   [`Error::InvalidArgument`].
/// * **Limits.** A polygon with (numerically) zero area (`2·area ≤ 1e-13 extent²`, the extent being
///   the largest distance from the first vertex) gives [`Error::Degenerate`]. For `x` in the polygon's plane (within 4 ulps of the coordinates) the
///   value is 0 (the polygon is seen edge-on) and the gradient is undefined (the two-sided form
///   factor has a crease there): orders above [`Order::Value`] give [`Error::Degenerate`]. A polygon
///   entirely below the tangent plane gives 0 with zero derivatives. Derivatives that overflow `f64`
///   give [`Error::Degenerate`]; NaN or Inf never come out.
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
        if let Some(d) =
            lambert_polygon::polygon_derivs_or_clipped(x, n, vertices, order, &mut clipped_value)
        {
            return Ok(d);
        }
    }
    // A sliver: the fan triangles' sliver rules instead of the robust path's isotropic
    // subdivision (~30x fewer instructions), or, declined with x near the sliver's plane, the
    // fan triangles through the triangle kernel's sliver handling
    // (`tests/kernels_b_polygon_slivers.rs`). Lambert's paths decline every polygon these take
    // (`lambert_polygon::SLIVER_AREA2`): their value is the value order's as it is.
    if let Some(d) = polygon::very_thin_polygon_form_factor(x, n, vertices, order) {
        return Ok(d);
    }
    let d = match polygon::polygon_form_factor_in_range(x, n, vertices, order) {
        Some(d) => d?,
        None => polygon::form_factor(x, n, vertices, order)?,
    };
    // The clipped loop's value and Lambert's unclipped one exclude each other (a vertex below
    // the tangent plane, or none).
    Ok(with_lambert_value(d, order, || {
        lambert_polygon::polygon_value(x, n, vertices).or(clipped_value)
    }))
}

/// Lambert's certified sum for a polygon, over the clipped loop when the tangent plane cuts it:
/// the value order's fast paths, in their order.
#[inline(always)]
fn polygon_lambert_value(x: DVec3, n: DVec3, vertices: &[DVec3]) -> Option<f64> {
    lambert_polygon::polygon_value_or_clipped(x, n, vertices)
}

/// Closed-form integrals along an edge, in the edge frame: `A_m = ∫ ds/ρ^{2m}`,
/// `B_m = ∫ s ds/ρ^{2m}`, `C_3 = ∫ s² ds/ρ⁶` over `s ∈ [s_a, s_b]`, `ρ² = s² + h²`.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct EdgeMoments {
    pub a1: f64,
    pub a2: f64,
    pub a3: f64,
    pub b2: f64,
    pub b3: f64,
    pub c3: f64,
}

/// An edge seen from the origin: `r(s) = p + s ê`, `s ∈ [s_a, s_a + len]`, `‖p‖ = h`, `p ⊥ ê`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct EdgeFrame {
    pub e_hat: DVec3,
    pub len: f64,
    pub p: DVec3,
    /// `r_a × e`.
    pub w: DVec3,
    pub h: f64,
    pub sa: f64,
    pub sb: f64,
}

/// Below this `‖w‖ / (‖r_a‖ ‖e‖)` (the sine of the angle between `r_a` and the edge), the f64 cross
/// product `w = r_a × e` has lost more than ~1% of its digits to the rounding of `r_a` and `e`, and
/// [`EdgeFrame::with_exact_ends`] recomputes it in double-double from the exact endpoints.
pub(crate) const NEAR_LINE_SINE: f64 = 1e-2;

impl EdgeFrame {
    /// `None` for a zero-length edge.
    pub(crate) fn new(r_a: DVec3, e: DVec3) -> Option<Self> {
        Self::with_exact_ends(r_a, e, None)
    }

    /// As [`EdgeFrame::new`]; when `x` is near the edge's line and `ends` gives the endpoints
    /// relative to `x` exactly (as unevaluated sums `hi + lo`), `w`, `h` and `p` are taken from a
    /// double-double cross product instead of the rounded `r_a × e`.
    pub(crate) fn with_exact_ends(r_a: DVec3, e: DVec3, ends: Option<&ExactEnds>) -> Option<Self> {
        let len = e.length();
        if len == 0.0 {
            return None;
        }
        let e_hat = e / len;
        let mut w = r_a.cross(e);
        let mut sa = r_a.dot(e_hat);
        let mut sb = sa + len;
        let mut p = r_a - sa * e_hat;
        if let Some(ends) = ends {
            let bound = NEAR_LINE_SINE * len;
            if w.length_squared() < bound * bound * r_a.length_squared() {
                w = ends.cross();
                // w = p × e, so e × w = p ‖e‖² (no cancellation once w is accurate).
                p = e.cross(w) / (len * len);
                // x near the line is often near an endpoint too, where `s_a + L` cancels.
                sa = ends.a[0].dot(e_hat) + ends.a[1].dot(e_hat);
                sb = ends.b[0].dot(e_hat) + ends.b[1].dot(e_hat);
            }
        }
        let h = w.length() / len;
        Some(EdgeFrame {
            e_hat,
            len,
            p,
            w,
            h,
            sa,
            sb,
        })
    }

    /// The moments up to what `order` needs (`A_1`; `A_2, B_2`; `A_3, B_3, C_3`).
    pub(crate) fn moments(&self, order: Order) -> Result<EdgeMoments> {
        let (sa, sb, h, len) = (self.sa, self.sb, self.h, self.len);
        let mut m = EdgeMoments::default();
        let h2 = h * h;
        let d = h2 + sa * sb; // r_a · r_b
        let axial = sa * sb > 0.0 && h < AXIAL_RATIO * sa.abs().min(sb.abs());
        if axial {
            // x near the extension of the edge's line: β ≈ hL/(s_a s_b) is tiny and every
            // h²-recurrence would cancel. tan β = hL/D with D > 0, and β/h = (L/D) atan(X)/X.
            let xx = h * len / d;
            m.a1 = len / d * atan_over(xx);
        } else {
            if h == 0.0 {
                return Err(Error::Degenerate(
                    "the point lies on the edge: the edge term is undefined".into(),
                ));
            }
            m.a1 = (h * len).atan2(d) / h;
        }
        if !order.gradient() {
            return Ok(m);
        }
        let ra2 = sa * sa + h2;
        let rb2 = sb * sb + h2;
        let rab2 = ra2 * rb2;
        m.b2 = len * (sa + sb) / (2.0 * rab2);
        let (near, far) = if sa.abs() < sb.abs() {
            (sa.abs(), sb.abs())
        } else {
            (sb.abs(), sa.abs())
        };
        if axial {
            m.a2 = axial_a2(near, far, len, h);
        } else {
            // [s/ρ²]_a^b = L (h² − s_a s_b) / (ρ_a² ρ_b²), factored so it cannot cancel.
            m.a2 = (len * (h2 - sa * sb) / rab2 + m.a1) / (2.0 * h2);
        }
        if !order.hessian() {
            return Ok(m);
        }
        m.b3 = len * (sa + sb) * (ra2 + rb2) / (4.0 * rab2 * rab2);
        if axial {
            m.a3 = axial_a3(near, far, len, h);
        } else {
            // [s/ρ⁴]_a^b = L (h⁴ − 2 s_a s_b h² − s_a s_b (s_a² + s_a s_b + s_b²)) / (ρ_a⁴ ρ_b⁴).
            let bracket = h2 * h2 - 2.0 * sa * sb * h2 - sa * sb * (sa * sa + sa * sb + sb * sb);
            m.a3 = (len * bracket / (rab2 * rab2) + 3.0 * m.a2) / (4.0 * h2);
        }
        m.c3 = m.a2 - h2 * m.a3;
        Ok(m)
    }
}

/// `atan(x)/x`, 1 at 0.
fn atan_over(x: f64) -> f64 {
    if x.abs() < 1e-8 {
        1.0 - x * x / 3.0
    } else {
        x.atan() / x
    }
}

/// `A_2 = ∫ dσ/(σ² + h²)²` over `[near, far]` (`far − near = len`, `h ≤ near/4`): the tails
/// `∫_s^∞ = T₂((h/s)²)/s³`, `T₂(y) = Σ_k (−1)^k (k+1) y^k / (2k+3)`, differenced in factored
/// form. Their plain difference cancels by `~near/len` (1.6e-8 relative for an edge 1e-8 of its
/// distance long, the error once blamed on a short edge's frame); here
/// `T₂(y_n)/n³ − T₂(y_f)/f³ = (y_n − y_f) T₂[y_n, y_f]/n³ + T₂(y_f)(1/n³ − 1/f³)` with
/// `y_n − y_f = y_n (1 + q) len/f` and `1/n³ − 1/f³ = (1 + q + q²) len/(n³ f)` (`q = n/f`) adds
/// two terms, the smaller (of opposite sign) at most ~0.3 of the other: a few ulps at every length.
fn axial_a2(near: f64, far: f64, len: f64, h: f64) -> f64 {
    let (y_n, y_f) = ((h / near) * (h / near), (h / far) * (h / far));
    let (t, slope) = axial_series::<20>(y_n, y_f, |k| (k + 1.0) / (2.0 * k + 3.0));
    let q = near / far;
    let inv = 1.0 / near;
    len / far * (inv * inv * inv) * (y_n * (1.0 + q) * slope + t * (1.0 + q * (1.0 + q)))
}

/// `A_3 = ∫ dσ/(σ² + h²)³` over `[near, far]` as [`axial_a2`]: tails `T₃((h/s)²)/s⁵` with
/// `T₃(y) = Σ_k (−1)^k (k+1)(k+2)/2 · y^k / (2k+5)`, and
/// `1/n⁵ − 1/f⁵ = (1 + q + q² + q³ + q⁴) len/(n⁵ f)`.
fn axial_a3(near: f64, far: f64, len: f64, h: f64) -> f64 {
    let (y_n, y_f) = ((h / near) * (h / near), (h / far) * (h / far));
    let (t, slope) =
        axial_series::<22>(y_n, y_f, |k| 0.5 * (k + 1.0) * (k + 2.0) / (2.0 * k + 5.0));
    let q = near / far;
    let inv = 1.0 / near;
    let inv5 = inv * inv * inv * inv * inv;
    let powers = 1.0 + q * (1.0 + q * (1.0 + q * (1.0 + q)));
    len / far * inv5 * (y_n * (1.0 + q) * slope + t * powers)
}

/// `(P(y_f), (P(y_n) − P(y_f))/(y_n − y_f))` for `P(y) = Σ_{k<K} (−1)^k c(k) y^k`: Horner's rule at
/// `y_f` and its divided difference alongside (`D_k = D_{k+1} y_n + P_{k+1}(y_f)`), which never
/// subtracts the two values (`y ≤ 1/16`, the terms fall like `16^{-k}`).
#[inline]
fn axial_series<const K: usize>(y_n: f64, y_f: f64, c: impl Fn(f64) -> f64) -> (f64, f64) {
    let (mut p, mut slope) = (0.0, 0.0);
    for k in (0..K).rev() {
        let kf = k as f64;
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        slope = slope * y_n + p;
        p = p * y_f + sign * c(kf);
    }
    (p, slope)
}

/// `a bᵀ + b aᵀ`.
pub(crate) fn sym_outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x + b * a.x, a * b.y + b * a.y, a * b.z + b * a.z)
}

/// `a aᵀ`.
pub(crate) fn outer_self(a: DVec3) -> DMat3 {
    DMat3::from_cols(a * a.x, a * a.y, a * a.z)
}

/// The edge term of an edge lying on the clip line (in the tangent plane through x), with the
/// motion of the clip line folded in.
///
/// In the tangent plane `q = n × ê` is the in-plane normal of the edge, `p = (q·p) q`, `ν = −q·p`.
/// Substituting these in the general term, the gradient becomes `(−[s/ρ²] q − 2 (q·p) B_2 ê)/2π`
/// and the Hessian `(−2 (q·p) [s/ρ⁴] (q qᵀ − ê êᵀ) + 2 (B_2 − 4h² B_3)(q êᵀ + ê qᵀ))/2π` once the
/// clip-line term `n nᵀ |h_P| A_2/(π‖n_t‖)` (with `|h_P| = h ‖n_t‖`) has cancelled the `n nᵀ`
/// part. The general expressions reach these as differences of terms of size `1/h` (`1/h²`) when x
/// is near the clip line, which is where the clip line always passes when x is near the plane.
pub(crate) fn clip_edge_term(
    r_a: DVec3,
    e: DVec3,
    n: DVec3,
    order: Order,
    ends: Option<&ExactEnds>,
) -> Result<Deriv3> {
    let Some(f) = EdgeFrame::with_exact_ends(r_a, e, ends) else {
        return Ok(Deriv3::constant(0.0));
    };
    let m = f.moments(Order::Value)?;
    let nu = n.dot(f.w) / f.len;
    let mut out = Deriv3::constant(INV_2PI * nu * m.a1);
    if !order.gradient() {
        return Ok(out);
    }
    let (gradient, hessian) = clip_edge_derivs(&f, n, order.hessian());
    out.gradient = INV_2PI * gradient;
    if order.hessian() {
        out.hessian = hessian * INV_2PI;
    }
    Ok(out)
}

/// `2π` times the gradient and (when `hessian`, else zero) the Hessian of [`clip_edge_term`] from
/// the edge's frame (only `e_hat`, `len`, `p`, `h`, `sa`, `sb` are read). No division by `h`:
/// bounded as `x` approaches the clip line, and changed only by `O(δ)` when the frame's inputs
/// move by `δ` (the derivative fast path for clipped triangles relies on both).
#[inline]
pub(crate) fn clip_edge_derivs(f: &EdgeFrame, n: DVec3, hessian: bool) -> (DVec3, DMat3) {
    let (sa, sb, h, len) = (f.sa, f.sb, f.h, f.len);
    let h2 = h * h;
    let ra2 = sa * sa + h2;
    let rb2 = sb * sb + h2;
    let rab2 = ra2 * rb2;
    let q = n.cross(f.e_hat);
    let qp = q.dot(f.p);
    let b2 = len * (sa + sb) / (2.0 * rab2);
    let s_rho2 = len * (h2 - sa * sb) / rab2;
    let gradient = -s_rho2 * q - 2.0 * qp * b2 * f.e_hat;
    if !hessian {
        return (gradient, DMat3::ZERO);
    }
    let b3 = len * (sa + sb) * (ra2 + rb2) / (4.0 * rab2 * rab2);
    let bracket = h2 * h2 - 2.0 * sa * sb * h2 - sa * sb * (sa * sa + sa * sb + sb * sb);
    let s_rho4 = len * bracket / (rab2 * rab2);
    let hess = (outer_self(q) - outer_self(f.e_hat)) * (-2.0 * qp * s_rho4)
        + sym_outer(q, f.e_hat) * (2.0 * (b2 - 4.0 * h2 * b3));
    (gradient, hess)
}

/// The edge term for `r_a = a − x` and `e = b − a` (in any consistent length unit), unit `n`.
pub(crate) fn edge_term(r_a: DVec3, e: DVec3, n: DVec3, order: Order) -> Result<Deriv3> {
    edge_term_exact(r_a, e, n, order, None)
}

/// [`edge_term`], with the exact endpoints (when known) for `x` near the edge's line.
pub(crate) fn edge_term_exact(
    r_a: DVec3,
    e: DVec3,
    n: DVec3,
    order: Order,
    ends: Option<&ExactEnds>,
) -> Result<Deriv3> {
    let Some(f) = EdgeFrame::with_exact_ends(r_a, e, ends) else {
        return Ok(Deriv3::constant(0.0));
    };
    frame_term(&f, n, order)
}

/// The edge term from its frame (see [`edge_term_exact`]).
pub(crate) fn frame_term(f: &EdgeFrame, n: DVec3, order: Order) -> Result<Deriv3> {
    let m = f.moments(order)?;
    // ν = n·w / L = n·(p × ê): the edge's lever arm about n.
    let nu = n.dot(f.w) / f.len;
    let mut out = Deriv3::constant(INV_2PI * nu * m.a1);
    if !order.gradient() {
        return Ok(out);
    }
    let n_x_e = n.cross(f.e_hat);
    // ∇I · L / 2 = p A_2 + ê B_2
    let g = f.p * m.a2 + f.e_hat * m.b2;
    out.gradient = INV_2PI * (n_x_e * m.a1 + 2.0 * nu * g);
    if order.hessian() {
        let curv =
            outer_self(f.p) * m.a3 + sym_outer(f.p, f.e_hat) * m.b3 + outer_self(f.e_hat) * m.c3;
        let hi = DMat3::IDENTITY * (-2.0 * m.a2) + curv * 8.0;
        out.hessian = (sym_outer(n_x_e, g) * 2.0 + hi * nu) * INV_2PI;
    }
    Ok(out)
}

/// The endpoints of an edge relative to `x`, each exactly `hi + lo` (from an error-free difference
/// of the input coordinates).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ExactEnds {
    pub a: [DVec3; 2],
    pub b: [DVec3; 2],
}

impl ExactEnds {
    /// `r_a × r_b` (= `r_a × e`) in double-double, rounded once.
    fn cross(&self) -> DVec3 {
        let a = dd::Dd3::from_parts(self.a[0], self.a[1]);
        let b = dd::Dd3::from_parts(self.b[0], self.b[1]);
        a.cross(&b).to_dvec3()
    }
}

// ------------------------------------------------------------------------------------------------
// Fast paths.

/// Coordinate differences the fast paths accept (outside, the robust path's exact power-of-two
/// rescaling is needed to keep intermediate products in range).
const FAST_RANGE: (f64, f64) = (1e-30, 1e30);

/// `‖v‖_∞` of the differences, `None` outside [`FAST_RANGE`] (NaN and infinities included).
#[inline]
fn in_fast_range<'a>(vs: impl IntoIterator<Item = &'a DVec3>) -> Option<()> {
    let m = vs
        .into_iter()
        .fold(0.0f64, |m, v| m.max(v.abs().max_element()));
    (m > FAST_RANGE.0 && m < FAST_RANGE.1).then_some(())
}

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

/// The fast evaluation of [`edge_form_factor`]: `None` when the inputs are invalid or out of
/// [`FAST_RANGE`], or `x` is near the edge's line (where the robust path switches to double-double
/// cross products). Elsewhere the robust path evaluates exactly these f64 operations on inputs
/// rescaled by a power of two, which changes no rounding: the result is bit-for-bit the robust one,
/// so it carries the robust path's accuracy, without its rescaling and exact-difference setup.
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
    let len = n.length();
    if !((len - 1.0).abs() <= polygon::NORMAL_TOLERANCE) {
        return None;
    }
    let d = frame_term(&fast_frame(r_a, e)?, n / len, order).ok()?;
    d.is_finite().then_some(d)
}

/// A cheap necessary condition for the robust path's far-field decision (vertex centroid at least
/// [`polygon::FAR_FIELD_RATIO`] radii `R` from x): then `‖v_0 − x‖ ≥ 15 R` and every vertex is
/// within `2R` of `v_0`, so `‖v_0 − x‖_∞ ≥ ‖v_0 − x‖/√3 ≥ 4.3 max_k ‖v_k − v_0‖_∞`; 4 leaves room
/// for rounding. Max-norms keep it to a few instructions on the generic path. It only decides
/// whether [`far_field_fast`] is tried first, which replays the exact decision.
#[inline(always)]
pub(crate) fn maybe_far<const M: usize>(v: &[DVec3; M], x: DVec3) -> bool {
    let mut edges = (v[1] - v[0]).abs();
    for vk in &v[2..] {
        edges = edges.max((*vk - v[0]).abs());
    }
    (v[0] - x).abs().max_element() >= 4.0 * edges.max_element()
}

/// The far-field evaluation of [`triangle_form_factor`] when the robust path's decisions are
/// certain: inputs valid and in [`FAST_RANGE`], every vertex above the tangent plane by more than
/// the rounding bound of its height (nothing clipped), not near the plane, not a sliver (whose fan
/// geometry the robust path takes from exact differences), and in the far field. Then the robust
/// path integrates the one fan triangle with the rule [`polygon::fast_decisions`] picks, on the same
/// f64 differences up to its exact power-of-two rescaling: the result is bit-for-bit the robust
/// one. Returned with the smallest ratio (distance over radius) of the rule's range; `None`
/// otherwise.
// Not inlined: the generic path only pays the call's test, not this function's frame.
#[inline(never)]
pub(crate) fn triangle_far_field_fast(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    order: Order,
) -> Option<(Deriv3, f64)> {
    far_field_fast(x, n, v, polygon::triangle_plane, order)
}

/// [`triangle_far_field_fast`] for a polygon of 4 to 8 vertices (`None` for other counts): the
/// robust path's validation ([`polygon::Plane::new`], so invalid polygons are declined and left to
/// the robust path's errors) and decisions, then its far-field rule on the fan triangles from
/// `v_0`, on the same f64 differences: bit-for-bit the robust result.
// Inlined up to the distance test, which declines every nearby polygon: the call of the rule's
// frame and the copy of the vertices cost ~100 instructions per declined call (callgrind).
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
    far_field_fast(x, n, v, |u| polygon::Plane::new(u).ok(), order)
}

/// The far-field replay shared by [`triangle_far_field_fast`] and [`polygon_far_field_fast`]
/// (`plane_of` validates the polygon given relative to `v_0` as the robust path does).
#[inline(always)]
fn far_field_fast<const M: usize>(
    x: DVec3,
    n: DVec3,
    v: [DVec3; M],
    plane_of: impl FnOnce(&[DVec3; M]) -> Option<polygon::Plane>,
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
        let d = polygon::triangle_rule(r[0], u[k], u[k + 1] - u[k], n, order, geometry, rule);
        sum.value += d.value;
        sum.gradient += d.gradient;
        sum.hessian += d.hessian;
    }
    Some((oriented(sum, h_p)?, rule.min_ratio()))
}

/// The fast evaluation of [`triangle_form_factor`] when the robust path's decisions are certain:
/// every vertex strictly above the tangent plane by more than the rounding bound of its height
/// (so nothing is clipped), not near the plane, no edge line near `x`, the triangle not in the far
/// field and the edge sum not cancelling beyond [`polygon::cancellation_limit`] (where the robust
/// path integrates by quadrature instead).
/// `None` otherwise, or for invalid or out-of-range inputs. Accepted results are bit-for-bit those
/// of the robust path (same f64 operations; its power-of-two rescaling changes no rounding).
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
    } = fast_setup(x, n, v, polygon::triangle_plane)?;
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
    if !(magnitude <= polygon::cancellation_limit(&plane, false) * sum.value.abs()) {
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
    pub(crate) plane: polygon::Plane,
    /// The far-field rule, when the robust path would integrate by quadrature.
    pub(crate) far: Option<polygon::Rule>,
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
    plane_of: impl FnOnce(&[DVec3; M]) -> Option<polygon::Plane>,
) -> Option<FastSetup<M>> {
    let r = v.map(|vk| vk - x);
    let u: [DVec3; M] = std::array::from_fn(|k| if k == 0 { DVec3::ZERO } else { v[k] - v[0] });
    in_fast_range(r.iter().chain(&u[1..]))?;
    let len = n.length();
    if !((len - 1.0).abs() <= polygon::NORMAL_TOLERANCE) {
        return None;
    }
    let n = n / len;
    // Heights over the tangent plane: the f64 dot product errs by less than 4u·(|n|·|r|) (one
    // rounding in r, three in the dot product), so above 8u·(|n|·|r|) the exact height is positive
    // and the robust clip keeps every vertex without cutting.
    for rk in &r {
        if !(n.dot(*rk) > 8.0 * f64::EPSILON * n.abs().dot(rk.abs())) {
            return None;
        }
    }
    let plane = plane_of(&u)?;
    let (far, h_p) = polygon::fast_decisions(&r, &plane)?;
    Some(FastSetup {
        r,
        u,
        n,
        plane,
        far,
        h_p,
    })
}

/// The robust path's last step: the form factor's sign follows the side of the plane `x` is on
/// (the edge sum's orientation), clamped to [0, 1]; `None` if not finite.
pub(crate) fn oriented(mut d: Deriv3, h_p: f64) -> Option<Deriv3> {
    if h_p < 0.0 {
        d.value = -d.value;
        d.gradient = -d.gradient;
        d.hessian = -d.hessian;
    }
    d.value = d.value.clamp(0.0, 1.0);
    d.is_finite().then_some(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The FMA build of the clipped-loop derivatives gives the portable build's bits, on random
    /// triangles with `x` 1e-3..1e-12 of their size from the plane, over them and beside them
    /// (beside them, the value order's near-plane route runs inside, with its value and loop).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn clipped_derivatives_fma_twin_keeps_the_bits() {
        if !crate::simd::avx2_fma() {
            return;
        }
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut unit = move || crate::test_rng::lcg(&mut state);
        let bits = |d: &ClippedDerivs| -> Vec<u64> {
            let (tag, d) = match d {
                ClippedDerivs::Done(d) => (0, *d),
                ClippedDerivs::ValueElsewhere(d, route_tried) => (1 + u64::from(*route_tried), *d),
                ClippedDerivs::Declined(v) => {
                    return vec![2, v.unwrap_or(f64::NAN).to_bits()];
                }
            };
            let mut out = vec![tag, d.value.to_bits()];
            out.extend(d.gradient.to_array().map(f64::to_bits));
            out.extend(d.hessian.to_cols_array().map(f64::to_bits));
            out
        };
        let mut answered = 0;
        for k in 0..4000 {
            let scale = [1e-3, 1.0, 1e3][k % 3];
            let mut p = || DVec3::new(unit() - 0.5, unit() - 0.5, 0.3 * unit()) * scale;
            let v = [p(), p(), p()];
            let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            let (a, b) = (2.4 * unit() - 0.7, 2.4 * unit() - 0.7);
            let foot = v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b;
            let side = if unit() < 0.5 { 1.0 } else { -1.0 };
            let x = foot + plane_n * (side * scale * 10f64.powf(-3.0 - 9.0 * unit()));
            let tilt = (10.0 + 70.0 * unit()).to_radians();
            let t = plane_n.any_orthonormal_vector();
            let n = (plane_n * side * tilt.cos() + t * tilt.sin()).normalize();
            for order in [Order::Gradient, Order::Hessian] {
                let portable = clipped_derivs_with(x, n, v, order, false);
                // SAFETY: checked above that the CPU has AVX2 and FMA.
                let fused = unsafe { clipped_derivs_fma(x, n, v, order) };
                assert_eq!(
                    portable.as_ref().map(bits),
                    fused.as_ref().map(bits),
                    "at {x:?} {n:?} {v:?} {order:?}"
                );
                answered += usize::from(matches!(
                    portable,
                    Some(ClippedDerivs::Done(_) | ClippedDerivs::ValueElsewhere(..))
                ));
            }
        }
        assert!(answered > 500, "only {answered} answered");
    }

    const TRI: [DVec3; 3] = [
        DVec3::new(-0.4, -0.3, 1.0),
        DVec3::new(0.7, -0.1, 1.2),
        DVec3::new(0.0, 0.8, 0.9),
    ];

    fn n() -> DVec3 {
        DVec3::new(0.2, -0.1, 1.0).normalize()
    }

    /// The robust evaluation (the polygon path, which has no fast path).
    fn robust(x: DVec3, n: DVec3, t: [DVec3; 3]) -> Deriv3 {
        polygon::form_factor(x, n, &t, Order::Hessian).unwrap()
    }

    /// Walks `x(t)` for `t` from `t0` down to `t1` (log steps) and checks that the fast path is
    /// taken at `t0`, declines at `t1`, and agrees bit for bit with the robust path wherever it is
    /// taken; returns the last certified and first declined parameters.
    fn walk(x_of: &dyn Fn(f64) -> DVec3, t: [DVec3; 3], t0: f64, t1: f64) -> (f64, f64) {
        walk_n(x_of, n(), t, t0, t1)
    }

    fn walk_n(
        x_of: &dyn Fn(f64) -> DVec3,
        n: DVec3,
        t: [DVec3; 3],
        t0: f64,
        t1: f64,
    ) -> (f64, f64) {
        let (mut last_ok, mut first_fail) = (f64::NAN, f64::NAN);
        let steps = 400;
        for k in 0..=steps {
            let p = t0 * (t1 / t0).powf(k as f64 / steps as f64);
            let x = x_of(p);
            match triangle_form_factor_fast(x, n, t, Order::Hessian) {
                Some(f) => {
                    assert_eq!(f, robust(x, n, t), "fast != robust at {x:?}");
                    if first_fail.is_nan() {
                        last_ok = p;
                    }
                }
                None => {
                    if first_fail.is_nan() {
                        first_fail = p;
                    }
                }
            }
        }
        assert!(
            !last_ok.is_nan() && !first_fail.is_nan(),
            "no switch in [{t1}, {t0}]"
        );
        // Narrow the switch down to configurations a relative 1e-12 apart.
        for _ in 0..60 {
            let mid = (last_ok * first_fail).sqrt();
            match triangle_form_factor_fast(x_of(mid), n, t, Order::Hessian) {
                Some(f) => {
                    assert_eq!(f, robust(x_of(mid), n, t));
                    last_ok = mid;
                }
                None => first_fail = mid,
            }
        }
        assert!((last_ok / first_fail - 1.0).abs() < 1e-12);
        (last_ok, first_fail)
    }

    fn close(p: &Deriv3, q: &Deriv3, tol: f64) -> bool {
        let hm = q
            .hessian
            .abs()
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, e| m.max(*e));
        let hd = (p.hessian - q.hessian)
            .abs()
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, e| m.max(*e));
        (p.value - q.value).abs() <= tol * q.value.abs()
            && (p.gradient - q.gradient).abs().max_element() <= tol * q.gradient.abs().max_element()
            && hd <= tol * hm
    }

    #[test]
    fn fast_triangle_equals_robust_and_switches_off_at_the_tangent_plane() {
        // Lower x's tangent plane onto vertex c: the fast path declines just before the clip starts.
        let c = TRI[2];
        let base = DVec3::new(0.1, -0.2, 0.05);
        // Move x along n so that n·(c − x) = t·|c − base|.
        let x_of = |t: f64| base + n() * (n().dot(c - base) - t * (c - base).length());
        let (ok, fail) = walk(&x_of, TRI, 0.3, 1e-18);
        // Both sides of the switch give the same function to well within the contract.
        let (a, b) = (robust(x_of(ok), n(), TRI), robust(x_of(fail), n(), TRI));
        assert!(close(
            &triangle_form_factor_fast(x_of(ok), n(), TRI, Order::Hessian).unwrap(),
            &a,
            0.0
        ));
        assert!(close(&a, &b, 1e-9), "{a:?} {b:?}");
    }

    #[test]
    fn fast_triangle_switches_off_near_an_edge_line_and_in_the_far_field() {
        // Approach the extension of edge ab beyond a, out of the triangle's plane, with a receiver
        // normal in that plane (every vertex stays above the tangent plane).
        let (a, b, c) = (TRI[0], TRI[1], TRI[2]);
        let ne = ((b - a).normalize() + (c - a).normalize()).normalize();
        let plane_n = (b - a).cross(c - a).normalize();
        let x_of = |t: f64| a - (b - a) * 0.5 + plane_n * t;
        let (ok, fail) = walk_n(&x_of, ne, TRI, 0.5, 1e-9);
        let (p, q) = (robust(x_of(ok), ne, TRI), robust(x_of(fail), ne, TRI));
        assert!(close(&p, &q, 1e-9), "{p:?} {q:?}");
        // Far away along −n: the robust path switches to quadrature at 16 radii.
        let centroid = (TRI[0] + TRI[1] + TRI[2]) / 3.0;
        let x_far = |t: f64| centroid - n() * (1.0 / t);
        let (ok, fail) = walk(&x_far, TRI, 1.0, 1e-3);
        assert!(1.0 / ok < 1.0 / fail);
        let (p, q) = (robust(x_far(ok), n(), TRI), robust(x_far(fail), n(), TRI));
        assert!(close(&p, &q, 1e-9), "{p:?} {q:?}");
    }

    /// The far-field fast path, walking x from 1e7 radii in to 8 along a few directions (every
    /// far-field rule switch is crossed): bit-for-bit the robust path wherever taken, taken at every
    /// step beyond 16 radii (nothing is clipped), declined below. Clipped and sliver triangles go
    /// to the robust path.
    #[test]
    fn far_field_fast_path_equals_robust_across_its_rule_switches() {
        let centroid = (TRI[0] + TRI[1] + TRI[2]) / 3.0;
        let radius = TRI
            .iter()
            .map(|v| (*v - centroid).length())
            .fold(0.0, f64::max);
        for dir in [
            -n(),
            DVec3::new(-0.3, 0.2, -1.0).normalize(),
            DVec3::new(0.5, -0.6, -0.4).normalize(),
        ] {
            let steps = 600;
            for k in 0..=steps {
                let ratio = 1e7 * (8.0f64 / 1e7).powf(k as f64 / steps as f64);
                let x = centroid + dir * (ratio * radius);
                let got = triangle_far_field_fast(x, n(), TRI, Order::Hessian);
                if ratio > 16.0 * (1.0 + 1e-9) {
                    let (got, min_ratio) = got.unwrap_or_else(|| panic!("declined at {ratio}"));
                    assert!(ratio >= min_ratio * (1.0 - 1e-12), "{ratio} < {min_ratio}");
                    assert_eq!(got, robust(x, n(), TRI), "at {ratio}");
                    // The entry point takes it, for every order, with the same value (Lambert's
                    // where certified: its far form is, out to 1e7 radii).
                    let entry =
                        |o| triangle_form_factor(x, n(), TRI[0], TRI[1], TRI[2], o).unwrap();
                    let (value, hessian) = (entry(Order::Value), entry(Order::Hessian));
                    assert_eq!(value.value, hessian.value, "at {ratio}");
                    assert_eq!(
                        (hessian.gradient, hessian.hessian),
                        (got.gradient, got.hessian)
                    );
                    let lambert = lambert::triangle_value(x, n(), TRI);
                    assert_eq!(value.value, lambert.unwrap_or(got.value), "at {ratio}");
                    assert!(lambert.is_some(), "Lambert not certified at {ratio}");
                } else if ratio < 16.0 * (1.0 - 1e-9) {
                    assert!(got.is_none(), "taken at {ratio}");
                }
            }
        }
        // Far away but clipped (the tangent plane through the triangle): declined.
        let x = centroid - n() * (1e3 * radius);
        let tilted = (TRI[0] - x).cross(TRI[1] - TRI[0]).normalize();
        let nn = if tilted.dot(TRI[2] - x) > 0.0 {
            tilted
        } else {
            -tilted
        };
        let nn = (nn + 1e-3 * (TRI[0] - TRI[1]).normalize()).normalize();
        assert!(TRI.iter().any(|v| nn.dot(*v - x) < 0.0));
        assert!(triangle_far_field_fast(x, nn, TRI, Order::Hessian).is_none());
        // A far sliver: declined (its fan geometry is taken from exact differences).
        let sliver = [TRI[0], TRI[1], (TRI[0] + TRI[1]) * 0.5 + DVec3::Z * 1e-4];
        assert!(triangle_far_field_fast(x, n(), sliver, Order::Hessian).is_none());
        assert!(
            triangle_form_factor(x, n(), sliver[0], sliver[1], sliver[2], Order::Hessian).is_ok()
        );
    }

    /// The polygon far-field replay, as the triangle's above for a quad and a pentagon (each
    /// fan triangle through every rule switch): bit-for-bit the robust path wherever taken, taken
    /// beyond 16 radii, declined below; through the entry point at every order with the certified
    /// value; invalid polygons far away are declined and refused by the robust path.
    #[test]
    fn polygon_far_field_fast_path_equals_robust_across_its_rule_switches() {
        let quad: Vec<DVec3> = [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
            .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
            .to_vec();
        let pentagon: Vec<DVec3> = (0..5)
            .map(|i| {
                let phi = std::f64::consts::TAU * i as f64 / 5.0;
                DVec3::new(phi.cos(), phi.sin(), 1.2 + 0.3 * phi.sin())
            })
            .collect();
        for v in [&quad, &pentagon] {
            let centroid = v.iter().sum::<DVec3>() / v.len() as f64;
            let radius = v
                .iter()
                .map(|p| (*p - centroid).length())
                .fold(0.0, f64::max);
            for dir in [-n(), DVec3::new(0.5, -0.6, -0.4).normalize()] {
                let steps = 400;
                for k in 0..=steps {
                    let ratio = 1e7 * (8.0f64 / 1e7).powf(k as f64 / steps as f64);
                    let x = centroid + dir * (ratio * radius);
                    let got = polygon_far_field_fast(x, n(), v, Order::Hessian);
                    if ratio > 16.0 * (1.0 + 1e-9) {
                        let (got, min_ratio) = got.unwrap_or_else(|| panic!("declined at {ratio}"));
                        assert!(ratio >= min_ratio * (1.0 - 1e-12), "{ratio} < {min_ratio}");
                        let robust = polygon::form_factor(x, n(), v, Order::Hessian).unwrap();
                        assert_eq!(got, robust, "at {ratio}");
                        let g = polygon::form_factor(x, n(), v, Order::Gradient).unwrap();
                        let fast_g = polygon_far_field_fast(x, n(), v, Order::Gradient).unwrap();
                        assert_eq!(fast_g.0, g, "at {ratio}");
                        let entry = |o| polygon_form_factor(x, n(), v, o).unwrap();
                        let (value, hessian) = (entry(Order::Value), entry(Order::Hessian));
                        assert_eq!(value.value, hessian.value, "at {ratio}");
                        assert_eq!(
                            (hessian.gradient, hessian.hessian),
                            (got.gradient, got.hessian)
                        );
                    } else if ratio < 16.0 * (1.0 - 1e-9) {
                        assert!(got.is_none(), "taken at {ratio}");
                    }
                }
            }
            // Three or nine vertices: not this replay's.
            let x = centroid - n() * (1e3 * radius);
            assert!(polygon_far_field_fast(x, n(), &v[..3], Order::Hessian).is_none());
            let mut nine = v.clone();
            while nine.len() < 9 {
                nine.push(nine[nine.len() - 1] + (v[0] - nine[nine.len() - 1]) * 0.01);
            }
            assert!(polygon_far_field_fast(x, n(), &nine, Order::Hessian).is_none());
        }
        // Far away but invalid: declined, and the robust path reports InvalidArgument.
        let x = DVec3::new(0.0, 0.0, -1e3);
        let mut bow = quad.clone();
        bow.swap(1, 2);
        let mut bent = quad.clone();
        bent[2].z += 1e-3;
        for v in [&bow, &bent] {
            assert!(polygon_far_field_fast(x, DVec3::Z, v, Order::Hessian).is_none());
            for o in [Order::Value, Order::Gradient, Order::Hessian] {
                assert!(matches!(
                    polygon_form_factor(x, DVec3::Z, v, o),
                    Err(Error::InvalidArgument(_))
                ));
            }
        }
        // A far non-convex (arrowhead) polygon is valid: the replay takes it, bit for bit.
        let arrow = [
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.5, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
            DVec3::new(0.3, 0.5, 1.0),
        ];
        let (got, _) = polygon_far_field_fast(x, DVec3::Z, &arrow, Order::Hessian).unwrap();
        assert_eq!(
            got,
            polygon::form_factor(x, DVec3::Z, &arrow, Order::Hessian).unwrap()
        );
    }

    /// Slivers: the replay takes an edge sum cancelling by up to THIN_CANCELLATION_LIMIT, bit for
    /// bit the robust path, and declines beyond (the robust path integrates by quadrature).
    #[test]
    fn fast_triangle_takes_slivers_up_to_the_thin_cancellation_limit() {
        let (a, b) = (TRI[0], TRI[1]);
        let perp = (b - a).cross(TRI[2] - a).cross(b - a).normalize();
        let x = DVec3::new(0.1, -0.2, 0.05);
        let (mut taken, mut declined) = (0, 0);
        for k in 0..=40 {
            let height = 10f64.powf(-2.0 - 0.1 * k as f64);
            let t = [a, b, (a + b) * 0.5 + perp * height];
            match triangle_form_factor_fast(x, n(), t, Order::Hessian) {
                Some(d) => {
                    assert_eq!(d, robust(x, n(), t), "at height {height}");
                    assert_eq!(declined, 0, "taken again at {height}");
                    taken += 1;
                }
                None => declined += 1,
            }
        }
        assert!(
            taken > 10 && declined > 10,
            "{taken} taken, {declined} declined"
        );
    }

    #[test]
    fn fast_edge_term_equals_robust_and_declines_near_its_line() {
        let (a, b) = (TRI[0], TRI[1]);
        let x = DVec3::new(0.1, -0.2, 0.05);
        let fast = edge_form_factor_fast(x, n(), a, b, Order::Hessian).unwrap();
        let scaled = polygon::Scaled::new(x, &[a, b]).unwrap();
        let ends = scaled.exact_ends(0, 1);
        let unit = polygon::unit_normal(n()).unwrap();
        let slow = edge_term_exact(
            scaled.r[0],
            scaled.u[1] - scaled.u[0],
            unit,
            Order::Hessian,
            Some(&ends),
        )
        .and_then(|d| scaled.finish(d, Order::Hessian))
        .unwrap();
        assert_eq!(fast, slow);
        // 1e-4 of the length off the line (sine below 1e-2): the double-double path.
        let near = a + (b - a) * 1.7 + DVec3::Z * 1e-4;
        assert!(edge_form_factor_fast(near, n(), a, b, Order::Hessian).is_none());
        assert!(edge_form_factor(near, n(), a, b, Order::Hessian).is_ok());
        // Invalid inputs are left to the robust path's validation.
        assert!(edge_form_factor_fast(x, n() * 1.1, a, b, Order::Value).is_none());
        assert!(edge_form_factor_fast(DVec3::NAN, n(), a, b, Order::Value).is_none());
    }

    /// `A_1`, `A_2`, `A_3` of the edge `r_a + t·e`, `t ∈ [0, 1]`, in 320-bit arithmetic from the
    /// f64 inputs as given: `A_1 = [atan(s/h)]/h`, `A_2 = ([s/ρ²] + A_1)/(2h²)`,
    /// `A_3 = ([s/ρ⁴] + 3A_2)/(4h²)` between `s_a = r_a·ê` and `s_a + ‖e‖`.
    fn reference_moments(r_a: DVec3, e: DVec3) -> [f64; 3] {
        use astro_float::{BigFloat, Consts, RoundingMode};
        const P: usize = 320;
        const RM: RoundingMode = RoundingMode::ToEven;
        let mut cc = Consts::new().unwrap();
        let big = |v: f64| BigFloat::from_f64(v, P);
        let dot = |a: [f64; 3], b: [f64; 3]| {
            (0..3).fold(big(0.0), |acc, k| {
                acc.add(&big(a[k]).mul(&big(b[k]), P, RM), P, RM)
            })
        };
        let (ra, ee) = (r_a.to_array(), e.to_array());
        let len = dot(ee, ee).sqrt(P, RM);
        let sa = dot(ra, ee).div(&len, P, RM);
        let sb = sa.add(&len, P, RM);
        let h2 = dot(ra, ra).sub(&sa.mul(&sa, P, RM), P, RM);
        let h = h2.sqrt(P, RM);
        let rho2 = |s: &BigFloat| s.mul(s, P, RM).add(&h2, P, RM);
        let mut atan = |s: &BigFloat| s.div(&h, P, RM).atan(P, RM, &mut cc);
        let a1 = atan(&sb).sub(&atan(&sa), P, RM).div(&h, P, RM);
        let bracket = |k: i32| {
            let at = |s: &BigFloat| s.div(&rho2(s).powi(k as usize, P, RM), P, RM);
            at(&sb).sub(&at(&sa), P, RM)
        };
        let two_h2 = h2.mul(&big(2.0), P, RM);
        let a2 = bracket(1).add(&a1, P, RM).div(&two_h2, P, RM);
        let a3 = bracket(2).add(&a2.mul(&big(3.0), P, RM), P, RM).div(
            &two_h2.mul(&big(2.0), P, RM),
            P,
            RM,
        );
        [a1, a2, a3].map(|m| {
            let text = format!("{m}");
            text.parse::<f64>().unwrap_or_else(|_| panic!("{text}"))
        })
    }

    /// The closed-form moments against the 320-bit reference on edges 1e-8..1 of their distance
    /// long, the foot of x on the line inside and outside the edge, x near the line's extension
    /// (the axial series) or at least 1e-2 of its distance off the line (nearer, callers give
    /// exact ends): within 1e-14 relative, except the recurrences' `A_3` (1e-13). The axial `A_2`, `A_3` were the
    /// difference of two tails, which cancelled by ~distance/length (1.6e-8 relative for an
    /// edge 1e-8 of its distance long).
    #[test]
    fn moments_match_the_reference_on_short_and_axial_edges() {
        let mut state = 1826;
        let mut worst = [[0.0f64; 3]; 2];
        let mut counted = [0; 2];
        for i in 0..1200 {
            let mut c = || crate::test_rng::lcg(&mut state);
            let scale = 10f64.powf(4.0 * c() - 2.0);
            let dir = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize();
            let off = dir.any_orthonormal_vector();
            let axial = i % 2 == 0;
            // Axial: h below |s|/4 (down to 1e-6 of it); otherwise h/|r| ≥ 1e-2.
            let (s, h) = if axial {
                let s = scale * (0.5 + 2.0 * c()) * if c() < 0.5 { -1.0 } else { 1.0 };
                (s, s.abs() * 0.25 * 10f64.powf(-6.0 * c()))
            } else {
                let s = scale * (6.0 * c() - 3.0);
                (s, scale * 10f64.powf(-1.5 * c()))
            };
            let distance = (s * s + h * h).sqrt();
            let len = distance * 10f64.powf(-8.0 * c());
            let r_a = off * h + dir * s;
            let e = dir * len;
            let frame = EdgeFrame::new(r_a, e).unwrap();
            let got = frame.moments(Order::Hessian).unwrap();
            let in_series = frame.sa * frame.sb > 0.0
                && frame.h < AXIAL_RATIO * frame.sa.abs().min(frame.sb.abs());
            let want = reference_moments(r_a, e);
            let k = usize::from(in_series);
            counted[k] += 1;
            for (slot, (g, w)) in worst[k]
                .iter_mut()
                .zip([got.a1, got.a2, got.a3].iter().zip(want))
            {
                *slot = slot.max((g - w).abs() / w.abs());
            }
        }
        assert!(counted.iter().all(|&n| n > 150), "{counted:?}");
        // The recurrences' `A_3` (foot near the edge, x within ~1e-2 of its distance of the
        // line) divides by `h²` twice: 4.8e-14 here, unchanged.
        println!("moments, general / axial series: worst {worst:?}");
        let [general, series] = worst;
        assert!(series.iter().all(|&e| e <= 1e-14), "{worst:?}");
        assert!(general[0] <= 1e-14 && general[1] <= 1e-14, "{worst:?}");
        assert!(general[2] <= 1e-13, "{worst:?}");
    }
}
