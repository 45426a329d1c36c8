use super::*;
use crate::kernels::form_factor::clip::{clip, ClipLoop};
use crate::kernels::form_factor::near_plane::split::{
    edge_frames, foot_inside, near_plane_value, Frames, SPLIT_VALUE_LIMIT,
};
use crate::kernels::form_factor::plane::{exact_height, Plane, NEAR_PLANE_HEIGHT};
use crate::kernels::form_factor::quadrature::rules::far_field_rule;
use crate::kernels::form_factor::robust::form_factor;
use crate::kernels::form_factor::scaled::Scaled;
use crate::kernels::form_factor::validate::unit_normal;
use crate::test_rng::lcg;
use crate::Order;

/// A random configuration near the triangle's plane: a triangle of size `scale` (offset from
/// the origin), `x` at a random in-plane point (inside or outside, near edges and vertices
/// too) lifted by `±10^-(1..13)` sizes, and a receiver normal tilted by 2-88 degrees from the
/// plane's, so that the tangent plane usually cuts the triangle.
fn configuration(state: &mut u64, scale: f64) -> (DVec3, DVec3, [DVec3; 3]) {
    let mut c = || lcg(state);
    let offset = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * 10.0 * scale;
    let mut p = || DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * scale + offset;
    let v = [p(), p(), p()];
    let mut c = || lcg(state);
    let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
    // Barycentric coordinates in [-1, 2): outside more often than inside.
    let (a, b) = (3.0 * c() - 1.0, 3.0 * c() - 1.0);
    let mut foot = v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b;
    if c() < 0.2 {
        // On an edge's line or at a vertex, where the split declines.
        let k = (3.0 * c()) as usize % 3;
        foot = v[k] + (v[(k + 1) % 3] - v[k]) * (3.0 * c() - 1.0) * f64::from(c() < 0.5);
    }
    let side = if c() < 0.5 { -1.0 } else { 1.0 };
    let x = foot + plane_n * side * scale * 10f64.powf(-1.0 - 12.0 * c());
    let tilt = (2.0 + 86.0 * c()).to_radians();
    let t = plane_n.any_orthonormal_vector();
    let phi = 6.3 * c();
    let t = t * phi.cos() + plane_n.cross(t) * phi.sin();
    let n = (plane_n * tilt.cos() + t * tilt.sin()).normalize();
    let n = if c() < 0.5 { n } else { -n };
    (x, n, v)
}

/// Wherever the route answers it returns the robust evaluation's bits, with and without FMA, and
/// it answers wherever the robust evaluation takes its near-plane split for the value; the
/// entry point's value is the same at every order.
#[test]
fn the_route_returns_the_robust_bits() {
    let mut state = 5;
    let (mut taken, mut robust_split) = (0, 0);
    let (mut far_taken, mut robust_far) = (0, 0);
    for k in 0..20000 {
        let scale = [1e-3, 1.0, 1e3][k % 3];
        let (x, n, v) = configuration(&mut state, scale);
        let got = triangle_value(x, n, v);
        assert_eq!(
            got.map(f64::to_bits),
            screen(x, n, v)
                .and_then(|s| split(x, v, &s))
                .map(f64::to_bits),
            "{k}: dispatch vs portable"
        );
        let Ok(want) = form_factor(x, n, &v, Order::Value) else {
            assert!(got.is_none(), "{k}");
            continue;
        };
        if let Some(f) = got {
            taken += 1;
            assert_eq!(f.to_bits(), want.value.to_bits(), "{k}: {x:?} {n:?} {v:?}");
        }
        // The entry point's value does not depend on the order (the route serves the value
        // order where Lambert's certified sums decline).
        let entry = |order| crate::kernels::triangle_form_factor(x, n, v[0], v[1], v[2], order);
        if let (Ok(value), Ok(hessian)) = (entry(Order::Value), entry(Order::Hessian)) {
            assert_eq!(value.value.to_bits(), hessian.value.to_bits(), "{k}: order");
        }
        // Wherever the robust path takes its split, the route answers; where it takes its
        // far-field rule on the clipped loop, the route answers unless its edge-line screen
        // (the split's decline, tested before the far-field test) declines first.
        let split = robust_takes_the_split(x, n, &v, false);
        let split_or_far = robust_takes_the_split(x, n, &v, true);
        assert!(!split || got.is_some(), "{k}: the split, but not the route");
        assert!(got.is_none() || split_or_far, "{k}: the route, but neither");
        robust_split += usize::from(split);
        robust_far += usize::from(split_or_far && !split);
        far_taken += usize::from(got.is_some() && !split);
    }
    assert!(
        far_taken * 10 >= robust_far * 9,
        "far {far_taken} of {robust_far}"
    );
    println!(
        "route taken in {taken} of 20000 configurations ({robust_split} robust splits, \
         {far_taken} of {robust_far} far-field rules)"
    );
    assert!(taken > 2000, "{taken}");
}

