//! Property tests (proptest) of the flatland segment form factor: the form factors of a convex
//! polygon's edges sum to 1 inside it, gradient and Hessian equal to finite differences.

use glam::DVec2;
use proptest::prelude::*;
use raddiff::{kernels, Order};
use std::f64::consts::PI;

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn segment_form_factors_of_a_convex_polygon_sum_to_one(
        n in 3usize..12, phase in 0.0f64..1.0, k in -3.0f64..3.0, c in (-5.0f64..5.0, -5.0f64..5.0),
        inside in (-0.5f64..0.5, -0.5f64..0.5), stretch in 0.2f64..5.0
    ) {
        let s = 10f64.powf(k);
        let center = DVec2::new(c.0, c.1);
        let verts: Vec<DVec2> = (0..n).map(|i| {
            let t = 2.0 * PI * (i as f64 + phase) / n as f64;
            (center + DVec2::new(t.cos() * stretch, t.sin())) * s
        }).collect();
        // The polygon inscribed in the unit circle contains the disc of radius cos(π/n) ≥ 0.5, and
        // |inside| · 0.6 ≤ 0.43: the (affinely stretched) polygon contains this point.
        let x = (center + DVec2::new(inside.0 * stretch, inside.1) * 0.6) * s;
        let mut value = 0.0;
        let mut grad = DVec2::ZERO;
        let mut hess = glam::DMat2::ZERO;
        let mut gscale = 0.0f64;
        let mut hscale = 0.0f64;
        for i in 0..n {
            let d = kernels::segment_form_factor_2d(x, verts[i], verts[(i + 1) % n], Order::Hessian)
                .unwrap();
            prop_assert_eq!(d.hessian, d.hessian.transpose());
            value += d.value;
            grad += d.gradient;
            hess += d.hessian;
            gscale = gscale.max(d.gradient.abs().max_element());
            hscale = hscale.max(d.hessian.to_cols_array().iter().fold(0.0f64, |m, v| m.max(v.abs())));
        }
        prop_assert!((value - 1.0).abs() <= 1e-13);
        prop_assert!(grad.abs().max_element() <= 1e-12 * gscale, "{:?}", grad);
        prop_assert!(hess.to_cols_array().iter().all(|v| v.abs() <= 1e-12 * hscale), "{:?}", hess);
    }

    #[test]
    fn segment_derivatives_match_finite_differences(
        x in (-3.0f64..3.0, -3.0f64..3.0), a in (-1.0f64..1.0, -1.0f64..1.0),
        b in (-1.0f64..1.0, -1.0f64..1.0), k in -3.0f64..3.0
    ) {
        let s = 10f64.powf(k);
        let (x, a, b) = (DVec2::new(x.0, x.1) * s, DVec2::new(a.0, a.1) * s, DVec2::new(b.0, b.1) * s);
        let len = (b - a).length();
        prop_assume!(len > 0.3 * s);
        let rho = ((x - a).perp_dot((b - a) / len)).abs().min((x - a).length()).min((x - b).length());
        prop_assume!(rho > 0.05 * s);
        let h = 1e-4 * rho;
        let d = kernels::segment_form_factor_2d(x, a, b, Order::Hessian).unwrap();
        let gs = d.gradient.abs().max_element();
        let hs = d.hessian.to_cols_array().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..2 {
            let mut e = DVec2::ZERO;
            e[i] = h;
            let p = kernels::segment_form_factor_2d(x + e, a, b, Order::Gradient).unwrap();
            let m = kernels::segment_form_factor_2d(x - e, a, b, Order::Gradient).unwrap();
            let g = (p.value - m.value) / (2.0 * h);
            prop_assert!((g - d.gradient[i]).abs() <= 1e-6 * gs);
            let col = (p.gradient - m.gradient) / (2.0 * h);
            prop_assert!((col - d.hessian.col(i)).abs().max_element() <= 1e-6 * hs);
        }
    }
}
