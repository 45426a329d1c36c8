//! Occlusion-aware surface gradients and Hessians from the triangulated gather: closure, shared-edge
//! bookkeeping, derivatives of the mesh function by finite differences, robustness, errors.

mod hessian_common;

use std::f64::consts::PI;

use glam::{DMat3, DVec2, DVec3};
use hessian_common::{Rect, SceneGather};
use raddiff::gather::hessian::{
    mesh_geometry, occlusion_derivatives, occlusion_derivatives_on,
    occlusion_derivatives_per_triangle, HemisphereGather, LayoutKind, MeshGeometry, Topology,
};
use raddiff::Order;

const KINDS: [LayoutKind; 2] = [LayoutKind::CosinePolar, LayoutKind::Concentric];

fn scene() -> Vec<Rect> {
    vec![
        Rect {
            min: DVec2::new(-0.5, -0.5),
            max: DVec2::new(0.5, 0.5),
            z: 2.0,
            radiance: 10.0,
        },
        Rect {
            min: DVec2::new(-1.0, -0.6),
            max: DVec2::new(-0.1, 0.6),
            z: 1.2,
            radiance: 0.3,
        },
        Rect {
            min: DVec2::new(0.15, -1.0),
            max: DVec2::new(0.8, 0.25),
            z: 0.5,
            radiance: 0.1,
        },
    ]
}

fn mat_err(a: DMat3, b: DMat3) -> f64 {
    (a - b)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()))
}

