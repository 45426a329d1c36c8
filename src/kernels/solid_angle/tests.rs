use glam::DMat3;

use super::certified::solid_angle_fast;
use super::hessian::{hessian_of_parts, Parts, Quotient};
use super::*;

/// The Hessian's six entries are those of the 3x3 matrix expression they were written from
/// (`−(2A/g) HD − (G vᵀ + v Gᵀ)` with glam's operations, `v = (A a + D d)/g`), bit for bit, on
/// random parts of mixed magnitudes.
#[test]
fn hessian_entries_are_the_matrix_expression_bit_for_bit() {
    fn outer(u: DVec3, v: DVec3) -> DMat3 {
        DMat3::from_cols(u * v.x, u * v.y, u * v.z)
    }
    let mut state = 77;
    let mut next = || {
        (crate::test_rng::lcg(&mut state) - 0.5)
            * 10f64.powi((crate::test_rng::lcg(&mut state) * 6.0) as i32 - 3)
    };
    for _ in 0..2000 {
        let mut v = || DVec3::new(next(), next(), next());
        let r = [v(), v(), v()];
        let (grad_a, grad_d, gradient) = (v(), v(), v());
        let s = r.map(|r| r.length());
        let inv_s = s.map(|s| 1.0 / s);
        let p = [next(), next(), next()];
        let c = [next(), next(), next()];
        let (a_num, d_den, inv_g) = (next(), next(), next().abs());
        let got = hessian_of_parts(
            &Parts { r, s, inv_s, p, c },
            &Quotient {
                a_num,
                d_den,
                inv_g,
                grad_a,
                grad_d,
                gradient,
            },
        );
        let s_sum = s[0] + s[1] + s[2];
        let u = [r[0] * inv_s[0], r[1] * inv_s[1], r[2] * inv_s[2]];
        let u_sum = u[0] + u[1] + u[2];
        let mut hess_d =
            DMat3::from_diagonal(DVec3::splat(c[0] + c[1] + c[2])) + outer(u_sum, u_sum) * s_sum;
        for k in 0..3 {
            hess_d -= outer(u[k], u[k]) * (s_sum + p[k] * inv_s[k]);
        }
        let v = (grad_a * a_num + grad_d * d_den) * inv_g;
        let gv = outer(gradient, v);
        let want = hess_d * (-2.0 * a_num * inv_g) - (gv + gv.transpose());
        let bits = |m: DMat3| m.to_cols_array().map(f64::to_bits);
        assert_eq!(bits(got), bits(want));
    }
}

use std::f64::consts::PI;

#[test]
fn octant_from_the_origin_is_an_eighth_of_the_sphere() {
    let d =
        triangle_solid_angle(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, Order::Hessian).unwrap();
    assert!((d.value - PI / 2.0).abs() < 1e-15);
    // Symmetric under permutation of the axes; moving towards the triangle increases Ω.
    assert!((d.gradient.x - d.gradient.y).abs() < 1e-15);
    assert!(d.gradient.x > 0.0);
}

#[test]
fn plane_limits() {
    let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
    let inside = triangle_solid_angle(DVec3::new(0.2, 0.2, 0.0), a, b, c, Order::Hessian);
    assert_eq!(inside.unwrap(), Deriv3::constant(2.0 * PI));
    let outside = triangle_solid_angle(DVec3::new(2.0, 2.0, 0.0), a, b, c, Order::Hessian);
    assert_eq!(outside.unwrap(), Deriv3::constant(0.0));
    let edge = triangle_solid_angle(DVec3::new(0.5, 0.0, 0.0), a, b, c, Order::Value);
    assert!(matches!(edge, Err(Error::Degenerate(_))));
    let vertex = triangle_solid_angle(b, a, b, c, Order::Value);
    assert!(matches!(vertex, Err(Error::Degenerate(_))));
    let signed = triangle_solid_angle_signed(DVec3::new(0.2, 0.2, 0.0), a, b, c, Order::Value);
    assert!(matches!(signed, Err(Error::Degenerate(_))));
    let flat = triangle_solid_angle(DVec3::Z, a, b, b * 2.0, Order::Hessian).unwrap();
    assert_eq!(flat, Deriv3::constant(0.0));
}

