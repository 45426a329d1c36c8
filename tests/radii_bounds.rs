//! Each radius formula of `gather::radii` against direct numerical integration of the error it
//! claims to bound: `½ ∫_D |dᵀ H d| dd` over the returned ellipse / ellipsoid must equal the tolerance
//! for a definite Hessian and stay below it otherwise (see the module docs and ERRATA item 5).

use std::f64::consts::PI;

use glam::{DMat2, DMat3, DVec2, DVec3};
use raddiff::gather::radii::{
    ellipse_error_bound, ellipse_radii, surface_radii, volume_radii, ErrorMode, MAX_RADIUS,
};

/// Deterministic pseudo-random numbers in [-1, 1) (splitmix64).
#[path = "common/splitmix.rs"]
mod splitmix;

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        splitmix::uniform(&mut self.0) * 2.0 - 1.0
    }
    fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.next(), self.next(), self.next());
            let l = v.length();
            if l > 0.1 && l < 1.0 {
                return v / l;
            }
        }
    }
}

fn rotation(rng: &mut Rng) -> DMat3 {
    let a = rng.unit();
    let b = (rng.unit() - a * a.dot(rng.unit())).normalize();
    let b = (b - a * a.dot(b)).normalize();
    DMat3::from_cols(a, b, a.cross(b))
}

/// `½ ∫ |dᵀ H d|` over the planar ellipse centred at 0 with semi-axes `r[i]` along world `axes[i]`,
/// by the midpoint rule in elliptic polar coordinates (Jacobian r0 r1 ρ).
fn integrate_ellipse_3d(h: DMat3, r: [f64; 2], axes: [DVec3; 2], n: usize) -> f64 {
    let mut sum = 0.0;
    for i in 0..n {
        let rho = (i as f64 + 0.5) / n as f64;
        for k in 0..n {
            let phi = 2.0 * PI * (k as f64 + 0.5) / n as f64;
            let d = rho * (r[0] * phi.cos() * axes[0] + r[1] * phi.sin() * axes[1]);
            sum += 0.5 * d.dot(h * d).abs() * rho;
        }
    }
    sum * r[0] * r[1] * (1.0 / n as f64) * (2.0 * PI / n as f64)
}

fn integrate_ellipse_2d(h: DMat2, r: [f64; 2], axes: [DVec2; 2], n: usize) -> f64 {
    let mut sum = 0.0;
    for i in 0..n {
        let rho = (i as f64 + 0.5) / n as f64;
        for k in 0..n {
            let phi = 2.0 * PI * (k as f64 + 0.5) / n as f64;
            let d = rho * (r[0] * phi.cos() * axes[0] + r[1] * phi.sin() * axes[1]);
            sum += 0.5 * d.dot(h * d).abs() * rho;
        }
    }
    sum * r[0] * r[1] * (1.0 / n as f64) * (2.0 * PI / n as f64)
}

/// `½ ∫ |dᵀ H d|` over the ellipsoid with semi-axes `r[i]` along `axes[i]`, midpoint rule in
/// ellipsoidal spherical coordinates (Jacobian r0 r1 r2 ρ² sinθ).
fn integrate_ellipsoid(h: DMat3, r: [f64; 3], axes: [DVec3; 3], n: usize) -> f64 {
    let mut sum = 0.0;
    for i in 0..n {
        let rho = (i as f64 + 0.5) / n as f64;
        for j in 0..n {
            let theta = PI * (j as f64 + 0.5) / n as f64;
            let (st, ct) = theta.sin_cos();
            for k in 0..2 * n {
                let phi = PI * (k as f64 + 0.5) / n as f64;
                let local = DVec3::new(st * phi.cos(), st * phi.sin(), ct) * rho;
                let d =
                    r[0] * local.x * axes[0] + r[1] * local.y * axes[1] + r[2] * local.z * axes[2];
                sum += 0.5 * d.dot(h * d).abs() * rho * rho * st;
            }
        }
    }
    sum * r[0] * r[1] * r[2] * (1.0 / n as f64) * (PI / n as f64) * (PI / n as f64)
}

fn sym_from_eigen(rot: DMat3, l: [f64; 3]) -> DMat3 {
    rot * DMat3::from_diagonal(DVec3::from(l)) * rot.transpose()
}

