use super::*;
use crate::kernels::form_factor::plane::is_very_thin_triangle;
use crate::test_rng::lcg;

/// Bit for bit the rescaled evaluation, in every regime `evaluate` distinguishes (clipped, near
/// the plane, near an edge line, slivers, far field, cancelling sums) and at every order.
#[test]
fn unscaled_triangles_give_the_rescaled_bits() {
    let mut state = 11;
    let mut compared = 0;
    for k in 0..3000 {
        let scale = [1e-3, 1.0, 1e3, 3e-20, 7e25][k % 5];
        let offset = [0.0, 1.0, -1e3][k % 3] * scale;
        let mut p = || {
            let mut c = || lcg(&mut state);
            DVec3::new(c(), c(), c()) - 0.5
        };
        let t = p();
        let mut v = [p(), p(), p()];
        if k % 7 == 0 {
            v[2] = (v[0] + v[1]) * 0.5 + p() * 1e-6; // sliver
        }
        let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        let x = match k % 4 {
            0 => p() * 2.0,
            1 => v[0] + (v[1] - v[0]) * (t.x + 0.5) + plane_n * 1e-7 * t.y,
            2 => (v[0] + v[1] + v[2]) / 3.0 + plane_n * 10f64.powf(-18.0 * (t.z + 0.5)),
            _ => p() * 100.0,
        };
        let n = (p() + plane_n * 0.3).normalize();
        let v = v.map(|vk| vk * scale + DVec3::splat(offset));
        let x = x * scale + DVec3::splat(offset);
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            let entry = if is_very_thin_triangle(v) {
                very_thin_triangle_form_factor_in_range
            } else {
                triangle_form_factor_in_range
            };
            let Some(fast) = entry(x, n, v, order) else {
                continue;
            };
            let robust = form_factor(x, n, &v, order);
            match (fast, robust) {
                (Ok(a), Ok(b)) => {
                    assert_eq!(a.value.to_bits(), b.value.to_bits(), "{k}");
                    for i in 0..3 {
                        assert_eq!(a.gradient[i].to_bits(), b.gradient[i].to_bits(), "{k}");
                        for j in 0..3 {
                            let (ha, hb) = (a.hessian.col(i)[j], b.hessian.col(i)[j]);
                            assert_eq!(ha.to_bits(), hb.to_bits(), "{k}");
                        }
                    }
                }
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
                (a, b) => panic!("{k}: {a:?} vs {b:?}"),
            }
            compared += 1;
        }
    }
    assert!(compared > 8000, "{compared}");
}

/// The polygon entry gives the rescaled bits too: quads and pentagons (convex, non-convex,
/// slivers) with x generic, near an edge line, near the plane over them and far away.
#[test]
fn unscaled_polygons_give_the_rescaled_bits() {
    let mut state = 17;
    let mut compared = 0;
    for k in 0..3000 {
        let scale = [1e-3, 1.0, 1e3, 3e-20, 7e25][k % 5];
        let offset = [0.0, 1.0, -1e3][k % 3] * scale;
        let mut c = || lcg(&mut state);
        let m = 4 + k % 2;
        let (t, jitter, tilt) = (DVec3::new(c(), c(), c()) - 0.5, c(), c());
        let width = if k % 7 == 0 { 1e-6 } else { 1.0 };
        // A star-shaped polygon around the origin in the plane z = 0.3 x - 0.2 y + 1,
        // non-convex when a radius is short.
        let v: Vec<DVec3> = (0..m)
            .map(|i| {
                let phi = std::f64::consts::TAU * (i as f64 + 0.3 * jitter) / m as f64;
                let rad = if k % 5 == 1 && i == 2 { 0.3 } else { 1.0 };
                let (px, py) = (rad * phi.cos(), width * rad * phi.sin());
                DVec3::new(px, py, 1.0 + 0.3 * px - 0.2 * py)
            })
            .collect();
        let plane_n = DVec3::new(-0.3, 0.2, 1.0).normalize();
        let x = match k % 4 {
            0 => t * 2.0,
            1 => v[0] + (v[1] - v[0]) * (t.x + 0.5) + plane_n * 1e-7 * t.y,
            2 => DVec3::new(0.1, 0.05 * width, 1.03) + plane_n * 10f64.powf(-18.0 * (t.z + 0.5)),
            _ => t * 100.0,
        };
        let n = (DVec3::new(t.y, tilt - 0.5, t.x) + plane_n * 0.3).normalize();
        let v: Vec<DVec3> = v
            .iter()
            .map(|vk| *vk * scale + DVec3::splat(offset))
            .collect();
        let x = x * scale + DVec3::splat(offset);
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            let Some(fast) = polygon_form_factor_in_range(x, n, &v, order) else {
                continue;
            };
            match (fast, form_factor(x, n, &v, order)) {
                (Ok(a), Ok(b)) => {
                    let bits = |d: Deriv3| {
                        let mut all = vec![d.value];
                        all.extend(d.gradient.to_array());
                        all.extend(d.hessian.to_cols_array());
                        all.iter().map(|e| e.to_bits()).collect::<Vec<_>>()
                    };
                    assert_eq!(bits(a), bits(b), "{k} {order:?}");
                }
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
                (a, b) => panic!("{k}: {a:?} vs {b:?}"),
            }
            compared += 1;
        }
    }
    assert!(compared > 8000, "{compared}");
}

/// Non-finite input is left to `form_factor`, which refuses it with `InvalidArgument`.
#[test]
fn non_finite_input_is_not_taken() {
    let v = [
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::X + DVec3::Z,
        DVec3::Y + DVec3::Z,
    ];
    let x = DVec3::new(0.2, 0.2, 0.0);
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let odd = DVec3::new(0.1, bad, 0.3);
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            assert!(triangle_form_factor_in_range(odd, DVec3::Z, v, order).is_none());
            assert!(triangle_form_factor_in_range(x, DVec3::Z, [v[0], odd, v[2]], order).is_none());
            assert!(triangle_form_factor_in_range(x, odd, v, order).is_none());
            for (x, n, v) in [
                (odd, DVec3::Z, v),
                (x, DVec3::Z, [v[0], v[1], odd]),
                (x, odd, v),
            ] {
                let got = crate::kernels::triangle_form_factor(x, n, v[0], v[1], v[2], order);
                assert!(matches!(got, Err(Error::InvalidArgument(_))), "{got:?}");
            }
        }
    }
}
