//! Occlusion-aware gradient and Hessian of the radiance arriving at a point inside a participating
//! medium (Marco et al. 2018, sec. 4), in 3D (sphere gather, triangles) and in flatland (a fan of
//! directions, segments).
//!
//! # Method
//!
//! The gather's rays are marched: step `s` of direction `i` carries the in-scattered radiance
//! `σ_s L_i` at `t_s = (s + ½)·step` (before attenuation). Each step becomes a closed **ring** of the
//! mesh around x (Marco Fig. 2e): vertex `i` sits at `min(t_s, d_i)` along its direction, and where
//! a surface occludes the ring (`d_i ≤ t_s`) it is a **zero-radiance** vertex at the surface hit.
//! A last ring holds the surface hits themselves with their radiance. Each triangle (segment) Δ
//! carries the radiance `L_Δ` of its farthest vertex `y_Δ`, attenuated by `T(x, y_Δ)`, and its
//! geometry term integrates to its solid angle Ω_Δ (angle θ_Δ in flatland):
//!
//! ```text
//!   Φ(x) ≈ Σ_rings (1/pdf(r)) Σ_Δ L_Δ T(x, y_Δ) Ω_Δ(x)                              (eq. 6, 10)
//!   ∇(T Ω) = T ∇Ω + Ω ∇T,   H(T Ω) = T HΩ + ∇T ∇Ωᵀ + ∇Ω ∇Tᵀ + Ω HT                 (eq. 17-18)
//! ```
//!
//! with `1/pdf(r) = step` for the marched rings (each ring stands for one step of the march) and
//! `pdf = 1` for the surface ring. Φ is the radiance integrated over all directions (the scalar
//! fluence of the gather's sphere layout; in flatland, over the circle of directions): multiply by
//! the phase function (1/4π, 1/2π for isotropic scattering) for the radiance towards the eye. Misses
//! are attenuated to zero when `σ_t > 0`; with `σ_t = 0` they are an environment at
//! [`super::gather_mesh::FAR_DISTANCE_FACTOR`] times the largest hit distance.
//!
//! The solid angles come from `kernels::triangle_solid_angle_signed` (the ring triangles are
//! oriented, so a triangle folded over by jitter counts negatively and every ring covers the sphere
//! exactly once), the flatland angles from
//! `kernels::segment_form_factor_2d` (App. B), the transmittance from `kernels::transmittance`.

use glam::{DMat2, DVec2, DVec3};

use super::gather_mesh::FAR_DISTANCE_FACTOR;
use super::mesh::{Topology, POLE, SOUTH_POLE};
use crate::error::{ensure_finite, Error, Result};
use crate::gather::layout::LayoutKind;
use crate::kernels;
use crate::{Deriv2, Deriv3, Order};

/// Marched in-scattered radiance along every direction of a gather.
#[derive(Debug, Clone, Copy)]
pub struct MediaSteps<'a> {
    /// `σ_s L_i` (radiance per unit length) before attenuation at `t_s = (s + ½)·step`,
    /// index `(i·steps + s)·channels + c`.
    pub radiance: &'a [f32],
    /// Steps per direction, ≥ 1.
    pub steps: usize,
    /// Step length (L), > 0.
    pub step: f64,
}

/// The rays of one gather at a point in a medium (3D: unit `DVec3` directions of a sphere layout;
/// flatland: unit `DVec2` directions in increasing angle around the full circle).
#[derive(Debug, Clone, Copy)]
pub struct MediaGather<'a, V> {
    /// Unit directions, index `i` (3D: `j·N + k` of the sphere layout).
    pub directions: &'a [V],
    /// Hit distances (L), > 0, `f64::INFINITY` for a miss.
    pub distance: &'a [f64],
    /// Surface (or environment) radiance at each hit, before attenuation, `channels` per direction.
    pub radiance: &'a [f32],
    /// Values per direction, ≥ 1.
    pub channels: usize,
    /// Homogeneous extinction coefficient (1/L), ≥ 0.
    pub sigma_t: f64,
    /// The marched media radiance, if any.
    pub media: Option<MediaSteps<'a>>,
}

/// Per-channel value, gradient and Hessian of the fluence at x (3D).
#[derive(Debug, Clone, PartialEq)]
pub struct MediaDerivatives {
    /// Value, gradient (per L) and Hessian (per L²) for every channel.
    pub channels: Vec<Deriv3>,
}

