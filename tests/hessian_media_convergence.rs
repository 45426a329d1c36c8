//! Flatland reproduction of Marco et al. 2018 Fig. 3: at a point in the penumbra of an occluder in
//! a homogeneous medium lit by an area (segment) light, the occlusion-aware gradient of the
//! single-scattered fluence converges to the reference (finite differences of a dense-angle
//! evaluation of the same marched integral) as the angular sample count grows.
//! Run with `--nocapture` to print the convergence table.

use std::f64::consts::TAU;

use glam::DVec2;
use raddiff::gather::hessian::media::{flatland_derivatives, MediaGather, MediaSteps};
use raddiff::Order;

const SIGMA_T: f64 = 0.3;
const SIGMA_S: f64 = 0.2;
const STEP: f64 = 0.05;
const STEPS: usize = 90;
const LIGHT: (DVec2, DVec2, f64) = (DVec2::new(-0.5, 2.0), DVec2::new(0.5, 2.0), 5.0);
const OCCLUDER: (DVec2, DVec2) = (DVec2::new(-0.2, 1.0), DVec2::new(0.6, 1.0));
const FLOOR: (DVec2, DVec2, f64) = (DVec2::new(-4.0, -1.0), DVec2::new(4.0, -1.0), 0.3);

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

fn trace(x: DVec2, w: DVec2) -> (f64, f64) {
    let mut best = (f64::INFINITY, 0.0);
    for (a, b, l) in [LIGHT, (OCCLUDER.0, OCCLUDER.1, 0.0), FLOOR] {
        if let Some(t) = seg_hit(x, w, a, b) {
            if t < best.0 {
                best = (t, l);
            }
        }
    }
    best
}

/// Single-scattered radiance σ_s/(2π) ∫_light L T V dθ at y (midpoint rule over the light).
fn in_scattered(y: DVec2) -> f64 {
    let (a, b, le) = LIGHT;
    let k = 24;
    let mut sum = 0.0;
    for i in 0..k {
        let z = a + (b - a) * ((i as f64 + 0.5) / k as f64);
        let d = z - y;
        let r = d.length();
        if d.y <= 0.0 {
            continue;
        }
        if seg_hit(y, d / r, OCCLUDER.0, OCCLUDER.1).is_some_and(|t| t < r) {
            continue;
        }
        let dtheta = d.y / (r * r) * (b - a).length() / k as f64;
        sum += le * (-SIGMA_T * r).exp() * dtheta;
    }
    SIGMA_S / TAU * sum
}

struct Flat {
    dirs: Vec<DVec2>,
    dist: Vec<f64>,
    rad: Vec<f32>,
    media: Vec<f32>,
}

fn gather(x: DVec2, n: usize) -> Flat {
    let mut f = Flat {
        dirs: vec![],
        dist: vec![],
        rad: vec![],
        media: vec![],
    };
    for k in 0..n {
        let phi = TAU * (k as f64 + 0.5) / n as f64;
        let w = DVec2::new(phi.cos(), phi.sin());
        let (d, l) = trace(x, w);
        f.dirs.push(w);
        f.dist.push(d);
        f.rad.push(l as f32);
        for s in 0..STEPS {
            let t = (s as f64 + 0.5) * STEP;
            f.media.push(if t < d {
                in_scattered(x + w * t) as f32
            } else {
                0.0
            });
        }
    }
    f
}

/// The marched fluence: media part with `n` directions, surface part (a step function of the
/// angle) with 200 `n` directions so that its differences are not quantized.
fn fluence(x: DVec2, n: usize) -> f64 {
    let mut media = 0.0;
    for k in 0..n {
        let phi = TAU * (k as f64 + 0.5) / n as f64;
        let w = DVec2::new(phi.cos(), phi.sin());
        let (d, _) = trace(x, w);
        for s in 0..STEPS {
            let t = (s as f64 + 0.5) * STEP;
            if t >= d {
                break;
            }
            media += STEP * (-SIGMA_T * t).exp() * in_scattered(x + w * t);
        }
    }
    let dense = 200 * n;
    let mut surface = 0.0;
    for k in 0..dense {
        let phi = TAU * (k as f64 + 0.5) / dense as f64;
        let (d, l) = trace(x, DVec2::new(phi.cos(), phi.sin()));
        if d.is_finite() {
            surface += (-SIGMA_T * d).exp() * l;
        }
    }
    media * TAU / n as f64 + surface * TAU / dense as f64
}

#[test]
fn occlusion_aware_media_gradient_converges_in_the_penumbra() {
    let x = DVec2::new(0.9, 0.2);
    // Reference: 4th-order differences of the dense-angle fluence.
    let dense = 1500;
    let h = 0.01;
    let d1 = |e: DVec2| {
        (8.0 * (fluence(x + e * h, dense) - fluence(x - e * h, dense))
            - (fluence(x + e * 2.0 * h, dense) - fluence(x - e * 2.0 * h, dense)))
            / (12.0 * h)
    };
    let reference = DVec2::new(d1(DVec2::X), d1(DVec2::Y));
    println!("reference value {:.4}", fluence(x, dense));
    let mut errors = Vec::new();
    for n in [32usize, 128, 512, 2048] {
        let f = gather(x, n);
        let g = MediaGather {
            directions: &f.dirs,
            distance: &f.dist,
            radiance: &f.rad,
            channels: 1,
            sigma_t: SIGMA_T,
            media: Some(MediaSteps {
                radiance: &f.media,
                steps: STEPS,
                step: STEP,
            }),
        };
        let d = flatland_derivatives(&g, Order::Hessian).unwrap().channels[0];
        let err = (d.gradient - reference).length() / reference.length();
        println!(
            "| {n:5} | {:.4} | ({:.4}, {:.4}) | ({:.4}, {:.4}) | {err:.2e} |",
            d.value, d.gradient.x, d.gradient.y, reference.x, reference.y
        );
        errors.push(err);
    }
    assert!(errors[3] < errors[0] / 3.0, "{errors:?}");
    assert!(errors[3] < 0.03, "{errors:?}");
}
