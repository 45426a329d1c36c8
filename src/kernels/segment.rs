//! Flatland form factor from a point to a segment: the angle the segment subtends, over 2π, with its
//! gradient and Hessian with respect to the point (Marco et al. 2018, App. B, re-derived).
//!
//! With `r_a = a − x`, `r_b = b − x`, `e = b − a`, the signed angle from `r_a` to `r_b` is
//! `φ = atan2(C, P)` with `C = r_a × e` (= `r_a × r_b`) and `P = r_a·r_b`. Writing 2D vectors as
//! complex numbers `z_a = r_a`, `z_b = r_b`, `φ = arg z_b − arg z_a`, and since `∇_x arg(y − x)` is
//! `−i / conj(z)` and its Hessian is `[[−Im w, −Re w], [−Re w, Im w]]` with `w = 1/z²`:
//!
//! * `∇φ = i · conj(e / (z_a z_b))`,
//! * `Hφ = [[−Im w, −Re w], [−Re w, Im w]]` with `w = 1/z_b² − 1/z_a² = −e (z_a + z_b)/(z_a z_b)²`.
//!
//! Both are free of cancellation far from the segment (the textbook difference of the two endpoint
//! terms loses `(distance/length)` digits), and `C` is evaluated from the edge vector, in
//! double-double when `x` is nearly on the segment's line.

use glam::{DMat2, DVec2};

use super::numeric::dd::Dd;
use super::numeric::pow2::pow2_scale;
use crate::error::{ensure_finite2, Error, Result};
use crate::{Deriv2, Order};

const INV_TWO_PI: f64 = 0.5 / std::f64::consts::PI;