#[test]
fn surface_radii_bound_the_integrated_error() {
    let mut rng = Rng(7);
    for case in 0..24 {
        let rot = rotation(&mut rng);
        // Eigenvalues spanning definite, indefinite and nearly singular tangent Hessians.
        let l = [
            rng.next() * 10.0,
            rng.next() * (if case % 4 == 0 { 1e-3 } else { 10.0 }),
            rng.next() * 10.0,
        ];
        let h = sym_from_eigen(rot, l);
        let n = rng.unit();
        let value = 0.5 + rng.next().abs();
        let error = 0.01 * (1.0 + rng.next().abs());
        for (mode, tau) in [
            (ErrorMode::Absolute, error),
            (ErrorMode::Relative, error * value),
        ] {
            for aniso in [1.0, 2.0, 8.0] {
                let r = surface_radii(h, n, value, error, mode, aniso).unwrap();
                assert!(
                    r.radii[0] <= r.radii[1] && r.radii[1] <= aniso * r.radii[0] * (1.0 + 1e-12)
                );
                for a in r.axes {
                    assert!((a.length() - 1.0).abs() < 1e-12 && a.dot(n).abs() < 1e-12);
                }
                assert!(r.axes[0].dot(r.axes[1]).abs() < 1e-12);
                let e = integrate_ellipse_3d(h, r.radii, r.axes, 400);
                assert!(
                    e <= tau * (1.0 + 1e-4),
                    "case {case}: error {e} > tolerance {tau}"
                );
                // For a definite tangent Hessian the bound is attained: the radii are not needlessly small.
                let t = raddiff::gather::radii::tangent_hessian(h, r.axes[0], r.axes[1]);
                if t.x_axis.x * t.y_axis.y > 0.0 {
                    assert!((e / tau - 1.0).abs() < 1e-4, "case {case}: {e} vs {tau}");
                }
            }
        }
    }
}

#[test]
fn ellipse_radii_bound_the_integrated_error() {
    let mut rng = Rng(11);
    for _ in 0..24 {
        let phi = rng.next() * PI;
        let v0 = DVec2::new(phi.cos(), phi.sin());
        let rot = DMat2::from_cols(v0, v0.perp());
        let l = DVec2::new(rng.next() * 5.0, rng.next() * 5.0);
        let h = rot * DMat2::from_diagonal(l) * rot.transpose();
        let r = ellipse_radii(h, 2.0, 0.05, ErrorMode::Relative, 3.0).unwrap();
        let e = integrate_ellipse_2d(h, r.radii, r.axes, 400);
        assert!(e <= 0.1 * (1.0 + 1e-4));
        if l.x * l.y > 0.0 {
            assert!((e / 0.1 - 1.0).abs() < 1e-4);
        }
    }
}

#[test]
fn volume_radii_bound_the_integrated_error() {
    let mut rng = Rng(13);
    for case in 0..10 {
        let rot = rotation(&mut rng);
        let mut l = [rng.next() * 4.0, rng.next() * 4.0, rng.next() * 4.0];
        if case % 3 == 0 {
            // definite
            l = l.map(|v| v.abs() + 0.1);
        }
        let h = sym_from_eigen(rot, l);
        for aniso in [1.0, 2.0, 10.0] {
            let r = volume_radii(h, 3.0, 0.02, ErrorMode::Relative, aniso).unwrap();
            assert!(r.radii[0] <= r.radii[1] && r.radii[1] <= r.radii[2]);
            assert!(r.radii[2] <= aniso * r.radii[0] * (1.0 + 1e-12));
            let m = DMat3::from_cols(r.axes[0], r.axes[1], r.axes[2]);
            assert!((m.transpose() * m - DMat3::IDENTITY)
                .to_cols_array()
                .iter()
                .all(|v| v.abs() < 1e-12));
            let e = integrate_ellipsoid(h, r.radii, r.axes, 80);
            assert!(e <= 0.06 * (1.0 + 1e-3), "case {case}: {e}");
            if case % 3 == 0 {
                assert!((e / 0.06 - 1.0).abs() < 1e-3, "case {case}: {e}");
            }
        }
    }
}

#[test]
fn the_papers_anisotropic_formula_overshoots_the_bound() {
    // Thesis eq. 4.22 / Marco eq. 21: every axis from the isotropic formula.
    let (l1, l2, tau) = (16.0f64, 1.0f64, 0.01);
    let paper = [
        (4.0 * tau / (PI * l1)).powf(0.25),
        (4.0 * tau / (PI * l2)).powf(0.25),
    ];
    let overshoot = ellipse_error_bound([l1, l2], paper) / tau;
    let ratio = paper[1] / paper[0];
    assert!((overshoot - 0.5 * (ratio + 1.0 / ratio)).abs() < 1e-12);
    assert!(overshoot > 1.2);
    let h = DMat2::from_diagonal(DVec2::new(l1, l2));
    let ours = ellipse_radii(h, 1.0, tau, ErrorMode::Absolute, 100.0).unwrap();
    // Same tolerance, exact bound, and more area than the paper's (overshooting) ellipse would need.
    assert!((ellipse_error_bound([l1, l2], ours.radii) / tau - 1.0).abs() < 1e-12);
    assert!((ours.radii[1] / ours.radii[0] - 4.0).abs() < 1e-12);
}

