//! Everything the demo asks raddiff for one irradiance record: gather directions, and the
//! library's evaluation of the traced gather (irradiance with its Ward-Heckbert gradients, the
//! luminance the metrics measure, the Hessians they need). Each part is timed separately so the
//! report can set raddiff's work against the ray casting.

use glam::DVec3;
use raddiff::cache::irradiance::{
    GatherEvaluation, HessianKind, Hessians, TracedGather, LUMINANCE_WEIGHTS,
};
use raddiff::gather::{Frame, GatherInput, Layout, LayoutKind, MediaRadiance};

use crate::geometry::{tangent_of, Ray};
use crate::lightmap::LightMap;
use crate::scene::Scene;
use crate::timing::ThreadTimer;

/// One gather's evaluation, kept for every metric (records differ only in their radii), and what
/// each part cost.
#[derive(Clone, Debug)]
pub struct Gathered {
    /// Irradiance, gradients, luminance (the metrics' scalar), distance and the Hessians the
    /// metrics asked for (the occlusion-unaware ones only outside media).
    pub evaluation: GatherEvaluation,
    /// Seconds spent: ray casting (including the hit radiance), raddiff's irradiance and
    /// gradients, raddiff's occlusion-aware, occlusion-unaware and geometric Hessians.
    pub trace_seconds: f64,
    pub gradient_seconds: f64,
    pub hessian_seconds: f64,
    pub unaware_seconds: f64,
    pub geometric_seconds: f64,
}

impl Gathered {
    /// The seconds raddiff spent on the Hessian `kind` (0 when no metric asked for it).
    pub fn hessian_seconds(&self, kind: HessianKind) -> f64 {
        match kind {
            HessianKind::OcclusionAware => self.hessian_seconds,
            HessianKind::Unaware => self.unaware_seconds,
            HessianKind::Geometric => self.geometric_seconds,
        }
    }
}

/// Steps along each gather direction at which in-scattering is sampled in a medium.
const MEDIA_STEPS: usize = 16;

/// What the rays of one gather found.
pub struct Traced {
    layout: Layout,
    frame: Frame,
    /// The shading normal the frame was built from (the record's normal, bit for bit).
    normal: DVec3,
    directions: Vec<DVec3>,
    distance: Vec<f64>,
    /// RGB radiance leaving each hit towards x, before attenuation.
    radiance: Vec<f32>,
    /// Its luminance, computed before the RGB values were rounded to f32.
    luminance: Vec<f32>,
    /// Unit normal at every hit (zero for misses), for the occlusion-unaware Hessian.
    normals: Vec<DVec3>,
    sigma_t: f64,
    /// In-scattered radiance samples (empty without a medium).
    media: Vec<f32>,
    media_step: f64,
}

/// Per-gather constants: the layout grid and the Hessians the metrics need.
pub struct Gatherer {
    pub m: u32,
    pub n: u32,
    hessians: Hessians,
}

fn lum(c: DVec3) -> f64 {
    crate::image::luminance(c)
}

impl Gatherer {
    pub fn new(m: usize, n: usize, hessians: Hessians) -> Result<Self, raddiff::Error> {
        // fails here, not at the first gather, for a grid too small for the Hessian's mesh
        raddiff::gather::hessian::Topology::new(LayoutKind::CosinePolar, m, n)?;
        Ok(Gatherer {
            m: m as u32,
            n: n as u32,
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
            normal,
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

    /// The traced gather as raddiff takes it (with the media terms in a medium).
    fn traced<'t>(&self, t: &'t Traced) -> TracedGather<'t> {
        TracedGather {
            layout: t.layout,
            frame: t.frame,
            normal: t.normal,
            input: GatherInput {
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
            },
            hit_normals: Some(&t.normals),
            scalar_radiance: Some(&t.luminance),
        }
    }

    /// raddiff's irradiance, Ward-Heckbert gradients (with the media terms in a medium), luminance
    /// and distance of a traced gather, no Hessian yet.
    pub fn evaluate(&self, t: &Traced) -> Result<GatherEvaluation, raddiff::Error> {
        GatherEvaluation::new(&self.traced(t), &LUMINANCE_WEIGHTS, Hessians::NONE)
    }

    /// Adds raddiff's Hessian `kind` of the luminance to `evaluation` (of the gather `t`).
    pub fn add_hessian(
        &self,
        t: &Traced,
        evaluation: &mut GatherEvaluation,
        kind: HessianKind,
    ) -> Result<(), raddiff::Error> {
        evaluation.add_hessian(&self.traced(t), kind)
    }

    /// Traces and evaluates the gather at (position, normal), timing each part on this thread.
    /// A Hessian no metric asks for is neither computed nor timed (its seconds stay 0); the
    /// occlusion-unaware ones are not defined in a medium.
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
        let (mut evaluation, gradient_seconds) = timed(|| self.evaluate(&traced))?;
        let mut seconds = [0.0; 3];
        let kinds = [
            HessianKind::OcclusionAware,
            HessianKind::Unaware,
            HessianKind::Geometric,
        ];
        for (kind, seconds) in kinds.into_iter().zip(&mut seconds) {
            let defined = kind == HessianKind::OcclusionAware || traced.sigma_t == 0.0;
            if self.hessians.contains(kind) && defined {
                *seconds = timed(|| self.add_hessian(&traced, &mut evaluation, kind))?.1;
            }
        }
        Ok(Gathered {
            evaluation,
            trace_seconds,
            gradient_seconds,
            hessian_seconds: seconds[0],
            unaware_seconds: seconds[1],
            geometric_seconds: seconds[2],
        })
    }
}

/// Runs `f` and measures its CPU time on this thread (seconds).
fn timed<T>(f: impl FnOnce() -> Result<T, raddiff::Error>) -> Result<(T, f64), raddiff::Error> {
    let start = ThreadTimer::start();
    let value = f()?;
    Ok((value, start.seconds()))
}
