//! The batched edge evaluation of `occlusion_derivatives` against the reference (every edge through
//! the general closed-form kernel, `occlusion_derivatives_reference`, and in a medium the
//! per-triangle product rule): random and adversarial gathers (near-grazing directions, mixed near
//! hits and misses, tiny and huge scales, x close to mesh edges, with and without a medium),
//! several channels, both orders; and the reuse of one workspace across gathers of every shape.

mod hessian_common;

use glam::{DMat3, DVec3};
use hessian_common::{scene, SceneGather};
use proptest::prelude::*;
use raddiff::gather::hessian::{
    occlusion_derivatives, occlusion_derivatives_reference, occlusion_derivatives_with,
    HemisphereGather, LayoutKind, OcclusionDerivatives, OcclusionWorkspace, Topology,
};
use raddiff::{Deriv3, Order};

/// Largest relative difference of irradiance, gradient and Hessian per channel and of the geometric
/// terms, each relative to the reference's norm or, for quantities that cancel to (near) zero, to
/// the natural scale of the terms summed: `|E|/d`, `|E|/d²` with `d` the nearest hit.
fn difference(a: &OcclusionDerivatives, b: &OcclusionDerivatives, nearest: f64) -> f64 {
    fn norm(m: &DMat3) -> f64 {
        m.to_cols_array().iter().map(|v| v * v).sum::<f64>().sqrt()
    }
    fn one(a: &Deriv3, b: &Deriv3, nearest: f64) -> f64 {
        let v = b.value.abs();
        let dv = (a.value - b.value).abs() / v.max(1e-300);
        let gs = b.gradient.length().max(v / nearest);
        let dg = (a.gradient - b.gradient).length() / gs.max(1e-300);
        let hs = norm(&b.hessian).max(v / (nearest * nearest));
        let dh = norm(&(a.hessian - b.hessian)) / hs.max(1e-300);
        dv.max(dg).max(dh)
    }
    let mut worst = one(&a.geometric, &b.geometric, nearest);
    for c in 0..b.irradiance.len() {
        let d = |o: &OcclusionDerivatives| Deriv3 {
            value: o.irradiance[c],
            gradient: o.gradient[c],
            hessian: o.hessian[c],
        };
        worst = worst.max(one(&d(a), &d(b), nearest));
    }
    worst
}

fn compare(topo: &Topology, g: &HemisphereGather, order: Order) -> f64 {
    let fast = occlusion_derivatives(topo, g, order).unwrap();
    let reference = occlusion_derivatives_reference(topo, g, order).unwrap();
    assert_eq!(fast.all_black, reference.all_black);
    if !order.hessian() {
        assert!(fast.hessian.iter().all(|h| *h == DMat3::ZERO));
        assert_eq!(fast.geometric.hessian, DMat3::ZERO);
    }
    let nearest = g.distance.iter().fold(f64::INFINITY, |m, &d| m.min(d));
    let nearest = if nearest.is_finite() { nearest } else { 1.0 };
    difference(&fast, &reference, nearest)
}

const TOLERANCE: f64 = 1e-12;

#[test]
fn evaluation_scene_with_noisy_radiance_matches_the_reference() {
    let x = DVec3::new(-0.3, -0.2, 0.0);
    for (kind, m, n) in [
        (LayoutKind::CosinePolar, 32, 128),
        (LayoutKind::Concentric, 48, 48),
        (LayoutKind::CosinePolar, 8, 24),
    ] {
        let sg = SceneGather::new(kind, m, n, 3, x, &scene::rects(), 0.5);
        let noisy = hessian_common::noisy_radiance(&sg.radiance);
        let topo = Topology::new(kind, m, n).unwrap();
        for radiance in [&sg.radiance, &noisy] {
            let g = HemisphereGather {
                radiance,
                ..sg.gather()
            };
            for order in [Order::Gradient, Order::Hessian] {
                let d = compare(&topo, &g, order);
                assert!(d < TOLERANCE, "{kind:?} {m}x{n} {order:?}: {d:e}");
            }
        }
    }
}

#[test]
fn evaluation_scene_in_a_medium_matches_the_reference() {
    let x = DVec3::new(-0.3, -0.2, 0.0);
    for (kind, m, n) in [
        (LayoutKind::CosinePolar, 32, 128),
        (LayoutKind::Concentric, 48, 48),
        (LayoutKind::CosinePolar, 8, 24),
    ] {
        let sg = SceneGather::new(kind, m, n, 3, x, &scene::rects(), 0.5);
        let noisy = hessian_common::noisy_radiance(&sg.radiance);
        let topo = Topology::new(kind, m, n).unwrap();
        for radiance in [&sg.radiance, &noisy] {
            // From a thin medium to one that hides everything beyond ~0.01 (T underflows to 0 at
            // the far wall for the largest).
            for sigma_t in [1e-6, 0.5, 3.0, 1e5] {
                let g = HemisphereGather {
                    radiance,
                    sigma_t,
                    ..sg.gather()
                };
                for order in [Order::Gradient, Order::Hessian] {
                    let d = compare(&topo, &g, order);
                    assert!(
                        d < TOLERANCE,
                        "{kind:?} {m}x{n} σ {sigma_t} {order:?}: {d:e}"
                    );
                }
            }
        }
    }
}