/// Flatland form factor `θ/(2π)` ∈ [0, 1/2] from the point `x` to the segment `(a, b)`, where θ is
/// the (unsigned) angle the segment subtends at `x`, with its gradient (1/L) and Hessian (1/L²)
/// with respect to `x`.
///
/// Limits (never NaN or Inf):
/// * Zero-length segment (`a == b`): it subtends nothing; 0 with zero derivatives.
/// * `x` on the segment's line (exactly, `(a − x)×(b − a) == 0`): the value is 1/2 between `a` and
///   `b` and 0 beyond them. θ is even in the distance to the line, so it has a kink there; the
///   gradient and Hessian returned are the averages of the one-sided limits, which are zero.
/// * `x` at an endpoint: the value depends on the direction of approach: [`Error::Degenerate`].
/// * Derivatives that overflow (within ~1e-150 of an endpoint relative to the segment's length):
///   [`Error::Degenerate`].
///
/// Non-finite input gives [`Error::InvalidArgument`].
pub fn segment_form_factor_2d(x: DVec2, a: DVec2, b: DVec2, order: Order) -> Result<Deriv2> {
    ensure_finite2(x, "x")?;
    ensure_finite2(a, "a")?;
    ensure_finite2(b, "b")?;
    if a == b {
        return Ok(Deriv2::constant(0.0));
    }
    let raw_a = a - x;
    let raw_b = b - x;
    let extent = raw_a.abs().max_element().max(raw_b.abs().max_element());
    if !extent.is_finite() || !(b - a).is_finite() {
        // Finite points more than f64::MAX apart: halve everything (exact) and retry.
        return segment_form_factor_2d(x * 0.5, a * 0.5, b * 0.5, order).map(|mut d| {
            d.gradient *= 0.5;
            d.hessian *= 0.25;
            d
        });
    }
    if raw_a == DVec2::ZERO || raw_b == DVec2::ZERO {
        return Err(Error::Degenerate(
            "segment form factor: x lies at an endpoint of the segment".into(),
        ));
    }
    let (f1, f2) = pow2_scale(extent);
    let ra = raw_a * f1 * f2;
    let rb = raw_b * f1 * f2;
    // From the coordinates: rb − ra would lose (distance/length) digits far away.
    let e = (b - a) * f1 * f2;
    let (la, lb) = (ra.length_squared(), rb.length_squared());

    // C = r × e for the nearer endpoint r (smaller rounding error); double-double when |C| is small
    // against its rounding bound, i.e. x is nearly on the segment's line.
    let near = if la <= lb { ra } else { rb };
    let mut cross = near.perp_dot(e);
    if cross.abs() < (near.length_squared() * e.length_squared()).sqrt() * (1.0 / 32.0) {
        let da = [Dd::diff(a.x, x.x), Dd::diff(a.y, x.y)].map(|v| v.scale(f1).scale(f2));
        let de = [Dd::diff(b.x, a.x), Dd::diff(b.y, a.y)].map(|v| v.scale(f1).scale(f2));
        cross = da[0].mul(de[1]).sub(da[1].mul(de[0])).to_f64();
    }
    let dot = ra.dot(rb);
    if cross == 0.0 {
        // On the line: 1/2 strictly between the endpoints (dot < 0), 0 beyond them.
        return Ok(Deriv2::constant(if dot < 0.0 { 0.5 } else { 0.0 }));
    }
    let sign = cross.signum();
    let mut out = Deriv2::constant(cross.abs().atan2(dot) * INV_TWO_PI);
    if !order.gradient() {
        if !out.value.is_finite() {
            return Err(Error::Degenerate(
                "segment form factor: the value overflows".into(),
            ));
        }
        return Ok(out);
    }

    // m = z_a z_b, |m|² = |z_a|² |z_b|².
    let m = DVec2::new(ra.x * rb.x - ra.y * rb.y, ra.x * rb.y + ra.y * rb.x);
    let inv_m2 = 1.0 / (la * lb);
    // e / m = e · conj(m) / |m|².
    let w1 = DVec2::new(e.x * m.x + e.y * m.y, e.y * m.x - e.x * m.y) * inv_m2;
    // i · conj(w1) = (Im w1, Re w1).
    let f = sign * INV_TWO_PI;
    out.gradient = DVec2::new(w1.y, w1.x) * (f * f1 * f2);

    if order.hessian() {
        // w2 = −e (z_a + z_b) conj(m)² / |m|⁴.
        let sum = ra + rb;
        let es = DVec2::new(e.x * sum.x - e.y * sum.y, e.x * sum.y + e.y * sum.x);
        let mc2 = DVec2::new(m.x * m.x - m.y * m.y, -2.0 * m.x * m.y);
        let w2 = -DVec2::new(es.x * mc2.x - es.y * mc2.y, es.x * mc2.y + es.y * mc2.x)
            * (inv_m2 * inv_m2);
        let h = f * f1 * f1 * f2 * f2;
        out.hessian = DMat2::from_cols(DVec2::new(-w2.y, -w2.x) * h, DVec2::new(-w2.x, w2.y) * h);
    }
    if !out.is_finite() {
        return Err(Error::Degenerate(
            "segment form factor derivatives overflow (x is extremely close to an endpoint)".into(),
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn right_angle_is_a_quarter_turn() {
        let d = segment_form_factor_2d(DVec2::ZERO, DVec2::X, DVec2::Y, Order::Hessian).unwrap();
        assert!((d.value - 0.25).abs() < 1e-16);
        // Moving towards the segment (along (1, 1)) increases the angle.
        assert!(d.gradient.x > 0.0 && (d.gradient.x - d.gradient.y).abs() < 1e-16);
    }

    #[test]
    fn line_and_endpoint_limits() {
        let (a, b) = (DVec2::ZERO, DVec2::X);
        let on = segment_form_factor_2d(DVec2::new(0.5, 0.0), a, b, Order::Hessian).unwrap();
        assert_eq!(on, Deriv2::constant(0.5));
        let beyond = segment_form_factor_2d(DVec2::new(3.0, 0.0), a, b, Order::Hessian).unwrap();
        assert_eq!(beyond, Deriv2::constant(0.0));
        let end = segment_form_factor_2d(b, a, b, Order::Value);
        assert!(matches!(end, Err(Error::Degenerate(_))));
        let point = segment_form_factor_2d(DVec2::Y, a, a, Order::Hessian).unwrap();
        assert_eq!(point, Deriv2::constant(0.0));
    }
}
