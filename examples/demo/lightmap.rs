//! Precomputed outgoing radiance on every surface: direct light plus one diffuse bounce, stored per
//! texel and interpolated bilinearly.
//!
//! This fixes the radiance that gather rays find at their hit points as a smooth, deterministic
//! function of the hit, so the reference and every cache integrate exactly the same integrand and
//! their differences are interpolation error only (not Monte Carlo noise in the hit radiance).

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::{cosine_polar_local, tangent_of, Ray};
use crate::scene::Scene;

pub struct LightMap {
    /// Per primitive: texels along u and v, RGB outgoing radiance row-major (v outer), and
    /// whether each texel's centre lies in open space (false: buried inside a solid, such as
    /// the floor under a block; see [`buried`]).
    maps: Vec<(usize, usize, Vec<DVec3>, Vec<bool>)>,
    /// In a medium: the in-scattered radiance on a voxel grid.
    volume: Option<VolumeMap>,
}

/// In-scattered radiance σ_s·L_i (single scattering of the sun, with its shadow) at voxel centres
/// of the medium's box, interpolated trilinearly: like the surface light map, it makes the media
/// radiance a smooth deterministic function that the reference and the caches share.
struct VolumeMap {
    lo: DVec3,
    cell: DVec3,
    dims: [usize; 3],
    values: Vec<DVec3>,
}

/// Voxels along the medium box's longest side.
const VOLUME_RESOLUTION: usize = 64;

impl VolumeMap {
    fn build(scene: &Scene) -> Option<VolumeMap> {
        let m = scene.medium?;
        let size = m.hi - m.lo;
        let h = size.max_element() / VOLUME_RESOLUTION as f64;
        let dims = [
            ((size.x / h).ceil() as usize).max(2),
            ((size.y / h).ceil() as usize).max(2),
            ((size.z / h).ceil() as usize).max(2),
        ];
        let cell = size / DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64);
        let values = (0..dims[0] * dims[1] * dims[2])
            .into_par_iter()
            .map(|i| {
                let (x, y, z) = (
                    i % dims[0],
                    (i / dims[0]) % dims[1],
                    i / (dims[0] * dims[1]),
                );
                let p = m.lo + cell * DVec3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5);
                scene.inscattered(p)
            })
            .collect();
        Some(VolumeMap {
            lo: m.lo,
            cell,
            dims,
            values,
        })
    }

    fn lookup(&self, p: DVec3) -> DVec3 {
        self.lookup_with_gradient(p).0
    }

    /// The trilinear value and its exact gradient (per channel, per L): what a gather needs to
    /// differentiate the in-scattered radiance it marches (zero along an axis clamped at the edge).
    fn lookup_with_gradient(&self, p: DVec3) -> (DVec3, [DVec3; 3]) {
        let g = (p - self.lo) / self.cell - DVec3::splat(0.5);
        let mut idx = [0usize; 3];
        let mut frac = [0.0f64; 3];
        let mut slope = [0.0f64; 3];
        for a in 0..3 {
            let max = (self.dims[a] - 1) as f64;
            let v = g[a].clamp(0.0, max);
            idx[a] = (v.floor() as usize).min(self.dims[a] - 2);
            frac[a] = v - idx[a] as f64;
            slope[a] = if g[a] > 0.0 && g[a] < max {
                1.0 / self.cell[a]
            } else {
                0.0
            };
        }
        let at =
            |x: usize, y: usize, z: usize| self.values[(z * self.dims[1] + y) * self.dims[0] + x];
        let mut sum = DVec3::ZERO;
        let mut gradient = [DVec3::ZERO; 3];
        for corner in 0..8 {
            let bit = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            // Per axis: the weight and its derivative along that axis.
            let w = [0, 1, 2].map(|a| if bit[a] == 1 { frac[a] } else { 1.0 - frac[a] });
            let dw = [0, 1, 2].map(|a| if bit[a] == 1 { slope[a] } else { -slope[a] });
            let v = at(idx[0] + bit[0], idx[1] + bit[1], idx[2] + bit[2]);
            sum += v * (w[0] * w[1] * w[2]);
            let d = DVec3::new(
                dw[0] * w[1] * w[2],
                w[0] * dw[1] * w[2],
                w[0] * w[1] * dw[2],
            );
            for (c, gc) in gradient.iter_mut().enumerate() {
                *gc += d * v[c];
            }
        }
        (sum, gradient)
    }
}

