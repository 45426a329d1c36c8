//! Occlusion-aware media derivatives (Marco et al. 2018 sec. 4): ring closure, zero-radiance
//! occluded vertices, product rules against finite differences of the ring mesh, in 3D and flatland.

mod hessian_common;

use std::f64::consts::{PI, TAU};

use glam::{DVec2, DVec3};
use raddiff::gather::hessian::media::{
    flatland_derivatives, flatland_derivatives_from, media_derivatives, media_derivatives_from,
    MediaGather, MediaSteps,
};
use raddiff::gather::hessian::{LayoutKind, Topology};
use raddiff::Order;

struct Sphere3 {
    dirs: Vec<DVec3>,
    dist: Vec<f64>,
    rad: Vec<f32>,
    media: Vec<f32>,
    steps: usize,
}

/// A sphere gather at the origin inside a box-like room: walls at varied distances, a small
/// occluding plate, and a media radiance field that varies in space.
fn room(m: usize, n: usize, steps: usize, step: f64) -> Sphere3 {
    let dirs = hessian_common::directions(LayoutKind::Sphere, m, n, 3, DVec3::Z, DVec3::X);
    let mut dist = Vec::new();
    let mut rad = Vec::new();
    let mut media = Vec::new();
    for w in &dirs {
        // Room [-2, 2.5] x [-1.5, 3] x [-1, 2]; plate z = 0.6 over [0, 0.8] x [-0.3, 0.5].
        let mut d = f64::INFINITY;
        let mut l = 0.0f32;
        for (axis, lo, hi) in [(0usize, -2.0, 2.5), (1, -1.5, 3.0), (2, -1.0, 2.0)] {
            let c = w[axis];
            let t = if c > 0.0 {
                hi / c
            } else if c < 0.0 {
                lo / c
            } else {
                f64::INFINITY
            };
            if t < d {
                d = t;
                l = 0.5 + 0.2 * axis as f32;
            }
        }
        if w.z > 0.0 {
            let t = 0.6 / w.z;
            let p = *w * t;
            if t < d && p.x >= 0.0 && p.x <= 0.8 && p.y >= -0.3 && p.y <= 0.5 {
                d = t;
                l = 0.05;
            }
        }
        dist.push(d);
        rad.push(l);
        for s in 0..steps {
            let y = *w * ((s as f64 + 0.5) * step);
            media.push((0.3 + 0.1 * y.x + 0.05 * y.z * y.z) as f32);
        }
    }
    Sphere3 {
        dirs,
        dist,
        rad,
        media,
        steps,
    }
}

#[test]
fn closed_rings_sum_to_the_full_sphere() {
    let (m, n) = (8, 16);
    let topo = Topology::new(LayoutKind::Sphere, m, n).unwrap();
    let dirs = hessian_common::directions(LayoutKind::Sphere, m, n, 0, DVec3::Z, DVec3::X);
    let dist = vec![f64::INFINITY; m * n];
    let rad = vec![1.0f32; m * n];
    let steps = 5;
    let media = vec![2.0f32; m * n * steps];
    let g = MediaGather {
        directions: &dirs,
        distance: &dist,
        radiance: &rad,
        channels: 1,
        sigma_t: 0.0,
        media: Some(MediaSteps {
            radiance: &media,
            steps,
            step: 0.1,
        }),
    };
    let d = media_derivatives(&topo, &g, Order::Hessian).unwrap();
    // Environment ring 4π·1, five marched rings 4π·2·0.1 each.
    let expect = 4.0 * PI * (1.0 + 5.0 * 2.0 * 0.1);
    assert!(
        (d.channels[0].value - expect).abs() < 1e-12 * expect,
        "{}",
        d.channels[0].value
    );
    // The room: the surface ring is still closed.
    let r = room(m, n, 0, 0.1);
    let ones = vec![1.0f32; m * n];
    let g = MediaGather {
        directions: &r.dirs,
        distance: &r.dist,
        radiance: &ones,
        channels: 1,
        sigma_t: 0.0,
        media: None,
    };
    let d = media_derivatives(&topo, &g, Order::Gradient).unwrap();
    assert!(
        (d.channels[0].value - 4.0 * PI).abs() < 1e-11,
        "{}",
        d.channels[0].value - 4.0 * PI
    );
}

