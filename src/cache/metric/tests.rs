use super::*;

#[test]
fn harmonic_mean_by_hand() {
    // 4 rays at 1, 2, 4 and a miss: 4 / (1 + 0.5 + 0.25 + 0) = 16/7
    let r = harmonic_mean_distance(&[1.0, 2.0, 4.0, f64::INFINITY]).unwrap();
    assert!((r - 16.0 / 7.0).abs() < 1e-15);
    assert!(matches!(
        harmonic_mean_distance(&[f64::INFINITY; 3]),
        Err(Error::Degenerate(_))
    ));
    assert!(harmonic_mean_distance(&[1.0, -1.0]).is_err());
    assert!(harmonic_mean_distance(&[1.0, f64::NAN]).is_err());
}

#[test]
fn split_sphere_and_gradient_bound_by_hand() {
    assert_eq!(split_sphere(0.2, 5.0).unwrap(), 1.0);
    // E/|∇E| = 2/1 = 2 < R = 5: bounded radius a·2 = 0.4
    let r = split_sphere_bounded(0.2, 5.0, 2.0, DVec3::new(0.0, 0.6, 0.8)).unwrap();
    assert!((r - 0.4).abs() < 1e-15);
    // small gradient: the split sphere wins
    let r = split_sphere_bounded(0.2, 5.0, 2.0, DVec3::new(0.0, 0.0, 0.1)).unwrap();
    assert_eq!(r, 1.0);
    assert_eq!(split_sphere_bounded(0.2, 5.0, 0.0, DVec3::X).unwrap(), 1.0);
    assert!(split_sphere(0.0, 1.0).is_err());
}

#[test]
fn gradient_metric_by_hand() {
    // ε (1 + 3) / (|(3,4,0)| + |(0,0,5)|) = 0.5 · 4 / 10
    let r = gradient_metric(
        0.5,
        &[1.0, 3.0],
        &[DVec3::new(3.0, 4.0, 0.0), DVec3::new(0.0, 0.0, 5.0)],
    )
    .unwrap();
    assert!((r - 0.2).abs() < 1e-15);
    assert!(matches!(
        gradient_metric(0.5, &[1.0], &[DVec3::ZERO]),
        Err(Error::Degenerate(_))
    ));
    assert!(gradient_metric(0.5, &[1.0], &[]).is_err());
}

#[test]
fn hessian_extents_follow_gather_radii() {
    // isotropic tangent Hessian 3: R = (4 τ/(π 3))^¼ with τ = 0.02 (thesis eq. 4.19)
    let h = DMat3::from_diagonal(DVec3::new(3.0, 3.0, 7.0));
    let e = hessian_surface(h, DVec3::Z, 1.0, 0.02, ErrorMode::Absolute, 2.0).unwrap();
    let expect = (4.0 * 0.02 / (std::f64::consts::PI * 3.0)).powf(0.25);
    assert!((e.radii[0] - expect).abs() < 1e-12 && (e.radii[1] - expect).abs() < 1e-12);
    // anisotropic: the short axis lies along the strong curvature (x)
    let h = DMat3::from_diagonal(DVec3::new(8.0, 1.0, 0.0));
    let e = hessian_surface(h, DVec3::Z, 1.0, 0.02, ErrorMode::Absolute, 4.0).unwrap();
    assert!(e.radii[0] < e.radii[1] && e.axes[0].x.abs() > 0.999);
    let e = hessian_volume(
        DMat3::from_diagonal(DVec3::splat(-2.0)),
        4.0,
        0.1,
        ErrorMode::Relative,
        2.0,
    )
    .unwrap();
    let ours = (5.0 * 0.4 / (2.0 * std::f64::consts::PI * 2.0)).powf(0.2);
    assert!(e.radii.iter().all(|r| (r - ours).abs() < 1e-12));
    assert!(matches!(
        hessian_volume(DMat3::IDENTITY, 1.0, 0.0, ErrorMode::Absolute, 2.0),
        Err(Error::Degenerate(_))
    ));
}

#[test]
fn limits_clamp_each_radius() {
    let l = RadiusLimits::new(0.5, 2.0).unwrap();
    let e = Extent {
        radii: [0.1, 1.0, 9.0],
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
    };
    assert_eq!(l.apply(&e).radii, [0.5, 1.0, 2.0]);
    assert!(RadiusLimits::new(2.0, 1.0).is_err());
}
