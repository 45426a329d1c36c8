use glam::DMat3;

use super::*;
use crate::kernels::form_factor::near_plane;
use crate::kernels::form_factor::near_plane::route_loop::RouteLoop;
use crate::kernels::form_factor::polygon_form_factor;
use crate::kernels::form_factor::robust::form_factor;
use crate::kernels::form_factor::validate::unit;
use crate::test_rng::lcg;

/// [`polygon_value`] for 4 to 8 vertices from `x`, `n` and the vertices (the tests' entry).
fn value_of(x: DVec3, n: DVec3, v: &[DVec3]) -> Option<f64> {
    fn at<const M: usize, const N: usize>(x: DVec3, n: DVec3, v: &[DVec3]) -> Option<f64> {
        polygon_value::<M, N>(x, n, v.try_into().ok()?)
    }
    match v.len() {
        4 => at::<4, 5>(x, n, v),
        5 => at::<5, 6>(x, n, v),
        6 => at::<6, 7>(x, n, v),
        7 => at::<7, 8>(x, n, v),
        8 => at::<8, 9>(x, n, v),
        _ => None,
    }
}

/// [`polygon_derivs`] for 4 to 8 vertices (the tests' entry).
fn derivs_of(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Option<Derivs> {
    fn at<const M: usize, const N: usize>(
        x: DVec3,
        n: DVec3,
        v: &[DVec3],
        order: Order,
    ) -> Option<Derivs> {
        polygon_derivs::<M, N>(x, n, v.try_into().ok()?, order)
    }
    match v.len() {
        4 => at::<4, 5>(x, n, v, order),
        5 => at::<5, 6>(x, n, v, order),
        6 => at::<6, 7>(x, n, v, order),
        7 => at::<7, 8>(x, n, v, order),
        8 => at::<8, 9>(x, n, v, order),
        _ => None,
    }
}

/// A random strictly convex polygon of `m` vertices and size `scale`: jittered angles on an
/// ellipse (axes 0.5-1) in a plane tilted up to ~17° from z = 0.3·scale; its unit normal.
fn random_convex(state: &mut u64, m: usize, scale: f64) -> (Vec<DVec3>, DVec3) {
    let tilt = DVec3::new(0.6 * (lcg(state) - 0.5), 0.6 * (lcg(state) - 0.5), 1.0);
    let normal = tilt.normalize();
    let u = normal.any_orthonormal_vector();
    let w = normal.cross(u);
    let (a, b) = (0.5 + 0.5 * lcg(state), 0.5 + 0.5 * lcg(state));
    let centre = DVec3::new(lcg(state) - 0.5, lcg(state) - 0.5, 0.3) * scale;
    let v = (0..m)
        .map(|k| {
            let phi = std::f64::consts::TAU * (k as f64 + 0.6 * (lcg(state) - 0.5)) / m as f64;
            centre + (u * (a * phi.cos()) + w * (b * phi.sin())) * scale
        })
        .collect();
    (v, normal)
}

/// A receiver normal tilted 10°-80° from `plane_n` (on `x`'s side), about a random axis.
fn tilted(state: &mut u64, plane_n: DVec3) -> DVec3 {
    let tilt = (10.0 + 70.0 * lcg(state)).to_radians();
    let t = plane_n.any_orthonormal_vector();
    let phi = 6.3 * lcg(state);
    let t = t * phi.cos() + plane_n.cross(t) * phi.sin();
    (plane_n * tilt.cos() + t * tilt.sin()).normalize()
}

fn robust(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Deriv3 {
    form_factor(x, n, v, order).unwrap()
}

/// Max-norm errors of the gradient and Hessian, each relative to the reference's largest entry.
fn rel(d: &Deriv3, r: &Deriv3) -> (f64, f64) {
    let hm = |m: DMat3| m.to_cols_array().iter().fold(0.0f64, |s, e| s.max(e.abs()));
    (
        (d.gradient - r.gradient).abs().max_element() / r.gradient.abs().max_element(),
        hm(d.hessian - r.hessian) / hm(r.hessian),
    )
}

/// Random clipped convex quads, pentagons, hexagons and octagons of sizes 1e-3 to 1e3, `x` 1 to
/// 1e-9 sizes above or below a point of the polygon (or of its plane within 0.3 of the size
/// beyond it): wherever the value is certified it agrees with the robust (exact-clip) path
/// within 1e-12, wherever the derivatives are accepted they agree within 1e-12 (gradient) and
/// 1e-10 (Hessian) of their largest entry, and the public kernel returns exactly these, the
/// value order's bits at every order. At least 95 % of the configurations 1e-7 to 1e-4 sizes
/// above the interior (away from the edges, `F > 0.05`) are certified, and at least 60 % of
/// those have their derivatives accepted.
#[test]
fn clipped_convex_polygons_agree_with_the_robust_path() {
    let mut state = 3;
    let (mut tried, mut certified, mut derived) = (0, 0, 0);
    let (mut worst, mut worst_g, mut worst_h) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..6000 {
        let scale = [1e-3, 1.0, 1e3][k % 3];
        let m = [4, 5, 6, 8][(k / 3) % 4];
        let (v, plane_n) = random_convex(&mut state, m, scale);
        let centroid = v.iter().sum::<DVec3>() / m as f64;
        // Inside (towards the centroid from a vertex) or up to 0.3 beyond it.
        let (p, q) = (lcg(&mut state), 1.3 * lcg(&mut state));
        let foot = centroid + (v[(k / 12) % m] - centroid) * q * (0.2 + 0.8 * p);
        let side = if lcg(&mut state) < 0.5 { 1.0 } else { -1.0 };
        let height = scale * 10f64.powf(-9.0 * lcg(&mut state));
        let x = foot + plane_n * (side * height);
        let n = tilted(&mut state, plane_n * side);
        if !v.iter().any(|vk| n.dot(*vk - x) < 0.0) {
            continue;
        }
        let away = q * (0.2 + 0.8 * p) < 0.8
            && height >= 1e-7 * scale
            && height < 1e-4 * scale
            && robust(x, n, &v, Order::Value).value > 0.05;
        tried += usize::from(away);
        let Some(f) = value_of(x, n, &v) else {
            assert!(derivs_of(x, n, &v, Order::Hessian).is_none());
            continue;
        };
        certified += usize::from(away);
        let want = robust(x, n, &v, Order::Value).value;
        let e = (f - want).abs() / want;
        worst = worst.max(e);
        assert!(e <= 1e-12, "{k}: {f:e} vs {want:e} at {x:?} {n:?} {v:?}");
        assert_eq!(
            polygon_form_factor(x, n, &v, Order::Value).unwrap().value,
            f
        );
        for order in [Order::Gradient, Order::Hessian] {
            let public = polygon_form_factor(x, n, &v, order).unwrap();
            assert_eq!(public.value.to_bits(), f.to_bits(), "{k} {order:?}");
            match derivs_of(x, n, &v, order) {
                Some(Ok(d)) => {
                    assert_eq!(public, d, "{k} {order:?}");
                    let (g, h) = rel(&d, &robust(x, n, &v, order));
                    let h = if order.hessian() { h } else { 0.0 };
                    worst_g = worst_g.max(g);
                    worst_h = worst_h.max(h);
                    assert!(
                        g < 1e-11 && h < 1e-10,
                        "{k}: {g:e} {h:e} at {x:?} {n:?} {v:?}"
                    );
                    derived += usize::from(away && order.hessian());
                }
                Some(Err(value)) => assert_eq!(value.to_bits(), f.to_bits()),
                None => panic!("{k}: the value is certified, the derivative loop is not"),
            }
        }
    }
    println!(
        "clipped polygons 1e-7 to 1e-4 sizes above the interior: {certified} of {tried} \
         certified, {derived} with derivatives; worst vs robust: value {worst:e}, gradient \
         {worst_g:e}, Hessian {worst_h:e}"
    );
    assert!(tried > 500, "{tried}");
    assert!(certified * 100 >= tried * 95, "{certified} of {tried}");
    assert!(derived * 10 >= certified * 6, "{derived} of {certified}");
}

/// The quad and pentagon of `benches/kernels_regimes.rs`, 1e-6 above the plane: taken at every
/// order.
#[test]
fn the_benchmarked_cases_are_taken() {
    let quad: Vec<DVec3> = [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
        .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
        .to_vec();
    let pentagon: Vec<DVec3> = (0..5)
        .map(|i| {
            let phi = std::f64::consts::TAU * i as f64 / 5.0;
            DVec3::new(phi.cos(), phi.sin(), 1.2 + 0.3 * phi.sin())
        })
        .collect();
    for v in [quad, pentagon] {
        let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        let x = v.iter().sum::<DVec3>() / v.len() as f64 - plane_n * 1e-6;
        let n = DVec3::new(0.1, -0.2, 1.0).normalize();
        assert!(v.iter().any(|vk| n.dot(*vk - x) < 0.0));
        let f = value_of(x, n, &v).expect("value declined");
        for order in [Order::Gradient, Order::Hessian] {
            let d = derivs_of(x, n, &v, order).unwrap().expect("declined");
            assert_eq!(d.value, f);
            let (g, h) = rel(&d, &robust(x, n, &v, order));
            let h = if order.hessian() { h } else { 0.0 };
            assert!(g < 1e-13 && h < 1e-12, "{g:e} {h:e}");
        }
    }
}

/// Central differences (Richardson-extrapolated, steps 1e-3 and 5e-4 of the height) of the
/// certified value and of the fast gradient, `x` 1e-3.5 sizes above a clipped quad and
/// hexagon: within 1e-7 of the largest entry (truncation ~(step/height)⁴).
#[test]
fn derivatives_agree_with_central_differences() {
    let mut state = 17;
    for m in [4, 6] {
        let (v, plane_n) = random_convex(&mut state, m, 1.0);
        let centroid = v.iter().sum::<DVec3>() / m as f64;
        let height = 10f64.powf(-3.5);
        let x = centroid + (v[0] - centroid) * 0.3 + plane_n * height;
        let n = (plane_n + plane_n.any_orthonormal_vector()).normalize();
        let d = derivs_of(x, n, &v, Order::Hessian).unwrap().unwrap();
        let f = |p: DVec3| value_of(p, n, &v).unwrap();
        let g = |p: DVec3| derivs_of(p, n, &v, Order::Gradient).unwrap().unwrap();
        let central = |h: f64, i: usize| {
            let dx = DVec3::AXES[i] * h;
            let df = (f(x + dx) - f(x - dx)) / (2.0 * h);
            let dg = (g(x + dx).gradient - g(x - dx).gradient) / (2.0 * h);
            (df, dg)
        };
        let g_scale = d.gradient.abs().max_element();
        let h_scale = d
            .hessian
            .to_cols_array()
            .iter()
            .fold(0.0f64, |s, e| s.max(e.abs()));
        for i in 0..3 {
            let (f1, g1) = central(1e-3 * height, i);
            let (f2, g2) = central(5e-4 * height, i);
            let fd = (4.0 * f2 - f1) / 3.0;
            let col = (g2 * 4.0 - g1) / 3.0;
            let eg = (fd - d.gradient[i]).abs() / g_scale;
            let eh = (col - d.hessian.col(i)).abs().max_element() / h_scale;
            assert!(eg < 1e-7 && eh < 1e-7, "m = {m}, axis {i}: {eg:e} {eh:e}");
        }
    }
}

/// [`routed_polygon_derivs`] for 4 to 8 vertices (the tests' entry).
fn routed_of(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Option<Derivs> {
    fn at<const M: usize, const N: usize, const R: usize>(
        x: DVec3,
        n: DVec3,
        v: &[DVec3],
        order: Order,
    ) -> Option<Derivs> {
        routed_polygon_derivs::<M, N, R>(x, n, v.try_into().ok()?, order)
    }
    match v.len() {
        4 => at::<4, 5, 8>(x, n, v, order),
        5 => at::<5, 6, 10>(x, n, v, order),
        6 => at::<6, 7, 12>(x, n, v, order),
        8 => at::<8, 9, 16>(x, n, v, order),
        _ => None,
    }
}

/// Random clipped convex quads, pentagons, hexagons and octagons of sizes 1e-3 to 1e3, `x`
/// 1e-3 to 1e-9 sizes from the plane over a point 0.1-1 sizes beyond a vertex (outside):
/// wherever the routed loop's derivatives are accepted they agree with the robust path within
/// 1e-11 (gradient) and 1e-10 (Hessian) of its largest entry (the loop keeps a few `u` times its
/// sums' cancellation, up to `LOOP_CANCELLATION` = 1e5: ~1e-11), their value is the value order's
/// bits, and the public kernel returns exactly them; they are accepted in at least half of the
/// configurations where the route answers.
#[test]
fn routed_derivatives_agree_with_the_robust_path() {
    let mut state = 11;
    let (mut routed, mut derived) = (0, 0);
    let (mut worst_g, mut worst_h) = (0.0f64, 0.0f64);
    for k in 0..6000 {
        let scale = [1e-3, 1.0, 1e3][k % 3];
        let m = [4, 5, 6, 8][(k / 3) % 4];
        let (v, plane_n) = random_convex(&mut state, m, scale);
        let centroid = v.iter().sum::<DVec3>() / m as f64;
        let beyond = 1.1 + lcg(&mut state);
        let foot = centroid + (v[(k / 12) % m] - centroid) * beyond;
        let side = if lcg(&mut state) < 0.5 { 1.0 } else { -1.0 };
        let height = scale * 10f64.powf(-3.0 - 6.0 * lcg(&mut state));
        let x = foot + plane_n * (side * height);
        let n = tilted(&mut state, plane_n * side);
        let value = polygon_form_factor(x, n, &v, Order::Value).unwrap().value;
        for order in [Order::Gradient, Order::Hessian] {
            let Some(d) = routed_of(x, n, &v, order) else {
                continue;
            };
            routed += usize::from(order.hessian());
            let public = polygon_form_factor(x, n, &v, order).unwrap();
            assert_eq!(public.value.to_bits(), value.to_bits(), "{k} {order:?}");
            match d {
                Ok(d) => {
                    assert_eq!(public, d, "{k} {order:?}");
                    let (g, h) = rel(&d, &robust(x, n, &v, order));
                    let h = if order.hessian() { h } else { 0.0 };
                    worst_g = worst_g.max(g);
                    worst_h = worst_h.max(h);
                    assert!(
                        g < 1e-11 && h < 1e-10,
                        "{k}: {g:e} {h:e} at {x:?} {n:?} {v:?}"
                    );
                    derived += usize::from(order.hessian());
                }
                Err(f) => assert_eq!(f.to_bits(), value.to_bits(), "{k}"),
            }
        }
    }
    println!(
        "outside near the plane: route {routed}, derivatives {derived}; worst vs robust: \
         gradient {worst_g:e}, Hessian {worst_h:e}"
    );
    assert!(routed > 1000, "{routed}");
    assert!(derived * 2 >= routed, "{derived} of {routed}");
}

/// The quad and pentagon of `benches/kernels_regimes.rs` 1e-6 from the plane outside: the
/// routed derivatives are taken, agree with the robust path, and with central differences
/// (Richardson-extrapolated, steps 1e-3 and 5e-4 of the height) of the value order and of
/// their own gradient within 1e-6 of the largest entry.
#[test]
fn the_benchmarked_outside_cases_are_routed() {
    let quad: Vec<DVec3> = [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
        .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
        .to_vec();
    let pentagon: Vec<DVec3> = (0..5)
        .map(|i| {
            let phi = std::f64::consts::TAU * i as f64 / 5.0;
            DVec3::new(phi.cos(), phi.sin(), 1.2 + 0.3 * phi.sin())
        })
        .collect();
    for (v, edge) in [(quad, 0), (pentagon, 1)] {
        let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        let centroid = v.iter().sum::<DVec3>() / v.len() as f64;
        let mid = (v[edge] + v[(edge + 1) % v.len()]) * 0.5;
        let height = 1e-6;
        let x = mid + (mid - centroid) * 0.2 - plane_n * height;
        let normal = DVec3::new(0.1, -0.2, 1.0).normalize();
        let n = if (v[0] - x).dot(normal) > 0.0 {
            normal
        } else {
            -normal
        };
        let d = routed_of(x, n, &v, Order::Hessian)
            .unwrap()
            .expect("declined");
        let (g, h) = rel(&d, &robust(x, n, &v, Order::Hessian));
        assert!(g < 1e-12 && h < 1e-10, "{g:e} {h:e}");
        let f = |p: DVec3| polygon_form_factor(p, n, &v, Order::Value).unwrap().value;
        let grad = |p: DVec3| routed_of(p, n, &v, Order::Gradient).unwrap().unwrap();
        let central = |step: f64, i: usize| {
            let dx = DVec3::AXES[i] * step;
            let df = (f(x + dx) - f(x - dx)) / (2.0 * step);
            let dg = (grad(x + dx).gradient - grad(x - dx).gradient) / (2.0 * step);
            (df, dg)
        };
        let g_scale = d.gradient.abs().max_element();
        let h_scale = d
            .hessian
            .to_cols_array()
            .iter()
            .fold(0.0f64, |s, e| s.max(e.abs()));
        for i in 0..3 {
            let (f1, g1) = central(1e-3 * height, i);
            let (f2, g2) = central(5e-4 * height, i);
            let eg = ((4.0 * f2 - f1) / 3.0 - d.gradient[i]).abs() / g_scale;
            let eh = ((g2 * 4.0 - g1) / 3.0 - d.hessian.col(i))
                .abs()
                .max_element()
                / h_scale;
            assert!(eg < 1e-6 && eh < 1e-6, "axis {i}: {eg:e} {eh:e}");
        }
    }
}

/// Outside-near-plane configurations whose visible part is far-field against its size (a
/// small corner cut off, seen from 1.05-3 radii), triangles, quads and pentagons: the route
/// takes the robust path's far-field rule on its loop for the value and the derivative orders
/// its derivatives, the robust bits (value) and within 1e-14 of them (derivatives; the robust
/// path works on coordinates scaled by a power of two), at every order, through the public
/// entries.
#[test]
fn far_field_corners_take_the_rule_on_the_route() {
    let mut state = 5;
    let mut far = [0; 3];
    let mut tried = 0;
    while far.iter().any(|&f| f < 30) {
        tried += 1;
        assert!(tried < 200_000, "{far:?} far corners");
        let m = 3 + (lcg(&mut state) * 3.0) as usize;
        let v: Vec<DVec3> = (0..m)
            .map(|k| {
                let a = (k as f64 + 0.3 * lcg(&mut state)) / m as f64 * std::f64::consts::TAU;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        let angle = lcg(&mut state) * std::f64::consts::TAU;
        let distance = 1.05 + 2.0 * lcg(&mut state);
        let h = if lcg(&mut state) < 0.5 { 1e-6 } else { -1e-6 };
        let x = DVec3::new(distance * angle.cos(), distance * angle.sin(), h);
        let n = DVec3::new(
            lcg(&mut state) - 0.5,
            lcg(&mut state) - 0.5,
            lcg(&mut state) - 0.5,
        )
        .normalize();
        let value = match m {
            3 => {
                let mut route = RouteLoop::<4>::new();
                let t = [v[0], v[1], v[2]];
                // The triangle route takes the unit normal as `lambert::unit` divides it.
                let unit = unit(n).unwrap();
                near_plane::triangle::clipped_triangle_value_and_loop(x, unit, t, &mut route)
                    .filter(|_| route.is_far())
            }
            _ => {
                let mut route = RouteLoop::<10>::new();
                let value = match m {
                    4 => near_plane::polygon::clipped_polygon_value_and_loop::<4, 10>(
                        x,
                        n,
                        v[..].try_into().unwrap(),
                        &mut route,
                    )
                    .map(|(value, ..)| value),
                    _ => near_plane::polygon::clipped_polygon_value_and_loop::<5, 10>(
                        x,
                        n,
                        v[..].try_into().unwrap(),
                        &mut route,
                    )
                    .map(|(value, ..)| value),
                };
                value.filter(|_| route.is_far())
            }
        };
        let Some(value) = value else {
            continue;
        };
        far[m - 3] += 1;
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            let got = match m {
                3 => crate::kernels::triangle_form_factor(x, n, v[0], v[1], v[2], order),
                _ => polygon_form_factor(x, n, &v, order),
            }
            .unwrap();
            let want = robust(x, n, &v, order);
            assert_eq!(got.value.to_bits(), value.to_bits(), "{order:?}");
            assert_eq!(got.value.to_bits(), want.value.to_bits(), "{order:?}");
            if order != Order::Value {
                if m > 3 {
                    assert_eq!(routed_of(x, n, &v, order).unwrap(), Ok(got));
                }
                let (g, eh) = rel(&got, &want);
                let eh = if order.hessian() { eh } else { 0.0 };
                assert!(g < 1e-14 && eh < 1e-14, "{m} {order:?}: {g:e} {eh:e}");
            }
        }
    }
    println!("{far:?} far-field corners (3, 4, 5 vertices) in {tried} configurations");
}

/// `x` outside a unit square `h` from its plane and `t` from the line of its edge (0,0)→(1,0),
/// beyond the edge's end: the edge subtends `sin β ≈ 1.3 t`, below the loop's floor for
/// Lambert's terms (`MIN_SINE` = 1/32) from `t` = 2e-2 down, so its term is the robust path's
/// (from the ends' exact differences below `t` ≈ 5e-3): the derivatives are taken (the route
/// answers down to `t` = 10 `h`, below which the near-plane split declines), agree with the
/// robust path, and with central differences of the value order.
#[test]
fn edges_below_the_sine_floor_take_the_robust_term() {
    const MIN_SINE_OF_THE_LOOP: f64 = 1.0 / 32.0;
    let square = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
        .map(|(x, y)| DVec3::new(x, y, 0.0))
        .to_vec();
    let mut worst = (0.0f64, 0.0f64);
    for (t, h) in [(2e-2, 1e-6), (1e-3, 1e-6), (1e-4, 1e-6), (1e-7, 1e-9)] {
        for side in [1.0, -1.0] {
            let x = DVec3::new(-0.5, t, side * h);
            // The tangent plane cuts the edges at x = 0 and x = 1: (0,0)→(1,0) is an ordinary
            // edge of the loop.
            let n = DVec3::new(0.3, -1.0, 0.2 * side).normalize();
            let (ra, rb) = (square[0] - x, square[1] - x);
            let sine = ra.cross(rb).length() / (ra.length() * rb.length());
            assert!(sine < MIN_SINE_OF_THE_LOOP, "{t:e}: {sine}");
            for order in [Order::Gradient, Order::Hessian] {
                let d = routed_of(x, n, &square, order)
                    .unwrap_or_else(|| panic!("not routed at {t:e} {side}"))
                    .unwrap_or_else(|_| panic!("declined at {t:e} {side} {order:?}"));
                assert_eq!(polygon_form_factor(x, n, &square, order).unwrap(), d);
                let (g, eh) = rel(&d, &robust(x, n, &square, order));
                let eh = if order.hessian() { eh } else { 0.0 };
                worst = (worst.0.max(g), worst.1.max(eh));
                assert!(g < 1e-13 && eh < 1e-13, "{t:e} {side}: {g:e} {eh:e}");
                let f = |p: DVec3| polygon_form_factor(p, n, &square, Order::Value).unwrap();
                let step = 1e-3 * h;
                for i in 0..3 {
                    let dx = DVec3::AXES[i] * step;
                    let central = (f(x + dx).value - f(x - dx).value) / (2.0 * step);
                    let e = (central - d.gradient[i]).abs() / d.gradient.abs().max_element();
                    assert!(e < 1e-5, "{t:e} {side} axis {i}: {e:e}");
                }
            }
        }
    }
    println!(
        "edges below the sine floor: worst vs robust {:e} / {:e}",
        worst.0, worst.1
    );
}

/// Declines what the robust path must judge or where the bound fails: far from the plane, on
/// and near the clip line, outside near the plane (the sum cancels), near an edge's line,
/// non-convex or non-planar polygons, a clip line through a vertex's rounding, everything or
/// nothing clipped, invalid input.
#[test]
fn declines_outside_its_regime() {
    let quad: Vec<DVec3> = [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
        .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
        .to_vec();
    let plane_n = (quad[1] - quad[0]).cross(quad[2] - quad[0]).normalize();
    let centroid = quad.iter().sum::<DVec3>() / 4.0;
    let n = (plane_n + plane_n.any_orthonormal_vector()).normalize();
    let above = |h: f64| centroid + plane_n * h;
    assert!(value_of(above(1e-6), n, &quad).is_some());
    // Walking x onto the clip line (through x's foot): certified near, declined from some
    // distance on, never certified again.
    let (mut certified, mut declined) = (false, false);
    for k in 4..=18 {
        let x = above(10f64.powi(-k));
        match value_of(x, n, &quad) {
            Some(f) => {
                assert!(!declined, "certified again at 1e-{k}");
                certified = true;
                let want = robust(x, n, &quad, Order::Value).value;
                assert!((f - want).abs() <= 1e-12 * want, "1e-{k}");
            }
            None => declined = true,
        }
    }
    assert!(certified && declined);
    // Far from the plane: the robust path's.
    assert_eq!(value_of(above(1e-2), n, &quad), None);
    // Outside near the plane, the clip line running into the polygon: the sum cancels.
    let outside = quad[0] + (quad[0] - centroid) * 0.5;
    let towards = (centroid - outside).normalize();
    let n_out = (plane_n + towards.cross(plane_n)).normalize();
    let x = outside + plane_n * 1e-6;
    assert!(quad.iter().any(|vk| n_out.dot(*vk - x) < 0.0));
    assert!(quad.iter().any(|vk| n_out.dot(*vk - x) > 0.0));
    assert_eq!(value_of(x, n_out, &quad), None);
    // Near an edge's segment (1e-4 of the size inside edge 0-1).
    let mid = (quad[0] + quad[1]) * 0.5;
    let near_edge = mid + (centroid - mid) * 1e-4 + plane_n * 1e-7;
    assert_eq!(value_of(near_edge, n, &quad), None);
    // Non-convex (an arrowhead) and non-planar beyond a quarter of the robust tolerance.
    let arrow: Vec<DVec3> = [(0.0, 0.0), (1.0, 0.5), (0.0, 1.0), (0.3, 0.5)]
        .map(|(x, y)| DVec3::new(x, y, 1.0))
        .to_vec();
    let x_arrow = DVec3::new(0.2, 0.5, 1.0 + 1e-6);
    let n_arrow = DVec3::new(0.0, 0.7, 0.7).normalize();
    assert!(arrow.iter().any(|vk| n_arrow.dot(*vk - x_arrow) < 0.0));
    assert_eq!(value_of(x_arrow, n_arrow, &arrow), None);
    let mut bent = quad.clone();
    bent[2] += plane_n * 3e-8;
    assert!(value_of(above(1e-6), n, &bent).is_none());
    // The tangent plane through a vertex (y = 0.6 exactly, n = ŷ: its height is 0), and a
    // control 0.3 beside it.
    let on_vertex = |dy: f64| {
        let (px, py) = (0.7 * quad[2].x + 0.3 * centroid.x, quad[2].y - dy);
        DVec3::new(px, py, 1.0 + 0.1 * px + 0.1 * py + 1e-6)
    };
    assert_eq!(DVec3::Y.dot(quad[2] - on_vertex(0.0)), 0.0);
    assert_eq!(value_of(on_vertex(0.0), DVec3::Y, &quad), None);
    assert!(value_of(on_vertex(0.3), DVec3::Y, &quad).is_some());
    // Nothing clipped, everything clipped, an invalid normal, NaN, a triangle.
    assert_eq!(value_of(above(1e-6), plane_n, &quad), None);
    assert_eq!(value_of(above(1e-6), -plane_n, &quad), None);
    assert_eq!(value_of(above(1e-6), n * 2.0, &quad), None);
    assert_eq!(value_of(above(1e-6) + DVec3::NAN, n, &quad), None);
    let mut nan = quad.clone();
    nan[1].y = f64::NAN;
    assert_eq!(value_of(above(1e-6), n, &nan), None);
    assert_eq!(value_of(above(1e-6), n, &quad[..3]), None);
    for order in [Order::Gradient, Order::Hessian] {
        assert!(derivs_of(above(1e-2), n, &quad, order).is_none());
        assert!(derivs_of(x, n_out, &quad, order).is_none());
    }
}