fn fd_check_3d(topo: &Topology, g: &MediaGather<DVec3>, h: f64, tol: f64) {
    let d = media_derivatives(topo, g, Order::Hessian).unwrap().channels[0];
    let at = |o: DVec3| {
        media_derivatives_from(topo, g, Order::Gradient, o)
            .unwrap()
            .channels[0]
    };
    let gs = d.gradient.length().max(1e-3);
    let hs = d
        .hessian
        .to_cols_array()
        .iter()
        .fold(1e-3f64, |a, v| a.max(v.abs()));
    for i in 0..3 {
        let e = DVec3::AXES[i] * h;
        let (p1, m1, p2, m2) = (at(e), at(-e), at(2.0 * e), at(-2.0 * e));
        let fd = (8.0 * (p1.value - m1.value) - (p2.value - m2.value)) / (12.0 * h);
        assert!(
            (fd - d.gradient[i]).abs() < tol * gs,
            "grad {i}: {fd} vs {}",
            d.gradient[i]
        );
        let col = ((p1.gradient - m1.gradient) * 8.0 - (p2.gradient - m2.gradient)) / (12.0 * h);
        assert!(
            (col - d.hessian.col(i)).abs().max_element() < tol * hs,
            "hess {i}: {col} vs {}",
            d.hessian.col(i)
        );
    }
}

#[test]
fn media_derivatives_match_finite_differences() {
    let (m, n, steps, step) = (8, 16, 12, 0.2);
    let topo = Topology::new(LayoutKind::Sphere, m, n).unwrap();
    let r = room(m, n, steps, step);
    for sigma in [0.0, 0.4] {
        let g = MediaGather {
            directions: &r.dirs,
            distance: &r.dist,
            radiance: &r.rad,
            channels: 1,
            sigma_t: sigma,
            media: Some(MediaSteps {
                radiance: &r.media,
                steps: r.steps,
                step,
            }),
        };
        fd_check_3d(&topo, &g, 1e-3, 1e-6);
    }
}

#[test]
fn occluded_ring_vertices_carry_no_radiance() {
    // A wall at distance 0.36 in every direction: rings beyond it are entirely occluded, so marching
    // further adds nothing.
    let (m, n) = (6, 12);
    let topo = Topology::new(LayoutKind::Sphere, m, n).unwrap();
    let dirs = hessian_common::directions(LayoutKind::Sphere, m, n, 0, DVec3::Z, DVec3::X);
    let dist = vec![0.36; m * n];
    let rad = vec![0.0f32; m * n];
    let eval = |steps: usize| {
        let media = vec![1.0f32; m * n * steps];
        let g = MediaGather {
            directions: &dirs,
            distance: &dist,
            radiance: &rad,
            channels: 1,
            sigma_t: 0.0,
            media: Some(MediaSteps {
                radiance: &media,
                steps,
                step: 0.1,
            }),
        };
        media_derivatives(&topo, &g, Order::Gradient)
            .unwrap()
            .channels[0]
            .value
    };
    assert!((eval(4) - eval(40)).abs() < 1e-12);
    assert!(
        (eval(4) - 4.0 * PI * 0.1 * 4.0).abs() < 1e-11,
        "{}",
        eval(4)
    );
    assert!((eval(2) - 4.0 * PI * 0.1 * 2.0).abs() < 1e-11);
}

/// Flatland: directions around the circle, a room with an occluder, media radiance varying in space.
fn flat_room(
    n: usize,
    steps: usize,
    step: f64,
    x: DVec2,
) -> (Vec<DVec2>, Vec<f64>, Vec<f32>, Vec<f32>) {
    let mut dirs = Vec::new();
    let mut dist = Vec::new();
    let mut rad = Vec::new();
    let mut media = Vec::new();
    for k in 0..n {
        let phi = TAU * (k as f64 + 0.37) / n as f64;
        let w = DVec2::new(phi.cos(), phi.sin());
        let (d, l) = flat_trace(x, w);
        dirs.push(w);
        dist.push(d);
        rad.push(l);
        for s in 0..steps {
            let y = x + w * ((s as f64 + 0.5) * step);
            media.push(flat_media(y) as f32);
        }
    }
    (dirs, dist, rad, media)
}

