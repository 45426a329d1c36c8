//! Everything the demo asks raddiff for one irradiance record: gather directions, irradiance with
//! its Ward-Heckbert gradients, and the occlusion-aware Hessian. Each part is timed separately so
//! the report can set raddiff's work against the ray casting.

use glam::{DMat3, DVec3};
use raddiff::gather::hessian::{occlusion_derivatives, HemisphereGather};
use raddiff::gather::hessian_mesh::Topology;
use raddiff::gather::hessian_unaware::{geometric_hessian, unaware_derivatives};
use raddiff::gather::{
    evaluate, Frame, GatherInput, GatherValues, Layout, LayoutKind, MediaRadiance, Wanted,
};
use raddiff::Order;

use crate::geometry::{tangent_of, Ray};
use crate::lightmap::LightMap;
use crate::scene::Scene;
use crate::timing::ThreadTimer;

/// One gather's results, kept for every metric (records differ only in their radii).
#[derive(Clone, Debug)]
pub struct Gathered {
    pub position: DVec3,
    pub normal: DVec3,
    /// RGB indirect irradiance.
    pub value: [f32; 3],
    /// Axis-major: `gradient[k][c]` = ∂E_c/∂x_k (the cache's convention).
    pub gradient: [[f32; 3]; 3],
    pub rotation_gradient: [[f32; 3]; 3],
    /// Luminance of the irradiance, its Ward-Heckbert gradient, the harmonic-mean distance.
    pub luminance: f64,
    pub luminance_gradient: DVec3,
    pub harmonic_mean_distance: f64,
    /// Occlusion-aware Hessian of the luminance with the thesis' 1% robustness term (zero unless
    /// [`Hessians::aware`]).
    pub hessian: DMat3,
    /// Occlusion-unaware (radiometric) Hessian of the luminance; `None` in media or unless
    /// [`Hessians::unaware`].
    pub unaware_hessian: Option<DMat3>,
    /// Geometric Hessian (thesis eq. 4.23: the radiometric Hessian with every hit's luminance
    /// replaced by the gather's largest); `None` in media or unless [`Hessians::geometric`].
    pub geometric_hessian: Option<DMat3>,
    /// Seconds spent: ray casting (including the hit radiance), raddiff's irradiance and
    /// gradients, raddiff's occlusion-aware gradient and Hessian.
    pub trace_seconds: f64,
    pub gradient_seconds: f64,
    pub hessian_seconds: f64,
    pub unaware_seconds: f64,
    pub geometric_seconds: f64,
}

/// Steps along each gather direction at which in-scattering is sampled in a medium.
const MEDIA_STEPS: usize = 16;

/// What the rays of one gather found.
pub struct Traced {
    layout: Layout,
    frame: Frame,
    directions: Vec<DVec3>,
    distance: Vec<f64>,
    /// RGB radiance leaving each hit towards x, before attenuation.
    radiance: Vec<f32>,
    luminance: Vec<f32>,
    /// Unit normal at every hit (zero for misses), for the occlusion-unaware Hessian.
    normals: Vec<DVec3>,
    sigma_t: f64,
    /// In-scattered radiance samples (empty without a medium).
    media: Vec<f32>,
    media_step: f64,
}

/// Which Hessians every gather computes: only those of the metrics that run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Hessians {
    /// The occlusion-aware Hessian (`gather::hessian`).
    pub aware: bool,
    /// The occlusion-unaware (radiometric) Hessian.
    pub unaware: bool,
    /// The geometric Hessian (thesis eq. 4.23).
    pub geometric: bool,
}

/// Per-gather constants: the layout grid and its triangulation.
pub struct Gatherer {
    pub m: u32,
    pub n: u32,
    topology: Topology,
    hessians: Hessians,
}

fn lum(c: DVec3) -> f64 {
    crate::image::luminance(c)
}

impl Gatherer {
    pub fn new(m: usize, n: usize, hessians: Hessians) -> Result<Self, raddiff::Error> {
        Ok(Gatherer {
            m: m as u32,
            n: n as u32,
            topology: Topology::new(LayoutKind::CosinePolar, m, n)?,
            hessians,
        })
    }

    /// Traces the gather at (position, normal): what the renderer does for every record.
    pub fn trace(
        &self,
        scene: &Scene,
        lightmap: &LightMap,
        position: DVec3,
        normal: DVec3,
        seed: u64,
    ) -> Result<Traced, raddiff::Error> {
        let layout = Layout::new(LayoutKind::CosinePolar, self.m, self.n, seed)?;
        let frame = Frame::new(position, normal, tangent_of(normal))?;
        let directions = layout.directions(&frame)?;
        let count = directions.len();
        let mut distance = Vec::with_capacity(count);
        let mut radiance = Vec::with_capacity(3 * count);
        let mut luminance = Vec::with_capacity(count);
        let mut normals = Vec::with_capacity(count);
        // In a medium: in-scattered radiance σ_s·L_i at the midpoints of MEDIA_STEPS steps along
        // every direction (zero past the hit), the input of raddiff's media terms.
        let media_step = scene.size * 1.8 / MEDIA_STEPS as f64;
        let mut media = Vec::new();
        for d in &directions {
            let ray = Ray {
                origin: position,
                direction: *d,
            };
            let (t, l, hit_normal) = lightmap.trace_with_normal(scene, &ray);
            distance.push(t);
            normals.push(hit_normal);
            radiance.extend([l.x as f32, l.y as f32, l.z as f32]);
            luminance.push(lum(l) as f32);
            if scene.medium.is_some() {
                for s in 0..MEDIA_STEPS {
                    let ts = (s as f64 + 0.5) * media_step;
                    let v = if ts < t {
                        lightmap.inscattered(scene, position + ts * *d)
                    } else {
                        DVec3::ZERO
                    };
                    media.extend([v.x as f32, v.y as f32, v.z as f32]);
                }
            }
        }
        Ok(Traced {
            layout,
            frame,
            directions,
            distance,
            radiance,
            luminance,
            normals,
            sigma_t: scene.medium.map_or(0.0, |m| m.sigma_t()),
            media,
            media_step,
        })
    }