/// Worst relative differences (value; gradient and Hessian normalized by their largest entry).
fn differences(p: &Deriv3, q: &Deriv3) -> [f64; 3] {
    let gm = q.gradient.abs().max_element();
    let hm = q
        .hessian
        .abs()
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, e| m.max(*e));
    let hd = (p.hessian - q.hessian)
        .abs()
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, e| m.max(*e));
    [
        (p.value - q.value).abs() / q.value.abs(),
        (p.gradient - q.gradient).abs().max_element() / gm,
        hd / hm,
    ]
}

/// The fast and robust results, both at order Hessian; asserts they agree within the generic
/// accuracy contract (1e-12 / 1e-12 / 1e-10) when the fast path certifies.
fn both(x: DVec3, y: [DVec3; 3], signed: bool) -> Option<Deriv3> {
    let robust = solid_angle_unchecked(x, y, Order::Hessian, signed).unwrap();
    let fast = solid_angle_fast(x, y, Order::Hessian, signed)?;
    let d = differences(&fast, &robust);
    assert!(
        d[0] <= 1e-12 && d[1] <= 1e-12 && d[2] <= 1e-10,
        "fast and robust differ by {d:?} at x={x:?} y={y:?}"
    );
    Some(fast)
}

const TRI: [DVec3; 3] = [
    DVec3::new(0.1, -0.2, 0.05),
    DVec3::new(1.1, 0.1, 0.2),
    DVec3::new(0.3, 0.9, -0.1),
];

#[test]
fn fast_path_certifies_the_target_regimes() {
    let n = (TRI[1] - TRI[0]).cross(TRI[2] - TRI[0]).normalize();
    let centroid = (TRI[0] + TRI[1] + TRI[2]) / 3.0;
    // Generic (one size above), 1e6 sizes away, 1e-6 sizes above the plane outside and inside
    // the triangle (double-double A), both signs of the normal.
    let outside = centroid + (TRI[1] - TRI[0]) * 1.5;
    for x in [
        centroid + n,
        centroid - n * 0.7 + DVec3::new(0.3, 0.1, 0.0),
        centroid + DVec3::new(4e5, -6e5, 7e5),
        outside + n * 1e-6,
        outside - n * 1e-9,
        centroid + n * 1e-6,
    ] {
        for signed in [false, true] {
            assert!(both(x, TRI, signed).is_some(), "not certified at {x:?}");
        }
    }
    // A sliver: apex 1e-6 of its length above the base (small angles at two vertices).
    let sliver = [DVec3::ZERO, DVec3::X, DVec3::new(0.4, 1e-6, 0.0)];
    for x in [DVec3::new(0.3, 0.5, 0.8), DVec3::new(-1.0, 0.2, 0.3)] {
        for k in 0..3 {
            let y = [sliver[k], sliver[(k + 1) % 3], sliver[(k + 2) % 3]];
            assert!(both(x, y, false).is_some(), "sliver not certified at {x:?}");
        }
    }
}

#[test]
fn fast_path_certifies_almost_all_generic_configurations() {
    // Random well-shaped triangles seen from 0.5..2 sizes away, anywhere off the plane by more
    // than 5% of the distance: the certificate should hardly ever send these to the robust path.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut unit = move || crate::test_rng::lcg(&mut state) * 2.0 - 1.0;
    let (mut tried, mut certified) = (0, 0);
    while tried < 2000 {
        let mut p = || DVec3::new(unit(), unit(), unit());
        let y = [p(), p(), p()];
        let x = p() * 2.0;
        let nn = (y[1] - y[0]).cross(y[2] - y[0]);
        let size = (y[1] - y[0]).length().max((y[2] - y[0]).length());
        let dist = y
            .iter()
            .map(|v| (*v - x).length())
            .fold(f64::INFINITY, f64::min);
        let height = (y[0] - x).dot(nn.normalize()).abs();
        if nn.length() < 0.2 * size * size || dist < 0.5 * size || height < 0.05 * dist {
            continue;
        }
        tried += 1;
        certified += both(x, y, tried % 2 == 0).is_some() as usize;
    }
    assert!(certified >= 1960, "certified {certified} of {tried}");
}

