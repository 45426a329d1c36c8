use super::*;
use crate::kernels::form_factor::edge::edge_term_exact;
use crate::kernels::form_factor::lambert;
use crate::kernels::form_factor::robust::form_factor;
use crate::kernels::form_factor::scaled::Scaled;
use crate::kernels::form_factor::validate::unit_normal;
use crate::kernels::form_factor::{edge_form_factor, polygon_form_factor, triangle_form_factor};
use crate::Error;

const TRI: [DVec3; 3] = [
    DVec3::new(-0.4, -0.3, 1.0),
    DVec3::new(0.7, -0.1, 1.2),
    DVec3::new(0.0, 0.8, 0.9),
];

fn n() -> DVec3 {
    DVec3::new(0.2, -0.1, 1.0).normalize()
}

/// The robust evaluation (the polygon path, which has no fast path).
fn robust(x: DVec3, n: DVec3, t: [DVec3; 3]) -> Deriv3 {
    form_factor(x, n, &t, Order::Hessian).unwrap()
}

/// Walks `x(t)` for `t` from `t0` down to `t1` (log steps) and checks that the fast path is
/// taken at `t0`, declines at `t1`, and agrees bit for bit with the robust path wherever it is
/// taken; returns the last certified and first declined parameters.
fn walk(x_of: &dyn Fn(f64) -> DVec3, t: [DVec3; 3], t0: f64, t1: f64) -> (f64, f64) {
    walk_n(x_of, n(), t, t0, t1)
}

fn walk_n(x_of: &dyn Fn(f64) -> DVec3, n: DVec3, t: [DVec3; 3], t0: f64, t1: f64) -> (f64, f64) {
    let (mut last_ok, mut first_fail) = (f64::NAN, f64::NAN);
    let steps = 400;
    for k in 0..=steps {
        let p = t0 * (t1 / t0).powf(k as f64 / steps as f64);
        let x = x_of(p);
        match triangle_form_factor_fast(x, n, t, Order::Hessian) {
            Some(f) => {
                assert_eq!(f, robust(x, n, t), "fast != robust at {x:?}");
                if first_fail.is_nan() {
                    last_ok = p;
                }
            }
            None => {
                if first_fail.is_nan() {
                    first_fail = p;
                }
            }
        }
    }
    assert!(
        !last_ok.is_nan() && !first_fail.is_nan(),
        "no switch in [{t1}, {t0}]"
    );
    // Narrow the switch down to configurations a relative 1e-12 apart.
    for _ in 0..60 {
        let mid = (last_ok * first_fail).sqrt();
        match triangle_form_factor_fast(x_of(mid), n, t, Order::Hessian) {
            Some(f) => {
                assert_eq!(f, robust(x_of(mid), n, t));
                last_ok = mid;
            }
            None => first_fail = mid,
        }
    }
    assert!((last_ok / first_fail - 1.0).abs() < 1e-12);
    (last_ok, first_fail)
}

fn close(p: &Deriv3, q: &Deriv3, tol: f64) -> bool {
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
    (p.value - q.value).abs() <= tol * q.value.abs()
        && (p.gradient - q.gradient).abs().max_element() <= tol * q.gradient.abs().max_element()
        && hd <= tol * hm
}

#[test]
fn fast_triangle_equals_robust_and_switches_off_at_the_tangent_plane() {
    // Lower x's tangent plane onto vertex c: the fast path declines just before the clip starts.
    let c = TRI[2];
    let base = DVec3::new(0.1, -0.2, 0.05);
    // Move x along n so that n·(c − x) = t·|c − base|.
    let x_of = |t: f64| base + n() * (n().dot(c - base) - t * (c - base).length());
    let (ok, fail) = walk(&x_of, TRI, 0.3, 1e-18);
    // Both sides of the switch give the same function to well within the contract.
    let (a, b) = (robust(x_of(ok), n(), TRI), robust(x_of(fail), n(), TRI));
    assert!(close(
        &triangle_form_factor_fast(x_of(ok), n(), TRI, Order::Hessian).unwrap(),
        &a,
        0.0
    ));
    assert!(close(&a, &b, 1e-9), "{a:?} {b:?}");
}

