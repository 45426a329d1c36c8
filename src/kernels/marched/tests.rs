use super::*;

#[test]
fn validation_and_limits() {
    let (x, y) = (DVec3::ZERO, DVec3::new(0.0, 0.0, 2.0));
    let bad = |r: Result<Deriv3>| matches!(r, Err(Error::InvalidArgument(_)));
    assert!(bad(transmittance_marched(
        x,
        y,
        &[1.0],
        None,
        Order::Hessian
    )));
    assert!(bad(transmittance_marched(x, y, &[], None, Order::Value)));
    assert!(bad(transmittance_marched(
        x,
        y,
        &[1.0, -0.5],
        None,
        Order::Value
    )));
    assert!(bad(transmittance_marched(
        x,
        y,
        &[1.0, f64::NAN],
        None,
        Order::Value
    )));
    assert!(bad(transmittance_marched(
        x,
        y,
        &[1.0, 1.0],
        Some(&[DVec3::ZERO]),
        Order::Value
    )));
    assert!(bad(transmittance_marched(
        x,
        y,
        &[1.0],
        Some(&[DVec3::new(0.0, f64::INFINITY, 0.0)]),
        Order::Gradient
    )));
    // x == y: value 1; gradient 0 in an empty medium, undefined otherwise.
    let empty = transmittance_marched(x, x, &[0.0, 0.0], Some(&[DVec3::X; 2]), Order::Gradient);
    assert_eq!(empty.unwrap(), Deriv3::constant(1.0));
    let thick = transmittance_marched(x, x, &[1.0], None, Order::Gradient);
    assert!(matches!(thick, Err(Error::Degenerate(_))));
    // Optical depth beyond ~745: T underflows to 0 with zero gradient, never NaN.
    let opaque = transmittance_marched(
        x,
        y,
        &[1e300],
        Some(&[DVec3::splat(1e300)]),
        Order::Gradient,
    );
    assert_eq!(opaque.unwrap(), Deriv3::constant(0.0));
}
