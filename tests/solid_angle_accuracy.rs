//! Accuracy of the triangle solid angle (`triangle_solid_angle`, `triangle_solid_angle_signed`)
//! against independent 320-bit references: the Van Oosterom-Strackee value evaluated in astro-float
//! from the exact f64 inputs, derivatives by 320-bit central differences. Errors are relative,
//! normalized by the largest entry of each output; the targets are `GENERIC` (1e-12 value and
//! gradient, 1e-10 Hessian) and, near the singular sets and at extreme scales, `HARD` (1e-10 /
//! 1e-9 / 1e-8). `cargo test --release --test solid_angle_accuracy -- --nocapture` prints the worst
//! errors.

mod kernel_reference;

use glam::DVec3;
use kernel_reference::*;
use raddiff::{kernels, Order};

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
