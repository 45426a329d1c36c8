//! The thesis evaluation scene (Fig. 5.3 / 6.6): receiver plane z = 0 (normal +z), a bright area
//! emitter above it and two black occluders at different heights; exact irradiance by clipping
//! (every shadow is an axis-aligned rectangle on the emitter's plane), exact derivatives by
//! Richardson-extrapolated central differences of it.
#![allow(dead_code)]

use std::f64::consts::PI;

use glam::{DMat2, DMat3, DVec2, DVec3};

use super::Rect;

pub const EMITTER_RADIANCE: f32 = 10.0;

pub fn emitter() -> Rect {
    Rect {
        min: DVec2::new(-0.5, -0.5),
        max: DVec2::new(0.5, 0.5),
        z: 2.0,
        radiance: EMITTER_RADIANCE,
    }
}

pub fn occluders() -> [Rect; 2] {
    [
        // high occluder: sharp-ish shadow boundary
        Rect {
            min: DVec2::new(-1.5, -1.5),
            max: DVec2::new(-0.1, 1.5),
            z: 1.5,
            radiance: 0.0,
        },
        // low occluder: wide penumbra
        Rect {
            min: DVec2::new(0.2, -1.5),
            max: DVec2::new(1.5, 0.1),
            z: 0.6,
            radiance: 0.0,
        },
    ]
}

pub fn rects() -> Vec<Rect> {
    let mut v = vec![emitter()];
    v.extend_from_slice(&occluders());
    v
}

/// Form factor from x (normal +z) to the axis-aligned rectangle [min, max] at height z > x.z.
fn rect_form_factor(x: DVec3, min: DVec2, max: DVec2, z: f64) -> f64 {
    if min.x >= max.x || min.y >= max.y {
        return 0.0;
    }
    let c = [
        DVec3::new(min.x, min.y, z) - x,
        DVec3::new(max.x, min.y, z) - x,
        DVec3::new(max.x, max.y, z) - x,
        DVec3::new(min.x, max.y, z) - x,
    ];
    let mut s = 0.0;
    for i in 0..4 {
        let (a, b) = (c[i], c[(i + 1) % 4]);
        let w = a.cross(b);
        let beta = w.length().atan2(a.dot(b));
        s += beta * w.z / w.length();
    }
    (s / (2.0 * PI)).abs()
}

/// The shadow of occluder `o` from x on the plane z = `plane`: an axis-aligned rectangle.
fn shadow(x: DVec3, o: &Rect, plane: f64) -> (DVec2, DVec2) {
    let k = (plane - x.z) / (o.z - x.z);
    let x2 = DVec2::new(x.x, x.y);
    (x2 + (o.min - x2) * k, x2 + (o.max - x2) * k)
}

fn intersect(a: (DVec2, DVec2), b: (DVec2, DVec2)) -> (DVec2, DVec2) {
    (a.0.max(b.0), a.1.min(b.1))
}

/// Exact irradiance at x (normal +z) by inclusion-exclusion of the shadows on the emitter.
pub fn exact_irradiance(x: DVec3) -> f64 {
    let e = emitter();
    let z = e.z;
    let em = (e.min, e.max);
    let [a, b] = occluders();
    let sa = intersect(em, shadow(x, &a, z));
    let sb = intersect(em, shadow(x, &b, z));
    let sab = intersect(sa, sb);
    let f = |r: (DVec2, DVec2)| rect_form_factor(x, r.0, r.1, z);
    PI * EMITTER_RADIANCE as f64 * (f(em) - f(sa) - f(sb) + f(sab))
}

/// Fraction of the emitter's form factor that is visible from x.
pub fn visible_fraction(x: DVec3) -> f64 {
    let e = emitter();
    exact_irradiance(x) / (PI * EMITTER_RADIANCE as f64 * rect_form_factor(x, e.min, e.max, e.z))
}

/// Fourth-order central difference of `f` along unit `e` with step `h`.
fn d1(f: &dyn Fn(DVec3) -> f64, x: DVec3, e: DVec3, h: f64) -> f64 {
    (8.0 * (f(x + e * h) - f(x - e * h)) - (f(x + e * 2.0 * h) - f(x - e * 2.0 * h))) / (12.0 * h)
}

/// Exact gradient of the irradiance at x.
pub fn exact_gradient(x: DVec3) -> DVec3 {
    let h = 1e-4;
    DVec3::new(
        d1(&exact_irradiance, x, DVec3::X, h),
        d1(&exact_irradiance, x, DVec3::Y, h),
        d1(&exact_irradiance, x, DVec3::Z, h),
    )
}

/// Exact Hessian of the irradiance at x (nested fourth-order differences, symmetrized).
pub fn exact_hessian(x: DVec3) -> DMat3 {
    hessian_by_differences(&exact_irradiance, x)
}

/// The Hessian of `f` at x by nested fourth-order central differences, symmetrized.
pub fn hessian_by_differences(f: &dyn Fn(DVec3) -> f64, x: DVec3) -> DMat3 {
    let h = 2e-3;
    let mut cols = [DVec3::ZERO; 3];
    for (j, col) in cols.iter_mut().enumerate() {
        let ej = DVec3::AXES[j];
        for i in 0..3 {
            let ei = DVec3::AXES[i];
            let gi = |p: DVec3| d1(f, p, ei, h);
            col[i] = d1(&gi, x, ej, h);
        }
    }
    let m = DMat3::from_cols(cols[0], cols[1], cols[2]);
    (m + m.transpose()) * 0.5
}

/// Exact irradiance at x from the emitter alone, or with the one black occluder `occluder` in
/// front of it (every shadow on the emitter's plane is an axis-aligned rectangle).
pub fn irradiance_behind(x: DVec3, occluder: Option<&Rect>) -> f64 {
    let e = emitter();
    let em = (e.min, e.max);
    let f = |r: (DVec2, DVec2)| rect_form_factor(x, r.0, r.1, e.z);
    let shadowed = occluder.map_or(0.0, |o| f(intersect(em, shadow(x, o, e.z))));
    PI * EMITTER_RADIANCE as f64 * (f(em) - shadowed)
}

/// The tangent-plane (xy) block of a Hessian at a point of the receiver and its eigenvalues,
/// ascending.
pub fn tangent_eigenvalues(h: DMat3) -> [f64; 2] {
    let t = DMat2::from_cols(
        DVec2::new(h.x_axis.x, h.x_axis.y),
        DVec2::new(h.y_axis.x, h.y_axis.y),
    );
    let tr = t.x_axis.x + t.y_axis.y;
    let det = t.determinant();
    let disc = (0.25 * tr * tr - det).max(0.0).sqrt();
    [0.5 * tr - disc, 0.5 * tr + disc]
}
