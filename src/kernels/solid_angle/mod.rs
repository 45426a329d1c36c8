//! Solid angle subtended by a triangle (Van Oosterom-Strackee), with its gradient and Hessian with
//! respect to the viewpoint.
//!
//! With `r_k = y_k − x` (the vertices seen from `x`), `s_k = ‖r_k‖` and
//!
//! * `A = (a − x)·N`, `N = (b − a)×(c − a)` (equal to `r_0·(r_1×r_2)`; Marco et al. eq. 47 prints
//!   its gradient without the transposes: `∇A = −N`, constant, so `HA = 0`),
//! * `D = s_0 s_1 s_2 + (r_0·r_1) s_2 + (r_1·r_2) s_0 + (r_2·r_0) s_1`,
//!
//! the signed solid angle is `Ω = 2 atan2(A, D)`. Derivatives (derived here, cross-checked against
//! 256-bit finite differences in `tests/solid_angle_accuracy.rs`; Marco et al. 2018 App. C was only a
//! guide): `∇A = −N` and `HA = 0`; with `p_k = s_i s_j + r_i·r_j`, `c_k = p_k/s_k + s_i + s_j`
//! (`{i, j}` the other two indices), `S = Σ s_k`, `u_k = r_k/s_k`, `U = Σ u_k`:
//!
//! * `∇D = −Σ c_k r_k`,
//! * `HD = (Σ c_k) I + S U Uᵀ − Σ (S + p_k/s_k) u_k u_kᵀ`,
//!
//! and for `f = atan2(A, D)`, `g = A² + D²`, `a = ∇A`, `d = ∇D`:
//!
//! * `∇f = (D a − A d)/g`,
//! * `Hf = −A HD/g − [2DA (a aᵀ − d dᵀ) + (D² − A²)(a dᵀ + d aᵀ)]/g²` (symmetric by construction).
//!
//! Precision: `A` from an edge cross product keeps full relative precision far from the triangle
//! (the textbook `r_0·(r_1×r_2)` loses `(distance/size)²`), and when `x` is close to the
//! triangle's plane relative to its distance, `A` is recomputed in double-double arithmetic from the
//! exact coordinate differences, so points 1e-12 off the plane still get a relative accuracy near
//! machine precision. Every term of `D`, `∇D`, `HD` and of the quotient rules is of the size of the
//! result far away (no cancellation), and inputs are rescaled by a power of two so that neither
//! tiny (1e-300) nor huge (1e300) coordinates overflow or underflow intermediate products (results
//! that are themselves out of range give `Error::Degenerate`).
//!
//! # The ladder
//!
//! Every call takes the first rung that answers; each meets the accuracy contract (1e-12 / 1e-12
//! / 1e-10 relative in generic configurations, 1e-10 / 1e-9 / 1e-8 in the hard regimes: near the
//! plane, an edge or a vertex, slivers, far away, extreme scales).
//!
//! 1. **Certified, f64** (`certified`): distances `|y_k − x|` in (1.75e-30, 1e30) (coordinate
//!    differences in [1e-30, 1e30]), `x` off the plane and the vertices. Van Oosterom-Strackee in
//!    plain f64 from the edges at the nearest vertex with a running error bound, accepted within
//!    5e-13 / 5e-13 / 5e-12; the angle from an inline `atan2` polynomial (no libm call). Answers
//!    almost every generic configuration, far away and near a vertex.
//! 2. **Certified, exact `A`** (same module): where only `A` fails its bound (`x` near the plane
//!    relative to its distance, slivers), `A` and `N` recomputed in double-double from the exact
//!    differences, then the same certificate.
//! 3. **Robust** (`robust`): everything else (near an edge, on the plane, at a vertex, extreme
//!    scales, non-finite input). Exact power-of-two rescaling, double-double where the
//!    configuration needs it, and the singular limits; measured within 5e-14 in every regime of
//!    `tests/solid_angle_accuracy.rs`.
//!
//! `hessian` is the one Hessian formula both rungs evaluate. The value order does no derivative
//! work on any rung (`solid_angle_value`), and the robust rung is out of line and cold: a generic
//! call executes the certified rung alone.

use glam::DVec3;

use crate::error::{Error, Result};
use crate::{Deriv3, Order};
use certified::{certified_parts, certified_value, solid_angle_fast};
use robust::solid_angle_unchecked;

mod certified;
mod hessian;
mod robust;
#[cfg(test)]
mod tests;

