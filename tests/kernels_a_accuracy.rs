//! Accuracy of the kernels-a kernels (triangle solid angle, flatland segment form factor,
//! homogeneous and marched transmittance) against independent 320-bit references: the value formula
//! evaluated in astro-float from the exact f64 inputs, derivatives by 320-bit central differences.
//!
//! Errors are relative, normalized by the largest entry of each output. Targets (issue 2): generic
//! inputs 1e-12 (value, gradient) and 1e-10 (Hessian); hard inputs 1e-10 / 1e-9 / 1e-8. Run with
//! `cargo test --release --test kernels_a_accuracy -- --nocapture` to print the worst errors.

mod kernels_a_ref;

use glam::{DVec2, DVec3};
use kernels_a_ref::*;
use raddiff::{kernels, Order};

const GENERIC: (f64, f64, f64) = (1e-12, 1e-12, 1e-10);
const HARD: (f64, f64, f64) = (1e-10, 1e-9, 1e-8);

fn samples() -> usize {
    std::env::var("RADDIFF_ACCURACY_SAMPLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200)
}

struct Tri {
    v: [DVec3; 3],
}

impl Tri {
    fn normal(&self) -> DVec3 {
        (self.v[1] - self.v[0])
            .cross(self.v[2] - self.v[0])
            .normalize()
    }
    fn centroid(&self) -> DVec3 {
        (self.v[0] + self.v[1] + self.v[2]) / 3.0
    }
    /// Lower bound on the distance from x to the solid angle's singular set (vertices, edges, and
    /// for the unsigned variant, the plane): the smaller of the vertex distances and the plane
    /// distance.
    fn rho(&self, x: DVec3) -> f64 {
        let h = (x - self.v[0]).dot(self.normal()).abs();
        self.v.iter().map(|v| (*v - x).length()).fold(h, f64::min)
    }
    fn size(&self) -> f64 {
        (self.v[1] - self.v[0])
            .length()
            .max((self.v[2] - self.v[0]).length())
    }
}

fn random_tri(rng: &mut Rng, center: DVec3, size: f64) -> Tri {
    loop {
        let v = [0, 1, 2].map(|_| center + rng.in_ball() * size);
        let t = Tri { v };
        let n = (v[1] - v[0]).cross(v[2] - v[0]).length();
        let l = t.size();
        if n > 0.2 * l * l {
            return t;
        }
    }
}

fn check_solid_angle(hp: &mut Hp, x: DVec3, t: &Tri, signed: bool, worst: &mut Worst) {
    let [a, b, c] = t.v;
    let d = if signed {
        kernels::triangle_solid_angle_signed(x, a, b, c, Order::Hessian)
    } else {
        kernels::triangle_solid_angle(x, a, b, c, Order::Hessian)
    }
    .unwrap_or_else(|e| panic!("{e} at x={x:?} tri={:?}", t.v));
    let tri = t.v.map(|v| V3::from(hp, v));
    let step = 1e-25 * t.rho(x);
    let r = central3(hp, x, step, &mut |hp, xv| {
        solid_angle_hp(hp, xv, &tri, signed)
    });
    let errs = (
        rel(d.value, r.value),
        rel3(d.gradient, r.gradient),
        rel33(d.hessian, r.hessian),
    );
    if errs.0 > 1e-10 || errs.1 > 1e-9 || errs.2 > 1e-8 {
        eprintln!(
            "large error {errs:?} at x={x:?} tri={:?}\n  got {d:?}\n  ref {} {:?} {:?}",
            t.v, r.value, r.gradient, r.hessian
        );
    }
    worst.add(errs.0, errs.1, errs.2);
}

/// A random point on the triangle's plane within ~2 sizes of the centroid, at least `margin·size`
/// away from the edges' lines.
fn plane_point(rng: &mut Rng, t: &Tri, margin: f64) -> DVec3 {
    let n = t.normal();
    let l = t.size();
    loop {
        let mut p = t.centroid() + rng.in_ball() * 2.0 * l;
        p -= n * (p - t.v[0]).dot(n);
        let ok = (0..3).all(|k| {
            let (a, b) = (t.v[k], t.v[(k + 1) % 3]);
            let e = (b - a).normalize();
            let w = p - a;
            (w - e * w.dot(e)).length() > margin * l
        });
        if ok {
            return p;
        }
    }
}

#[test]
fn solid_angle_generic_across_scales() {
    let mut hp = Hp::new();
    let mut rng = Rng(1);
    let mut worst = Worst::default();
    let mut worst_signed = Worst::default();
    for i in 0..samples() {
        let l = rng.log_range(-3.0, 3.0);
        let center = rng_point(&mut rng, 5.0 * l);
        let t = random_tri(&mut rng, center, l);
        let x = loop {
            let x = t.centroid() + rng.in_ball() * 3.0 * l;
            if t.rho(x) > 0.05 * l {
                break x;
            }
        };
        check_solid_angle(&mut hp, x, &t, false, &mut worst);
        if i % 2 == 0 {
            check_solid_angle(&mut hp, x, &t, true, &mut worst_signed);
        }
    }
    worst.check(
        "solid angle, generic 1e-3..1e3",
        GENERIC.0,
        GENERIC.1,
        GENERIC.2,
    );
    worst_signed.check(
        "signed solid angle, generic",
        GENERIC.0,
        GENERIC.1,
        GENERIC.2,
    );
}

fn rng_point(rng: &mut Rng, scale: f64) -> DVec3 {
    rng.in_ball() * scale
}

#[test]
fn solid_angle_far_away() {
    let mut hp = Hp::new();
    let mut rng = Rng(2);
    let mut worst = Worst::default();
    for _ in 0..samples() {
        let l = rng.log_range(-2.0, 2.0);
        let center = rng_point(&mut rng, l);
        let t = random_tri(&mut rng, center, l);
        let x = t.centroid() + rng.dir() * l * rng.log_range(3.0, 6.0);
        check_solid_angle(&mut hp, x, &t, false, &mut worst);
    }
    worst.check("solid angle, 1e3..1e6 sizes away", HARD.0, HARD.1, HARD.2);
}

#[test]
fn solid_angle_near_plane() {
    let mut hp = Hp::new();
    let mut rng = Rng(3);
    let mut worst = Worst::default();
    let mut worst_signed = Worst::default();
    for i in 0..samples() {
        let l = rng.log_range(-2.0, 2.0);
        let center = rng_point(&mut rng, l);
        let t = random_tri(&mut rng, center, l);
        let p = plane_point(&mut rng, &t, 1e-3);
        let side = if i % 2 == 0 { 1.0 } else { -1.0 };
        let x = p + t.normal() * side * l * rng.log_range(-12.0, -6.0);
        check_solid_angle(&mut hp, x, &t, false, &mut worst);
        check_solid_angle(&mut hp, x, &t, true, &mut worst_signed);
    }
    worst.check(
        "solid angle, 1e-12..1e-6 off the plane",
        HARD.0,
        HARD.1,
        HARD.2,
    );
    worst_signed.check("signed solid angle, near the plane", HARD.0, HARD.1, HARD.2);
}

#[test]
fn solid_angle_grazing_far_away() {
    let mut hp = Hp::new();
    let mut rng = Rng(4);
    let mut worst = Worst::default();
    for _ in 0..samples() {
        let l = rng.log_range(-2.0, 2.0);
        let center = rng_point(&mut rng, l);
        let t = random_tri(&mut rng, center, l);
        let n = t.normal();
        let inplane = {
            let d = rng.dir();
            (d - n * d.dot(n)).normalize()
        };
        let dist = l * rng.log_range(1.0, 6.0);
        let x = t.centroid() + inplane * dist + n * dist * rng.log_range(-9.0, -3.0);
        check_solid_angle(&mut hp, x, &t, false, &mut worst);
    }
    worst.check(
        "solid angle, grazing 1e1..1e6 sizes away",
        HARD.0,
        HARD.1,
        HARD.2,
    );
}

#[test]
fn solid_angle_near_vertices_and_edges() {
    let mut hp = Hp::new();
    let mut rng = Rng(5);
    let mut vertex = Worst::default();
    let mut edge = Worst::default();
    for i in 0..samples() {
        let l = rng.log_range(-2.0, 2.0);
        let center = rng_point(&mut rng, l);
        let t = random_tri(&mut rng, center, l);
        let k = i % 3;
        let x = t.v[k] + rng.dir() * l * rng.log_range(-9.0, -5.0);
        check_solid_angle(&mut hp, x, &t, false, &mut vertex);
        let (a, b) = (t.v[k], t.v[(k + 1) % 3]);
        let e = (b - a).normalize();
        let perp = {
            let d = rng.dir();
            (d - e * d.dot(e)).normalize()
        };
        let x = a + (b - a) * rng.range(0.05, 0.95) + perp * l * rng.log_range(-9.0, -5.0);
        check_solid_angle(&mut hp, x, &t, false, &mut edge);
    }
    vertex.check(
        "solid angle, 1e-9..1e-5 from a vertex",
        HARD.0,
        HARD.1,
        HARD.2,
    );
    edge.check(
        "solid angle, 1e-9..1e-5 from an edge",
        HARD.0,
        HARD.1,
        HARD.2,
    );
}

#[test]
fn solid_angle_slivers_and_extreme_coordinates() {
    let mut hp = Hp::new();
    let mut rng = Rng(6);
    let mut sliver = Worst::default();
    let mut huge = Worst::default();
    let mut tiny = Worst::default();
    for _ in 0..samples() {
        // Sliver: apex 1e-8..1e-4 sizes above the opposite edge.
        let l = rng.log_range(-1.0, 1.0);
        let a = rng.in_ball() * l;
        let b = a + rng.dir() * l;
        let e = (b - a).normalize();
        let perp = {
            let d = rng.dir();
            (d - e * d.dot(e)).normalize()
        };
        let c =
            (a + b) * 0.5 + (b - a) * rng.range(-0.3, 0.3) + perp * l * rng.log_range(-8.0, -4.0);
        let t = Tri { v: [a, b, c] };
        let x = t.centroid() + rng.in_ball() * 2.0 * l;
        if t.rho(x) > 1e-3 * l {
            check_solid_angle(&mut hp, x, &t, false, &mut sliver);
        }
        // Huge coordinates: unit-size triangles around 1e6.
        let offset = DVec3::new(1e6, -2e6, 3e6) + rng.in_ball() * 1e5;
        let t = random_tri(&mut rng, offset, 1.0);
        let x = t.centroid() + rng.in_ball() * 3.0;
        if t.rho(x) > 1e-2 {
            check_solid_angle(&mut hp, x, &t, false, &mut huge);
        }
        // Tiny coordinates: 1e-6-size triangles around 1e-6.
        let center = rng.in_ball() * 1e-6;
        let t = random_tri(&mut rng, center, 1e-6);
        let x = t.centroid() + rng.in_ball() * 3e-6;
        if t.rho(x) > 1e-8 {
            check_solid_angle(&mut hp, x, &t, false, &mut tiny);
        }
    }
    sliver.check(
        "solid angle, slivers (apex 1e-8..1e-4)",
        HARD.0,
        HARD.1,
        HARD.2,
    );
    huge.check("solid angle, unit triangles at 1e6", HARD.0, HARD.1, HARD.2);
    tiny.check(
        "solid angle, 1e-6 triangles at 1e-6",
        GENERIC.0,
        GENERIC.1,
        GENERIC.2,
    );
}

// ---------------------------------------------------------------------------------------------
// Flatland segment form factor.

fn check_segment(hp: &mut Hp, x: DVec2, a: DVec2, b: DVec2, worst: &mut Worst) {
    let d = kernels::segment_form_factor_2d(x, a, b, Order::Hessian)
        .unwrap_or_else(|e| panic!("{e} at x={x:?} a={a:?} b={b:?}"));
    let dir = (b - a).normalize();
    let h = (x - a).perp_dot(dir).abs();
    let rho = h.min((x - a).length()).min((x - b).length());
    let r = central2(hp, x, 1e-25 * rho, &mut |hp, xs, ys| {
        segment_hp(hp, xs, ys, a, b)
    });
    let errs = (
        rel(d.value, r.value),
        rel2(d.gradient, r.gradient),
        rel22(d.hessian, r.hessian),
    );
    if errs.0 > 1e-10 || errs.1 > 1e-9 || errs.2 > 1e-8 {
        eprintln!(
            "large error {errs:?} at x={x:?} a={a:?} b={b:?}\n  got {d:?}\n  ref {} {:?} {:?}",
            r.value, r.gradient, r.hessian
        );
    }
    worst.add(errs.0, errs.1, errs.2);
}

fn rand2(rng: &mut Rng) -> DVec2 {
    let v = rng.in_ball();
    DVec2::new(v.x, v.y)
}

fn dir2(rng: &mut Rng) -> DVec2 {
    let a = rng.range(0.0, std::f64::consts::TAU);
    DVec2::new(a.cos(), a.sin())
}

#[test]
fn segment_form_factor_all_regimes() {
    let mut hp = Hp::new();
    let mut rng = Rng(7);
    let mut generic = Worst::default();
    let mut far = Worst::default();
    let mut line = Worst::default();
    let mut ends = Worst::default();
    let mut huge = Worst::default();
    let mut tiny = Worst::default();
    for i in 0..2 * samples() {
        let l = rng.log_range(-3.0, 3.0);
        let a = rand2(&mut rng) * 5.0 * l;
        let b = a + dir2(&mut rng) * l * rng.range(0.3, 1.0);
        let len = (b - a).length();
        let dir = (b - a) / len;
        let normal = dir.perp();
        // Generic: within 3 lengths, not close to the line.
        let x = a + rand2(&mut rng) * 3.0 * l;
        if (x - a).perp_dot(dir).abs() > 0.05 * len {
            check_segment(&mut hp, x, a, b, &mut generic);
        }
        let x = (a + b) * 0.5 + dir2(&mut rng) * len * rng.log_range(3.0, 6.0);
        check_segment(&mut hp, x, a, b, &mut far);
        // Near the line, beside the segment or beyond its ends.
        let t = if i % 2 == 0 {
            rng.range(0.05, 0.95)
        } else {
            rng.range(1.1, 3.0)
        };
        let side = if i % 4 < 2 { 1.0 } else { -1.0 };
        let x = a + (b - a) * t + normal * side * len * rng.log_range(-12.0, -6.0);
        check_segment(&mut hp, x, a, b, &mut line);
        let x = if i % 2 == 0 { a } else { b } + dir2(&mut rng) * len * rng.log_range(-9.0, -5.0);
        check_segment(&mut hp, x, a, b, &mut ends);
        let off = DVec2::new(1e6, -3e6);
        let (ha, hb) = (off + a / l, off + b / l);
        let x = ha + rand2(&mut rng) * 3.0;
        if (x - ha).perp_dot((hb - ha).normalize()).abs() > 1e-2 {
            check_segment(&mut hp, x, ha, hb, &mut huge);
        }
        let (ta, tb) = (a / l * 1e-6, b / l * 1e-6);
        let x = ta + rand2(&mut rng) * 3e-6;
        if (x - ta).perp_dot((tb - ta).normalize()).abs() > 5e-8 {
            check_segment(&mut hp, x, ta, tb, &mut tiny);
        }
    }
    generic.check(
        "segment FF, generic 1e-3..1e3",
        GENERIC.0,
        GENERIC.1,
        GENERIC.2,
    );
    far.check("segment FF, 1e3..1e6 lengths away", HARD.0, HARD.1, HARD.2);
    line.check(
        "segment FF, 1e-12..1e-6 off the line",
        HARD.0,
        HARD.1,
        HARD.2,
    );
    ends.check(
        "segment FF, 1e-9..1e-5 from an endpoint",
        HARD.0,
        HARD.1,
        HARD.2,
    );
    huge.check("segment FF, coordinates ~1e6", HARD.0, HARD.1, HARD.2);
    tiny.check(
        "segment FF, coordinates ~1e-6",
        GENERIC.0,
        GENERIC.1,
        GENERIC.2,
    );
}

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
