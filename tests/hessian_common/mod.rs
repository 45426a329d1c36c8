//! Shared helpers for the Hessian tests: layout directions (from `gather::Layout`), a tiny ray
//! caster over rectangles, and the thesis evaluation scene.
#![allow(dead_code)]

pub mod peer;
pub mod scene;

use glam::{DVec2, DVec3};
use raddiff::gather::hessian::HemisphereGather;
use raddiff::gather::{Frame, Layout, LayoutKind};

/// `radiance` with every ray made different (`+0.01 × (i·7919 mod 101)`), as in a path-traced
/// gather: no edge of the mesh can be skipped for equal radiance on both sides.
pub fn noisy_radiance(radiance: &[f32]) -> Vec<f32> {
    radiance
        .iter()
        .enumerate()
        .map(|(i, l)| l + 0.01 * ((i * 7919 % 101) as f32))
        .collect()
}

/// World directions of the gather layout for the frame (normal, tangent), index j*n + k.
pub fn directions(
    kind: LayoutKind,
    m: usize,
    n: usize,
    seed: u64,
    normal: DVec3,
    tangent: DVec3,
) -> Vec<DVec3> {
    let layout = Layout::new(kind, m as u32, n as u32, seed).unwrap();
    let frame = Frame::new(DVec3::ZERO, normal, tangent).unwrap();
    layout.directions(&frame).unwrap()
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
        kind: LayoutKind,
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