/// Finds, by bisection on `t ∈ [t_ok, t_fail]` (log scale), two configurations `x(t)` just on
/// each side of the point where the fast path stops certifying; checks both paths agree on the
/// certified side and that the robust path answers on the other.
fn check_switch(x_of: &dyn Fn(f64) -> DVec3, mut t_ok: f64, mut t_fail: f64, signed: bool) {
    assert!(both(x_of(t_ok), TRI, signed).is_some());
    assert!(solid_angle_fast(x_of(t_fail), TRI, Order::Hessian, signed).is_none());
    for _ in 0..60 {
        let t = (t_ok * t_fail).sqrt();
        if both(x_of(t), TRI, signed).is_some() {
            t_ok = t;
        } else {
            t_fail = t;
        }
    }
    assert!((t_ok / t_fail - 1.0).abs() < 1e-9);
    let robust = solid_angle_unchecked(x_of(t_fail), TRI, Order::Hessian, signed).unwrap();
    let fast = both(x_of(t_ok), TRI, signed).unwrap();
    // The function is smooth across the switch: the two sides agree to the contract too.
    let d = differences(&fast, &robust);
    assert!(d[0] < 1e-9 && d[1] < 1e-7 && d[2] < 1e-6, "{d:?}");
}

#[test]
fn both_paths_agree_at_the_near_edge_switch() {
    // Approaching the middle of edge ab from above the triangle's plane.
    let n = (TRI[1] - TRI[0]).cross(TRI[2] - TRI[0]).normalize();
    let mid = (TRI[0] + TRI[1]) * 0.5;
    let out = (TRI[1] - TRI[0]).cross(n).normalize();
    for dir in [n, (n + out).normalize(), (out - n * 0.01).normalize()] {
        for signed in [false, true] {
            check_switch(&|t| mid + dir * t, 0.3, 1e-12, signed);
        }
    }
}

#[test]
fn near_a_vertex_nothing_cancels_and_the_fast_path_stays() {
    // r_k = y_k − x is exact there (Sterbenz) and D, A, g all scale with the distance: the bound
    // keeps certifying down to 1e-14 sizes from the vertex.
    let n = (TRI[1] - TRI[0]).cross(TRI[2] - TRI[0]).normalize();
    let dir = (n + DVec3::new(0.3, -0.2, 0.1)).normalize();
    for t in [1e-3, 1e-6, 1e-9, 1e-12, 1e-14] {
        assert!(both(TRI[2] + dir * t, TRI, false).is_some(), "{t}");
    }
}

#[test]
fn fast_path_leaves_singular_and_out_of_range_inputs_to_the_robust_path() {
    let flat_tri = [DVec3::ZERO, DVec3::X, DVec3::Y];
    let on_plane = DVec3::new(0.2, 0.3, 0.0);
    assert!(solid_angle_fast(on_plane, flat_tri, Order::Value, false).is_none());
    assert!(solid_angle_fast(on_plane * 5.0, flat_tri, Order::Value, true).is_none());
    assert!(solid_angle_fast(TRI[1], TRI, Order::Value, false).is_none());
    let far = DVec3::new(1e31, 0.0, 0.0);
    assert!(solid_angle_fast(far, TRI, Order::Value, false).is_none());
    let nan = DVec3::new(f64::NAN, 0.0, 0.0);
    assert!(solid_angle_fast(nan, TRI, Order::Value, false).is_none());
    let flat = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
    assert!(solid_angle_fast(DVec3::Z, flat, Order::Value, false).is_none());
}

#[test]
fn hessian_at_huge_scales_is_the_rescaled_hessian() {
    // Ω is scale-invariant and HΩ scales as 1/L²: at the ends of the certified rung's range
    // (lengths 1e-29 to 1e29, g = A² + D² from 1e-174 to 1e174) every product of the Hessian and
    // of its bound stays normal (1/g² would not: it underflows from lengths near 1e25), so the
    // certified rung answers there, with the rescaled Hessian.
    let x = DVec3::new(0.4, 0.3, 0.8);
    let unit = triangle_solid_angle(x, TRI[0], TRI[1], TRI[2], Order::Hessian).unwrap();
    for scale in [1e-29, 1e-25, 1e20, 1e25, 1e28, 1e29] {
        let [a, b, c] = TRI.map(|v| v * scale);
        let fast = solid_angle_fast(x * scale, [a, b, c], Order::Hessian, false);
        assert!(fast.is_some(), "{scale}: the certified rung declines");
        let d = triangle_solid_angle(x * scale, a, b, c, Order::Hessian).unwrap();
        let rescaled = Deriv3 {
            value: d.value,
            gradient: d.gradient * scale,
            hessian: d.hessian * (scale * scale),
        };
        let diff = differences(&rescaled, &unit);
        assert!(
            diff[0] <= 1e-12 && diff[1] <= 1e-12 && diff[2] <= 1e-10,
            "{scale}: {diff:?}"
        );
    }
}
