//! Accuracy of the homogeneous and marched transmittance (`transmittance`,
//! `transmittance_marched`) against 320-bit references, from tiny to huge optical depths.
//! `cargo test --release --test transmittance_accuracy -- --nocapture` prints the worst errors.

mod kernel_reference;

use glam::DVec3;
use kernel_reference::*;
use raddiff::{kernels, Order};

// ---------------------------------------------------------------------------------------------
// Transmittance.

#[test]
fn homogeneous_transmittance() {
    let mut hp = Hp::new();
    let mut rng = Rng(8);
    let mut generic = Worst::default();
    let mut extreme = Worst::default();
    for i in 0..2 * samples() {
        let l = rng.log_range(-3.0, 3.0);
        let y = rng.in_ball() * 5.0 * l;
        let x = y + rng.dir() * l * rng.range(0.1, 1.0);
        // Optical depths 1e-6..50 in the generic set; 50..700 and coordinates at 1e6 in the other.
        let tau = rng.log_range(-6.0, 1.7);
        let sigma = tau / (x - y).length();
        let (x, y, sigma, worst) = if i % 2 == 0 {
            (x, y, sigma, &mut generic)
        } else {
            let off = DVec3::new(1e6, 2e6, -1e6);
            let tau = rng.range(50.0, 700.0);
            let (x, y) = (x / l + off, y / l + off);
            (x, y, tau / (x - y).length(), &mut extreme)
        };
        let d = kernels::transmittance(x, y, sigma, Order::Hessian).unwrap();
        let yv = V3::from(&hp, y);
        let s = hp.f(sigma);
        let r = central3(&mut hp, x, 1e-25 * (x - y).length(), &mut |hp, xv| {
            let dist = xv.sub(hp, &yv).norm(hp);
            hp.exp(&hp.mul(&s, &dist).neg())
        });
        worst.add(
            rel(d.value, r.value),
            rel3(d.gradient, r.gradient),
            rel33(d.hessian, r.hessian),
        );
    }
    generic.check(
        "transmittance, tau 1e-6..50, 1e-3..1e3",
        GENERIC.0,
        GENERIC.1,
        GENERIC.2,
    );
    extreme.check(
        "transmittance, tau 50..700, coords 1e6",
        HARD.0,
        HARD.1,
        HARD.2,
    );
}

/// An analytic extinction field σ(p) = s0 + k·p + q|p − c|² (≥ 0 on the sampled region) and its
/// gradient, so that the marched kernel's ∇σ̄ can be checked against differentiating the whole
/// midpoint estimate (samples move with x) at 320 bits.
#[test]
fn marched_transmittance() {
    let mut hp = Hp::new();
    let mut rng = Rng(9);
    let mut worst = Worst::default();
    let mut no_gradient = Worst::default();
    for i in 0..2 * samples() {
        let l = rng.log_range(-2.0, 2.0);
        let y = rng.in_ball() * 3.0 * l;
        let x = y + rng.dir() * l * rng.range(0.2, 1.0);
        let n = 1 + (i % 7) * 3;
        let depth = rng.log_range(-3.0, 0.5); // typical σ·L
        let c = rng.in_ball() * l;
        let k = rng.dir() * depth / l / l * 0.5;
        let q = depth / l / l / l * rng.range(0.0, 0.5);
        let s0 = depth / l + k.length() * 5.0 * l;
        let sigma_at = |p: DVec3| s0 + k.dot(p) + q * (p - c).length_squared();
        let grad_at = |p: DVec3| k + (p - c) * (2.0 * q);
        let pts: Vec<DVec3> = (0..n)
            .map(|j| x + (y - x) * ((j as f64 + 0.5) / n as f64))
            .collect();
        let sig: Vec<f64> = pts.iter().map(|&p| sigma_at(p)).collect();
        let grad: Vec<DVec3> = pts.iter().map(|&p| grad_at(p)).collect();
        assert!(sig.iter().all(|&s| s >= 0.0));
        let d = kernels::transmittance_marched(x, y, &sig, Some(&grad), Order::Gradient).unwrap();
        let yv = V3::from(&hp, y);
        let (s0b, qb) = (hp.f(s0), hp.f(q));
        let kb = V3::from(&hp, k);
        let cb = V3::from(&hp, c);
        let r = central3(&mut hp, x, 1e-25 * l, &mut |hp, xv| {
            // τ(x) = |x − y| · (1/n) Σ σ(x + t_j (y − x)), everything at 320 bits.
            let diff = yv.sub(hp, xv);
            let mut sum = hp.f(0.0);
            for j in 0..n {
                let t = hp.f((j as f64 + 0.5) / n as f64);
                let p = V3([0, 1, 2].map(|m| hp.add(&xv.0[m], &hp.mul(&t, &diff.0[m]))));
                let pc = p.sub(hp, &cb);
                let s = hp.add(
                    &hp.add(&s0b, &kb.dot(hp, &p)),
                    &hp.mul(&qb, &pc.dot(hp, &pc)),
                );
                sum = hp.add(&sum, &s);
            }
            let mean = hp.div(&sum, &hp.f(n as f64));
            hp.exp(&hp.mul(&mean, &diff.norm(hp)).neg())
        });
        // Sampling σ in f64 rounds each sample: allow for that in the value (relative 1e-15·τ).
        worst.add(rel(d.value, r.value), rel3(d.gradient, r.gradient), 0.0);
        // Without gradients: equals the homogeneous kernel with σ = mean.
        let d0 = kernels::transmittance_marched(x, y, &sig, None, Order::Gradient).unwrap();
        let mean = sig.iter().sum::<f64>() / n as f64;
        let h = kernels::transmittance(x, y, mean, Order::Gradient).unwrap();
        no_gradient.add(rel(d0.value, h.value), rel3(d0.gradient, h.gradient), 0.0);
    }
    worst.check(
        "marched transmittance (∇σ̄ from samples)",
        GENERIC.0,
        GENERIC.1,
        GENERIC.2,
    );
    no_gradient.check(
        "marched, no gradient vs homogeneous(mean)",
        5e-15,
        5e-15,
        0.0,
    );
}