/// Per-channel value, gradient and Hessian of the flatland fluence at x.
#[derive(Debug, Clone, PartialEq)]
pub struct FlatlandDerivatives {
    /// Value, gradient (per L) and Hessian (per L²) for every channel.
    pub channels: Vec<Deriv2>,
}

fn check<V>(g: &MediaGather<V>, count: usize, order: Order) -> Result<()> {
    if !order.gradient() {
        return Err(Error::InvalidArgument(
            "media derivatives need order >= RADDIFF_ORDER_GRADIENT".into(),
        ));
    }
    if g.channels == 0 || g.directions.len() != count || g.distance.len() != count {
        return Err(Error::InvalidArgument(format!(
            "directions ({}) and distances ({}) must hold {count} values, channels >= 1",
            g.directions.len(),
            g.distance.len()
        )));
    }
    if Some(g.radiance.len()) != count.checked_mul(g.channels) {
        return Err(Error::InvalidArgument(format!(
            "radiance holds {} values, expected {count} x {} channels",
            g.radiance.len(),
            g.channels
        )));
    }
    ensure_finite(g.sigma_t, "sigma_t")?;
    if g.sigma_t < 0.0 {
        return Err(Error::InvalidArgument("sigma_t must be >= 0".into()));
    }
    if let Some(i) = g.distance.iter().position(|d| d.is_nan() || *d <= 0.0) {
        return Err(Error::InvalidArgument(format!(
            "distance[{i}] must be > 0 or +inf"
        )));
    }
    if g.radiance.iter().any(|v| !v.is_finite()) {
        return Err(Error::InvalidArgument("radiance is not finite".into()));
    }
    if let Some(m) = &g.media {
        ensure_finite(m.step, "step")?;
        if m.steps == 0 || m.step <= 0.0 {
            return Err(Error::InvalidArgument(
                "media steps must be >= 1 and step > 0".into(),
            ));
        }
        let want = count
            .checked_mul(m.steps)
            .and_then(|v| v.checked_mul(g.channels));
        if want != Some(m.radiance.len()) {
            return Err(Error::InvalidArgument(format!(
                "media radiance holds {} values, expected directions x steps x channels",
                m.radiance.len()
            )));
        }
        if m.radiance.iter().any(|v| !v.is_finite()) {
            return Err(Error::InvalidArgument(
                "media radiance is not finite".into(),
            ));
        }
    }
    Ok(())
}

/// One ring: vertex distances from x and radiance per vertex and channel.
struct Ring {
    distance: Vec<f64>,
    radiance: Vec<f64>,
    weight: f64,
}

/// The surface ring and every marched ring that has a visible (unoccluded) vertex.
fn rings<V>(g: &MediaGather<V>, count: usize) -> (f64, Vec<Ring>) {
    let largest = g
        .distance
        .iter()
        .filter(|d| d.is_finite())
        .fold(0.0f64, |m, &d| m.max(d));
    let far = FAR_DISTANCE_FACTOR * if largest > 0.0 { largest } else { 1.0 };
    let hit = |i: usize| {
        if g.distance[i].is_finite() {
            g.distance[i]
        } else {
            far
        }
    };
    let ch = g.channels;
    let mut out = Vec::new();
    out.push(Ring {
        distance: (0..count).map(hit).collect(),
        radiance: g.radiance.iter().map(|&v| v as f64).collect(),
        weight: 1.0,
    });
    if let Some(m) = &g.media {
        for s in 0..m.steps {
            let t = (s as f64 + 0.5) * m.step;
            if !(0..count).any(|i| t < g.distance[i]) {
                break;
            }
            let mut distance = Vec::with_capacity(count);
            let mut radiance = Vec::with_capacity(count * ch);
            for i in 0..count {
                let visible = t < g.distance[i];
                distance.push(if visible { t } else { g.distance[i] });
                for c in 0..ch {
                    radiance.push(if visible {
                        m.radiance[(i * m.steps + s) * ch + c] as f64
                    } else {
                        0.0
                    });
                }
            }
            out.push(Ring {
                distance,
                radiance,
                weight: m.step,
            });
        }
    }
    (far, out)
}

