use super::*;
use crate::kernels::form_factor::polygon_form_factor;
use crate::kernels::form_factor::robust::form_factor;
use crate::{Error, Order};

#[inline(always)]
pub(crate) fn derivs<const M: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
    order: Order,
) -> Option<Deriv3> {
    derivs_or(x, n, v, order, || None)
}

/// Value, gradient (and Hessian at [`Order::Hessian`]) of
/// [`polygon_form_factor`](super::polygon_form_factor) for `order` above [`Order::Value`], by the
/// analytic derivatives of Lambert's sum, for the polygons [`polygon_value`] takes (strictly convex,
/// 4 to 8 vertices, every vertex certainly above the tangent plane) when the value is certified,
/// no edge's line passes near `x` (`sin β ≥ 1/4` per edge) and neither the gradient nor the Hessian
/// sum cancels by more than 100x; `None` otherwise. The value is [`polygon_value`]'s, bit for bit.
/// The tests' entry (the kernel calls [`polygon_derivs_or_clipped`]).
pub(crate) fn polygon_derivs(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Option<Deriv3> {
    match v.len() {
        4 => derivs::<4>(x, n, v.try_into().ok()?, order),
        5 => derivs::<5>(x, n, v.try_into().ok()?, order),
        6 => derivs::<6>(x, n, v.try_into().ok()?, order),
        7 => derivs::<7>(x, n, v.try_into().ok()?, order),
        8 => derivs::<8>(x, n, v.try_into().ok()?, order),
        _ => None,
    }
}

fn pentagon(z: f64) -> Vec<DVec3> {
    (0..5)
        .map(|i| {
            let phi = std::f64::consts::TAU * i as f64 / 5.0;
            DVec3::new(phi.cos(), phi.sin(), z + 0.3 * phi.sin())
        })
        .collect()
}

/// A convex quad in the plane z = 1 + 0.1 x + 0.1 y.
fn quad() -> Vec<DVec3> {
    [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
        .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
        .to_vec()
}

fn robust(x: DVec3, n: DVec3, v: &[DVec3]) -> f64 {
    form_factor(x, n, v, Order::Value).unwrap().value
}

#[test]
fn convex_polygons_agree_with_the_robust_path_near_and_far() {
    let n = DVec3::new(0.1, -0.2, 1.0).normalize();
    for v in [quad(), pentagon(1.0)] {
        let c = v.iter().sum::<DVec3>() / v.len() as f64;
        // From 0.3 to 1e4 sizes below the centroid: Lambert's sum near, the far form beyond.
        for k in 0..=40 {
            let t = 0.3 * 10f64.powf(k as f64 / 8.0);
            let x = c - DVec3::new(0.1, 0.05, 1.0) * t;
            let f = polygon_value(x, n, &v).unwrap_or_else(|| panic!("declined at {t:e}"));
            let r = robust(x, n, &v);
            assert!((f - r).abs() < 1e-12 * r, "t = {t:e}: {f} vs {r}");
            // The public entry returns the certified value at every order.
            assert_eq!(
                polygon_form_factor(x, n, &v, Order::Value).unwrap().value,
                f
            );
            assert_eq!(
                polygon_form_factor(x, n, &v, Order::Hessian).unwrap().value,
                f
            );
        }
    }
}

#[test]
fn declines_what_the_robust_path_must_judge() {
    let n = DVec3::Z;
    let x = DVec3::new(0.1, 0.0, 0.0);
    // Control: the quad is taken.
    assert!(polygon_value(x, n, &quad()).is_some());
    // Self-intersecting (bow-tie): declined, and the robust path reports it.
    let mut bow = quad();
    bow.swap(1, 2);
    assert!(polygon_value(x, n, &bow).is_none());
    assert!(matches!(
        polygon_form_factor(x, n, &bow, Order::Value),
        Err(Error::InvalidArgument(_))
    ));
    // A pentagram (all turns the same way, winding twice).
    let p = pentagon(1.0);
    let star: Vec<DVec3> = [0, 2, 4, 1, 3].iter().map(|&i| p[i]).collect();
    assert!(polygon_value(x, n, &star).is_none());
    // Non-planar beyond the tolerance: declined, InvalidArgument.
    let mut bent = quad();
    bent[2].z += 1e-3;
    assert!(polygon_value(x, n, &bent).is_none());
    assert!(matches!(
        polygon_form_factor(x, n, &bent, Order::Value),
        Err(Error::InvalidArgument(_))
    ));
    // Non-planar within the robust tolerance but beyond a quarter of it: declined, and the
    // robust path evaluates it.
    let mut slight = quad();
    slight[2].z += 3e-8;
    assert!(polygon_value(x, n, &slight).is_none());
    assert!(polygon_form_factor(x, n, &slight, Order::Value).is_ok());
    // Non-convex (an arrowhead), a repeated vertex, a collinear vertex: declined.
    let arrow = vec![
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(1.0, 0.5, 1.0),
        DVec3::new(0.0, 1.0, 1.0),
        DVec3::new(0.3, 0.5, 1.0),
    ];
    assert!(polygon_value(x, n, &arrow).is_none());
    assert!(polygon_form_factor(x, n, &arrow, Order::Value).is_ok());
    let mut rep = quad();
    rep.insert(2, rep[2]);
    assert!(polygon_value(x, n, &rep).is_none());
    let mut col = quad();
    col.insert(1, (col[0] + col[1]) * 0.5);
    assert!(polygon_value(x, n, &col).is_none());
    // Clipped, non-finite, too many vertices.
    assert!(polygon_value(DVec3::new(0.0, 0.0, 1.05), n, &quad()).is_none());
    assert!(polygon_value(DVec3::NAN, n, &quad()).is_none());
    let ring: Vec<DVec3> = (0..9)
        .map(|i| {
            let phi = std::f64::consts::TAU * i as f64 / 9.0;
            DVec3::new(phi.cos(), phi.sin(), 1.0)
        })
        .collect();
    assert!(polygon_value(x, n, &ring).is_none());
    assert!(polygon_value(x, n, &ring[..8]).is_some());
}

/// The unit normal of a convex polygon (right-handed with its vertex order).
fn normal_of(v: &[DVec3]) -> DVec3 {
    (v[1] - v[0]).cross(v[2] - v[0]).normalize()
}

/// Relative differences of value, gradient and Hessian, each normalized by the largest entry
/// of the reference (as the accuracy tests measure them).
fn rel_d(a: &Deriv3, b: &Deriv3) -> (f64, f64, f64) {
    let hm = |m: glam::DMat3| {
        m.to_cols_array()
            .iter()
            .fold(0.0f64, |acc, e| acc.max(e.abs()))
    };
    (
        (a.value - b.value).abs() / b.value.abs(),
        (a.gradient - b.gradient).abs().max_element() / b.gradient.abs().max_element(),
        hm(a.hessian - b.hessian) / hm(b.hessian),
    )
}

/// Receiver normal, path x(t), first and last t, whether the fast path must decline by t1.
type Walk = (DVec3, Box<dyn Fn(f64) -> DVec3>, f64, f64, bool);

/// Walks x from generic positions to an edge's line, to the polygon's plane and into the far
/// field: wherever the derivative fast path accepts, it agrees with the robust path (1e-12
/// value and gradient, 1e-11 Hessian, each relative to its largest entry), the public entry
/// returns exactly its result, and the value is the Value order's, bit for bit; once it
/// declines it does not accept again further along the path.
#[test]
fn polygon_derivatives_agree_with_the_robust_path_until_they_switch_off() {
    let n = DVec3::new(0.1, -0.2, 1.0).normalize();
    for (name, v) in [("quad", quad()), ("pentagon", pentagon(1.0))] {
        let c = v.iter().sum::<DVec3>() / v.len() as f64;
        let pn = normal_of(&v);
        // Seen from below, pn points away from x: the receiver faces the plane with -pn.
        let up = if pn.z > 0.0 { pn } else { -pn };
        let (a, b) = (v[0], v[1]);
        let mid = (a + b) * 0.5;
        let out = (b - a).cross(up).normalize();
        let out = if out.dot(mid - c) > 0.0 { out } else { -out };
        let side = c + (v[0] - c) * 1.5;
        let paths: [Walk; 4] = [
            // Diagonally from outside and below towards the line of edge (v0, v1).
            (
                up,
                Box::new(move |t| mid + (out - up) * t),
                1.0,
                1e-12,
                true,
            ),
            // Along the normal towards the plane, outside the polygon's projection.
            (up, Box::new(move |t| side - up * t), 1.0, 1e-12, true),
            // Away below the centroid into the far field.
            (n, Box::new(move |t| c - n * t), 0.3, 1e8, true),
            // Generic points scaled towards the polygon.
            (
                n,
                Box::new(|t| DVec3::new(0.3, -0.2, 0.1) * t),
                1.0,
                1e-2,
                false,
            ),
        ];
        for (k, (nr, x_of, t0, t1, must_decline)) in paths.iter().enumerate() {
            for order in [Order::Gradient, Order::Hessian] {
                let (mut accepted, mut declined, mut off) = (0, false, f64::NAN);
                for step in 0..=200 {
                    let t = t0 * (t1 / t0).powf(step as f64 / 200.0);
                    let x = x_of(t);
                    let Some(d) = polygon_derivs(x, *nr, &v, order) else {
                        if !declined {
                            off = t;
                        }
                        declined = true;
                        continue;
                    };
                    let at = format!("{name} path {k} t = {t:e} {order:?}");
                    assert!(!declined, "{at}: accepted again after declining");
                    accepted += 1;
                    let r = form_factor(x, *nr, &v, order).unwrap();
                    let (ev, eg, eh) = rel_d(&d, &r);
                    let eh = if order.hessian() { eh } else { 0.0 };
                    assert!(
                        ev < 1e-12 && eg < 1e-12 && eh < 1e-11,
                        "{at}: {ev:e} {eg:e} {eh:e}"
                    );
                    assert_eq!(polygon_form_factor(x, *nr, &v, order).unwrap(), d, "{at}");
                    assert_eq!(Some(d.value), polygon_value(x, *nr, &v), "{at}");
                    if !order.hessian() {
                        assert_eq!(d.hessian, glam::DMat3::ZERO);
                    }
                }
                println!("{name} path {k} {order:?}: {accepted} accepted, off at {off:e}");
                assert!(
                    accepted >= 10,
                    "{name} path {k} {order:?}: {accepted} accepted"
                );
                assert!(
                    declined == *must_decline,
                    "{name} path {k} {order:?}: declined {declined}"
                );
            }
        }
    }
}

#[test]
fn polygon_derivatives_agree_with_central_differences() {
    let n = DVec3::new(0.2, -0.1, 1.0).normalize();
    for v in [quad(), pentagon(1.0)] {
        for x in [DVec3::new(0.1, -0.2, 0.05), DVec3::new(-0.3, 0.4, -0.5)] {
            let d = polygon_derivs(x, n, &v, Order::Hessian).expect("declined");
            // Central differences (h = 1e-4: truncation ~1e-8 of the derivatives' size) of
            // the certified value and of the fast gradient.
            let h = 1e-4;
            let f = |p: DVec3| polygon_value(p, n, &v).unwrap();
            let g = |p: DVec3| polygon_derivs(p, n, &v, Order::Gradient).unwrap().gradient;
            let g_scale = d.gradient.abs().max_element();
            let h_scale = d
                .hessian
                .to_cols_array()
                .iter()
                .fold(0.0f64, |m, e| m.max(e.abs()));
            for i in 0..3 {
                let dx = DVec3::AXES[i] * h;
                let fd = (f(x + dx) - f(x - dx)) / (2.0 * h);
                assert!(
                    (fd - d.gradient[i]).abs() < 1e-7 * g_scale,
                    "grad {i}: {fd} vs {}",
                    d.gradient[i]
                );
                let col = (g(x + dx) - g(x - dx)) / (2.0 * h);
                let err = (col - d.hessian.col(i)).abs().max_element();
                assert!(err < 1e-7 * h_scale, "hess col {i}: {err:e}");
            }
            // The gradient order gives the Hessian order's value and gradient.
            let dg = polygon_derivs(x, n, &v, Order::Gradient).unwrap();
            assert_eq!((dg.value, dg.gradient), (d.value, d.gradient));
        }
    }
}

#[test]
fn invalid_polygons_are_refused_at_every_order() {
    let n = DVec3::Z;
    let x = DVec3::new(0.1, 0.0, 0.0);
    let mut bow = quad();
    bow.swap(1, 2);
    let p = pentagon(1.0);
    let star: Vec<DVec3> = [0, 2, 4, 1, 3].iter().map(|&i| p[i]).collect();
    let mut bent = quad();
    bent[2].z += 1e-3;
    for order in [Order::Value, Order::Gradient, Order::Hessian] {
        // Control: the quad is taken by the fast paths.
        if order != Order::Value {
            assert!(polygon_derivs(x, n, &quad(), order).is_some());
        }
        for (name, v) in [("bow-tie", &bow), ("pentagram", &star), ("bent", &bent)] {
            assert!(polygon_derivs(x, n, v, order).is_none(), "{name} {order:?}");
            assert!(
                matches!(
                    polygon_form_factor(x, n, v, order),
                    Err(Error::InvalidArgument(_))
                ),
                "{name} {order:?}"
            );
        }
        // Non-convex but valid: declined, the robust path evaluates it.
        let arrow = vec![
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.5, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
            DVec3::new(0.3, 0.5, 1.0),
        ];
        assert!(polygon_derivs(x, n, &arrow, order).is_none());
        assert!(polygon_form_factor(x, n, &arrow, order).is_ok());
    }
    // Clipped, non-finite, a bad normal: declined.
    assert!(polygon_derivs(DVec3::new(0.0, 0.0, 1.05), n, &quad(), Order::Hessian).is_none());
    assert!(polygon_derivs(DVec3::NAN, n, &quad(), Order::Hessian).is_none());
    assert!(polygon_derivs(x, n * 1.1, &quad(), Order::Hessian).is_none());
}