fn mat_norm(a: DMat3) -> f64 {
    a.to_cols_array().iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

#[test]
fn all_miss_hemisphere_closes_to_form_factor_one() {
    for kind in KINDS {
        for (m, n, seed) in [(4, 8, 0u64), (7, 6, 3), (16, 16, 9)] {
            let dirs = hessian_common::directions(kind, m, n, seed, DVec3::Z, DVec3::X);
            let dist = vec![f64::INFINITY; m * n];
            let rad = vec![2.0f32; m * n];
            let g = HemisphereGather {
                normal: DVec3::Z,
                directions: &dirs,
                distance: &dist,
                radiance: &rad,
                channels: 1,
                sigma_t: 0.0,
            };
            let topo = Topology::new(kind, m, n).unwrap();
            let d = occlusion_derivatives(&topo, &g, Order::Hessian).unwrap();
            assert!(
                (d.geometric.value - PI).abs() < 1e-12,
                "{kind:?} {m}x{n}: {}",
                d.geometric.value
            );
            assert!((d.irradiance[0] - 2.0 * PI).abs() < 1e-12);
            // The environment is at the far distance (1 L here, times 2^20): derivatives ~ 1e-6, 1e-12.
            assert!(d.gradient[0].length() < 1e-9);
            assert!(mat_norm(d.hessian[0]) < 1e-9);
            // Every triangle has a positive form factor: the per-triangle sum of |F| is also 1.
            let p = occlusion_derivatives_per_triangle(&topo, &g, Order::Gradient).unwrap();
            assert!((p.geometric.value - PI).abs() < 1e-12);
        }
    }
}

#[test]
fn closed_box_around_the_point_also_closes() {
    // Hits on a box of varied distances: the mesh still covers the hemisphere exactly once.
    for kind in KINDS {
        let rects = [Rect {
            min: DVec2::splat(-3.0),
            max: DVec2::splat(3.0),
            z: 0.7,
            radiance: 1.0,
        }];
        let sg = SceneGather::new(kind, 12, 12, 5, DVec3::new(0.2, -0.1, 0.0), &rects, 1.0);
        let topo = Topology::new(kind, 12, 12).unwrap();
        let d = occlusion_derivatives(&topo, &sg.gather(), Order::Gradient).unwrap();
        assert!((d.geometric.value - PI).abs() < 1e-13);
    }
}

#[test]
fn shared_edges_match_the_per_triangle_sum() {
    let rects = scene();
    for kind in KINDS {
        for (m, n, seed) in [(8, 24, 0u64), (16, 16, 7)] {
            let sg = SceneGather::new(kind, m, n, seed, DVec3::new(0.05, 0.1, 0.0), &rects, 0.5);
            let topo = Topology::new(kind, m, n).unwrap();
            let a = occlusion_derivatives(&topo, &sg.gather(), Order::Hessian).unwrap();
            let b =
                occlusion_derivatives_per_triangle(&topo, &sg.gather(), Order::Hessian).unwrap();
            let scale = mat_norm(a.hessian[0]).max(1.0);
            assert!(
                (a.irradiance[0] - b.irradiance[0]).abs() < 1e-9 * a.irradiance[0].abs().max(1.0)
            );
            assert!(
                (a.gradient[0] - b.gradient[0]).length() < 1e-9 * a.gradient[0].length().max(1.0)
            );
            assert!(mat_err(a.hessian[0], b.hessian[0]) < 1e-9 * scale);
            assert!((a.geometric.value - b.geometric.value).abs() < 1e-9);
        }
    }
}

fn shifted(mesh: &MeshGeometry, delta: DVec3) -> MeshGeometry {
    let mut m = mesh.clone();
    for p in &mut m.positions {
        *p -= delta;
    }
    m
}

/// Checks gradient and Hessian of the mesh function E(x) = π Σ L_Δ F_Δ(x) (mesh fixed) by
/// fourth-order (Richardson) central differences of its value and gradient with step `h`.
fn check_mesh_derivatives(topo: &Topology, g: &HemisphereGather, h: f64, tol: f64) {
    let mesh = mesh_geometry(topo, g).unwrap();
    let at = |delta: DVec3| {
        occlusion_derivatives_on(topo, &shifted(&mesh, delta), g, Order::Gradient).unwrap()
    };
    let d = occlusion_derivatives_on(topo, &mesh, g, Order::Hessian).unwrap();
    let gscale = d.gradient[0].length().max(1e-3);
    let hscale = mat_norm(d.hessian[0]).max(1e-3);
    for axis in 0..3 {
        let e = DVec3::AXES[axis] * h;
        let (p1, m1, p2, m2) = (at(e), at(-e), at(2.0 * e), at(-2.0 * e));
        for c in 0..g.channels {
            let fd_grad = (8.0 * (p1.irradiance[c] - m1.irradiance[c])
                - (p2.irradiance[c] - m2.irradiance[c]))
                / (12.0 * h);
            let got = d.gradient[c][axis];
            assert!(
                (fd_grad - got).abs() < tol * gscale,
                "grad axis {axis}: fd {fd_grad} vs {got}"
            );
            let fd_col = ((p1.gradient[c] - m1.gradient[c]) * 8.0
                - (p2.gradient[c] - m2.gradient[c]))
                / (12.0 * h);
            let col = d.hessian[c].col(axis);
            assert!(
                (fd_col - col).abs().max_element() < tol * hscale,
                "hess col {axis}: fd {fd_col} vs {col}"
            );
        }
        let fd_geo = (8.0 * (p1.geometric.value - m1.geometric.value)
            - (p2.geometric.value - m2.geometric.value))
            / (12.0 * h);
        let geo_scale = d.geometric.gradient.length().max(1.0);
        assert!((fd_geo - d.geometric.gradient[axis]).abs() < tol * geo_scale);
    }
}

#[test]
fn mesh_derivatives_match_finite_differences() {
    let rects = scene();
    for kind in KINDS {
        for x in [
            DVec3::new(0.05, 0.1, 0.0),
            DVec3::new(-0.4, 0.3, 0.0),
            DVec3::new(0.6, -0.2, 0.0),
        ] {
            let sg = SceneGather::new(kind, 8, 16, 11, x, &rects, 0.5);
            let topo = Topology::new(kind, 8, 16).unwrap();
            check_mesh_derivatives(&topo, &sg.gather(), 1e-3, 1e-7);
        }
    }
}

#[test]
fn medium_derivatives_match_finite_differences() {
    let rects = scene();
    for kind in KINDS {
        let sg = SceneGather::new(kind, 8, 16, 2, DVec3::new(0.1, 0.2, 0.0), &rects, 0.5);
        let mut g = sg.gather();
        g.sigma_t = 0.7;
        let topo = Topology::new(kind, 8, 16).unwrap();
        check_mesh_derivatives(&topo, &g, 1e-3, 1e-7);
        // sigma_t -> 0 approaches the surface path (misses excepted: they are attenuated away).
        let rects_closed = [Rect {
            min: DVec2::splat(-50.0),
            max: DVec2::splat(50.0),
            z: 3.0,
            radiance: 0.2,
        }];
        let mut all = rects.clone();
        all.extend_from_slice(&rects_closed);
        // Black environment: misses contribute nothing in either case.
        let sg = SceneGather::new(kind, 8, 16, 2, DVec3::new(0.1, 0.2, 0.0), &all, 0.0);
        let mut g = sg.gather();
        let clear = occlusion_derivatives(&topo, &g, Order::Hessian).unwrap();
        g.sigma_t = 1e-9;
        let thin = occlusion_derivatives(&topo, &g, Order::Hessian).unwrap();
        assert!((clear.irradiance[0] - thin.irradiance[0]).abs() < 1e-6 * clear.irradiance[0]);
        assert!(mat_err(clear.hessian[0], thin.hessian[0]) < 1e-6 * mat_norm(clear.hessian[0]));
    }
}

#[test]
fn robust_hessian_adds_one_percent_and_falls_back_when_black() {
    let rects = scene();
    for kind in KINDS {
        let sg = SceneGather::new(kind, 8, 16, 4, DVec3::new(0.05, 0.1, 0.0), &rects, 0.5);
        let topo = Topology::new(kind, 8, 16).unwrap();
        let d = occlusion_derivatives(&topo, &sg.gather(), Order::Hessian).unwrap();
        // Adding 1% of E to every sample radiance adds it to every triangle (and the pole).
        let shift = (0.01 * d.irradiance[0]) as f32;
        let bumped: Vec<f32> = sg.radiance.iter().map(|l| l + shift).collect();
        let mut g = sg.gather();
        g.radiance = &bumped;
        let e = occlusion_derivatives(&topo, &g, Order::Hessian).unwrap();
        let robust = d.robust_hessian(0);
        assert!(mat_err(robust, e.hessian[0]) < 1e-5 * mat_norm(e.hessian[0]));
        // All black: the geometric Hessian.
        let black = vec![0.0f32; sg.radiance.len()];
        g.radiance = &black;
        let z = occlusion_derivatives(&topo, &g, Order::Hessian).unwrap();
        assert!(z.all_black[0]);
        assert_eq!(z.hessian[0], DMat3::ZERO);
        assert_eq!(z.robust_hessian(0), z.geometric.hessian);
        assert!(mat_norm(z.geometric.hessian) > 0.0);
    }
}

#[test]
fn channels_are_independent() {
    let rects = scene();
    let sg = SceneGather::new(
        LayoutKind::Concentric,
        8,
        8,
        1,
        DVec3::new(0.05, 0.1, 0.0),
        &rects,
        0.5,
    );
    let topo = Topology::new(LayoutKind::Concentric, 8, 8).unwrap();
    let single = occlusion_derivatives(&topo, &sg.gather(), Order::Hessian).unwrap();
    let rgb: Vec<f32> = sg
        .radiance
        .iter()
        .flat_map(|&l| [l, 2.0 * l, 0.0])
        .collect();
    let mut g = sg.gather();
    g.radiance = &rgb;
    g.channels = 3;
    let d = occlusion_derivatives(&topo, &g, Order::Hessian).unwrap();
    assert!((d.irradiance[0] - single.irradiance[0]).abs() < 1e-12 * single.irradiance[0]);
    assert!((d.irradiance[1] - 2.0 * single.irradiance[0]).abs() < 1e-12 * single.irradiance[0]);
    assert_eq!(d.hessian[2], DMat3::ZERO);
    assert!(d.all_black[2] && !d.all_black[0]);
    assert!(mat_err(d.hessian[1], single.hessian[0] * 2.0) < 1e-12 * mat_norm(single.hessian[0]));
}

#[test]
fn gradient_order_skips_the_hessian_and_value_order_is_rejected() {
    let rects = scene();
    let sg = SceneGather::new(LayoutKind::CosinePolar, 4, 8, 0, DVec3::ZERO, &rects, 0.5);
    let topo = Topology::new(LayoutKind::CosinePolar, 4, 8).unwrap();
    let d = occlusion_derivatives(&topo, &sg.gather(), Order::Gradient).unwrap();
    assert_eq!(d.hessian[0], DMat3::ZERO);
    assert!(d.gradient[0].length() > 0.0);
    assert!(occlusion_derivatives(&topo, &sg.gather(), Order::Value).is_err());
}

#[test]
fn invalid_gathers_are_rejected() {
    let rects = scene();
    let sg = SceneGather::new(LayoutKind::CosinePolar, 4, 8, 0, DVec3::ZERO, &rects, 0.5);
    let topo = Topology::new(LayoutKind::CosinePolar, 4, 8).unwrap();
    let mut g = sg.gather();
    g.channels = 2;
    assert!(occlusion_derivatives(&topo, &g, Order::Gradient).is_err());
    let mut g = sg.gather();
    g.normal = DVec3::new(0.0, 0.0, 1.5);
    assert!(occlusion_derivatives(&topo, &g, Order::Gradient).is_err());
    let mut g = sg.gather();
    g.sigma_t = -1.0;
    assert!(occlusion_derivatives(&topo, &g, Order::Gradient).is_err());
    let mut bad = sg.distance.clone();
    bad[3] = 0.0;
    let mut g = sg.gather();
    g.distance = &bad;
    assert!(occlusion_derivatives(&topo, &g, Order::Gradient).is_err());
    let mut nan = sg.distance.clone();
    nan[3] = f64::NAN;
    g.distance = &nan;
    assert!(occlusion_derivatives(&topo, &g, Order::Gradient).is_err());
    let mut rad = sg.radiance.clone();
    rad[1] = f32::NAN;
    let mut g = sg.gather();
    g.radiance = &rad;
    assert!(occlusion_derivatives(&topo, &g, Order::Gradient).is_err());
    let small = Topology::new(LayoutKind::CosinePolar, 4, 6).unwrap();
    assert!(occlusion_derivatives(&small, &sg.gather(), Order::Gradient).is_err());
}

#[test]
fn fill_from_gather_writes_row_major_per_channel() {
    use raddiff::ffi::fill_from_gather;
    use raddiff::gather::hessian::occlusion_outputs;
    use raddiff::gather::{Frame, GatherInput, Layout, ValidGather};
    let rects = scene();
    let x = DVec3::new(0.05, 0.1, 0.0);
    let sg = SceneGather::new(LayoutKind::Concentric, 8, 8, 0, x, &rects, 0.5);
    let rgb: Vec<f32> = sg.radiance.iter().flat_map(|&l| [l, 0.5 * l]).collect();
    let layout = Layout::new(LayoutKind::Concentric, 8, 8, 0).unwrap();
    let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
    let input = GatherInput {
        directions: &sg.directions,
        distance: &sg.distance,
        radiance: &rgb,
        channels: 2,
        sigma_t: 0.0,
        media: None,
    };
    let valid = ValidGather::new(&layout, &frame, &input).unwrap();
    let (g, h) = occlusion_outputs(&valid, true).unwrap();
    let mut og = [0.0; 6];
    let mut hess = [0.0; 18];
    fill_from_gather(&valid, Some(&mut og), Some(&mut hess)).unwrap();
    for c in 0..2 {
        assert_eq!(&og[3 * c..3 * c + 3], &g[c].to_array());
        for row in 0..3 {
            for col in 0..3 {
                assert_eq!(hess[9 * c + 3 * row + col], h[c].col(col)[row]);
            }
        }
    }
    assert!((h[1] * 2.0 - h[0])
        .to_cols_array()
        .iter()
        .all(|v| v.abs() < 1e-12 * mat_norm(h[0])));
    let mut short = [7.0; 5];
    assert!(fill_from_gather(&valid, Some(&mut short), None).is_err());
    assert_eq!(short, [7.0; 5]);
    fill_from_gather(&valid, None, None).unwrap();
}