fn product3(l: f64, t: &Deriv3, o: &Deriv3, w: f64, acc: &mut Deriv3, order: Order) {
    let s = l * w;
    acc.value += s * t.value * o.value;
    acc.gradient += (o.gradient * t.value + t.gradient * o.value) * s;
    if order.hessian() {
        let cross = glam::DMat3::from_cols(
            t.gradient * o.gradient.x + o.gradient * t.gradient.x,
            t.gradient * o.gradient.y + o.gradient * t.gradient.y,
            t.gradient * o.gradient.z + o.gradient * t.gradient.z,
        );
        acc.hessian += (o.hessian * t.value + cross + t.hessian * o.value) * s;
    }
}

/// Occlusion-aware fluence, gradient and Hessian at a point in a medium from a sphere gather
/// (module docs). `topo` must be a [`LayoutKind::Sphere`] topology of the layout's M×N.
pub fn media_derivatives(
    topo: &Topology,
    g: &MediaGather<DVec3>,
    order: Order,
) -> Result<MediaDerivatives> {
    media_derivatives_from(topo, g, order, DVec3::ZERO)
}

/// [`media_derivatives`] of the same ring mesh (vertices fixed in space) seen from `x + offset`
/// instead of x: the function whose derivatives [`media_derivatives`] returns, for
/// finite-difference checks.
pub fn media_derivatives_from(
    topo: &Topology,
    g: &MediaGather<DVec3>,
    order: Order,
    offset: DVec3,
) -> Result<MediaDerivatives> {
    if topo.connectivity != LayoutKind::Sphere {
        return Err(Error::InvalidArgument(
            "media derivatives need a sphere topology".into(),
        ));
    }
    let count = topo.m * topo.n;
    check(g, count, order)?;
    if let Some(i) = g
        .directions
        .iter()
        .position(|w| !w.is_finite() || (w.length_squared() - 1.0).abs() > 1e-6)
    {
        return Err(Error::InvalidArgument(format!(
            "directions[{i}] is not a unit vector"
        )));
    }
    let ch = g.channels;
    let (far, rings) = rings(g, count);
    let (n, m) = (topo.n, topo.m);
    let mut acc = vec![Deriv3::constant(0.0); ch];
    let mut pos = vec![DVec3::ZERO; topo.vertex_count()];
    let mut rad = vec![0.0f64; topo.vertex_count() * ch];
    let mut dist = vec![0.0f64; topo.vertex_count()];
    for ring in &rings {
        for (v, &src) in topo.vertex_source.iter().enumerate() {
            if src == POLE || src == SOUTH_POLE {
                // Poles: harmonic mean distance and mean radiance of the adjacent ring, along the
                // mean direction of that ring (the layout's axis).
                let j = if src == POLE { 0 } else { m - 1 };
                let idx = (0..n).map(|k| j * n + k);
                let inv: f64 = idx.clone().map(|i| 1.0 / ring.distance[i]).sum::<f64>() / n as f64;
                let axis = idx.clone().map(|i| g.directions[i]).sum::<DVec3>();
                let axis = if axis.length() > 0.0 {
                    axis.normalize()
                } else {
                    DVec3::Z
                };
                // within the ring's range, as for surface gathers (`hessian::place`): equal
                // ring distances give the pole exactly theirs, so farthest-vertex ties do not
                // depend on rounding
                let (lo, hi) = idx.clone().fold((f64::INFINITY, 0.0f64), |(lo, hi), i| {
                    (lo.min(ring.distance[i]), hi.max(ring.distance[i]))
                });
                dist[v] = (1.0 / inv).max(lo).min(hi);
                pos[v] = axis * dist[v] - offset;
                for c in 0..ch {
                    rad[v * ch + c] =
                        idx.clone().map(|i| ring.radiance[i * ch + c]).sum::<f64>() / n as f64;
                }
            } else {
                let i = src as usize;
                dist[v] = ring.distance[i];
                pos[v] = g.directions[i] * dist[v] - offset;
                for c in 0..ch {
                    rad[v * ch + c] = ring.radiance[i * ch + c];
                }
            }
        }
        for tri in &topo.triangles {
            let mut best = tri[0] as usize;
            for &v in &tri[1..] {
                if dist[v as usize] > dist[best] {
                    best = v as usize;
                }
            }
            let ls = &rad[best * ch..(best + 1) * ch];
            if ls.iter().all(|&l| l == 0.0) || (g.sigma_t > 0.0 && dist[best] >= far) {
                continue;
            }
            let [a, b, c] = tri.map(|v| pos[v as usize]);
            // Signed: a triangle folded over by jitter counts negatively, so every ring covers the
            // sphere exactly once (triangles are clockwise as seen from x).
            let omega = kernels::triangle_solid_angle_signed(DVec3::ZERO, a, b, c, order)?;
            let t = kernels::transmittance(DVec3::ZERO, pos[best], g.sigma_t, order)?;
            for (k, &l) in ls.iter().enumerate() {
                if l != 0.0 {
                    product3(l, &t, &omega, ring.weight, &mut acc[k], order);
                }
            }
        }
    }
    Ok(MediaDerivatives { channels: acc })
}