#[test]
fn flat_and_singular_hessians_give_finite_radii() {
    let n = DVec3::new(0.0, 0.6, 0.8);
    let r = surface_radii(DMat3::ZERO, n, 1.0, 0.1, ErrorMode::Relative, 2.0).unwrap();
    assert_eq!(r.radii, [MAX_RADIUS; 2]);
    // Curvature only along the normal: the tangent Hessian vanishes.
    let along_n = DMat3::from_cols(n * n.x, n * n.y, n * n.z) * 5.0;
    let r = surface_radii(along_n, n, 1.0, 0.1, ErrorMode::Relative, 2.0).unwrap();
    assert_eq!(r.radii, [MAX_RADIUS; 2]);
    // One zero eigenvalue: the anisotropy clamp decides the long axis.
    let h = DMat3::from_diagonal(DVec3::new(4.0, 0.0, 0.0));
    let r = surface_radii(h, DVec3::Z, 1.0, 0.1, ErrorMode::Absolute, 2.0).unwrap();
    assert!(r.radii[0].is_finite() && (r.radii[1] / r.radii[0] - 2.0).abs() < 1e-12);
    assert!(r.axes[0].x.abs() > 0.999_999);
    // Tiny and huge scales.
    for s in [1e-300, 1e-150, 1e150, 1e300] {
        let h = DMat3::from_diagonal(DVec3::new(s, 2.0 * s, s));
        let r = volume_radii(h, 1.0, 1e-3, ErrorMode::Relative, 2.0).unwrap();
        assert!(r
            .radii
            .iter()
            .all(|a| a.is_finite() && *a >= 0.0 && *a <= MAX_RADIUS));
        let r = surface_radii(h, DVec3::Z, 1e300, 1e300, ErrorMode::Relative, 2.0).unwrap();
        assert!(r
            .radii
            .iter()
            .all(|a| a.is_finite() && *a >= 0.0 && *a <= MAX_RADIUS));
    }
    // Zero tolerance: zero radii.
    let h = DMat3::IDENTITY;
    let r = volume_radii(h, 0.0, 0.1, ErrorMode::Relative, 2.0).unwrap();
    assert_eq!(r.radii, [0.0; 3]);
}

#[test]
fn relative_radii_are_scale_invariant_and_absolute_follow_the_fourth_root() {
    let h = DMat3::from_cols(
        DVec3::new(2.0, 0.5, 0.1),
        DVec3::new(0.5, -1.0, 0.3),
        DVec3::new(0.1, 0.3, 0.7),
    );
    let n = DVec3::new(0.48, 0.6, 0.64);
    let a = surface_radii(h, n, 3.0, 0.01, ErrorMode::Relative, 4.0).unwrap();
    let b = surface_radii(h * 1e6, n, 3e6, 0.01, ErrorMode::Relative, 4.0).unwrap();
    for i in 0..2 {
        assert!((a.radii[i] / b.radii[i] - 1.0).abs() < 1e-12);
        assert!(a.axes[i].dot(b.axes[i]).abs() > 1.0 - 1e-12);
    }
    let c = surface_radii(h, n, 3.0, 0.16, ErrorMode::Absolute, 4.0).unwrap();
    let d = surface_radii(h, n, 3.0, 0.01, ErrorMode::Absolute, 4.0).unwrap();
    assert!((c.radii[0] / d.radii[0] - 2.0).abs() < 1e-12);
    let v = volume_radii(h, 1.0, 32.0, ErrorMode::Absolute, 4.0).unwrap();
    let w = volume_radii(h, 1.0, 1.0, ErrorMode::Absolute, 4.0).unwrap();
    assert!((v.radii[2] / w.radii[2] - 2.0).abs() < 1e-12);
}

#[test]
fn invalid_arguments_are_rejected() {
    let h = DMat3::IDENTITY;
    let bad_h = DMat3::from_diagonal(DVec3::new(f64::NAN, 1.0, 1.0));
    let m = ErrorMode::Absolute;
    assert!(surface_radii(bad_h, DVec3::Z, 1.0, 0.1, m, 2.0).is_err());
    assert!(surface_radii(h, DVec3::new(0.0, 0.0, 2.0), 1.0, 0.1, m, 2.0).is_err());
    assert!(surface_radii(h, DVec3::ZERO, 1.0, 0.1, m, 2.0).is_err());
    assert!(surface_radii(h, DVec3::Z, f64::INFINITY, 0.1, m, 2.0).is_err());
    assert!(surface_radii(h, DVec3::Z, 1.0, -0.1, m, 2.0).is_err());
    assert!(surface_radii(h, DVec3::Z, 1.0, 0.1, m, 0.5).is_err());
    assert!(volume_radii(bad_h, 1.0, 0.1, m, 2.0).is_err());
    assert!(volume_radii(h, 1.0, f64::NAN, m, 2.0).is_err());
    assert!(volume_radii(h, 1.0, 0.1, m, f64::INFINITY).is_err());
    assert!(ErrorMode::try_from(2).is_err());
    assert_eq!(ErrorMode::try_from(1).unwrap(), ErrorMode::Relative);
}
