//! Property tests (proptest) of the homogeneous and marched transmittance: gradient and Hessian
//! equal to finite differences, the marched gradient that of resampled values.

use glam::DVec3;
use proptest::prelude::*;
use raddiff::{kernels, Deriv3, Order};

fn vec3(range: f64) -> impl Strategy<Value = DVec3> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

fn scale_of(d: &Deriv3) -> (f64, f64) {
    let g = d.gradient.abs().max_element();
    let h = d
        .hessian
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    (g, h)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn transmittance_derivatives_match_finite_differences(
        x in vec3(2.0), y in vec3(2.0), sigma in 0.0f64..3.0, k in -3.0f64..3.0
    ) {
        let s = 10f64.powf(k);
        let (x, y, sigma) = (x * s, y * s, sigma / s);
        let dist = (x - y).length();
        prop_assume!(dist > 0.05 * s);
        let d = kernels::transmittance(x, y, sigma, Order::Hessian).unwrap();
        prop_assert_eq!(d.hessian, d.hessian.transpose());
        let (gs, hs) = scale_of(&d);
        let h = 1e-4 * dist;
        for i in 0..3 {
            let mut e = DVec3::ZERO;
            e[i] = h;
            let p = kernels::transmittance(x + e, y, sigma, Order::Gradient).unwrap();
            let m = kernels::transmittance(x - e, y, sigma, Order::Gradient).unwrap();
            prop_assert!(((p.value - m.value) / (2.0 * h) - d.gradient[i]).abs() <= 1e-6 * gs + 1e-300);
            let col = (p.gradient - m.gradient) / (2.0 * h);
            prop_assert!((col - d.hessian.col(i)).abs().max_element() <= 1e-6 * hs + 1e-300);
        }
        // Rigid motion: T depends on the distance only.
        let e = kernels::transmittance(x + DVec3::splat(s), y + DVec3::splat(s), sigma, Order::Value)
            .unwrap();
        prop_assert!((e.value - d.value).abs() <= 1e-13);
    }

    #[test]
    fn marched_gradient_matches_finite_differences_of_resampled_values(
        x in vec3(2.0), y in vec3(2.0), n in 1usize..16, s0 in 0.5f64..2.0, kv in vec3(0.2)
    ) {
        prop_assume!((x - y).length() > 0.1);
        // Linear field σ(p) = s0 + kv·p (kept ≥ 0 on the sampled region), resampled at each x.
        let sample = |x: DVec3| -> (Vec<f64>, Vec<DVec3>) {
            (0..n).map(|j| {
                let p = x + (y - x) * ((j as f64 + 0.5) / n as f64);
                (s0 + kv.dot(p), kv)
            }).unzip()
        };
        let (sig, grad) = sample(x);
        prop_assume!(sig.iter().all(|&s| s >= 0.0));
        let d = kernels::transmittance_marched(x, y, &sig, Some(&grad), Order::Gradient).unwrap();
        let h = 1e-5;
        for i in 0..3 {
            let mut e = DVec3::ZERO;
            e[i] = h;
            let (sp, _) = sample(x + e);
            let (sm, _) = sample(x - e);
            let p = kernels::transmittance_marched(x + e, y, &sp, None, Order::Value).unwrap();
            let m = kernels::transmittance_marched(x - e, y, &sm, None, Order::Value).unwrap();
            let g = (p.value - m.value) / (2.0 * h);
            prop_assert!((g - d.gradient[i]).abs() <= 1e-7 * d.gradient.abs().max_element().max(1e-3),
                "{i}: {g} vs {}", d.gradient[i]);
        }
    }
}