/// Unsigned solid angle Ω ∈ [0, 2π] (steradians) subtended at `x` by the triangle `(a, b, c)`, with
/// its gradient (sr/L) and Hessian (sr/L²) with respect to `x`.
///
/// Computed as `2 atan2(|A|, D)` (Van Oosterom-Strackee; see the module documentation for the
/// formulation and its precision).
///
/// Limits at singular configurations (never NaN or Inf):
/// * `x` on the triangle's plane, off the triangle's boundary: the value is 2π inside the triangle
///   and 0 outside. |Ω| is even in the distance to the plane, so it has a kink there; the returned
///   gradient and Hessian are the averages of the two one-sided limits, which are exactly zero
///   (Ω is constant on the plane and its second normal derivative tends to 0).
/// * `x` on an edge or at a vertex (within rounding): the value depends on the direction of
///   approach, [`Error::Degenerate`] at every order.
/// * Zero-area triangle (collinear vertices, exactly): it subtends no solid angle; returns 0 with zero
///   derivatives. Nearly degenerate (sliver) triangles are computed normally.
/// * If a derivative overflows (points within ~1e-100 of an edge relative to the triangle's size,
///   or coordinates near the limits of `f64`), [`Error::Degenerate`].
///
/// Non-finite input gives [`Error::InvalidArgument`].
#[inline]
pub fn triangle_solid_angle(
    x: DVec3,
    a: DVec3,
    b: DVec3,
    c: DVec3,
    order: Order,
) -> Result<Deriv3> {
    solid_angle(x, [a, b, c], order, false)
}

/// Signed solid angle Ω ∈ (−2π, 2π) (steradians) subtended at `x` by the oriented triangle
/// `(a, b, c)`, with its gradient and Hessian with respect to `x`.
///
/// Ω is positive when `x` lies on the side opposite the normal `(b − a)×(c − a)` (the vertices appear
/// clockwise from `x`), so for a closed mesh with outward-facing triangles the signed solid angles
/// sum to 4π at interior points and to 0 outside. Computed as `2 atan2(A, D)`.
///
/// Limits: on the triangle's plane outside the triangle the function is smooth (value 0, ordinary
/// derivatives). Inside the triangle on its plane the value jumps between −2π and 2π:
/// [`Error::Degenerate`]. On an edge or at a vertex: [`Error::Degenerate`]. Zero-area triangles:
/// 0 with zero derivatives. Overflowing derivatives: [`Error::Degenerate`].
#[inline]
pub fn triangle_solid_angle_signed(
    x: DVec3,
    a: DVec3,
    b: DVec3,
    c: DVec3,
    order: Order,
) -> Result<Deriv3> {
    solid_angle(x, [a, b, c], order, true)
}

/// The certified fast path, else the robust path: for the value order [`solid_angle_value`], for
/// the others one call out of line.
#[inline(always)]
fn solid_angle(x: DVec3, y: [DVec3; 3], order: Order, signed: bool) -> Result<Deriv3> {
    if !order.gradient() {
        return solid_angle_value(x, y, signed).map(Deriv3::constant);
    }
    solid_angle_derivs(x, y, order, signed)
}

/// The value of [`triangle_solid_angle`] (`signed == false`) or
/// [`triangle_solid_angle_signed`]: the certified fast path's angle, inlined into the caller down
/// to its one call (the robust path, where the certificate fails), so that a caller that wants
/// the value alone pays for no derivative plumbing (the C ABI's value order).
#[inline(always)]
pub(crate) fn solid_angle_value(x: DVec3, y: [DVec3; 3], signed: bool) -> Result<f64> {
    match certified_parts(x, y, signed).and_then(|parts| certified_value(&parts)) {
        Some(value) => Ok(value),
        None => robust_solid_angle(x, y, Order::Value, signed).map(|d| d.value),
    }
}

/// [`solid_angle`] for the gradient and Hessian orders: the certified fast path, else the robust
/// path.
#[inline(always)]
fn solid_angle_derivs(x: DVec3, y: [DVec3; 3], order: Order, signed: bool) -> Result<Deriv3> {
    solid_angle_to(x, y, order, signed, |d| *d)
}

/// `emit` of [`solid_angle`]'s result (for any order; the value order's derivatives are zero):
/// the fast path's and the robust path's results each handed to `emit` where they are, so that a
/// caller storing them elsewhere (the C ABI's row-major output) copies them once.
#[inline(always)]
pub(crate) fn solid_angle_to<R>(
    x: DVec3,
    y: [DVec3; 3],
    order: Order,
    signed: bool,
    emit: impl FnOnce(&Deriv3) -> R,
) -> Result<R> {
    if let Some(out) = solid_angle_fast(x, y, order, signed) {
        return Ok(emit(&out));
    }
    robust_solid_angle(x, y, order, signed).map(|d| emit(&d))
}

/// The robust path, with the overflow check of its result. Cold: its call's argument copies are
/// then made on its branch only.
#[cold]
#[inline(never)]
fn robust_solid_angle(x: DVec3, y: [DVec3; 3], order: Order, signed: bool) -> Result<Deriv3> {
    let out = solid_angle_unchecked(x, y, order, signed)?;
    if !out.is_finite() {
        return Err(Error::Degenerate(
            "solid angle: the result overflows (x is extremely close to an edge or vertex, or \
             coordinates are near the limits of f64)"
                .into(),
        ));
    }
    Ok(out)
}
