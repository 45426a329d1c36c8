//! One record of the media (volume) cache: a sphere gather at a point inside the room's medium,
//! traced with the demo's own BVH and light maps, and what raddiff derives from it.
//!
//! The cached quantity is the *indirect* in-scattered radiance q(x) = σ_s/(4π) · Φ(x) (isotropic
//! phase function), Φ the fluence a sphere gather measures: light reflected by the surfaces (the
//! surface light map, sun patch included) and the sun's single scattering in the medium seen along
//! each ray (the volume map), both attenuated. The sun's own single scattering at x (the light
//! shafts) stays computed directly, as direct light on surfaces is; q is what a camera ray through
//! the medium would otherwise have to gather at every march step, the media analogue of indirect
//! irradiance. Units: radiance per unit length, like `LightMap::inscattered`.

use glam::{DMat3, DVec3};
use raddiff::gather::hessian::media::{media_derivatives, MediaGather, MediaSteps};
use raddiff::gather::hessian::mesh::Topology;
use raddiff::gather::{evaluate, Frame, GatherInput, Layout, LayoutKind, MediaRadiance, Wanted};
use raddiff::Order;

use crate::geometry::Ray;
use crate::lightmap::LightMap;
use crate::scene::Scene;
use crate::timing::ThreadTimer;

/// Steps along each gather direction at which the in-scattered radiance is sampled (as the surface
/// gathers do in the room).
pub const MEDIA_STEPS: usize = 16;

/// One media gather's results, shared by every metric (records differ only in their radii).
#[derive(Clone, Debug)]
pub struct MediaGathered {
    pub position: DVec3,
    /// RGB indirect in-scattered radiance q.
    pub value: [f32; 3],
    /// Axis-major: `gradient[k][c]` = ∂q_c/∂x_k (Jarosz et al. 2008 gradient, with media terms).
    pub gradient: [[f32; 3]; 3],
    /// Per-channel gradients (the samples of the Jarosz metric, Marco et al. eq. 5).
    pub channel_gradients: [DVec3; 3],
    pub luminance: f64,
    /// Harmonic-mean distance to the surfaces around x (the split-sphere baseline's R).
    pub harmonic_mean_distance: f64,
    /// Occlusion-aware Hessian of q's luminance (Marco et al. 2018; zero when no Hessian metric
    /// runs).
    pub hessian: DMat3,
    /// CPU seconds on the computing thread: ray casting with the light-map lookups, raddiff's
    /// fluence and gradients, raddiff's occlusion-aware gradient and Hessian.
    pub trace_seconds: f64,
    pub gradient_seconds: f64,
    pub hessian_seconds: f64,
}

/// What the rays of one sphere gather found.
struct Traced {
    layout: Layout,
    frame: Frame,
    directions: Vec<DVec3>,
    distance: Vec<f64>,
    radiance: Vec<f32>,
    media: Vec<f32>,
    /// ∇(σ_s L_i) at every media sample, index `((i·steps + s)·3 + c)·3 + axis` (record gathers
    /// only; empty for the reference's).
    media_gradient: Vec<f32>,
}

/// Per-gather constants: the sphere layout's size, the march and the triangulation.
pub struct MediaGatherer {
    pub m: u32,
    pub n: u32,
    step: f64,
    sigma_t: f64,
    /// σ_s/(4π): fluence to in-scattered radiance.
    phase: f64,
    topology: Option<Topology>,
}

fn lum(c: DVec3) -> f64 {
    crate::image::luminance(c)
}

impl MediaGatherer {
    /// `None` if the scene has no medium. `hessian`: also build the sphere triangulation for the
    /// occlusion-aware Hessian.
    pub fn new(scene: &Scene, m: usize, n: usize, hessian: bool) -> Option<Self> {
        let medium = scene.medium?;
        let topology = if hessian {
            Some(Topology::new(LayoutKind::Sphere, m, n).ok()?)
        } else {
            None
        };
        Some(MediaGatherer {
            m: m as u32,
            n: n as u32,
            step: scene.size * 1.8 / MEDIA_STEPS as f64,
            sigma_t: medium.sigma_t(),
            phase: medium.sigma_s / (4.0 * std::f64::consts::PI),
            topology,
        })
    }

