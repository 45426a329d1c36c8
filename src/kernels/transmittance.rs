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
/// overflow (distances below ~1e-300 L), [`Error::Degenerate`] is returned.
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
    let d = x - y;
    // The difference of finite points can overflow when they are ~1e308 apart: T is 0 there.
    let dist = d.length();
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
    let u = d / dist;
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