/// One workspace reused across gathers of different layouts, sizes, channel counts, orders and
/// media gives exactly the per-thread workspace's results (which are checked against the
/// reference above).
#[test]
fn a_reused_workspace_gives_identical_results() {
    let x = DVec3::new(0.2, -0.2, 0.0);
    let mut ws = OcclusionWorkspace::new();
    for round in 0..2 {
        for (kind, m, n) in [
            (LayoutKind::CosinePolar, 16, 64),
            (LayoutKind::Concentric, 9, 9),
            (LayoutKind::CosinePolar, 32, 128),
            (LayoutKind::CosinePolar, 3, 6),
        ] {
            let sg = SceneGather::new(kind, m, n, round, x, &scene::rects(), 0.5);
            let topo = Topology::new(kind, m, n).unwrap();
            let rgb: Vec<f32> = sg
                .radiance
                .iter()
                .flat_map(|&l| [l, 0.5 * l, 0.0])
                .collect();
            for (radiance, channels) in [(&sg.radiance, 1), (&rgb, 3)] {
                for sigma_t in [0.0, 0.7] {
                    for order in [Order::Gradient, Order::Hessian] {
                        let g = HemisphereGather {
                            radiance,
                            channels,
                            sigma_t,
                            ..sg.gather()
                        };
                        let mine = occlusion_derivatives_with(&mut ws, &topo, &g, order).unwrap();
                        let fresh = occlusion_derivatives(&topo, &g, order).unwrap();
                        assert_eq!(mine, fresh, "{kind:?} {m}x{n} {channels} σ {sigma_t}");
                    }
                }
            }
        }
    }
    // An invalid gather leaves the workspace usable.
    let sg = SceneGather::new(LayoutKind::CosinePolar, 8, 24, 0, x, &scene::rects(), 0.5);
    let topo = Topology::new(LayoutKind::CosinePolar, 8, 24).unwrap();
    let mut bad = sg.distance.clone();
    bad[5] = -1.0;
    let g = HemisphereGather {
        distance: &bad,
        ..sg.gather()
    };
    assert!(occlusion_derivatives_with(&mut ws, &topo, &g, Order::Hessian).is_err());
    let g = sg.gather();
    assert_eq!(
        occlusion_derivatives_with(&mut ws, &topo, &g, Order::Hessian).unwrap(),
        occlusion_derivatives(&topo, &g, Order::Hessian).unwrap()
    );
}

/// Hit distance of sample `i` for a distance pattern: near hits, far hits, misses, and a plane
/// above x (grazing rays hit it very far away, so occlusion edges run nearly along the rays).
fn pattern_distance(kind: u8, w: DVec3, normal: DVec3, u: f64, s: f64) -> f64 {
    match kind % 5 {
        0 => s * (1e-3 + u),
        1 => s * (10.0 + 1e3 * u),
        2 => f64::INFINITY,
        3 => {
            let c = w.dot(normal);
            if c > 1e-9 {
                s * (0.5 + u) / c
            } else {
                f64::INFINITY
            }
        }
        _ => s * (1.0 + 1e-9 * u),
    }
}

/// Cases of the property test: 64 by default, `RADDIFF_HESSIAN_FAST_CASES` for a longer run.
fn cases() -> u32 {
    std::env::var("RADDIFF_HESSIAN_FAST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(64)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases()))]

    #[test]
    fn random_gathers_match_the_reference(
        polar in any::<bool>(),
        m in 3usize..14,
        n in 6usize..24,
        seed in 0u64..1000,
        theta in 0.0f64..std::f64::consts::PI,
        phi in 0.0f64..std::f64::consts::TAU,
        scale in -8i32..9,
        channels in 1usize..4,
        kinds in prop::collection::vec(0u8..5, 336),
        us in prop::collection::vec(0.0f64..1.0, 336),
        levels in prop::collection::vec(0u8..4, 336 * 3),
        hessian in any::<bool>(),
        medium in 0u8..3,
        sigma_scale in -3i32..4,
    ) {
        let kind = if polar { LayoutKind::CosinePolar } else { LayoutKind::Concentric };
        let normal = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
        let tangent = normal.any_orthonormal_vector();
        let dirs = hessian_common::directions(kind, m, n, seed, normal, tangent);
        let s = 10f64.powi(scale);
        let distance: Vec<f64> = (0..m * n)
            .map(|i| pattern_distance(kinds[i], dirs[i], normal, us[i], s))
            .collect();
        // Few distinct radiance levels: some edges are skipped, most are not.
        let radiance: Vec<f32> = (0..m * n * channels)
            .map(|i| levels[i] as f32 * 0.7 + (i % 3) as f32 * 0.01)
            .collect();
        let topo = Topology::new(kind, m, n).unwrap();
        let g = HemisphereGather {
            normal,
            directions: &dirs,
            distance: &distance,
            radiance: &radiance,
            channels,
            // A third of the cases in a medium (σ_t · distance from 1e-3 to 1e3).
            sigma_t: if medium == 0 { 10f64.powi(sigma_scale) / s } else { 0.0 },
        };
        let order = if hessian { Order::Hessian } else { Order::Gradient };
        let d = compare(&topo, &g, order);
        prop_assert!(d < TOLERANCE, "{d:e}");
    }
}
