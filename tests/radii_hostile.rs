//! The radii functions on hostile but finite Hessians (issue 17): entries of ±1e300, ±f64::MAX,
//! subnormal, zero, indefinite and non-symmetric matrices. Every radius is finite, in
//! `[0, MAX_RADIUS]`, ascending, along orthonormal axes, and the radii follow the exact scaling law
//! of the bound (`R ∝ (τ/|λ|)^{1/4}` on surfaces, `^{1/5}` in volumes) across the whole exponent
//! range.

use std::f64::consts::PI;

use glam::{DMat3, DVec3};
use raddiff::gather::radii::{
    surface_radii, surface_radii_floored, volume_radii, CurvatureFloor, ErrorMode, MAX_RADIUS,
};

/// Entry magnitudes the matrices are built from.
const ENTRIES: [f64; 14] = [
    0.0,
    1.0,
    -1.0,
    3.7,
    1e300,
    -1e300,
    f64::MAX,
    -f64::MAX,
    5e-324,
    -5e-324,
    2.2e-308,
    1e-300,
    -7.5e150,
    4.2e-160,
];

/// splitmix64.
fn mix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The hostile matrices: every diagonal from ENTRIES³ (indefinite ones included), then symmetric
/// and non-symmetric matrices with entries drawn from ENTRIES.
fn hostile_matrices() -> Vec<DMat3> {
    let mut out = Vec::new();
    for &a in &ENTRIES {
        for &b in &ENTRIES {
            for &c in &ENTRIES {
                out.push(DMat3::from_diagonal(DVec3::new(a, b, c)));
            }
        }
    }
    for s in 0..3000u64 {
        let mut e = [0.0; 9];
        for (i, v) in e.iter_mut().enumerate() {
            *v = ENTRIES[(mix(s * 16 + i as u64) % ENTRIES.len() as u64) as usize];
        }
        let m = DMat3::from_cols_array(&e);
        out.push(if s % 2 == 0 {
            m
        } else {
            0.5 * m + 0.5 * m.transpose()
        });
    }
    out
}

fn check_axes(axes: &[DVec3], normal: Option<DVec3>) {
    for (i, a) in axes.iter().enumerate() {
        assert!((a.length() - 1.0).abs() < 1e-12, "{axes:?}");
        if let Some(n) = normal {
            assert!(a.dot(n).abs() < 1e-12, "{axes:?}");
        }
        for b in &axes[i + 1..] {
            assert!(a.dot(*b).abs() < 1e-12, "{axes:?}");
        }
    }
}

fn check_radii(r: &[f64]) {
    for w in r.windows(2) {
        assert!(w[0] <= w[1], "{r:?}");
    }
    assert!(
        r.iter()
            .all(|&v| v.is_finite() && (0.0..=MAX_RADIUS).contains(&v)),
        "{r:?}"
    );
}

#[test]
fn radii_are_finite_and_clamped_for_any_finite_hessian() {
    let normals = [
        DVec3::Z,
        DVec3::new(0.6, 0.0, 0.8),
        DVec3::new(-0.48, 0.6, -0.64),
    ];
    // (value, error): ordinary, and products that overflow or underflow
    let tolerances = [
        (1.0, 0.05),
        (1e-300, 1e300),
        (1e300, 1e-300),
        (0.0, 0.1),
        (1e300, 1e300),
    ];
    let anisotropies = [1.0, 2.0, 1e200];
    let floors = [1.0, 1e-200, 1e200];
    let mut calls = 0;
    for (i, h) in hostile_matrices().into_iter().enumerate() {
        let n = normals[i % 3];
        let (value, error) = tolerances[i % tolerances.len()];
        let aniso = anisotropies[(i / 5) % 3];
        for mode in [ErrorMode::Absolute, ErrorMode::Relative] {
            let s = surface_radii(h, n, value, error, mode, aniso).unwrap();
            check_radii(&s.radii);
            check_axes(&s.axes, Some(n));
            let floor = CurvatureFloor::new(floors[(i / 7) % 3]);
            let s = surface_radii_floored(h, n, value, error, mode, aniso, floor).unwrap();
            check_radii(&s.radii);
            check_axes(&s.axes, Some(n));
            let v = volume_radii(h, value, error, mode, aniso).unwrap();
            check_radii(&v.radii);
            check_axes(&v.axes, None);
            calls += 3;
        }
    }
    assert_eq!(calls, 6 * (14 * 14 * 14 + 3000));
}

