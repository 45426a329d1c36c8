//! Shared scene set-up for the scatter integration tests.
#![allow(dead_code)]

pub mod flat_reference;

use glam::DVec3;
use raddiff::scatter::{Medium, RefractiveMesh};

/// The eye segment of a ray through the mesh: its first two surface hits.
pub fn chord(mesh: &RefractiveMesh, origin: DVec3, dir: DVec3) -> Option<(DVec3, DVec3)> {
    let dir = dir.normalize();
    let a = mesh.closest_hit(origin, dir, 0.0, 1e9)?;
    let b = mesh.closest_hit(origin, dir, a.t + 1e-9, 1e9)?;
    Some((origin + a.t * dir, origin + b.t * dir))
}

/// The medium of the tests: glass-like index, moderately dense, forward scattering.
pub fn medium() -> Medium {
    Medium {
        eta: 1.5,
        sigma_t: 0.6,
        sigma_s: 0.5,
        g: 0.3,
    }
}

/// Back light behind the sphere (the camera looks along −z from z > 0).
pub const LIGHT: DVec3 = DVec3::new(0.4, 0.7, -4.0);

/// Deterministic eye rays from a camera at z = 4 through a small window.
pub fn eye_rays(count: usize) -> Vec<(DVec3, DVec3)> {
    let cam = DVec3::new(0.0, 0.0, 4.0);
    let mut state = 0x9e3779b97f4a7c15u64;
    let mut rnd = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..count)
        .map(|_| {
            let target = DVec3::new(1.6 * rnd() - 0.8, 1.6 * rnd() - 0.8, 0.0);
            (cam, (target - cam).normalize())
        })
        .collect()
}
