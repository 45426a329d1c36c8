use super::*;
use crate::kernels::form_factor::lambert::clipped_derivs::loop_derivs;
use crate::kernels::form_factor::near_plane::route_loop::RouteLoop;
use crate::kernels::form_factor::robust::form_factor;
use crate::test_rng::lcg;
use crate::Order;

/// The clipped loop without the value's certificate, for the derivatives where the value comes
/// from elsewhere (`x` near the plane outside the triangle, where Lambert's sum cancels). Its
/// `sum` is only the orientation, `±1`: the sign of the certified sum, `sign(N·r_0)` for the
/// triangle's normal `N = (v_1 − v_0) × (v_2 − v_0)`; `None` when that sign is uncertain (`x`
/// within rounding of the triangle's plane) or where [`triangle_value`]'s loop is not built.
/// Where the certified loop is not tried its clip points are the value order's route's when that
/// answers, as in [`with_valued_derivative_loop`].
pub(crate) fn uncertified_loop(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<ClippedLoop> {
    let cut = cut(x, n, &v)?;
    let screen = screen(&v, &cut.r);
    if !screen.uncertified() {
        return None;
    }
    let mut route = RouteLoop::new();
    let routed = screen.left_to_the_robust_path()
        && near_plane::triangle::clipped_triangle_value_and_loop(x, cut.n, v, &mut route).is_some()
        && !route.is_far();
    Some(with_loop(x, &v, &cut, routed.then_some(&route), |l| {
        l.sum = screen.side.signum();
        l.clone()
    }))
}

/// [`triangle_value`]'s loop and signed sum (times `2π`) when it certifies the value.
pub(crate) fn certified_loop(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<ClippedLoop> {
    with_certified_loop(x, n, v, ClippedLoop::clone)
}

/// [`with_valued_derivative_loop`] telling `f` only whether the loop is certified.
pub(crate) fn with_derivative_loop<R>(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    f: impl FnOnce(&ClippedLoop, bool) -> R,
) -> Option<R> {
    let fma = cfg!(target_arch = "x86_64") && crate::simd::avx2_fma();
    with_valued_derivative_loop(x, n, v, fma, |l, value| {
        f(l, matches!(value, LoopValue::Certified))
    })
}

fn robust(x: DVec3, n: DVec3, v: [DVec3; 3]) -> f64 {
    form_factor(x, n, &v, Order::Value).unwrap().value
}

fn random_triangle(state: &mut u64, scale: f64) -> [DVec3; 3] {
    let mut p = || DVec3::new(lcg(state) - 0.5, lcg(state) - 0.5, 0.5 * (lcg(state) - 0.5)) * scale;
    [p(), p(), p()]
}

/// Random clipped configurations from generic to 1e-12 above the triangle's interior: wherever
/// the path certifies, it agrees with the robust (exact-clip) path within the contract, and it
/// certifies at least 95 % of those 1e-7 to 1e-5 sizes above, not near an edge and without
/// cancellation (it leaves x further from the plane to the robust path).
#[test]
fn clipped_triangles_agree_with_the_robust_path() {
    let mut state = 7;
    let (mut tried, mut certified, mut worst) = (0, 0, 0.0f64);
    for k in 0..4000 {
        let scale = [1e-3, 1.0, 1e3][k % 3];
        let v = random_triangle(&mut state, scale);
        let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        // A point of the triangle (barycentric), lifted off its plane by 10^-(0..12) sizes.
        let (p, q) = (lcg(&mut state), lcg(&mut state));
        let (p, q) = if p + q > 1.0 {
            (1.0 - p, 1.0 - q)
        } else {
            (p, q)
        };
        let foot = v[0] + (v[1] - v[0]) * p + (v[2] - v[0]) * q;
        let height = scale * 10f64.powf(-12.0 * lcg(&mut state));
        let x = foot + plane_n * height;
        // A normal tilted from the plane's by 10-80 degrees: the tangent plane cuts the triangle.
        let tilt = (10.0 + 70.0 * lcg(&mut state)).to_radians();
        let side = plane_n.any_orthonormal_vector();
        let side = side * (lcg(&mut state) * 6.3).cos()
            + plane_n.cross(side) * (lcg(&mut state) * 6.3).sin();
        let n = (plane_n * tilt.cos() + side.normalize() * tilt.sin()).normalize();
        let clipped = v.iter().any(|vk| n.dot(*vk - x) < 0.0);
        if !clipped {
            continue;
        }
        // Declined by design: within ~1e-9 of the clip line (the bound's second-order terms),
        // near an edge line of the triangle (Lambert's own bound) and when the sum cancels
        // (its terms are O(1): a small form factor).
        let inside = p.min(q).min(1.0 - p - q) > 0.05;
        let away =
            inside && height >= 1e-7 * scale && height < 1e-5 * scale && robust(x, n, v) > 0.05;
        tried += usize::from(away);
        if let Some(f) = triangle_value(x, n, v) {
            certified += usize::from(away);
            let want = robust(x, n, v);
            let rel = (f - want).abs() / want.abs();
            worst = worst.max(rel);
            assert!(rel <= 1e-12, "{f:e} vs {want:e} at {x:?}, {n:?}, {v:?}");
        }
    }
    assert!(
        certified * 100 >= tried * 95,
        "{certified} of {tried} certified"
    );
    println!("clipped, 1e-7 to 1e-5 sizes above, not near an edge, F > 0.05: {certified} of {tried} certified; worst {worst:e}");
}

/// Outside the triangle near its plane (the route's case, 1e-3 to 1e-12 sizes from the
/// plane): wherever the value order's route answers, its loop lists the points the cut's
/// own loop lists, in the same order (kept vertices to the bit), each route clip point is
/// within the displacement bound the loop carries of the loop's own f64-`t` one (and carries a
/// tighter bound of its own, from the double-double heights), the route's
/// vertex-to-clip-point edge vectors are the loop's own rounding of its points' difference,
/// and its angles are the angles between the edges' ends to a few ulps; the gradient and
/// Hessian orders return the value order's value bit for bit, with the derivatives of the
/// shared loop.
#[test]
fn the_route_loop_is_the_cut_loop_and_keeps_the_value_bits() {
    let mut state = 23;
    let (mut routed, mut accepted, mut worst_angle, mut worst_atan2) = (0, 0, 0.0f64, 0.0f64);
    for k in 0..6000 {
        let scale = [1e-3, 1.0, 1e3][k % 3];
        let v = random_triangle(&mut state, scale);
        let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        // Barycentric coordinates in [-0.7, 1.7): mostly outside.
        let (p, q) = (2.4 * lcg(&mut state) - 0.7, 2.4 * lcg(&mut state) - 0.7);
        let foot = v[0] + (v[1] - v[0]) * p + (v[2] - v[0]) * q;
        let side = if lcg(&mut state) < 0.5 { 1.0 } else { -1.0 };
        let x = foot + plane_n * (side * scale * 10f64.powf(-3.0 - 9.0 * lcg(&mut state)));
        let tilt = (10.0 + 70.0 * lcg(&mut state)).to_radians();
        let t = plane_n.any_orthonormal_vector();
        let phi = 6.3 * lcg(&mut state);
        let t = t * phi.cos() + plane_n.cross(t) * phi.sin();
        let n = (plane_n * side * tilt.cos() + t * tilt.sin()).normalize();
        let Some(c) = cut(x, n, &v) else {
            continue;
        };
        let screen = screen(&v, &c.r);
        if !(screen.left_to_the_robust_path() && screen.uncertified()) {
            continue;
        }
        let mut route = RouteLoop::new();
        let Some(value) =
            near_plane::triangle::clipped_triangle_value_and_loop(x, c.n, v, &mut route)
        else {
            continue;
        };
        // A far-field visible part: the route's value is its far-field rule's, and the
        // derivative orders take that rule, not this loop.
        if route.is_far() {
            continue;
        }
        routed += 1;
        assert_eq!(
            Some(value.to_bits()),
            near_plane::triangle::triangle_value(x, n, v).map(f64::to_bits)
        );
        assert!(same_loop(&route, &c), "{k}: order of the points");
        let own = with_loop(x, &v, &c, None, |l| l.clone());
        let shared = with_loop(x, &v, &c, Some(&route), |l| l.clone());
        assert_eq!(own.count, shared.count);
        let count = own.count;
        for i in 0..count {
            let (a, b) = (&own.points[i], &shared.points[i]);
            assert_eq!(a.vertex, b.vertex);
            // The route's clip points (from double-double heights) have the tighter bound.
            assert!(b.displacement <= a.displacement, "{k}: point {i}");
            if a.vertex.is_some() {
                assert_eq!(a.displacement, b.displacement);
                assert_eq!(a.hi, b.hi, "{k}: vertex {i}");
            } else {
                let apart = (a.hi - b.hi).length();
                assert!(
                    apart <= a.displacement + 4.0 * U * a.hi.length(),
                    "{k}: clip point {i} {apart:e} apart, bound {:e}",
                    a.displacement
                );
            }
            let j = (i + 1) % count;
            let (pa, pb) = (&shared.points[i], &shared.points[j]);
            assert_eq!(shared.edges[i], edge_vector(&v, pa, pb), "{k}: edge {i}");
            // Where the split hands out an angle (sin β ≥ 1/4, neither end within a quarter
            // of the edge's length of x), it is the angle between the ends to a few ulps.
            let sine = pa.hi.cross(pb.hi).length() / (pa.hi.length() * pb.hi.length());
            let angle = shared.angles[i];
            let nearest = pa.hi.length_squared().min(pb.hi.length_squared());
            let e2 = shared.edges[i].length_squared();
            // The split hands out only well-conditioned angles (margins for the rounding of
            // its tests).
            if !angle.is_nan() {
                assert!(
                    sine >= 0.249 && 16.0 * 1.001 * nearest >= e2,
                    "{k}: edge {i}"
                );
                // The reference from the exact ends (double-double cross and dot products).
                let w = pa.exact.cross(&pb.exact).to_dvec3().length();
                let beta = w.atan2(pa.exact.dot(&pb.exact).to_f64());
                let err = (angle - beta).abs() / (U * beta);
                worst_angle = worst_angle.max(err);
                // For comparison: atan2(s, c) of the loop's rounded inputs, as recomputed.
                let e = shared.edges[i];
                let recomputed = pa.hi.cross(e).length().atan2(pa.hi.dot(pb.hi));
                worst_atan2 = worst_atan2.max((recomputed - beta).abs() / (U * beta));
                assert!(err <= 32.0, "{k}: angle {i} off by {err} ulps");
            }
        }
        let call = |order| crate::kernels::triangle_form_factor(x, n, v[0], v[1], v[2], order);
        let value_order = call(Order::Value).unwrap().value;
        assert_eq!(value_order.to_bits(), value.to_bits(), "{k}");
        let mut loop_ = shared.clone();
        loop_.sum = screen.side.signum();
        for order in [Order::Gradient, Order::Hessian] {
            let public = call(order).unwrap();
            assert_eq!(public.value.to_bits(), value.to_bits(), "{k}: {order:?}");
            if let Some(d) = loop_derivs(&loop_, value, order) {
                accepted += 1;
                assert_eq!(public, d, "{k}: {order:?}");
            }
        }
    }
    println!(
        "route loops: {routed} routed, {accepted} derivatives accepted; where taken, the \
         split's angles within {worst_angle:.1} ulps (atan2(s, c) of the rounded inputs \
         {worst_atan2:.1})"
    );
    assert!(routed > 300 && accepted > 300, "{routed} {accepted}");
}

/// Walking x onto the clip line inside the triangle (the clip line through x's foot point): the
/// path agrees with the robust one wherever it certifies and declines from some distance on.
#[test]
fn declines_on_the_clip_line_and_when_the_sum_cancels() {
    let v = [
        DVec3::new(-0.4, -0.3, 1.0),
        DVec3::new(0.7, -0.1, 1.2),
        DVec3::new(0.0, 0.8, 0.9),
    ];
    let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
    let centroid = (v[0] + v[1] + v[2]) / 3.0;
    let n = (plane_n + plane_n.any_orthonormal_vector()).normalize();
    let (mut certified, mut declined) = (false, false);
    for k in 4..=18 {
        let x = centroid + plane_n * 10f64.powi(-k);
        assert!(v.iter().any(|vk| n.dot(*vk - x) < 0.0), "clipped at 1e-{k}");
        match triangle_value(x, n, v) {
            Some(f) => {
                certified = true;
                assert!(!declined, "certified again at 1e-{k}");
                let want = robust(x, n, v);
                assert!(
                    (f - want).abs() <= 1e-12 * want,
                    "1e-{k}: {f:e} vs {want:e}"
                );
            }
            None => declined = true,
        }
    }
    assert!(
        certified && declined,
        "certified near, declined on the clip line"
    );
    assert!(triangle_value(centroid + plane_n * 1e-6, n, v).is_some());
    // Outside the triangle, near its plane, the sum cancels: the robust path's case.
    let outside = v[0] + (v[0] - centroid) * 0.5;
    // Tilted about the direction to the centroid: the clip line runs from x's foot into the
    // triangle.
    let towards = (centroid - outside).normalize();
    let n_out = (plane_n + towards.cross(plane_n)).normalize();
    let x = outside + plane_n * 1e-6;
    assert!(v.iter().any(|vk| n_out.dot(*vk - x) < 0.0));
    assert_eq!(triangle_value(x, n_out, v), None);
    // Away from the plane the robust path keeps clipped triangles at every order.
    assert_eq!(triangle_value(centroid + plane_n * 1e-2, n, v), None);
    // Nothing clipped, everything clipped, invalid normal: not this path's.
    assert_eq!(triangle_value(DVec3::ZERO, plane_n, v), None);
    assert_eq!(triangle_value(DVec3::ZERO, -plane_n, v), None);
    assert_eq!(triangle_value(centroid + plane_n * 1e-3, n * 2.0, v), None);
    let nan = DVec3::new(0.0, f64::NAN, 0.0);
    let near = centroid + plane_n * 1e-6;
    assert_eq!(triangle_value(near + nan, n, v), None);
    assert_eq!(triangle_value(near, n, [v[0], v[1] + nan, v[2]]), None);
}