/// Isotropic radius of the module docs: surface `(4τ/(π|λ|))^{1/4}`, volume `(5τ/(2π|λ|))^{1/5}`,
/// evaluated in logarithms so that it is exact across the exponent range, then clamped.
fn isotropic(tau: f64, lambda: f64, volume: bool) -> f64 {
    let (c, p) = if volume {
        (2.5 / PI, 5.0)
    } else {
        (4.0 / PI, 4.0)
    };
    let log = (c.ln() + tau.ln() - lambda.abs().ln()) / p;
    log.exp().min(MAX_RADIUS)
}

/// `λ·I` for λ = ±2^k across the whole exponent range (normal and subnormal), and tolerances
/// 2^t: the radii are the isotropic formula's, to 1e-12 where it is a normal number.
#[test]
fn radii_follow_the_scaling_law_across_the_exponent_range() {
    let n = DVec3::new(0.6, 0.0, 0.8);
    let mut checked = 0;
    for k in (-1070..=1023).step_by(7) {
        for sign in [1.0, -1.0] {
            let lambda = sign * 2f64.powi(k);
            let h = DMat3::from_diagonal(DVec3::splat(lambda));
            for t in [-1000, -300, -10, 0, 10, 300, 1000] {
                let tau = 2f64.powi(t);
                let s = surface_radii(h, n, 1.0, tau, ErrorMode::Absolute, 2.0).unwrap();
                let v = volume_radii(h, 1.0, tau, ErrorMode::Absolute, 2.0).unwrap();
                for (got, want) in [
                    (s.radii[0], isotropic(tau, lambda, false)),
                    (s.radii[1], isotropic(tau, lambda, false)),
                    (v.radii[0], isotropic(tau, lambda, true)),
                    (v.radii[2], isotropic(tau, lambda, true)),
                ] {
                    if want >= 1e-300 {
                        assert!(
                            (got - want).abs() <= 1e-12 * want,
                            "lambda 2^{k}, tau 2^{t}: {got} vs {want}"
                        );
                    } else {
                        assert!((0.0..1e-299).contains(&got), "{got} vs {want}");
                    }
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 8000);
}

/// An indefinite tangent Hessian diag(λ, −λ) of any magnitude gives the isotropic radius of |λ|
/// (the bound uses magnitudes), and one with a zero and a huge eigenvalue hits the anisotropy
/// clamp exactly.
#[test]
fn indefinite_and_rank_one_hessians_of_any_magnitude() {
    for lambda in [1e-300, 1.0, 1e150, 1e300, f64::MAX / 4.0] {
        let h = DMat3::from_diagonal(DVec3::new(lambda, -lambda, lambda));
        let s = surface_radii(h, DVec3::Z, 1.0, 0.01, ErrorMode::Absolute, 4.0).unwrap();
        let want = isotropic(0.01, lambda, false);
        for r in s.radii {
            assert!((r - want).abs() <= 1e-12 * want, "{lambda}: {r} vs {want}");
        }
        let h = DMat3::from_diagonal(DVec3::new(lambda, 0.0, 0.0));
        let s = surface_radii(h, DVec3::Z, 1.0, 0.01, ErrorMode::Absolute, 4.0).unwrap();
        if want * 4.0 < MAX_RADIUS {
            assert!(
                (s.radii[1] / s.radii[0] - 4.0).abs() < 1e-12,
                "{lambda}: {:?}",
                s.radii
            );
        } else {
            assert_eq!(s.radii, [MAX_RADIUS; 2], "{lambda}");
        }
    }
}
