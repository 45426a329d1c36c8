//! Transmittance through a homogeneous medium, T(x) = exp(−σ_t ‖x − y‖), and its derivatives with
//! respect to x (Marco et al. 2018, App. A).

use glam::{DMat3, DVec3};

use crate::error::{ensure_finite, ensure_finite3, Error, Result};
use crate::{Deriv3, Order};

/// Transmittance `exp(-sigma_t * |x - y|)` between `x` and `y`, with derivatives with respect to `x`.
///
/// * `sigma_t`: extinction coefficient in 1/L, must be finite and ≥ 0. `sigma_t == 0` gives the
///   constant 1 with zero derivatives.
/// * Gradient: `-sigma_t T u` with `u = (x - y)/|x - y|` (1/L).
/// * Hessian: `T (sigma_t² u uᵀ − sigma_t (I − u uᵀ)/|x − y|)` (1/L²).
///
/// Limits: at `x == y` the value is 1 and the gradient is undefined (the distance has a cone
/// point): orders above [`Order::Value`] return [`Error::Degenerate`]. For `sigma_t·|x−y|` beyond
/// ~745 the value underflows to 0 and so do the derivatives. If the Hessian's `1/|x−y|` term would
/// overflow (distances below ~1e-300 L), [`Error::Degenerate`] is returned. Points more than
/// `f64::MAX` apart give 0. Distances are computed without overflow or underflow of the squared
/// length, so separations from 1e-320 to 1e308 keep full precision.
pub fn transmittance(x: DVec3, y: DVec3, sigma_t: f64, order: Order) -> Result<Deriv3> {
    ensure_finite3(x, "x")?;
    ensure_finite3(y, "y")?;
    ensure_finite(sigma_t, "sigma_t")?;
    if sigma_t < 0.0 {
        return Err(Error::InvalidArgument(format!(
            "sigma_t must be >= 0 (got {sigma_t})"
        )));
    }
    if sigma_t == 0.0 {
        return Ok(Deriv3::constant(1.0));
    }
    // Points more than f64::MAX apart: T is 0 for any sigma_t above ~1e-305 (documented limit).
    let (u, dist) = separation(x, y);
    if !dist.is_finite() {
        return Ok(Deriv3::constant(0.0));
    }
    let t = (-sigma_t * dist).exp();
    let mut out = Deriv3::constant(t);
    if !order.gradient() {
        return Ok(out);
    }
    if dist == 0.0 {
        return Err(Error::Degenerate(
            "transmittance gradient is undefined at x == y".into(),
        ));
    }
    if t == 0.0 {
        return Ok(out);
    }
    out.gradient = -sigma_t * t * u;
    if order.hessian() {
        let uu = DMat3::from_cols(u * u.x, u * u.y, u * u.z);
        let radial = sigma_t * sigma_t * t;
        let tangential = sigma_t * t / dist;
        out.hessian = uu * (radial + tangential) - DMat3::IDENTITY * tangential;
    }
    if !out.is_finite() {
        return Err(Error::Degenerate(format!(
            "transmittance derivatives overflow at distance {dist:e}"
        )));
    }
    Ok(out)
}

/// The unit vector `(x − y)/‖x − y‖` (zero when `x == y`) and the distance `‖x − y‖`, without the
/// overflow or underflow of the squared length that `DVec3::length` suffers beyond ~1e154 or below
/// ~1e-154. The distance is `inf` only when it exceeds `f64::MAX`.
pub(crate) fn separation(x: DVec3, y: DVec3) -> (DVec3, f64) {
    let d = x - y;
    if !d.is_finite() {
        // Finite points whose difference overflows: measure at half scale (exact).
        let h = x * 0.5 - y * 0.5;
        let (u, dist) = scaled_length(h);
        return (u, 2.0 * dist);
    }
    scaled_length(d)
}

fn scaled_length(d: DVec3) -> (DVec3, f64) {
    let m = d.abs().max_element();
    if m == 0.0 {
        return (DVec3::ZERO, 0.0);
    }
    if (1e-150..1e150).contains(&m) {
        let dist = d.length();
        return (d / dist, dist);
    }
    let v = d / m;
    let len = v.length();
    (v / len, len * m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extreme_separations_keep_full_precision() {
        // 1e-200 apart: the squared length would underflow to 0.
        let (x, y) = (DVec3::new(3e-200, 0.0, 4e-200), DVec3::ZERO);
        let d = transmittance(x, y, 1e199, Order::Gradient).unwrap();
        let t = (-1e199f64 * 5e-200).exp();
        assert!((d.value - t).abs() <= 1e-15 * t);
        assert!(
            (d.gradient - DVec3::new(-0.6, 0.0, -0.8) * 1e199 * t)
                .abs()
                .max_element()
                <= 1e-15 * 1e199
        );
        // 5e200 apart: the squared length would overflow.
        let x = DVec3::new(3e200, 0.0, 4e200);
        let d = transmittance(x, y, 1e-210, Order::Hessian).unwrap();
        let t = (-5e-10f64).exp();
        assert!((d.value - t).abs() <= 1e-15);
        assert!((d.gradient.x + 0.6e-210 * t).abs() <= 1e-15 * 1e-210);
        // More than f64::MAX apart: documented limit 0.
        let far = transmittance(
            DVec3::splat(f64::MAX),
            DVec3::splat(-f64::MAX),
            1.0,
            Order::Hessian,
        );
        assert_eq!(far.unwrap(), Deriv3::constant(0.0));
        // Coincident points: value 1, derivatives undefined.
        assert_eq!(transmittance(x, x, 1.0, Order::Value).unwrap().value, 1.0);
        assert!(matches!(
            transmittance(x, x, 1.0, Order::Gradient),
            Err(Error::Degenerate(_))
        ));
    }
}
