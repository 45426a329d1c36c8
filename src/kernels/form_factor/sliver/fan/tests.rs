use super::*;
use crate::kernels::form_factor::replay::fast_decisions;
use crate::kernels::form_factor::robust::form_factor;
use crate::test_rng::lcg;

/// [`thin_differences`] then [`validated`] (the unit tests' entry).
fn thin_polygon(x: DVec3, v: &[DVec3]) -> Option<ThinPolygon> {
    validated(v.len(), thin_differences(x, v)?)
}

/// [`fan_rule`] from the vertices alone (the unit tests' entry).
pub(crate) fn very_thin_polygon(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Option<Deriv3> {
    fan_rule(x, n, v, &thin_polygon(x, v)?, order)
}

/// [`fan_of_triangles`] from the vertices alone (the unit tests' entry).
pub(crate) fn very_thin_polygon_by_triangles(
    x: DVec3,
    n: DVec3,
    v: &[DVec3],
    order: Order,
) -> Option<Deriv3> {
    let triangle =
        |a, b, c| crate::kernels::form_factor::triangle_form_factor(x, n, a, b, c, order);
    fan_of_triangles(x, v, &thin_polygon(x, v)?, triangle)
}

/// A convex sliver in a random plane: `m` points along a flat arc of length `len` and height
/// `width` (the first two at the ends of the long side), shifted by `origin`.
fn sliver(seed: &mut u64, m: usize, len: f64, width: f64, origin: DVec3) -> Vec<DVec3> {
    let along = DVec3::new(lcg(seed) - 0.5, lcg(seed) - 0.5, lcg(seed) - 0.5).normalize();
    let across = along.any_orthonormal_vector();
    let mut v = vec![origin, origin + along * len];
    // The arc's points from the far end back, strictly convex (heights of a parabola).
    for k in (1..m - 1).rev() {
        let t = k as f64 / (m - 1) as f64 + 0.1 * (lcg(seed) - 0.5) / m as f64;
        v.push(origin + along * (t * len) + across * (width * 4.0 * t * (1.0 - t)));
    }
    v
}

/// Agreement with [`fan_reference`]: the same triangles' sums up to the order of the additions.
/// (Not with the robust path on the whole polygon: its subdivided quadrature and edge sum are
/// the inaccurate side here, off by up to 4e-8 where `tests/form_factor_polygon_slivers.rs`
/// measures the fan path within 1e-15 of 320-bit references.)
const TOL: [f64; 3] = [1e-14, 1e-14, 1e-14];

/// The robust path on each fan triangle (its own set-up, rescaling and clipping), summed.
fn fan_reference(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Deriv3 {
    let mut sum = Deriv3::constant(0.0);
    for k in 1..v.len() - 1 {
        let d = form_factor(x, n, &[v[0], v[k], v[k + 1]], order).unwrap();
        sum.value += d.value;
        sum.gradient += d.gradient;
        sum.hessian += d.hessian;
    }
    sum
}

/// Value relative error; gradient and Hessian relative to their largest reference entry.
fn errors(a: &Deriv3, b: &Deriv3) -> [f64; 3] {
    let big = |m: glam::DMat3| m.to_cols_array().iter().fold(0.0f64, |s, e| s.max(e.abs()));
    [
        (a.value - b.value).abs() / b.value.abs(),
        (a.gradient - b.gradient).abs().max_element() / b.gradient.abs().max_element(),
        big(a.hessian - b.hessian) / big(b.hessian),
    ]
}

/// On random convex slivers (4 to 8 vertices, widths 1e-5.2..1e-10 of the length, x from 0.2
/// to 30 lengths away, some near the plane): wherever the fan path accepts it agrees with the
/// robust path on its fan triangles, at every order, the value the same at every order;
/// it accepts over a third of them and declines the rest (x over the sliver near its plane, far
/// field, clipped).
#[test]
fn fan_of_slivers_agrees_with_the_robust_path() {
    let mut seed = 7u64;
    let (mut accepted, mut total, mut worst) = (0, 0, [0.0f64; 3]);
    for case in 0..400 {
        let m = 4 + case % 5;
        let len = 10f64.powf(4.0 * lcg(&mut seed) - 2.0);
        let width = len * 10f64.powf(-5.2 - 4.8 * lcg(&mut seed));
        let origin = DVec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed)) * 3.0 * len;
        let v = sliver(&mut seed, m, len, width, origin);
        let c = v.iter().sum::<DVec3>() / m as f64;
        let dir = DVec3::new(
            lcg(&mut seed) - 0.5,
            lcg(&mut seed) - 0.5,
            lcg(&mut seed) - 0.5,
        )
        .normalize();
        let x = c + dir * (len * 10f64.powf(2.2 * lcg(&mut seed) - 0.7));
        let tilt = DVec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed)) - 0.5;
        let n0 = ((c - x).normalize() + tilt).normalize();
        total += 1;
        let values: Vec<Option<Deriv3>> = [Order::Value, Order::Gradient, Order::Hessian]
            .iter()
            .map(|&order| {
                let got = very_thin_polygon(x, n0, &v, order)?;
                let want = fan_reference(x, n0, &v, order);
                let e = errors(&got, &want);
                let at = format!("case {case} {order:?}: {e:?} x={x:?} n={n0:?} v={v:?} got={got:?} want={want:?}");
                assert!(e[0] < TOL[0], "{at}");
                if order.gradient() {
                    assert!(e[1] < TOL[1], "{at}");
                }
                if order.hessian() {
                    assert!(e[2] < TOL[2], "{at}");
                }
                for k in 0..3 {
                    worst[k] = worst[k].max(if k <= order as usize { e[k] } else { 0.0 });
                }
                Some(got)
            })
            .collect();
        // All orders accept or decline together, with one value.
        assert!(values.iter().all(Option::is_some) || values.iter().all(Option::is_none));
        if let [Some(a), Some(b), Some(c)] = &values[..] {
            assert!(a.value == b.value && b.value == c.value, "case {case}");
            accepted += 1;
        }
    }
    println!("accepted {accepted} of {total}, worst {worst:?}");
    assert!(accepted > total / 3, "accepted {accepted} of {total}");
}

