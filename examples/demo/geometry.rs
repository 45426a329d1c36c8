//! Rays, parallelograms (the demo scenes' only primitive) and a small deterministic random source.

use glam::DVec3;

/// A ray `origin + t * direction`, `direction` of unit length.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: DVec3,
    pub direction: DVec3,
}

/// A parallelogram `corner + s * edge_u + t * edge_v`, (s, t) in [0, 1]².
///
/// Its normal is `edge_u × edge_v` normalized: the side that faces the scene. Scenes are built from
/// these because walls, blocks, windows and lights are all parallelograms, and (s, t) is directly the
/// light-map texture coordinate.
#[derive(Clone, Copy, Debug)]
pub struct Parallelogram {
    pub corner: DVec3,
    pub edge_u: DVec3,
    pub edge_v: DVec3,
    pub normal: DVec3,
    /// Dual basis: s = dual_u · (p − corner), t = dual_v · (p − corner) for p in the plane.
    dual_u: DVec3,
    dual_v: DVec3,
}

/// Where a ray hit a parallelogram.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub distance: f64,
    pub primitive: usize,
    pub s: f64,
    pub t: f64,
}

impl Parallelogram {
    pub fn new(corner: DVec3, edge_u: DVec3, edge_v: DVec3) -> Self {
        let cross = edge_u.cross(edge_v);
        let normal = cross.normalize();
        // p − corner = s u + t v; the dual vectors solve for s and t with one dot product each.
        let inv = 1.0 / cross.length_squared();
        let dual_u = edge_v.cross(cross) * inv;
        let dual_v = cross.cross(edge_u) * inv;
        Parallelogram {
            corner,
            edge_u,
            edge_v,
            normal,
            dual_u,
            dual_v,
        }
    }

    pub fn area(&self) -> f64 {
        self.edge_u.cross(self.edge_v).length()
    }

    pub fn point(&self, s: f64, t: f64) -> DVec3 {
        self.corner + s * self.edge_u + t * self.edge_v
    }

    pub fn bounds(&self) -> (DVec3, DVec3) {
        let pts = [
            self.corner,
            self.corner + self.edge_u,
            self.corner + self.edge_v,
            self.corner + self.edge_u + self.edge_v,
        ];
        let mut lo = pts[0];
        let mut hi = pts[0];
        for p in &pts[1..] {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        (lo, hi)
    }

    /// Two-sided intersection in (t_min, t_max): distance and (s, t).
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, f64, f64)> {
        let denom = ray.direction.dot(self.normal);
        if denom.abs() < 1e-14 {
            return None;
        }
        let dist = (self.corner - ray.origin).dot(self.normal) / denom;
        if !(dist > t_min && dist < t_max) {
            return None;
        }
        let rel = ray.origin + dist * ray.direction - self.corner;
        let s = self.dual_u.dot(rel);
        let t = self.dual_v.dot(rel);
        if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t) {
            Some((dist, s, t))
        } else {
            None
        }
    }
}

/// An orthonormal frame (tangent, bitangent, normal) around a unit normal, continuous in the normal
/// except at one pole (Duff et al. 2017 branchless construction).
pub fn tangent_of(normal: DVec3) -> DVec3 {
    let sign = 1.0f64.copysign(normal.z);
    let a = -1.0 / (sign + normal.z);
    let b = normal.x * normal.y * a;
    DVec3::new(
        1.0 + sign * normal.x * normal.x * a,
        sign * b,
        -sign * normal.x,
    )
}

/// splitmix64: a tiny, well-distributed deterministic generator; enough for jitter and sampling.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Cosine-weighted direction in the local frame (z up) from the stratum (j, k) of an m × n polar
/// grid with jitter (u, v): the same parametrization as raddiff's COSINE_POLAR layout.
pub fn cosine_polar_local(j: usize, k: usize, m: usize, n: usize, u: f64, v: f64) -> DVec3 {
    let sin2 = (j as f64 + u) / m as f64;
    let sin_theta = sin2.sqrt();
    let cos_theta = (1.0 - sin2).max(0.0).sqrt();
    let phi = std::f64::consts::TAU * (k as f64 + v) / n as f64;
    DVec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
}
