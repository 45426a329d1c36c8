//! Primary visibility, the incident radiance a gather ray brings back, and the path-traced
//! reference of indirect irradiance at every pixel.

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::{cosine_polar_local, tangent_of, Ray, Rng};
use crate::lightmap::LightMap;
use crate::scene::{Scene, SurfacePoint};

/// What one pixel's camera ray found.
#[derive(Clone, Copy, Debug)]
pub struct Pixel {
    pub surface: Option<SurfacePoint>,
    /// Radiance reaching the camera excluding the indirect irradiance term: emission, direct light
    /// reflected, and (in media) the camera ray's in-scattering and attenuation.
    pub base: DVec3,
    /// Multiplier turning indirect irradiance at the surface into radiance at the camera:
    /// albedo / π times the camera ray's transmittance.
    pub indirect_weight: DVec3,
}

impl Pixel {
    /// The surface point, if indirect light is visible there (a surface with non-zero albedo):
    /// the pixels irradiance caching serves and the error is measured on. Emitters and black
    /// surfaces show no indirect light, so a renderer computes none for them.
    pub fn shaded(&self) -> Option<SurfacePoint> {
        if self.indirect_weight.max_element() > 0.0 {
            self.surface
        } else {
            None
        }
    }
}

pub struct GBuffer {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Pixel>,
}

/// Steps used when marching the camera ray's in-scattering.
const CAMERA_MARCH_STEPS: usize = 96;

impl GBuffer {
    pub fn build(scene: &Scene, lightmap: &LightMap, width: usize, height: usize) -> GBuffer {
        let pixels = (0..width * height)
            .into_par_iter()
            .map(|i| {
                let ray = scene.camera.ray(i % width, i / width, width, height);
                primary(scene, lightmap, &ray, i as u64)
            })
            .collect();
        GBuffer {
            width,
            height,
            pixels,
        }
    }
}

fn primary(scene: &Scene, lightmap: &LightMap, ray: &Ray, seed: u64) -> Pixel {
    let surface = scene.intersect(ray);
    let distance = surface.map_or(f64::INFINITY, |s| s.hit.distance);
    let mut base = DVec3::ZERO;
    let mut transmittance = 1.0;
    if let Some(m) = scene.medium {
        let length = m.inside_length(ray.origin, ray.direction, distance);
        transmittance = (-m.sigma_t() * length).exp();
        // In-scattering along the camera ray (light shafts), midpoint rule with a jittered start.
        let step = length / CAMERA_MARCH_STEPS as f64;
        let jitter = Rng::new(seed).next_f64();
        for s in 0..CAMERA_MARCH_STEPS {
            let t = (s as f64 + jitter) * step;
            let p = ray.origin + t * ray.direction;
            base += lightmap.inscattered(scene, p) * ((-m.sigma_t() * t).exp() * step);
        }
    }
    let Some(sp) = surface else {
        return Pixel {
            surface: None,
            base,
            indirect_weight: DVec3::ZERO,
        };
    };
    let material = scene.materials[sp.hit.primitive];
    let albedo = material.albedo / std::f64::consts::PI;
    let direct = scene.direct_irradiance(sp.position, sp.normal, 16);
    base += (material.emission + albedo * direct) * transmittance;
    Pixel {
        surface: Some(sp),
        base,
        indirect_weight: albedo * transmittance,
    }
}

/// Incident radiance along a gather ray from x: the hit's reflected radiance attenuated by the
/// medium, plus the in-scattering along the ray estimated with `march` jittered steps.
/// Returns (hit distance or ∞, radiance).
pub fn incident(
    scene: &Scene,
    lightmap: &LightMap,
    ray: &Ray,
    march: usize,
    rng: &mut Rng,
) -> (f64, DVec3) {
    let (distance, radiance) = lightmap.trace(scene, ray);
    let Some(m) = scene.medium else {
        return (distance, radiance);
    };
    let length = m.inside_length(ray.origin, ray.direction, distance);
    let mut l = if distance.is_finite() {
        radiance * (-m.sigma_t() * distance).exp()
    } else {
        radiance
    };
    let step = length / march as f64;
    let jitter = rng.next_f64();
    for s in 0..march {
        let t = (s as f64 + jitter) * step;
        l += lightmap.inscattered(scene, ray.origin + t * ray.direction)
            * ((-m.sigma_t() * t).exp() * step);
    }
    (distance, l)
}

/// Reference indirect irradiance (RGB) at every pixel's surface point: `m` × `n` jittered
/// cosine-weighted strata per pixel (E = π/(mn) Σ L).
pub fn reference(
    scene: &Scene,
    lightmap: &LightMap,
    gbuffer: &GBuffer,
    m: usize,
    n: usize,
    progress: &indicatif::ProgressBar,
) -> Vec<DVec3> {
    progress.set_length(gbuffer.pixels.len() as u64);
    gbuffer
        .pixels
        .par_iter()
        .enumerate()
        .map(|(i, px)| {
            progress.inc(1);
            let Some(sp) = px.shaded() else {
                return DVec3::ZERO;
            };
            let mut rng = Rng::new(0x5EED_0000 + i as u64);
            let t = tangent_of(sp.normal);
            let b = sp.normal.cross(t);
            let mut sum = DVec3::ZERO;
            for j in 0..m {
                for k in 0..n {
                    let l = cosine_polar_local(j, k, m, n, rng.next_f64(), rng.next_f64());
                    let ray = Ray {
                        origin: sp.position,
                        direction: l.x * t + l.y * b + l.z * sp.normal,
                    };
                    sum += incident(scene, lightmap, &ray, 1, &mut rng).1;
                }
            }
            sum * (std::f64::consts::PI / (m * n) as f64)
        })
        .collect()
}