    /// raddiff's irradiance, Ward-Heckbert gradients (with the media terms in a medium) and
    /// distances of a traced gather.
    pub fn evaluate(&self, t: &Traced) -> Result<GatherValues, raddiff::Error> {
        let input = GatherInput {
            directions: &t.directions,
            distance: &t.distance,
            radiance: &t.radiance,
            channels: 3,
            sigma_t: t.sigma_t,
            media: (!t.media.is_empty()).then_some(MediaRadiance {
                radiance: &t.media,
                gradient: None,
                steps: MEDIA_STEPS,
                step: t.media_step,
            }),
        };
        evaluate(&t.layout, &t.frame, &input, Wanted::ALL)
    }

    /// raddiff's occlusion-aware Hessian of the luminance, with the thesis' robustness term.
    pub fn hessian(&self, t: &Traced) -> Result<DMat3, raddiff::Error> {
        Ok(
            occlusion_derivatives(&self.topology, &self.hemisphere(t), Order::Hessian)?
                .robust_hessian(0),
        )
    }

    /// raddiff's occlusion-unaware (radiometric) Hessian of the luminance, thesis eq. 4.10-4.14.
    /// Surfaces only: `None` in a medium, where it is not defined.
    pub fn unaware_hessian(&self, t: &Traced) -> Result<Option<DMat3>, raddiff::Error> {
        if t.sigma_t > 0.0 {
            return Ok(None);
        }
        let d = unaware_derivatives(&self.hemisphere(t), &t.normals, Order::Hessian)?;
        Ok(Some(d.hessian[0]))
    }

    /// raddiff's geometric Hessian (thesis eq. 4.23) with the gather's largest hit luminance
    /// standing in for the scene's largest radiance. Surfaces only, as the unaware one.
    pub fn geometric_hessian(&self, t: &Traced) -> Result<Option<DMat3>, raddiff::Error> {
        if t.sigma_t > 0.0 {
            return Ok(None);
        }
        let l_max = t.luminance.iter().fold(0.0f32, |m, &l| m.max(l)) as f64;
        Ok(Some(geometric_hessian(
            &self.hemisphere(t),
            &t.normals,
            l_max,
        )?))
    }

    fn hemisphere<'t>(&self, t: &'t Traced) -> HemisphereGather<'t> {
        HemisphereGather {
            normal: t.frame.normal,
            directions: &t.directions,
            distance: &t.distance,
            radiance: &t.luminance,
            channels: 1,
            sigma_t: t.sigma_t,
        }
    }

    /// Traces and evaluates the gather at (position, normal), timing each part on this thread.
    pub fn gather(
        &self,
        scene: &Scene,
        lightmap: &LightMap,
        position: DVec3,
        normal: DVec3,
        seed: u64,
    ) -> Result<Gathered, raddiff::Error> {
        let start = ThreadTimer::start();
        let traced = self.trace(scene, lightmap, position, normal, seed)?;
        let trace_seconds = start.seconds();

        let (values, gradient_seconds) = timed(|| self.evaluate(&traced))?;
        // a Hessian no metric asks for is neither computed nor timed (its seconds stay 0)
        let wanted = self.hessians;
        let (hessian, hessian_seconds) = match wanted.aware {
            true => timed(|| self.hessian(&traced))?,
            false => (DMat3::ZERO, 0.0),
        };
        let (unaware_hessian, unaware_seconds) = match wanted.unaware {
            true => timed(|| self.unaware_hessian(&traced))?,
            false => (None, 0.0),
        };
        let (geometric, geometric_seconds) = match wanted.geometric {
            true => timed(|| self.geometric_hessian(&traced))?,
            false => (None, 0.0),
        };

        let e = DVec3::new(
            values.irradiance[0],
            values.irradiance[1],
            values.irradiance[2],
        );
        let axis_major = |g: &[DVec3]| {
            let mut out = [[0.0f32; 3]; 3];
            for (c, v) in g.iter().enumerate() {
                for (k, row) in out.iter_mut().enumerate() {
                    row[c] = v[k] as f32;
                }
            }
            out
        };
        let lg =
            values.gradient[0] * 0.2126 + values.gradient[1] * 0.7152 + values.gradient[2] * 0.0722;
        Ok(Gathered {
            position,
            normal,
            value: [e.x as f32, e.y as f32, e.z as f32],
            gradient: axis_major(&values.gradient),
            rotation_gradient: axis_major(&values.rotation_gradient),
            luminance: lum(e),
            luminance_gradient: lg,
            harmonic_mean_distance: values.harmonic_mean_distance.unwrap_or(f64::INFINITY),
            hessian,
            unaware_hessian,
            geometric_hessian: geometric,
            trace_seconds,
            gradient_seconds,
            hessian_seconds,
            unaware_seconds,
            geometric_seconds,
        })
    }
}

/// Runs `f` and measures its CPU time on this thread (seconds).
fn timed<T>(f: impl FnOnce() -> Result<T, raddiff::Error>) -> Result<(T, f64), raddiff::Error> {
    let start = ThreadTimer::start();
    let value = f()?;
    Ok((value, start.seconds()))
}
