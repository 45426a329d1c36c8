//! Transmittance through a heterogeneous medium from extinction samples along the segment, and its
//! gradient with respect to the segment's start (Jarosz et al. 2008, App. A).

use glam::DVec3;

use super::transmittance::separation;
use crate::error::{ensure_finite3, Error, Result};
use crate::{Deriv3, Order};

/// Transmittance `T = exp(−τ)` between `x` and `y` in a heterogeneous medium, with its gradient with
/// respect to `x` (1/L).
///
/// * `sigma_t[i]` (1/L, finite, ≥ 0) is the extinction at the midpoint sample
///   `p_i = x + t_i (y − x)`, `t_i = (i + 0.5)/n`, `n = sigma_t.len() ≥ 1`.
/// * `τ = ‖x − y‖ σ̄` with `σ̄ = (1/n) Σ σ_i` (the midpoint rule for the mean extinction).
/// * `∇τ = σ̄ (x − y)/‖x − y‖ + ‖x − y‖ ∇σ̄` (Jarosz et al. 2008, eq. 30), where `∇σ̄` is the exact
///   gradient of the midpoint-rule mean when the samples move with `x` (`y` fixed): sample `i` moves
///   by `(1 − t_i)` times the displacement of `x`, so `∇σ̄ = (1/n) Σ (1 − t_i) g_i` with `g_i` the
///   spatial gradient of σ_t at `p_i` (1/L², `sigma_t_gradient[i]`).
/// * `sigma_t_gradient == None` means the medium's spatial variation is unknown: `∇σ̄` is taken as
///   zero (the mean extinction is held fixed), leaving `∇τ = σ̄ (x − y)/‖x − y‖`.
/// * `∇T = −T ∇τ`.
///
/// Only [`Order::Value`] and [`Order::Gradient`] are supported: a Hessian needs the second
/// derivatives of σ_t, which samples do not provide, so [`Order::Hessian`] is an
/// [`Error::InvalidArgument`].
///
/// Limits: at `x == y` the value is 1; the gradient is zero if `σ̄ == 0` and undefined otherwise
/// ([`Error::Degenerate`]). When `T` underflows to 0 the gradient is 0. Distances beyond `f64::MAX`
/// give `T = 0` (or 1 if `σ̄ == 0`). A gradient that overflows gives [`Error::Degenerate`].
///
/// Errors ([`Error::InvalidArgument`]): empty `sigma_t`, a negative or non-finite sample, a
/// gradient slice of a different length or with non-finite entries, non-finite `x` or `y`.
pub fn transmittance_marched(
    x: DVec3,
    y: DVec3,
    sigma_t: &[f64],
    sigma_t_gradient: Option<&[DVec3]>,
    order: Order,
) -> Result<Deriv3> {
    ensure_finite3(x, "x")?;
    ensure_finite3(y, "y")?;
    if order.hessian() {
        return Err(Error::InvalidArgument(
            "transmittance_marched computes the value and the gradient only: a Hessian would need \
             second derivatives of sigma_t (use order Value or Gradient)"
                .into(),
        ));
    }
    let n = sigma_t.len();
    if n == 0 {
        return Err(Error::InvalidArgument(
            "transmittance_marched needs at least one sigma_t sample (count >= 1)".into(),
        ));
    }
    for (i, &s) in sigma_t.iter().enumerate() {
        if !s.is_finite() || s < 0.0 {
            return Err(Error::InvalidArgument(format!(
                "sigma_t[{i}] must be finite and >= 0 (got {s})"
            )));
        }
    }
    if let Some(g) = sigma_t_gradient {
        if g.len() != n {
            return Err(Error::InvalidArgument(format!(
                "sigma_t_gradient has {} entries but sigma_t has {n}",
                g.len()
            )));
        }
        if let Some(i) = g.iter().position(|v| !v.is_finite()) {
            return Err(Error::InvalidArgument(format!(
                "sigma_t_gradient[{i}] is not finite ({})",
                g[i]
            )));
        }
    }

    let inv_n = 1.0 / n as f64;
    let mut mean = sigma_t.iter().sum::<f64>() * inv_n;
    if !mean.is_finite() {
        mean = sigma_t.iter().map(|s| s * inv_n).sum();
    }
    let (dir, dist) = separation(x, y);
    let tau = if mean == 0.0 { 0.0 } else { mean * dist };
    let t = (-tau).exp();
    let mut out = Deriv3::constant(t);
    if !order.gradient() || t == 0.0 {
        return Ok(out);
    }
    if dist == 0.0 && mean > 0.0 {
        return Err(Error::Degenerate(
            "marched transmittance gradient is undefined at x == y".into(),
        ));
    }
    let mut grad_tau = dir * mean;
    if let Some(g) = sigma_t_gradient {
        let mut grad_mean = DVec3::ZERO;
        for (i, gi) in g.iter().enumerate() {
            let weight = 1.0 - (i as f64 + 0.5) * inv_n;
            grad_mean += *gi * weight;
        }
        grad_tau += grad_mean * (inv_n * dist);
    }
    out.gradient = -t * grad_tau;
    if !out.is_finite() {
        return Err(Error::Degenerate(format!(
            "marched transmittance gradient overflows (distance {dist:e})"
        )));
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