/// Directions (cosine-polar strata centres) probed to decide whether a texel centre is buried.
const BURIED_PROBES: (usize, usize) = (4, 8);

/// Whether the point `p` on a surface with normal `normal` lies inside a closed solid: most
/// probe rays leave it through the back of a face (solids' faces point outward). A buried texel
/// sees no light, and a bilinear lookup that blended it into its open neighbours would paint a
/// dark band one texel wide along every contact line (the floor beside a block), a feature of
/// the light map rather than of the scene's light transport.
fn buried(scene: &Scene, p: DVec3, normal: DVec3) -> bool {
    let (m, n) = BURIED_PROBES;
    let inside = stratum_centre_rays(p, normal, m, n)
        .filter(|ray| {
            scene
                .bvh
                .intersect(ray, scene.epsilon(), f64::INFINITY)
                .is_some_and(|hit| {
                    scene.bvh.primitive(hit.primitive).normal.dot(ray.direction) > 0.0
                })
        })
        .count();
    2 * inside > m * n
}

/// Rays from `p` through the centres of the m x n cosine-polar strata about `normal` (the same
/// pattern at every point, so what they gather is a smooth function of the point).
fn stratum_centre_rays(p: DVec3, normal: DVec3, m: usize, n: usize) -> impl Iterator<Item = Ray> {
    let t = tangent_of(normal);
    let b = normal.cross(t);
    (0..m).flat_map(move |j| {
        (0..n).map(move |k| {
            let l = cosine_polar_local(j, k, m, n, 0.5, 0.5);
            Ray {
                origin: p,
                direction: l.x * t + l.y * b + l.z * normal,
            }
        })
    })
}

/// Texels per unit length (the scenes' L); the Cornell box walls get 48 × 48.
fn texel_density(scene: &Scene) -> f64 {
    48.0 / scene.size
}

impl LightMap {
    pub fn build(scene: &Scene, progress: &indicatif::ProgressBar) -> LightMap {
        let density = texel_density(scene);
        let dims: Vec<(usize, usize)> = (0..scene.bvh.primitive_count())
            .map(|i| {
                let p = scene.bvh.primitive(i);
                let nu = ((p.edge_u.length() * density).ceil() as usize).clamp(4, 256);
                let nv = ((p.edge_v.length() * density).ceil() as usize).clamp(4, 256);
                (nu, nv)
            })
            .collect();
        let texels: Vec<(usize, usize, usize)> = dims
            .iter()
            .enumerate()
            .flat_map(|(i, &(nu, nv))| (0..nv).flat_map(move |b| (0..nu).map(move |a| (i, a, b))))
            .collect();
        progress.set_length(2 * texels.len() as u64);
        let texel_point = |&(i, a, b): &(usize, usize, usize)| {
            let (nu, nv) = dims[i];
            let prim = scene.bvh.primitive(i);
            prim.point((a as f64 + 0.5) / nu as f64, (b as f64 + 0.5) / nv as f64)
        };
        // Pass 1: direct irradiance, and which texels are buried.
        let direct: Vec<(DVec3, bool)> = texels
            .par_iter()
            .map(|texel| {
                progress.inc(1);
                let prim = scene.bvh.primitive(texel.0);
                let p = texel_point(texel);
                (
                    scene.direct_irradiance(p, prim.normal, 16),
                    !buried(scene, p, prim.normal),
                )
            })
            .collect();
        let mut direct_map = LightMap {
            maps: Vec::new(),
            volume: VolumeMap::build(scene),
        };
        let mut offset = 0;
        for (i, &(nu, nv)) in dims.iter().enumerate() {
            let albedo = scene.materials[i].albedo / std::f64::consts::PI;
            let texels = &direct[offset..offset + nu * nv];
            direct_map.maps.push((
                nu,
                nv,
                texels.iter().map(|(e, _)| *e * albedo).collect(),
                texels.iter().map(|(_, open)| *open).collect(),
            ));
            offset += nu * nv;
        }
        // Pass 2: one diffuse bounce of the direct light, gathered with stratum centres (the same
        // pattern at every texel, so the result is smooth).
        let (m, n) = (16, 48);
        let bounce: Vec<DVec3> = texels
            .par_iter()
            .map(|texel| {
                progress.inc(1);
                let prim = scene.bvh.primitive(texel.0);
                let sum: DVec3 = stratum_centre_rays(texel_point(texel), prim.normal, m, n)
                    .map(|ray| direct_map.radiance_along(scene, &ray))
                    .sum();
                sum * (std::f64::consts::PI / (m * n) as f64)
            })
            .collect();
        let mut offset = 0;
        for (i, map) in direct_map.maps.iter_mut().enumerate() {
            let albedo = scene.materials[i].albedo / std::f64::consts::PI;
            let count = map.0 * map.1;
            for (value, e) in map.2.iter_mut().zip(&bounce[offset..offset + count]) {
                *value += *e * albedo;
            }
            offset += count;
        }
        direct_map
    }