fn seg_hit(x: DVec2, w: DVec2, a: DVec2, b: DVec2) -> Option<f64> {
    let e = b - a;
    let den = w.perp_dot(e);
    if den.abs() < 1e-300 {
        return None;
    }
    let t = (a - x).perp_dot(e) / den;
    let u = (a - x).perp_dot(w) / den;
    (t > 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
}

/// Light segment at y = 2 (radiance 5), black occluder at y = 1, grey floor at y = -1.
fn flat_trace(x: DVec2, w: DVec2) -> (f64, f32) {
    let mut best = (f64::INFINITY, 0.0f32);
    for (a, b, l) in [
        (DVec2::new(-0.5, 2.0), DVec2::new(0.5, 2.0), 5.0f32),
        (DVec2::new(-0.2, 1.0), DVec2::new(0.6, 1.0), 0.0),
        (DVec2::new(-3.0, -1.0), DVec2::new(3.0, -1.0), 0.3),
    ] {
        if let Some(t) = seg_hit(x, w, a, b) {
            if t < best.0 {
                best = (t, l);
            }
        }
    }
    best
}

fn flat_media(y: DVec2) -> f64 {
    0.2 + 0.05 * y.y + 0.02 * y.x * y.x
}

#[test]
fn flatland_rings_close_and_match_finite_differences() {
    let n = 48;
    let (dirs, dist, rad, media) = flat_room(n, 10, 0.15, DVec2::new(0.1, 0.2));
    let ones = vec![1.0f32; n];
    let g = MediaGather {
        directions: &dirs,
        distance: &dist,
        radiance: &ones,
        channels: 1,
        sigma_t: 0.0,
        media: None,
    };
    let d = flatland_derivatives(&g, Order::Gradient).unwrap().channels[0];
    assert!((d.value - TAU).abs() < 1e-12, "{}", d.value);
    for sigma in [0.0, 0.5] {
        let g = MediaGather {
            directions: &dirs,
            distance: &dist,
            radiance: &rad,
            channels: 1,
            sigma_t: sigma,
            media: Some(MediaSteps {
                radiance: &media,
                steps: 10,
                step: 0.15,
            }),
        };
        let d = flatland_derivatives(&g, Order::Hessian).unwrap().channels[0];
        let at = |o: DVec2| {
            flatland_derivatives_from(&g, Order::Gradient, o)
                .unwrap()
                .channels[0]
        };
        let h = 1e-3;
        let hs = d
            .hessian
            .to_cols_array()
            .iter()
            .fold(1e-3f64, |a, v| a.max(v.abs()));
        for i in 0..2 {
            let e = if i == 0 { DVec2::X * h } else { DVec2::Y * h };
            let (p1, m1, p2, m2) = (at(e), at(-e), at(2.0 * e), at(-2.0 * e));
            let fd = (8.0 * (p1.value - m1.value) - (p2.value - m2.value)) / (12.0 * h);
            assert!((fd - d.gradient[i]).abs() < 1e-6 * d.gradient.length().max(1e-3));
            let col =
                ((p1.gradient - m1.gradient) * 8.0 - (p2.gradient - m2.gradient)) / (12.0 * h);
            assert!((col - d.hessian.col(i)).abs().max_element() < 1e-6 * hs);
        }
    }
}

#[test]
fn invalid_media_gathers_are_rejected() {
    let (dirs, dist, rad, media) = flat_room(16, 4, 0.1, DVec2::ZERO);
    let base = MediaGather {
        directions: &dirs,
        distance: &dist,
        radiance: &rad,
        channels: 1,
        sigma_t: 0.1,
        media: Some(MediaSteps {
            radiance: &media,
            steps: 4,
            step: 0.1,
        }),
    };
    assert!(flatland_derivatives(&base, Order::Gradient).is_ok());
    assert!(flatland_derivatives(&base, Order::Value).is_err());
    let mut g = base;
    g.sigma_t = f64::NAN;
    assert!(flatland_derivatives(&g, Order::Gradient).is_err());
    let mut g = base;
    g.media = Some(MediaSteps {
        radiance: &media,
        steps: 5,
        step: 0.1,
    });
    assert!(flatland_derivatives(&g, Order::Gradient).is_err());
    let mut g = base;
    g.media = Some(MediaSteps {
        radiance: &media,
        steps: 4,
        step: 0.0,
    });
    assert!(flatland_derivatives(&g, Order::Gradient).is_err());
    let topo = Topology::new(LayoutKind::CosinePolar, 4, 8).unwrap();
    let d3 = vec![DVec3::Z; 16];
    let g3 = MediaGather {
        directions: &d3,
        distance: &dist,
        radiance: &rad,
        channels: 1,
        sigma_t: 0.0,
        media: None,
    };
    assert!(media_derivatives(&topo, &g3, Order::Gradient).is_err());
}