    /// Traces a sphere layout at x, marching the in-scattered radiance (and its gradient, for
    /// record gathers).
    fn trace(
        &self,
        scene: &Scene,
        lightmap: &LightMap,
        x: DVec3,
        layout: Layout,
        with_gradient: bool,
    ) -> Result<Traced, raddiff::Error> {
        // A sphere gather has no normal: any frame.
        let frame = Frame::new(x, DVec3::Y, DVec3::X)?;
        let directions = layout.directions(&frame)?;
        let count = directions.len();
        let mut distance = Vec::with_capacity(count);
        let mut radiance = Vec::with_capacity(3 * count);
        let mut media = Vec::with_capacity(3 * count * MEDIA_STEPS);
        let mut media_gradient = Vec::with_capacity(if with_gradient {
            9 * count * MEDIA_STEPS
        } else {
            0
        });
        for d in &directions {
            let (t, l) = lightmap.trace(
                scene,
                &Ray {
                    origin: x,
                    direction: *d,
                },
            );
            distance.push(t);
            radiance.extend([l.x as f32, l.y as f32, l.z as f32]);
            for s in 0..MEDIA_STEPS {
                let ts = (s as f64 + 0.5) * self.step;
                // Without its gradient, raddiff's media terms would hold the in-scattered
                // radiance fixed along each ray, and the gradient would miss the light shaft's
                // boundary (Jarosz et al. 2008 differentiate the in-scattering too).
                let (v, g) = if ts >= t {
                    (DVec3::ZERO, [DVec3::ZERO; 3])
                } else if with_gradient {
                    lightmap.inscattered_with_gradient(scene, x + ts * *d)
                } else {
                    (lightmap.inscattered(scene, x + ts * *d), [DVec3::ZERO; 3])
                };
                media.extend([v.x as f32, v.y as f32, v.z as f32]);
                if with_gradient {
                    for gc in g {
                        media_gradient.extend([gc.x as f32, gc.y as f32, gc.z as f32]);
                    }
                }
            }
        }
        Ok(Traced {
            layout,
            frame,
            directions,
            distance,
            radiance,
            media,
            media_gradient,
        })
    }

    fn input<'t>(&self, t: &'t Traced) -> GatherInput<'t> {
        GatherInput {
            directions: &t.directions,
            distance: &t.distance,
            radiance: &t.radiance,
            channels: 3,
            sigma_t: self.sigma_t,
            media: Some(MediaRadiance {
                radiance: &t.media,
                gradient: (!t.media_gradient.is_empty()).then_some(&t.media_gradient[..]),
                steps: MEDIA_STEPS,
                step: self.step,
            }),
        }
    }

    /// q at x from an `m`×`n` sphere gather (no derivatives): the reference's dense estimate.
    pub fn value(
        &self,
        scene: &Scene,
        lightmap: &LightMap,
        x: DVec3,
        m: u32,
        n: u32,
        seed: u64,
    ) -> Result<DVec3, raddiff::Error> {
        let layout = Layout::new(LayoutKind::Sphere, m, n, seed)?;
        let t = self.trace(scene, lightmap, x, layout, false)?;
        let v = evaluate(&t.layout, &t.frame, &self.input(&t), Wanted::IRRADIANCE)?;
        Ok(DVec3::new(v.irradiance[0], v.irradiance[1], v.irradiance[2]) * self.phase)
    }

    /// Traces and evaluates the record gather at x, timing each part on this thread.
    pub fn gather(
        &self,
        scene: &Scene,
        lightmap: &LightMap,
        x: DVec3,
        seed: u64,
    ) -> Result<MediaGathered, raddiff::Error> {
        let start = ThreadTimer::start();
        let layout = Layout::new(LayoutKind::Sphere, self.m, self.n, seed)?;
        let t = self.trace(scene, lightmap, x, layout, true)?;
        let trace_seconds = start.seconds();

        let start = ThreadTimer::start();
        let v = evaluate(&t.layout, &t.frame, &self.input(&t), Wanted::ALL)?;
        let gradient_seconds = start.seconds();

        let start = ThreadTimer::start();
        let hessian = match &self.topology {
            Some(topo) => {
                // The Hessian of the luminance only (one channel), as the surface records do.
                let luminance = |c: &[f32]| {
                    c.chunks_exact(3)
                        .map(|l| lum(DVec3::new(l[0] as f64, l[1] as f64, l[2] as f64)) as f32)
                        .collect::<Vec<f32>>()
                };
                let radiance = luminance(&t.radiance);
                let media = luminance(&t.media);
                let g = MediaGather {
                    directions: &t.directions,
                    distance: &t.distance,
                    radiance: &radiance,
                    channels: 1,
                    sigma_t: self.sigma_t,
                    media: Some(MediaSteps {
                        radiance: &media,
                        steps: MEDIA_STEPS,
                        step: self.step,
                    }),
                };
                media_derivatives(topo, &g, Order::Hessian)?.channels[0].hessian * self.phase
            }
            None => DMat3::ZERO,
        };
        let hessian_seconds = start.seconds();

        let q = DVec3::new(v.irradiance[0], v.irradiance[1], v.irradiance[2]) * self.phase;
        let g: [DVec3; 3] = [0, 1, 2].map(|c| v.gradient[c] * self.phase);
        let mut gradient = [[0.0f32; 3]; 3];
        for (c, gc) in g.iter().enumerate() {
            for (k, row) in gradient.iter_mut().enumerate() {
                row[c] = gc[k] as f32;
            }
        }
        Ok(MediaGathered {
            position: x,
            value: [q.x as f32, q.y as f32, q.z as f32],
            gradient,
            channel_gradients: g,
            luminance: lum(q),
            harmonic_mean_distance: v.harmonic_mean_distance.unwrap_or(f64::INFINITY),
            hessian,
            trace_seconds,
            gradient_seconds,
            hessian_seconds,
        })
    }
}