#[test]
fn fast_triangle_switches_off_near_an_edge_line_and_in_the_far_field() {
    // Approach the extension of edge ab beyond a, out of the triangle's plane, with a receiver
    // normal in that plane (every vertex stays above the tangent plane).
    let (a, b, c) = (TRI[0], TRI[1], TRI[2]);
    let ne = ((b - a).normalize() + (c - a).normalize()).normalize();
    let plane_n = (b - a).cross(c - a).normalize();
    let x_of = |t: f64| a - (b - a) * 0.5 + plane_n * t;
    let (ok, fail) = walk_n(&x_of, ne, TRI, 0.5, 1e-9);
    let (p, q) = (robust(x_of(ok), ne, TRI), robust(x_of(fail), ne, TRI));
    assert!(close(&p, &q, 1e-9), "{p:?} {q:?}");
    // Far away along −n: the robust path switches to quadrature at 16 radii.
    let centroid = (TRI[0] + TRI[1] + TRI[2]) / 3.0;
    let x_far = |t: f64| centroid - n() * (1.0 / t);
    let (ok, fail) = walk(&x_far, TRI, 1.0, 1e-3);
    assert!(1.0 / ok < 1.0 / fail);
    let (p, q) = (robust(x_far(ok), n(), TRI), robust(x_far(fail), n(), TRI));
    assert!(close(&p, &q, 1e-9), "{p:?} {q:?}");
}

/// The far-field fast path, walking x from 1e7 radii in to 8 along a few directions (every
/// far-field rule switch is crossed): bit-for-bit the robust path wherever taken, taken at every
/// step beyond 16 radii (nothing is clipped), declined below. Clipped and sliver triangles go
/// to the robust path.
#[test]
fn far_field_fast_path_equals_robust_across_its_rule_switches() {
    let centroid = (TRI[0] + TRI[1] + TRI[2]) / 3.0;
    let radius = TRI
        .iter()
        .map(|v| (*v - centroid).length())
        .fold(0.0, f64::max);
    for dir in [
        -n(),
        DVec3::new(-0.3, 0.2, -1.0).normalize(),
        DVec3::new(0.5, -0.6, -0.4).normalize(),
    ] {
        let steps = 600;
        for k in 0..=steps {
            let ratio = 1e7 * (8.0f64 / 1e7).powf(k as f64 / steps as f64);
            let x = centroid + dir * (ratio * radius);
            let got = triangle_far_field_fast(x, n(), TRI, Order::Hessian);
            if ratio > 16.0 * (1.0 + 1e-9) {
                let (got, min_ratio) = got.unwrap_or_else(|| panic!("declined at {ratio}"));
                assert!(ratio >= min_ratio * (1.0 - 1e-12), "{ratio} < {min_ratio}");
                assert_eq!(got, robust(x, n(), TRI), "at {ratio}");
                // The entry point takes it, for every order, with the same value (Lambert's
                // where certified: its far form is, out to 1e7 radii).
                let entry = |o| triangle_form_factor(x, n(), TRI[0], TRI[1], TRI[2], o).unwrap();
                let (value, hessian) = (entry(Order::Value), entry(Order::Hessian));
                assert_eq!(value.value, hessian.value, "at {ratio}");
                assert_eq!(
                    (hessian.gradient, hessian.hessian),
                    (got.gradient, got.hessian)
                );
                let lambert = lambert::sum::triangle_value(x, n(), TRI);
                assert_eq!(value.value, lambert.unwrap_or(got.value), "at {ratio}");
                assert!(lambert.is_some(), "Lambert not certified at {ratio}");
            } else if ratio < 16.0 * (1.0 - 1e-9) {
                assert!(got.is_none(), "taken at {ratio}");
            }
        }
    }
    // Far away but clipped (the tangent plane through the triangle): declined.
    let x = centroid - n() * (1e3 * radius);
    let tilted = (TRI[0] - x).cross(TRI[1] - TRI[0]).normalize();
    let nn = if tilted.dot(TRI[2] - x) > 0.0 {
        tilted
    } else {
        -tilted
    };
    let nn = (nn + 1e-3 * (TRI[0] - TRI[1]).normalize()).normalize();
    assert!(TRI.iter().any(|v| nn.dot(*v - x) < 0.0));
    assert!(triangle_far_field_fast(x, nn, TRI, Order::Hessian).is_none());
    // A far sliver: declined (its fan geometry is taken from exact differences).
    let sliver = [TRI[0], TRI[1], (TRI[0] + TRI[1]) * 0.5 + DVec3::Z * 1e-4];
    assert!(triangle_far_field_fast(x, n(), sliver, Order::Hessian).is_none());
    assert!(triangle_form_factor(x, n(), sliver[0], sliver[1], sliver[2], Order::Hessian).is_ok());
}