/// The entry point's value on both sides of the switch in `t` between the route answering (at
/// `t0`) and declining (at `t1`), bisected until the two points are adjacent (their `x` a few
/// ulps apart; `n` fixed): the two sides (the route, and the robust path's edge sum or
/// quadrature) agree to 1e-12 of the value beyond the first-order change `∇F·Δx` (the
/// gradient from the robust path on the declining side). Returns that excess, relative.
fn across_the_switch(
    x_of: &dyn Fn(f64) -> DVec3,
    n: DVec3,
    v: [DVec3; 3],
    (mut t0, mut t1): (f64, f64),
) -> f64 {
    let route = |t: f64| triangle_value(x_of(t), n, v);
    assert!(
        route(t0).is_some() && route(t1).is_none(),
        "no switch in [{t0}, {t1}]"
    );
    for _ in 0..200 {
        let mid = 0.5 * (t0 + t1);
        if mid == t0 || mid == t1 {
            break;
        }
        if route(mid).is_some() {
            t0 = mid;
        } else {
            t1 = mid;
        }
    }
    let entry = |t: f64, order| {
        let x = x_of(t);
        crate::kernels::triangle_form_factor(x, n, v[0], v[1], v[2], order).unwrap()
    };
    let (a, b) = (entry(t0, Order::Value).value, entry(t1, Order::Gradient));
    let change = b.gradient.dot(x_of(t1) - x_of(t0));
    ((b.value - a - change).abs() - 1e-9 * change.abs()).max(0.0) / a
}

/// Continuity where the route starts or stops answering, for fat random triangles at scales
/// 1e-3..1e3 and tilts 10-80 degrees: x's foot approaching an edge line outside the triangle
/// (the split's limit `|h_P| = 0.1 d_e`, 1e-5 and 1e-8 sizes from the plane) and x rising
/// through the near-plane limit (`|h_P| = 1e-3 r_max`) outside the triangle.
#[test]
fn continuous_where_the_route_switches() {
    let mut state = 17;
    let mut worst = [0.0f64; 2];
    for k in 0..24 {
        let scale = [1e-3, 1.0, 1e3][k % 3];
        let mut c = || lcg(&mut state);
        let v = [
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.1 * c(), 1.2),
            DVec3::new(0.2 + 0.3 * c(), 0.9, 0.8),
        ]
        .map(|p| p * scale);
        let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        let e = (v[1] - v[0]).normalize();
        // Away from the triangle, beside edge (0, 1), past its midpoint.
        let out = plane_n.cross(e);
        let out = if out.dot(v[2] - v[0]) > 0.0 {
            -out
        } else {
            out
        };
        let base = v[0] + (v[1] - v[0]) * (0.3 + 0.4 * c());
        let centroid = (v[0] + v[1] + v[2]) / 3.0;
        let tilt = (10.0 + 70.0 * c()).to_radians();
        // The receiver tilted about the line from `base` to the centroid, so that its
        // tangent plane cuts the triangle along that line.
        let across = plane_n.cross((centroid - base).normalize());
        let n = (plane_n * tilt.cos() + across * tilt.sin()).normalize();
        // (a) The foot towards the edge line, h_P fixed.
        let h = [1e-5, 1e-8][k % 2] * scale;
        let x_of = |d: f64| base + out * (d * scale) + plane_n * h;
        let d = h / scale;
        worst[0] = worst[0].max(across_the_switch(&x_of, n, v, (100.0 * d, 3.0 * d)));
        // (b) x rising at a foot 0.2 sizes outside, through 1e-3 of r_max.
        let foot = base + out * (0.2 * scale);
        let x_of = |t: f64| foot + plane_n * (t * scale);
        worst[1] = worst[1].max(across_the_switch(&x_of, n, v, (5e-4, 2e-3)));
    }
    println!(
        "jumps beyond the first-order change at the route's switches: edge line {:.1e}, \
         height 1e-3 {:.1e}",
        worst[0], worst[1]
    );
    assert!(worst.iter().all(|w| *w <= 1e-12), "{worst:?}");
}

/// Whether `evaluate` takes its near-plane split for the value of this configuration (its
/// decisions, through the route's own steps but with the robust path's `clip` and frames).
/// Also the polygon route's reference (`near_plane::polygon`), hence over any vertex count;
/// with `far_counts` also where it takes its far-field rule on the clipped loop instead (a
/// far-field visible part), which the polygon route replays.
pub(crate) fn robust_takes_the_split(x: DVec3, n: DVec3, v: &[DVec3], far_counts: bool) -> bool {
    let Ok(scaled) = Scaled::new(x, v) else {
        return false;
    };
    let Ok(plane) = Plane::new(&scaled.u) else {
        return false;
    };
    let Ok(n) = unit_normal(n) else {
        return false;
    };
    let r_max = scaled.r.iter().map(|r| r.length()).fold(0.0, f64::max);
    let nearest = scaled
        .r
        .iter()
        .min_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))
        .copied()
        .unwrap();
    let h = plane.normal.dot(nearest);
    if h.abs() <= 4.0 * f64::EPSILON * r_max || h.abs() >= NEAR_PLANE_HEIGHT * r_max {
        return false;
    }
    let h_p = exact_height(&scaled, plane.twice_area);
    let mut loop_ = ClipLoop::new();
    if !clip(&scaled.u, &scaled.r, &scaled.r_lo, n, &mut loop_) || loop_.len() < 3 {
        return false;
    }
    let centroid = loop_.iter().map(|v| v.r).sum::<DVec3>() / loop_.len() as f64;
    let radius = loop_
        .iter()
        .map(|v| (v.r - centroid).length())
        .fold(0.0, f64::max);
    if far_field_rule(centroid.length(), radius).is_some() {
        return far_counts;
    }
    if foot_inside(&loop_, plane.normal, h_p) {
        return false;
    }
    let mut frames = Frames::new();
    edge_frames(&loop_, true, &mut frames);
    near_plane_value(
        &loop_,
        &frames,
        n,
        plane.normal,
        h_p,
        SPLIT_VALUE_LIMIT,
        &mut [],
        &mut [],
    )
    .is_some()
}