    /// In-scattered radiance σ_s·L_i (RGB, per unit length) at a point: zero outside the medium.
    pub fn inscattered(&self, scene: &Scene, p: DVec3) -> DVec3 {
        match (&self.volume, scene.medium) {
            (Some(v), Some(m)) if p.cmpge(m.lo).all() && p.cmple(m.hi).all() => v.lookup(p),
            _ => DVec3::ZERO,
        }
    }

    /// [`LightMap::inscattered`] and its gradient per channel (per L²), zero outside the medium.
    pub fn inscattered_with_gradient(&self, scene: &Scene, p: DVec3) -> (DVec3, [DVec3; 3]) {
        match (&self.volume, scene.medium) {
            (Some(v), Some(m)) if p.cmpge(m.lo).all() && p.cmple(m.hi).all() => {
                v.lookup_with_gradient(p)
            }
            _ => (DVec3::ZERO, [DVec3::ZERO; 3]),
        }
    }

    /// Outgoing (reflected, non-emitted) radiance at (s, t) of a primitive, bilinear over texel
    /// centres and clamped at the edges; buried texels are left out of the blend (the weights of
    /// the open ones renormalized) unless all four are buried.
    pub fn radiance(&self, primitive: usize, s: f64, t: f64) -> DVec3 {
        let (nu, nv, ref data, ref open) = self.maps[primitive];
        let x = (s * nu as f64 - 0.5).clamp(0.0, (nu - 1) as f64);
        let y = (t * nv as f64 - 0.5).clamp(0.0, (nv - 1) as f64);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(nu - 1), (y0 + 1).min(nv - 1));
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let corners = [
            (x0, y0, (1.0 - fx) * (1.0 - fy)),
            (x1, y0, fx * (1.0 - fy)),
            (x0, y1, (1.0 - fx) * fy),
            (x1, y1, fx * fy),
        ];
        let (mut sum, mut weight) = (DVec3::ZERO, 0.0);
        for &(a, b, w) in &corners {
            if open[b * nu + a] {
                sum += data[b * nu + a] * w;
                weight += w;
            }
        }
        if weight > 0.0 {
            return sum / weight;
        }
        corners
            .iter()
            .fold(DVec3::ZERO, |acc, &(a, b, w)| acc + data[b * nu + a] * w)
    }

    /// Reflected radiance found along a ray (zero on a miss), and the hit distance (∞ on a miss).
    pub fn trace(&self, scene: &Scene, ray: &Ray) -> (f64, DVec3) {
        let (distance, radiance, _) = self.trace_with_normal(scene, ray);
        (distance, radiance)
    }

    /// [`LightMap::trace`] and the unit normal at the hit facing the ray's origin (zero on a miss).
    pub fn trace_with_normal(&self, scene: &Scene, ray: &Ray) -> (f64, DVec3, DVec3) {
        match scene.bvh.intersect(ray, scene.epsilon(), f64::INFINITY) {
            Some(hit) => {
                let n = scene.bvh.primitive(hit.primitive).normal;
                let n = if n.dot(ray.direction) > 0.0 { -n } else { n };
                (hit.distance, self.radiance(hit.primitive, hit.s, hit.t), n)
            }
            None => (f64::INFINITY, DVec3::ZERO, DVec3::ZERO),
        }
    }

    fn radiance_along(&self, scene: &Scene, ray: &Ray) -> DVec3 {
        let (distance, radiance) = self.trace(scene, ray);
        match scene.medium {
            Some(m) if distance.is_finite() => radiance * (-m.sigma_t() * distance).exp(),
            _ => radiance,
        }
    }
}