/// The polygon far-field replay, as the triangle's above for a quad and a pentagon (each
/// fan triangle through every rule switch): bit-for-bit the robust path wherever taken, taken
/// beyond 16 radii, declined below; through the entry point at every order with the certified
/// value; invalid polygons far away are declined and refused by the robust path.
#[test]
fn polygon_far_field_fast_path_equals_robust_across_its_rule_switches() {
    let quad: Vec<DVec3> = [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
        .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
        .to_vec();
    let pentagon: Vec<DVec3> = (0..5)
        .map(|i| {
            let phi = std::f64::consts::TAU * i as f64 / 5.0;
            DVec3::new(phi.cos(), phi.sin(), 1.2 + 0.3 * phi.sin())
        })
        .collect();
    for v in [&quad, &pentagon] {
        let centroid = v.iter().sum::<DVec3>() / v.len() as f64;
        let radius = v
            .iter()
            .map(|p| (*p - centroid).length())
            .fold(0.0, f64::max);
        for dir in [-n(), DVec3::new(0.5, -0.6, -0.4).normalize()] {
            let steps = 400;
            for k in 0..=steps {
                let ratio = 1e7 * (8.0f64 / 1e7).powf(k as f64 / steps as f64);
                let x = centroid + dir * (ratio * radius);
                let got = polygon_far_field_fast(x, n(), v, Order::Hessian);
                if ratio > 16.0 * (1.0 + 1e-9) {
                    let (got, min_ratio) = got.unwrap_or_else(|| panic!("declined at {ratio}"));
                    assert!(ratio >= min_ratio * (1.0 - 1e-12), "{ratio} < {min_ratio}");
                    let robust = form_factor(x, n(), v, Order::Hessian).unwrap();
                    assert_eq!(got, robust, "at {ratio}");
                    let g = form_factor(x, n(), v, Order::Gradient).unwrap();
                    let fast_g = polygon_far_field_fast(x, n(), v, Order::Gradient).unwrap();
                    assert_eq!(fast_g.0, g, "at {ratio}");
                    let entry = |o| polygon_form_factor(x, n(), v, o).unwrap();
                    let (value, hessian) = (entry(Order::Value), entry(Order::Hessian));
                    assert_eq!(value.value, hessian.value, "at {ratio}");
                    assert_eq!(
                        (hessian.gradient, hessian.hessian),
                        (got.gradient, got.hessian)
                    );
                } else if ratio < 16.0 * (1.0 - 1e-9) {
                    assert!(got.is_none(), "taken at {ratio}");
                }
            }
        }
        // Three or nine vertices: not this replay's.
        let x = centroid - n() * (1e3 * radius);
        assert!(polygon_far_field_fast(x, n(), &v[..3], Order::Hessian).is_none());
        let mut nine = v.clone();
        while nine.len() < 9 {
            nine.push(nine[nine.len() - 1] + (v[0] - nine[nine.len() - 1]) * 0.01);
        }
        assert!(polygon_far_field_fast(x, n(), &nine, Order::Hessian).is_none());
    }
    // Far away but invalid: declined, and the robust path reports InvalidArgument.
    let x = DVec3::new(0.0, 0.0, -1e3);
    let mut bow = quad.clone();
    bow.swap(1, 2);
    let mut bent = quad.clone();
    bent[2].z += 1e-3;
    for v in [&bow, &bent] {
        assert!(polygon_far_field_fast(x, DVec3::Z, v, Order::Hessian).is_none());
        for o in [Order::Value, Order::Gradient, Order::Hessian] {
            assert!(matches!(
                polygon_form_factor(x, DVec3::Z, v, o),
                Err(Error::InvalidArgument(_))
            ));
        }
    }
    // A far non-convex (arrowhead) polygon is valid: the replay takes it, bit for bit.
    let arrow = [
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(1.0, 0.5, 1.0),
        DVec3::new(0.0, 1.0, 1.0),
        DVec3::new(0.3, 0.5, 1.0),
    ];
    let (got, _) = polygon_far_field_fast(x, DVec3::Z, &arrow, Order::Hessian).unwrap();
    assert_eq!(
        got,
        form_factor(x, DVec3::Z, &arrow, Order::Hessian).unwrap()
    );
}

/// Slivers: the replay takes an edge sum cancelling by up to THIN_CANCELLATION_LIMIT, bit for
/// bit the robust path, and declines beyond (the robust path integrates by quadrature).
#[test]
fn fast_triangle_takes_slivers_up_to_the_thin_cancellation_limit() {
    let (a, b) = (TRI[0], TRI[1]);
    let perp = (b - a).cross(TRI[2] - a).cross(b - a).normalize();
    let x = DVec3::new(0.1, -0.2, 0.05);
    let (mut taken, mut declined) = (0, 0);
    for k in 0..=40 {
        let height = 10f64.powf(-2.0 - 0.1 * k as f64);
        let t = [a, b, (a + b) * 0.5 + perp * height];
        match triangle_form_factor_fast(x, n(), t, Order::Hessian) {
            Some(d) => {
                assert_eq!(d, robust(x, n(), t), "at height {height}");
                assert_eq!(declined, 0, "taken again at {height}");
                taken += 1;
            }
            None => declined += 1,
        }
    }
    assert!(
        taken > 10 && declined > 10,
        "{taken} taken, {declined} declined"
    );
}

#[test]
fn fast_edge_term_equals_robust_and_declines_near_its_line() {
    let (a, b) = (TRI[0], TRI[1]);
    let x = DVec3::new(0.1, -0.2, 0.05);
    let fast = edge_form_factor_fast(x, n(), a, b, Order::Hessian).unwrap();
    let scaled = Scaled::new(x, &[a, b]).unwrap();
    let ends = scaled.exact_ends(0, 1);
    let unit = unit_normal(n()).unwrap();
    let slow = edge_term_exact(
        scaled.r[0],
        scaled.u[1] - scaled.u[0],
        unit,
        Order::Hessian,
        Some(&ends),
    )
    .and_then(|d| scaled.finish(d, Order::Hessian))
    .unwrap();
    assert_eq!(fast, slow);
    // 1e-4 of the length off the line (sine below 1e-2): the double-double path.
    let near = a + (b - a) * 1.7 + DVec3::Z * 1e-4;
    assert!(edge_form_factor_fast(near, n(), a, b, Order::Hessian).is_none());
    assert!(edge_form_factor(near, n(), a, b, Order::Hessian).is_ok());
    // Invalid inputs are left to the robust path's validation.
    assert!(edge_form_factor_fast(x, n() * 1.1, a, b, Order::Value).is_none());
    assert!(edge_form_factor_fast(DVec3::NAN, n(), a, b, Order::Value).is_none());
}
