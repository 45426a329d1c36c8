//! Shared helpers for the Hessian tests: layout directions (LAYOUTS.md), a tiny ray caster over
//! rectangles, and reference evaluation by shifted meshes.
#![allow(dead_code)]

pub mod scene;

use std::f64::consts::{FRAC_PI_4, TAU};

use glam::{DVec2, DVec3};
use raddiff::gather::hessian::{Connectivity, HemisphereGather};

fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn jitter(seed: u64, j: usize, k: usize) -> DVec2 {
    if seed == 0 {
        return DVec2::splat(0.5);
    }
    let h = splitmix64(seed ^ splitmix64(((j as u64) << 32) | k as u64));
    let h2 = splitmix64(h);
    let u = |v: u64| (v >> 11) as f64 / (1u64 << 53) as f64;
    DVec2::new(u(h), u(h2))
}

fn concentric(s: DVec2) -> DVec3 {
    let (a, b) = (s.x, s.y);
    let (r, phi) = if a == 0.0 && b == 0.0 {
        (0.0, 0.0)
    } else if a.abs() > b.abs() {
        (a, FRAC_PI_4 * (b / a))
    } else {
        (b, 2.0 * FRAC_PI_4 - FRAC_PI_4 * (a / b))
    };
    let d = DVec2::new(r * phi.cos(), r * phi.sin());
    DVec3::new(d.x, d.y, (1.0 - d.length_squared()).max(0.0).sqrt())
}

/// Local direction of stratum (j, k) per LAYOUTS.md.
pub fn local_direction(
    kind: Connectivity,
    m: usize,
    n: usize,
    seed: u64,
    j: usize,
    k: usize,
) -> DVec3 {
    let uv = jitter(seed, j, k);
    match kind {
        Connectivity::Polar => {
            let s2 = (j as f64 + uv.x) / m as f64;
            let st = s2.sqrt();
            let ct = (1.0 - s2).max(0.0).sqrt();
            let phi = TAU * (k as f64 + uv.y) / n as f64;
            DVec3::new(st * phi.cos(), st * phi.sin(), ct)
        }
        Connectivity::Concentric => concentric(DVec2::new(
            2.0 * (j as f64 + uv.x) / m as f64 - 1.0,
            2.0 * (k as f64 + uv.y) / n as f64 - 1.0,
        )),
    }
}

/// World directions for the frame (normal, tangent), index j*n + k.
pub fn directions(
    kind: Connectivity,
    m: usize,
    n: usize,
    seed: u64,
    normal: DVec3,
    tangent: DVec3,
) -> Vec<DVec3> {
    let b = normal.cross(tangent);
    let mut out = Vec::with_capacity(m * n);
    for j in 0..m {
        for k in 0..n {
            let l = local_direction(kind, m, n, seed, j, k);
            out.push((tangent * l.x + b * l.y + normal * l.z).normalize());
        }
    }
    out
}

/// An axis-aligned rectangle at height z, radiance seen from below.
#[derive(Debug, Clone, Copy)]
pub struct Rect {
    pub min: DVec2,
    pub max: DVec2,
    pub z: f64,
    pub radiance: f32,
}

impl Rect {
    pub fn corners(&self) -> [DVec3; 4] {
        [
            DVec3::new(self.min.x, self.min.y, self.z),
            DVec3::new(self.max.x, self.min.y, self.z),
            DVec3::new(self.max.x, self.max.y, self.z),
            DVec3::new(self.min.x, self.max.y, self.z),
        ]
    }
}

/// Closest hit of the ray x + t w among the rectangles: (distance, radiance), or (inf, env).
pub fn trace(x: DVec3, w: DVec3, rects: &[Rect], env: f32) -> (f64, f32) {
    let mut best = (f64::INFINITY, env);
    for r in rects {
        if w.z.abs() < 1e-300 {
            continue;
        }
        let t = (r.z - x.z) / w.z;
        if t <= 0.0 || t >= best.0 {
            continue;
        }
        let p = x + w * t;
        if p.x >= r.min.x && p.x <= r.max.x && p.y >= r.min.y && p.y <= r.max.y {
            best = (t, r.radiance);
        }
    }
    best
}

/// A gather of the rectangles scene at x (normal +z, tangent +x).
pub struct SceneGather {
    pub directions: Vec<DVec3>,
    pub distance: Vec<f64>,
    pub radiance: Vec<f32>,
}

impl SceneGather {
    pub fn new(
        kind: Connectivity,
        m: usize,
        n: usize,
        seed: u64,
        x: DVec3,
        rects: &[Rect],
        env: f32,
    ) -> Self {
        let directions = directions(kind, m, n, seed, DVec3::Z, DVec3::X);
        let mut distance = Vec::with_capacity(m * n);
        let mut radiance = Vec::with_capacity(m * n);
        for w in &directions {
            let (d, l) = trace(x, *w, rects, env);
            distance.push(d);
            radiance.push(l);
        }
        SceneGather {
            directions,
            distance,
            radiance,
        }
    }

    pub fn gather(&self) -> HemisphereGather<'_> {
        HemisphereGather {
            normal: DVec3::Z,
            directions: &self.directions,
            distance: &self.distance,
            radiance: &self.radiance,
            channels: 1,
            sigma_t: 0.0,
        }
    }
}
