use super::*;

#[test]
fn isotropic_2d_matches_thesis_eq_4_19() {
    let h = DMat2::from_diagonal(DVec2::new(3.0, 3.0));
    let r = ellipse_radii(h, 1.0, 0.02, ErrorMode::Absolute, 2.0).unwrap();
    let expect = (4.0 * 0.02 / (std::f64::consts::PI * 3.0)).powf(0.25);
    assert!((r.radii[0] - expect).abs() < 1e-14 * expect);
    assert!((r.radii[1] - expect).abs() < 1e-14 * expect);
}

#[test]
fn isotropic_3d_is_marco_eq_22_without_the_overshoot() {
    let h = DMat3::from_diagonal(DVec3::splat(-2.0));
    let r = volume_radii(h, 4.0, 0.1, ErrorMode::Relative, 2.0).unwrap();
    let tau = 0.4;
    let ours = (5.0 * tau / (2.0 * std::f64::consts::PI * 2.0)).powf(0.2);
    for a in r.radii {
        assert!((a - ours).abs() < 1e-13 * ours);
    }
    let marco = (15.0 * tau / (4.0 * std::f64::consts::PI * 2.0)).powf(0.2);
    let b = ellipsoid_error_bound([-2.0; 3], [marco; 3]);
    assert!((b / tau - 1.5).abs() < 1e-12);
}

/// Isotropic surface radius for tangent curvature `mu` and tolerance `tau` (module docs).
fn isotropic_radius(mu: f64, tau: f64) -> f64 {
    (4.0 * tau / (std::f64::consts::PI * mu)).powf(0.25)
}

#[test]
fn curvature_floor_binds_where_the_hessian_vanishes() {
    let floor = CurvatureFloor::new(0.5);
    let (e, eps) = (2.0, 1e-3);
    // A flat estimate: without the floor the largest radius, with it the split-sphere-like one.
    let plain = surface_radii(DMat3::ZERO, DVec3::Z, e, eps, ErrorMode::Relative, 2.0).unwrap();
    assert_eq!(plain.radii, [MAX_RADIUS; 2]);
    let floored = surface_radii_floored(
        DMat3::ZERO,
        DVec3::Z,
        e,
        eps,
        ErrorMode::Relative,
        2.0,
        floor,
    )
    .unwrap();
    let expect = isotropic_radius(CURVATURE_FLOOR_WEIGHT * e / 0.25, eps * e);
    for r in floored.radii {
        assert!((r - expect).abs() < 1e-12 * expect, "{r} vs {expect}");
    }
    // = (4 eps D² / (pi kappa))^(1/4), whatever the value
    let closed = (4.0 * eps * 0.25 / (std::f64::consts::PI * CURVATURE_FLOOR_WEIGHT)).powf(0.25);
    assert!((expect - closed).abs() < 1e-12 * closed);
    // The normal component of the Hessian is not curvature along the surface.
    let normal_only = DMat3::from_diagonal(DVec3::new(0.0, 0.0, 50.0));
    let r = surface_radii_floored(
        normal_only,
        DVec3::Z,
        e,
        eps,
        ErrorMode::Relative,
        2.0,
        floor,
    )
    .unwrap();
    assert!((r.radii[0] - expect).abs() < 1e-12 * expect);
}

#[test]
fn curvature_floor_gives_black_gathers_a_finite_radius() {
    let floor = CurvatureFloor::new(0.8);
    let eps = 1e-4;
    let plain = surface_radii(DMat3::ZERO, DVec3::Y, 0.0, eps, ErrorMode::Relative, 2.0).unwrap();
    assert_eq!(plain.radii, [MAX_RADIUS; 2]);
    let r = surface_radii_floored(
        DMat3::ZERO,
        DVec3::Y,
        0.0,
        eps,
        ErrorMode::Relative,
        2.0,
        floor,
    )
    .unwrap();
    let closed = (4.0 * eps * 0.64 / (std::f64::consts::PI * CURVATURE_FLOOR_WEIGHT)).powf(0.25);
    for a in r.radii {
        assert!((a - closed).abs() < 1e-12 * closed, "{a} vs {closed}");
    }
    // the limit of a vanishing value: continuous
    let tiny = surface_radii_floored(
        DMat3::ZERO,
        DVec3::Y,
        1e-200,
        eps,
        ErrorMode::Relative,
        2.0,
        floor,
    )
    .unwrap();
    assert!((tiny.radii[0] - closed).abs() < 1e-12 * closed);
    // absolute mode: a zero value adds no curvature (an absolute error of 0 stays 0)
    let abs = surface_radii_floored(
        DMat3::ZERO,
        DVec3::Y,
        0.0,
        eps,
        ErrorMode::Absolute,
        2.0,
        floor,
    )
    .unwrap();
    assert_eq!(abs.radii, [MAX_RADIUS; 2]);
}

