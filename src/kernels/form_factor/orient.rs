//! The robust path's last step: the edge sum's sign follows the side of the polygon's plane `x`
//! is on, and the visible part's form factor is clamped to `[0, 1]`.

use crate::Deriv3;

/// The robust path's last step: the form factor's sign follows the side of the plane `x` is on
/// (the edge sum's orientation), clamped to [0, 1]; `None` if not finite.
#[inline]
pub(crate) fn oriented(mut d: Deriv3, h_p: f64) -> Option<Deriv3> {
    if h_p < 0.0 {
        d.value = -d.value;
        d.gradient = -d.gradient;
        d.hessian = -d.hessian;
    }
    d.value = d.value.clamp(0.0, 1.0);
    d.is_finite().then_some(d)
}

/// The form factor of the visible part from the signed sum `value` over its loop: the edge sum's
/// sign convention (positive when the polygon's right-hand normal points away from x, whose exact
/// height over the plane is `h_p`), then the clamp to `[0, 1]` that rounding may step outside;
/// `None` when not finite. Shared by the near-plane routes' split and far-field branch, whose
/// values at the value and derivative orders must have the same bits.
#[inline]
pub(crate) fn visible_value(value: f64, h_p: f64) -> Option<f64> {
    let value = if h_p < 0.0 { -value } else { value };
    let value = value.clamp(0.0, 1.0);
    value.is_finite().then_some(value)
}
