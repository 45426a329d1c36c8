//! The refractive mesh: triangles with per-vertex shading normals, validated, with their bounding
//! spheres, shading-normal cones and a bounding-sphere hierarchy.

use glam::DVec3;

use super::bvh::{BoundingSphere, RayHit, SphereHierarchy};
use super::constraint::TriangleGeometry;
use super::interval::Ownership;
use super::prune::NormalCone;
use crate::error::{Error, Result};

/// A closed (or open) triangle mesh bounding a refractive medium, with interpolated shading normals.
///
/// Conventions: triangles wind counter-clockwise seen from outside, so the geometric normal
/// (P1 − P0) × (P2 − P0) points out of the medium; vertex normals point outwards too (each must make
/// an angle below 90° with the geometric normal of every triangle using it). Normals need not be unit.
#[derive(Debug, Clone)]
pub struct RefractiveMesh {
    triangles: Vec<TriangleGeometry>,
    spheres: Vec<BoundingSphere>,
    cones: Vec<NormalCone>,
    hierarchy: SphereHierarchy,
    closed: bool,
    ownership: Vec<Ownership>,
}

impl RefractiveMesh {
    /// Builds a mesh from flat arrays as in the C ABI: `positions` and `normals` hold 3 floats per
    /// vertex, `indices` 3 vertex indices per triangle.
    pub fn from_flat(positions: &[f32], normals: &[f32], indices: &[u32]) -> Result<Self> {
        if positions.len() % 3 != 0 || normals.len() != positions.len() {
            return Err(Error::InvalidArgument(format!(
                "positions ({}) and normals ({}) must both hold 3 floats per vertex",
                positions.len(),
                normals.len()
            )));
        }
        if indices.len() % 3 != 0 {
            return Err(Error::InvalidArgument(format!(
                "indices ({}) must hold 3 per triangle",
                indices.len()
            )));
        }
        let to_vec = |a: &[f32]| {
            a.chunks_exact(3)
                .map(|c| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64))
                .collect::<Vec<_>>()
        };
        let tris: Vec<[u32; 3]> = indices
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        Self::new(&to_vec(positions), &to_vec(normals), &tris)
    }

    /// Builds a mesh from vertex positions, vertex normals and triangles (vertex index triples).
    ///
    /// Errors ([`Error::InvalidArgument`] unless noted): no triangles, non-finite position or
    /// normal, zero normal, index out of range, a normal facing away from the geometric normal of a
    /// triangle using it; [`Error::Degenerate`] for a triangle of (relatively) zero area
    /// (|e1 × e2| ≤ 1e-12 max(|e1|², |e2|²)).
    pub fn new(positions: &[DVec3], normals: &[DVec3], triangles: &[[u32; 3]]) -> Result<Self> {
        if triangles.is_empty() {
            return Err(Error::InvalidArgument("the mesh has no triangles".into()));
        }
        if normals.len() != positions.len() {
            return Err(Error::InvalidArgument(format!(
                "{} normals for {} vertices",
                normals.len(),
                positions.len()
            )));
        }
        for (i, (p, n)) in positions.iter().zip(normals).enumerate() {
            if !p.is_finite() {
                return Err(Error::InvalidArgument(format!(
                    "position of vertex {i} is not finite ({p})"
                )));
            }
            if !n.is_finite() {
                return Err(Error::InvalidArgument(format!(
                    "normal of vertex {i} is not finite ({n})"
                )));
            }
            if n.try_normalize().is_none() {
                return Err(Error::InvalidArgument(format!(
                    "normal of vertex {i} is zero"
                )));
            }
        }
        let mut geometry = Vec::with_capacity(triangles.len());
        for (ti, tri) in triangles.iter().enumerate() {
            if let Some(&bad) = tri.iter().find(|&&k| k as usize >= positions.len()) {
                return Err(Error::InvalidArgument(format!(
                    "triangle {ti} references vertex {bad}, but there are {} vertices",
                    positions.len()
                )));
            }
            let p = tri.map(|k| positions[k as usize]);
            let n = tri.map(|k| normals[k as usize]);
            let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
            let cross = e1.cross(e2).length();
            let scale = e1.length_squared().max(e2.length_squared());
            if !(cross > 1e-12 * scale) || !cross.is_finite() {
                return Err(Error::Degenerate(format!(
                    "triangle {ti} (vertices {tri:?}) has zero area"
                )));
            }
            let g = TriangleGeometry::new(p, n).ok_or_else(|| {
                Error::Degenerate(format!("triangle {ti} has a degenerate frame"))
            })?;
            for (k, normal) in g.normals.iter().enumerate() {
                if !(normal.dot(g.geometric_normal) > 0.0) {
                    // A nearly collinear triangle (angles below ~1e-6, e.g. collinear points
                    // rounded to f32) has a meaningless geometric normal: say so, not "faces away".
                    if !(cross > 1e-6 * scale) {
                        return Err(Error::Degenerate(format!(
                            "triangle {ti} (vertices {tri:?}) has (nearly) zero area: its \
                             vertices are collinear"
                        )));
                    }
                    return Err(Error::InvalidArgument(format!(
                        "the normal of vertex {} faces away from triangle {ti}'s geometric normal: \
                         triangles must wind counter-clockwise seen from outside, normals point outwards",
                        tri[k]
                    )));
                }
            }
            geometry.push(g);
        }
        let mut edges: std::collections::HashMap<(u32, u32), i32> = Default::default();
        for t in triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let closed = edges.values().all(|&c| c == 2);
        // Each shared edge and vertex belongs to the lowest-index triangle using it.
        let mut edge_owner: std::collections::HashMap<(u32, u32), usize> = Default::default();
        let mut vertex_owner = vec![usize::MAX; positions.len()];
        for (ti, t) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edge_owner.entry((a.min(b), a.max(b))).or_insert(ti);
                let v = &mut vertex_owner[t[k] as usize];
                *v = (*v).min(ti);
            }
        }
        let ownership = triangles
            .iter()
            .enumerate()
            .map(|(ti, t)| {
                let mut bits = 0u8;
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    if edge_owner[&(a.min(b), a.max(b))] == ti {
                        bits |= 1 << k;
                    }
                    if vertex_owner[t[k] as usize] == ti {
                        bits |= 1 << (3 + k);
                    }
                }
                Ownership(bits)
            })
            .collect();
        let mut mesh = Self::from_geometry(geometry, closed);
        mesh.ownership = ownership;
        Ok(mesh)
    }

    fn from_geometry(triangles: Vec<TriangleGeometry>, closed: bool) -> Self {
        let spheres = triangles
            .iter()
            .map(|t| BoundingSphere::of_triangle(t.vertices()))
            .collect();
        let cones = triangles
            .iter()
            .map(|t| NormalCone::of_normals(&t.normals))
            .collect();
        let hierarchy = SphereHierarchy::build(&triangles);
        let n = triangles.len();
        RefractiveMesh {
            triangles,
            spheres,
            cones,
            hierarchy,
            closed,
            ownership: vec![Ownership::ALL; n],
        }
    }

    /// Whether every edge is shared by exactly two triangles (a closed surface, bounding a volume).
    /// Only closed meshes get the inside/outside checks of the eye segment and the light.
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// For a closed mesh: whether `p` is strictly inside, by the parity of the surface crossings of
    /// a ray (in a fixed direction chosen to avoid axis-aligned edges) and of the opposite ray: both
    /// must be odd. A point on the surface (a vertex, an edge) makes the two disagree, since the
    /// crossing at the point itself is seen by at most one of them: it is not inside. `false` for
    /// open meshes.
    pub fn contains(&self, p: DVec3) -> bool {
        if !self.closed {
            return false;
        }
        let s = self.bounding_sphere();
        if (p - s.center).length() > s.radius {
            return false;
        }
        let dir = DVec3::new(0.572_393_7, 0.614_981_3, 0.542_351_9).normalize();
        // Hits within 1e-9 of the mesh's size of p: p is on the surface (a vertex, an edge), so
        // not inside, whether or not the ray test sees that crossing.
        let near = 1e-9 * s.radius;
        let (Some(forward), Some(backward)) = (
            self.crossings_beyond(p, dir, near),
            self.crossings_beyond(p, -dir, near),
        ) else {
            return false;
        };
        forward % 2 == 1 && backward % 2 == 1
    }

    /// Surface crossings of the ray p + t dir beyond t = `near`; `None` if one is closer.
    fn crossings_beyond(&self, p: DVec3, dir: DVec3, near: f64) -> Option<usize> {
        let s = self.bounding_sphere();
        let mut t = 0.0;
        let mut crossings = 0;
        while let Some(hit) = self.closest_hit(p, dir, t, f64::INFINITY) {
            if hit.t <= near {
                return None;
            }
            crossings += 1;
            t = hit.t * (1.0 + 1e-12) + 1e-12 * s.radius;
            if crossings > self.triangles.len() {
                break;
            }
        }
        Some(crossings)
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Triangle `i` with unit shading normals.
    pub fn triangle(&self, i: usize) -> &TriangleGeometry {
        &self.triangles[i]
    }

    /// All triangles.
    pub fn triangles(&self) -> &[TriangleGeometry] {
        &self.triangles
    }

    /// Which of triangle `i`'s edges and vertices count the paths through them (each shared edge
    /// and vertex is owned by one triangle, so that such a path is counted once).
    pub fn triangle_ownership(&self, i: usize) -> Ownership {
        self.ownership[i]
    }

    /// The bounding sphere of triangle `i`.
    pub fn triangle_sphere(&self, i: usize) -> &BoundingSphere {
        &self.spheres[i]
    }

    /// The cone containing triangle `i`'s interpolated shading normals.
    pub fn triangle_normal_cone(&self, i: usize) -> &NormalCone {
        &self.cones[i]
    }

    /// The bounding-sphere hierarchy.
    pub fn hierarchy(&self) -> &SphereHierarchy {
        &self.hierarchy
    }

    /// The sphere bounding the whole mesh.
    pub fn bounding_sphere(&self) -> &BoundingSphere {
        &self.hierarchy.nodes()[0].sphere
    }

    /// The closest triangle hit by origin + t dir (unit `dir`) for t in (t_min, t_max).
    pub fn closest_hit(&self, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> Option<RayHit> {
        self.hierarchy
            .closest_hit(&self.triangles, origin, dir, t_min, t_max)
    }
}

#[cfg(test)]
mod tests;
