use super::*;
use crate::kernels::form_factor::robust::form_factor;

/// Coordinates whose differences overflow take `Scaled::new`'s second attempt (pre-scaled by
/// 2⁻⁴): the value is bit for bit that of the same configuration scaled down exactly by
/// 2⁻¹⁰⁰⁰, and so is the gradient scaled back (it is ~1e-309, subnormal, at this scale; the
/// Hessian underflows to zero).
#[test]
fn overflowing_differences_are_rescaled_exactly() {
    let big = 1.5e308;
    let tri = [
        DVec3::new(big, 0.2 * big, 0.9 * big),
        DVec3::new(0.7 * big, -0.1 * big, big),
        DVec3::new(0.9 * big, 0.8 * big, 0.6 * big),
    ];
    let x = DVec3::new(-big, -0.3 * big, -0.2 * big);
    assert!(!(tri[0] - x).is_finite());
    let n = DVec3::new(0.8, 0.3, 0.5).normalize();
    let down = pow2(-1000);
    let small: Vec<DVec3> = tri.iter().map(|v| *v * down).collect();
    let got = form_factor(x, n, &tri, Order::Hessian).unwrap();
    let want = form_factor(x * down, n, &small, Order::Hessian).unwrap();
    assert!(got.value > 0.0);
    assert_eq!(got.value, want.value);
    assert_eq!(got.gradient, want.gradient * down);
    assert!(got.gradient.abs().max_element() > 0.0);
}