#[test]
fn curvature_floor_is_negligible_where_the_hessian_is_strong() {
    // a penumbra-like Hessian: |λ| = 400 E / D², 10⁴ times the floor
    let (e, d, eps) = (1.5, 0.3, 1e-3);
    let lambda = 400.0 * e / (d * d);
    let h = DMat3::from_diagonal(DVec3::new(-lambda, 0.5 * lambda, 7.0));
    let floor = CurvatureFloor::new(d);
    let plain = surface_radii(h, DVec3::Z, e, eps, ErrorMode::Relative, 2.0).unwrap();
    let floored =
        surface_radii_floored(h, DVec3::Z, e, eps, ErrorMode::Relative, 2.0, floor).unwrap();
    for (a, b) in plain.radii.iter().zip(floored.radii) {
        let change = (a - b) / a;
        assert!(change > 0.0 && change < 2e-4, "relative change {change}");
    }
    assert!((plain.axes[0] - floored.axes[0]).length() < 1e-12);
    // indefinite Hessians are floored on magnitudes: the floor never cancels curvature
    let saddle = DMat3::from_diagonal(DVec3::new(-2.0, 2.0, 0.0));
    let a = surface_radii(saddle, DVec3::Z, 1.0, eps, ErrorMode::Relative, 1.0).unwrap();
    let b = surface_radii_floored(
        saddle,
        DVec3::Z,
        1.0,
        eps,
        ErrorMode::Relative,
        1.0,
        CurvatureFloor {
            distance: 1.0,
            weight: 2.0,
        },
    )
    .unwrap();
    let expect = isotropic_radius(4.0, eps);
    assert!(a.radii[0] > b.radii[0] && (b.radii[0] - expect).abs() < 1e-12 * expect);
}

#[test]
fn curvature_floor_rejects_bad_input_and_stays_finite() {
    for f in [
        CurvatureFloor {
            distance: 0.0,
            weight: 0.04,
        },
        CurvatureFloor {
            distance: f64::INFINITY,
            weight: 0.04,
        },
        CurvatureFloor {
            distance: 1.0,
            weight: -1.0,
        },
        CurvatureFloor {
            distance: 1.0,
            weight: f64::NAN,
        },
    ] {
        assert!(surface_radii_floored(
            DMat3::ZERO,
            DVec3::Z,
            1.0,
            1e-3,
            ErrorMode::Relative,
            2.0,
            f
        )
        .is_err());
    }
    for (h, v, d) in [
        (DMat3::from_diagonal(DVec3::splat(1e300)), 1e-300, 1e-300),
        (DMat3::ZERO, 1e300, 1e-300),
        (DMat3::from_diagonal(DVec3::splat(-1e-300)), 1e300, 1e300),
    ] {
        let f = CurvatureFloor::new(d);
        let r = surface_radii_floored(h, DVec3::Z, v, 1e-3, ErrorMode::Relative, 2.0, f).unwrap();
        assert!(r.radii.iter().all(|a| a.is_finite() && *a >= 0.0), "{r:?}");
    }
}

#[test]
fn tangent_basis_is_orthonormal_and_right_handed() {
    for n in [
        DVec3::Z,
        -DVec3::Z,
        DVec3::X,
        DVec3::new(0.3, -0.4, 0.866).normalize(),
        DVec3::new(1e-9, 0.0, -1.0).normalize(),
    ] {
        let (u1, u2) = tangent_basis(n);
        assert!((u1.length() - 1.0).abs() < 1e-14);
        assert!((u2.length() - 1.0).abs() < 1e-14);
        assert!(u1.dot(u2).abs() < 1e-14 && u1.dot(n).abs() < 1e-14);
        assert!((u1.cross(u2) - n).length() < 1e-14);
    }
}
