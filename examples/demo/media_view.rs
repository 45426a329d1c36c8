//! The camera rays of the media caches' image and the points along them where the render needs the
//! cached in-scattering (and where records may be placed): every camera ray is cut into equal
//! segments up to its surface hit, and the image term is the midpoint sum of q · T · Δt.

use glam::DVec3;

use crate::scene::Scene;

/// The camera rays of the media image and their march points.
pub struct MediaView {
    pub width: usize,
    pub height: usize,
    /// Points per camera ray.
    pub steps: usize,
    origin: DVec3,
    directions: Vec<DVec3>,
    /// Length of each camera ray inside the medium, up to its surface hit (0: no medium).
    lengths: Vec<f64>,
    sigma_t: f64,
}

impl MediaView {
    pub fn build(scene: &Scene, width: usize, height: usize, steps: usize) -> MediaView {
        let medium = scene.medium.expect("media caches need a medium");
        let (directions, lengths) = (0..width * height)
            .map(|i| {
                let ray = scene.camera.ray(i % width, i / width, width, height);
                let hit = scene
                    .intersect(&ray)
                    .map_or(f64::INFINITY, |s| s.hit.distance);
                // The camera is inside the room and the medium fills it.
                let length = medium.inside_length(ray.origin, ray.direction, hit);
                (ray.direction, if length.is_finite() { length } else { 0.0 })
            })
            .unzip();
        MediaView {
            width,
            height,
            steps: steps.max(1),
            origin: scene.camera.position,
            directions,
            lengths,
            sigma_t: medium.sigma_t(),
        }
    }

    pub fn points(&self) -> usize {
        self.directions.len() * self.steps
    }

    /// Whether pixel `p`'s camera ray crosses the medium (the pixels the error is measured on).
    pub fn in_medium(&self, p: usize) -> bool {
        self.lengths[p] > 0.0
    }

    /// March point `id` = pixel · steps + k: the midpoint of segment k.
    pub fn point(&self, id: usize) -> DVec3 {
        let (p, k) = (id / self.steps, id % self.steps);
        let dt = self.lengths[p] / self.steps as f64;
        self.origin + self.directions[p] * ((k as f64 + 0.5) * dt)
    }

    /// Radiance at the camera, per pixel, from q at every point: Σ_k q_k T(t_k) Δt.
    pub fn integrate(&self, q: &[DVec3]) -> Vec<DVec3> {
        (0..self.directions.len())
            .map(|p| {
                let dt = self.lengths[p] / self.steps as f64;
                (0..self.steps)
                    .map(|k| {
                        let t = (k as f64 + 0.5) * dt;
                        q[p * self.steps + k] * ((-self.sigma_t * t).exp() * dt)
                    })
                    .sum()
            })
            .collect()
    }

    /// Radiance at the camera, per pixel, of a field f marched with `steps` midpoints per ray (the
    /// directly computed single scattering, for the context image).
    pub fn march(&self, steps: usize, f: impl Fn(DVec3) -> DVec3) -> Vec<DVec3> {
        (0..self.directions.len())
            .map(|p| {
                let dt = self.lengths[p] / steps as f64;
                (0..steps)
                    .map(|k| {
                        let t = (k as f64 + 0.5) * dt;
                        f(self.origin + self.directions[p] * t) * ((-self.sigma_t * t).exp() * dt)
                    })
                    .sum()
            })
            .collect()
    }

    /// Pixel coordinates of a world point, if in front of the camera.
    pub fn project(&self, scene: &Scene, x: DVec3) -> Option<(usize, usize)> {
        let c = &scene.camera;
        let d = x - c.position;
        let z = d.dot(c.forward);
        if z <= 1e-9 {
            return None;
        }
        let aspect = self.width as f64 / self.height as f64;
        let px = d.dot(c.right) / (z * c.tan_half_fov * aspect);
        let py = d.dot(c.up) / (z * c.tan_half_fov);
        let (x, y) = (
            ((px + 1.0) * 0.5 * self.width as f64 - 0.5).round(),
            ((1.0 - py) * 0.5 * self.height as f64 - 0.5).round(),
        );
        (x >= 0.0 && y >= 0.0 && (x as usize) < self.width && (y as usize) < self.height)
            .then_some((x as usize, y as usize))
    }
}