/// Across the switches: the thinness threshold (widths around 1e-5 of the length: on the
/// thin side the fan path, the public entry's result, on the other the robust path) and x
/// walking in towards the sliver until the rule declines, once.
#[test]
fn continuous_across_the_switches() {
    let base = |w: f64| {
        vec![
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.7, w, 1.0),
            DVec3::new(0.2, w, 1.0),
        ]
    };
    let n = DVec3::new(0.1, -0.2, 1.0).normalize();
    let x = DVec3::new(0.4, 0.1, 0.3);
    // Twice the area of the trapezoid is 1.5 w: very thin below w = 1e-5 / 1.5.
    let (mut thin, mut thick) = (0, 0);
    for k in -20..=20 {
        let w = 1e-5 / 1.5 * (1.0 + k as f64 * 1e-3);
        let v = base(w);
        let robust = fan_reference(x, n, &v, Order::Hessian);
        let public = crate::kernels::polygon_form_factor(x, n, &v, Order::Hessian).unwrap();
        match very_thin_polygon(x, n, &v, Order::Hessian) {
            Some(d) => {
                thin += 1;
                assert_eq!(d, public);
                let e = errors(&d, &robust);
                assert!(
                    e[0] < TOL[0] && e[1] < TOL[1] && e[2] < TOL[2],
                    "w {w:e}: {e:?}"
                );
            }
            None => thick += 1,
        }
    }
    assert!(thin > 10 && thick > 10, "{thin} thin, {thick} thick");
    // x down the normal onto the sliver's middle: accepted far out, declined once x is
    // close (the rule's width condition, then near the plane).
    let v = base(1e-7);
    let (mut last, mut declined) = (None::<Deriv3>, false);
    for k in 0..=120 {
        let h = 10f64.powf(0.3 - k as f64 * 0.1);
        let x = DVec3::new(0.45, 0.5e-7, 1.0 - h);
        let got = very_thin_polygon(x, DVec3::Z, &v, Order::Hessian);
        let robust = fan_reference(x, DVec3::Z, &v, Order::Hessian);
        match got {
            Some(d) => {
                assert!(!declined, "accepted again at h = {h:e}");
                let e = errors(&d, &robust);
                assert!(
                    e[0] < TOL[0] && e[1] < TOL[1] && e[2] < TOL[2],
                    "h {h:e}: {e:?}"
                );
                last = Some(d);
            }
            None => declined = true,
        }
    }
    assert!(declined && last.is_some());
}

