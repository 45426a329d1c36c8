//! Property tests of the triangulated gather: for any layout size, jitter seed and hit distances,
//! the unit-radiance mesh covers the hemisphere exactly once (irradiance π), shared-edge and
//! per-triangle sums agree, and a uniform radiance has no tangential derivatives.

mod hessian_common;

use std::f64::consts::PI;

use glam::DVec3;
use proptest::prelude::*;
use raddiff::gather::hessian::{
    occlusion_derivatives, occlusion_derivatives_per_triangle, HemisphereGather, LayoutKind,
    Topology,
};
use raddiff::Order;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn any_gather_closes_and_bookkeeping_agrees(
        polar in any::<bool>(),
        m in 3usize..12,
        n in 6usize..16,
        seed in 0u64..1000,
        scale in -6i32..6,
        dist in prop::collection::vec(prop_oneof![0.1f64..10.0, Just(f64::INFINITY)], 192),
        rad in prop::collection::vec(0.0f32..4.0, 192),
    ) {
        let kind = if polar { LayoutKind::CosinePolar } else { LayoutKind::Concentric };
        let dirs = hessian_common::directions(kind, m, n, seed, DVec3::Z, DVec3::X);
        let s = 10f64.powi(scale);
        let distance: Vec<f64> = dist[..m * n].iter().map(|d| d * s).collect();
        let topo = Topology::new(kind, m, n).unwrap();
        let g = HemisphereGather {
            normal: DVec3::Z,
            directions: &dirs,
            distance: &distance,
            radiance: &rad[..m * n],
            channels: 1,
            sigma_t: 0.0,
        };
        let a = occlusion_derivatives(&topo, &g, Order::Hessian).unwrap();
        prop_assert!((a.geometric.value - PI).abs() < 1e-12);
        let b = occlusion_derivatives_per_triangle(&topo, &g, Order::Hessian).unwrap();
        prop_assert!((a.irradiance[0] - b.irradiance[0]).abs() < 1e-12 * (1.0 + a.irradiance[0].abs()));
        let gs = a.gradient[0].length().max(b.gradient[0].length()).max(1e-300);
        prop_assert!((a.gradient[0] - b.gradient[0]).length() <= 1e-9 * gs + 1e-300);
        // Scaling the scene scales the derivatives exactly as 1/L and 1/L².
        let unit: Vec<f64> = dist[..m * n].to_vec();
        let g1 = HemisphereGather { distance: &unit, ..g };
        let c = occlusion_derivatives(&topo, &g1, Order::Hessian).unwrap();
        prop_assert!((c.gradient[0] / s - a.gradient[0]).length() <= 1e-9 * a.gradient[0].length() + 1e-300);
        let dh = (c.hessian[0] * (1.0 / (s * s)) - a.hessian[0]).to_cols_array().iter().fold(0.0f64, |x, v| x.max(v.abs()));
        let hs = a.hessian[0].to_cols_array().iter().fold(0.0f64, |x, v| x.max(v.abs()));
        prop_assert!(dh <= 1e-9 * hs + 1e-300);
        // Uniform radiance: only the horizon loop remains, flat along the tangent plane.
        let ones = vec![1.0f32; m * n];
        let u = occlusion_derivatives(&topo, &HemisphereGather { radiance: &ones, ..g }, Order::Hessian).unwrap();
        prop_assert!(u.gradient[0].x.abs() < 1e-9 / s && u.gradient[0].y.abs() < 1e-9 / s);
        prop_assert!(u.hessian[0].x_axis.x.abs() < 1e-8 / (s * s) && u.hessian[0].y_axis.y.abs() < 1e-8 / (s * s));
    }
}