/// Flatland transmittance `exp(−σ|y − x|)` at x = 0 with derivatives w.r.t. x.
fn transmittance_2d(y: DVec2, sigma: f64, order: Order) -> Deriv2 {
    if sigma == 0.0 {
        return Deriv2::constant(1.0);
    }
    let r = y.length();
    let t = (-sigma * r).exp();
    let mut d = Deriv2::constant(t);
    if t == 0.0 || r == 0.0 {
        return d;
    }
    let u = -y / r; // (x − y)/|x − y|
    d.gradient = -sigma * t * u;
    if order.hessian() {
        let uu = DMat2::from_cols(u * u.x, u * u.y);
        d.hessian = uu * (sigma * sigma * t + sigma * t / r) - DMat2::IDENTITY * (sigma * t / r);
    }
    d
}

/// Flatland version (Marco sec. 4 and App. B): `directions` go once around the circle in
/// increasing angle, consecutive directions (and the last with the first) are neighbours; each ring
/// is a closed polygon of segments. Returns the flatland fluence `∫ L dφ` and its derivatives.
pub fn flatland_derivatives(g: &MediaGather<DVec2>, order: Order) -> Result<FlatlandDerivatives> {
    flatland_derivatives_from(g, order, DVec2::ZERO)
}

/// [`flatland_derivatives`] of the same segment rings (vertices fixed in space) seen from
/// `x + offset`, for finite-difference checks.
pub fn flatland_derivatives_from(
    g: &MediaGather<DVec2>,
    order: Order,
    offset: DVec2,
) -> Result<FlatlandDerivatives> {
    let count = g.directions.len();
    if count < 3 {
        return Err(Error::InvalidArgument(
            "a flatland gather needs at least 3 directions".into(),
        ));
    }
    check(g, count, order)?;
    if let Some(i) = g
        .directions
        .iter()
        .position(|w| !w.is_finite() || (w.length_squared() - 1.0).abs() > 1e-6)
    {
        return Err(Error::InvalidArgument(format!(
            "directions[{i}] is not a unit vector"
        )));
    }
    let ch = g.channels;
    let (far, rings) = rings(g, count);
    let mut acc = vec![Deriv2::constant(0.0); ch];
    let tau = std::f64::consts::TAU;
    for ring in &rings {
        for i in 0..count {
            let j = (i + 1) % count;
            let best = if ring.distance[j] > ring.distance[i] {
                j
            } else {
                i
            };
            let ls = &ring.radiance[best * ch..(best + 1) * ch];
            if ls.iter().all(|&l| l == 0.0) || (g.sigma_t > 0.0 && ring.distance[best] >= far) {
                continue;
            }
            let a = g.directions[i] * ring.distance[i] - offset;
            let b = g.directions[j] * ring.distance[j] - offset;
            let theta = kernels::segment_form_factor_2d(DVec2::ZERO, a, b, order)?;
            let y = g.directions[best] * ring.distance[best] - offset;
            let t = transmittance_2d(y, g.sigma_t, order);
            for (k, &l) in ls.iter().enumerate() {
                if l == 0.0 {
                    continue;
                }
                let s = l * ring.weight * tau;
                let d = &mut acc[k];
                d.value += s * t.value * theta.value;
                d.gradient += (theta.gradient * t.value + t.gradient * theta.value) * s;
                if order.hessian() {
                    let cross = DMat2::from_cols(
                        t.gradient * theta.gradient.x + theta.gradient * t.gradient.x,
                        t.gradient * theta.gradient.y + theta.gradient * t.gradient.y,
                    );
                    d.hessian += (theta.hessian * t.value + cross + t.hessian * theta.value) * s;
                }
            }
        }
    }
    Ok(FlatlandDerivatives { channels: acc })
}