/// The near-plane fallback: taken with x within 1e-3 of the largest vertex distance from the
/// plane (the sum of the public triangle kernel on the fan, the public entry's result),
/// declined farther, for polygons that are not very thin or whose fan turns over, and for
/// x in the plane with derivatives (the robust path reports the crease).
#[test]
fn fan_of_triangles_near_the_plane() {
    let v = vec![
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(0.7, 1e-7, 1.0),
        DVec3::new(0.2, 1e-7, 1.0),
    ];
    // Beside the sliver, 1e-5 above its plane, the tangent plane cutting it across.
    let x = DVec3::new(0.5, 0.1, 1.0 - 1e-5);
    let n = DVec3::new(1.0, 0.0, 0.3).normalize();
    for order in [Order::Value, Order::Gradient, Order::Hessian] {
        assert!(very_thin_polygon(x, n, &v, order).is_none());
        let got = very_thin_polygon_by_triangles(x, n, &v, order).unwrap();
        let mut want = Deriv3::constant(0.0);
        for k in 1..3 {
            let d =
                crate::kernels::triangle_form_factor(x, n, v[0], v[k], v[k + 1], order).unwrap();
            want.value += d.value;
            want.gradient += d.gradient;
            want.hessian += d.hessian;
        }
        assert_eq!(got, want);
        assert!(got.value > 0.0);
        assert_eq!(
            crate::kernels::polygon_form_factor(x, n, &v, order).unwrap(),
            got
        );
    }
    // Farther from the plane than 1e-3 of the distance: the robust path's.
    let far = DVec3::new(0.5, 0.1, 1.0 - 1e-2);
    assert!(very_thin_polygon_by_triangles(far, n, &v, Order::Hessian).is_none());
    let fat = vec![
        v[0],
        v[1],
        DVec3::new(0.7, 0.1, 1.0),
        DVec3::new(0.2, 0.1, 1.0),
    ];
    assert!(very_thin_polygon_by_triangles(x, n, &fat, Order::Hessian).is_none());
    let arrow = vec![
        v[0],
        v[1],
        DVec3::new(0.5, 1e-7, 1.0),
        DVec3::new(0.5, 0.5e-7, 1.0),
    ];
    assert!(very_thin_polygon_by_triangles(x, n, &arrow, Order::Hessian).is_none());
    let in_plane = DVec3::new(0.5, 0.1, 1.0);
    assert!(very_thin_polygon_by_triangles(in_plane, n, &v, Order::Gradient).is_none());
    assert!(matches!(
        crate::kernels::polygon_form_factor(in_plane, n, &v, Order::Gradient),
        Err(crate::Error::Degenerate(_))
    ));
}

/// [`near_field_height`] takes [`fast_decisions`]'s decisions with its height, bit for bit, on
/// random slivers seen from 1e-4 to 1e3 lengths away (near the plane, beside, far).
#[test]
fn near_field_height_decides_as_fast_decisions() {
    let mut seed = 11u64;
    let (mut near, mut far, mut taken) = (0, 0, 0);
    for case in 0..3000 {
        let m = 4 + case % 5;
        let origin = DVec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed));
        let v = sliver(&mut seed, m, 1.0, 1e-7, origin);
        let dir = DVec3::new(
            lcg(&mut seed) - 0.5,
            lcg(&mut seed) - 0.5,
            lcg(&mut seed) - 0.5,
        );
        let x = origin + dir * 10f64.powf(7.0 * lcg(&mut seed) - 4.0);
        let Some(thin) = thin_polygon(x, &v) else {
            continue;
        };
        let r: Vec<DVec3> = v.iter().map(|p| *p - x).collect();
        let r2: Vec<f64> = r.iter().map(|p| p.length_squared()).collect();
        let got = near_field_height(&r, &r2, &thin.plane);
        let want = fast_decisions(&r, &thin.plane);
        match want {
            None => near += 1,
            Some((Some(_), _)) => far += 1,
            Some((None, _)) => taken += 1,
        }
        let want = want.and_then(|(rule, h)| rule.is_none().then_some(h));
        assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "case {case}");
    }
    assert!(
        near > 100 && far > 100 && taken > 100,
        "{near} {far} {taken}"
    );
}

/// The fan's half-turn test certifies simplicity only where it holds: a thin hexagon whose fan
/// from `v_0` keeps its orientation but sweeps more than a turn (its last edge crosses the
/// first) fails it, is checked by the robust path's simplicity test and refused, while a
/// convex sliver passes it and is taken.
#[test]
fn a_fan_sweeping_past_a_half_turn_is_checked_for_simplicity() {
    let at = |degrees: f64, radius: f64| {
        let a = degrees.to_radians();
        DVec3::new(radius * a.cos(), radius * a.sin(), 1.0)
    };
    let v = vec![
        at(0.0, 0.0),
        at(0.0, 1.0),
        at(120.0, 1e-6),
        at(240.0, 1e-6),
        at(359.0, 1e-6),
        at(370.0, 1e-6),
    ];
    let u: Vec<DVec3> = v.iter().map(|p| *p - v[0]).collect();
    assert_eq!(fan_is_star(&u, DVec3::Z), Some(false));
    let x = DVec3::new(0.4, 0.1, 0.3);
    assert!(very_thin_polygon(x, DVec3::Z, &v, Order::Value).is_none());
    let got = crate::kernels::polygon_form_factor(x, DVec3::Z, &v, Order::Value);
    assert!(
        matches!(&got, Err(crate::Error::InvalidArgument(m)) if m.contains("simple")),
        "{got:?}"
    );
    let convex = sliver(&mut 3, 6, 1.0, 1e-7, DVec3::new(0.1, 0.2, 1.0));
    let u: Vec<DVec3> = convex.iter().map(|p| *p - convex[0]).collect();
    let normal = thin_polygon(x, &convex).unwrap().plane.normal;
    assert_eq!(fan_is_star(&u, normal), Some(true));
}

#[test]
fn declines_what_it_must() {
    let n = DVec3::Z;
    let x = DVec3::new(0.4, 0.1, 0.3);
    let v = vec![
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(0.7, 1e-7, 1.0),
        DVec3::new(0.2, 1e-7, 1.0),
    ];
    assert!(very_thin_polygon(x, n, &v, Order::Value).is_some());
    // A bow-tie (self-intersecting): declined, and the robust path refuses it.
    let bow = vec![v[0], v[1], v[3], v[2]];
    assert!(very_thin_polygon(x, n, &bow, Order::Value).is_none());
    assert!(matches!(
        crate::kernels::polygon_form_factor(x, n, &bow, Order::Value),
        Err(crate::Error::InvalidArgument(_))
    ));
    // Non-planar beyond the tolerance.
    let mut bent = v.clone();
    bent[2].z += 1e-6;
    assert!(very_thin_polygon(x, n, &bent, Order::Value).is_none());
    // Non-convex (a fan triangle turned over), clipped, a bad normal, non-finite, triangles
    // and more than 8 vertices.
    let arrow = vec![
        v[0],
        v[1],
        DVec3::new(0.5, 1e-7, 1.0),
        DVec3::new(0.5, 0.5e-7, 1.0),
    ];
    assert!(very_thin_polygon(x, n, &arrow, Order::Value).is_none());
    let tilted = DVec3::new(0.9, 0.0, 0.1).normalize();
    assert!(very_thin_polygon(DVec3::new(0.5, 0.0, 0.5), tilted, &v, Order::Value).is_none());
    assert!(very_thin_polygon(x, n * 1.1, &v, Order::Value).is_none());
    assert!(very_thin_polygon(DVec3::NAN, n, &v, Order::Value).is_none());
    assert!(very_thin_polygon(x, n, &v[..3], Order::Value).is_none());
    let many: Vec<DVec3> = (0..9)
        .map(|k| {
            let t = k as f64 / 8.0;
            DVec3::new(t, 1e-7 * t * (1.0 - t), 1.0)
        })
        .collect();
    assert!(very_thin_polygon(x, n, &many, Order::Value).is_none());
    assert!(very_thin_polygon(x, n, &many[..8], Order::Value).is_some());
    // Not thin.
    let fat = vec![
        v[0],
        v[1],
        DVec3::new(0.7, 0.1, 1.0),
        DVec3::new(0.2, 0.1, 1.0),
    ];
    assert!(very_thin_polygon(x, n, &fat, Order::Value).is_none());
}
