//! A bounding-sphere hierarchy over the triangles of a refractive mesh (the spindle test of report
//! sec. 3.2.4 works on bounding spheres), with a closest-hit ray query.

use glam::DVec3;

use super::constraint::TriangleGeometry;

/// A sphere containing a triangle or a group of triangles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundingSphere {
    /// Centre.
    pub center: DVec3,
    /// Radius (L), ≥ 0.
    pub radius: f64,
}

impl BoundingSphere {
    /// The smallest sphere containing the triangle's three vertices (its circumsphere when acute,
    /// the sphere on its longest edge otherwise), grown by a relative 1e-12 for rounding.
    pub fn of_triangle(v: [DVec3; 3]) -> Self {
        let mut best = None;
        for k in 0..3 {
            let (a, b, c) = (v[k], v[(k + 1) % 3], v[(k + 2) % 3]);
            let center = 0.5 * (a + b);
            let radius = 0.5 * (a - b).length();
            if (c - center).length() <= radius {
                best = Some(BoundingSphere { center, radius });
                break;
            }
        }
        let s = best.unwrap_or_else(|| {
            // Acute: the circumcentre in the triangle's plane.
            let (a, b) = (v[1] - v[0], v[2] - v[0]);
            let axb = a.cross(b);
            let denom = 2.0 * axb.length_squared();
            let center = if denom > 0.0 {
                v[0] + (b.length_squared() * axb.cross(a) + a.length_squared() * b.cross(axb))
                    / denom
            } else {
                (v[0] + v[1] + v[2]) / 3.0
            };
            let radius = v.iter().map(|p| (*p - center).length()).fold(0.0, f64::max);
            BoundingSphere { center, radius }
        });
        s.grown()
    }

    /// A sphere containing all `points` (centre of their bounding box; not minimal).
    pub fn of_points(points: impl Iterator<Item = DVec3> + Clone) -> Self {
        let (lo, hi) = points.clone().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(p), hi.max(p)),
        );
        let center = 0.5 * (lo + hi);
        let radius = points.map(|p| (p - center).length()).fold(0.0, f64::max);
        BoundingSphere { center, radius }.grown()
    }

    fn grown(self) -> Self {
        BoundingSphere {
            center: self.center,
            radius: self.radius * (1.0 + 1e-12) + 1e-300,
        }
    }

    /// The ray parameters where origin + t dir (unit dir) is inside the sphere, if any.
    pub fn ray_interval(&self, origin: DVec3, dir: DVec3) -> Option<(f64, f64)> {
        let oc = origin - self.center;
        let b = oc.dot(dir);
        let c = oc.length_squared() - self.radius * self.radius;
        let disc = b * b - c;
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        Some((-b - s, -b + s))
    }
}

/// One node of the hierarchy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Node {
    /// Sphere containing every triangle below the node.
    pub sphere: BoundingSphere,
    /// Leaf: first index into [`SphereHierarchy::order`]; interior: index of the right child (the
    /// left child is the next node).
    pub start_or_right: u32,
    /// Number of triangles of a leaf; 0 for an interior node.
    pub count: u32,
}

/// A binary bounding-sphere hierarchy, nodes in depth-first order (node 0 is the root).
#[derive(Debug, Clone, PartialEq)]
pub struct SphereHierarchy {
    nodes: Vec<Node>,
    order: Vec<u32>,
}

/// Maximum triangles per leaf.
pub(crate) const LEAF_SIZE: usize = 4;

impl SphereHierarchy {
    /// Builds the hierarchy by median splits along the widest axis of the triangle centroids.
    pub fn build(triangles: &[TriangleGeometry]) -> Self {
        let centroids: Vec<DVec3> = triangles
            .iter()
            .map(|t| t.p0 + (t.e1 + t.e2) / 3.0)
            .collect();
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * triangles.len() / LEAF_SIZE + 1);
        build_node(triangles, &centroids, &mut order, 0, &mut nodes);
        SphereHierarchy { nodes, order }
    }

    /// The nodes, depth-first.
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Triangle indices referenced by the leaves.
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// The triangles of a leaf node.
    pub fn leaf_triangles(&self, node: &Node) -> &[u32] {
        let s = node.start_or_right as usize;
        &self.order[s..s + node.count as usize]
    }
}

fn build_node(
    tris: &[TriangleGeometry],
    centroids: &[DVec3],
    order: &mut [u32],
    offset: usize,
    nodes: &mut Vec<Node>,
) -> usize {
    let sphere = BoundingSphere::of_points(
        order
            .iter()
            .flat_map(|&i| tris[i as usize].vertices().into_iter()),
    );
    let index = nodes.len();
    if order.len() <= LEAF_SIZE {
        nodes.push(Node {
            sphere,
            start_or_right: offset as u32,
            count: order.len() as u32,
        });
        return index;
    }
    nodes.push(Node {
        sphere,
        start_or_right: 0,
        count: 0,
    });
    let (lo, hi) = order.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &i| (lo.min(centroids[i as usize]), hi.max(centroids[i as usize])),
    );
    let ext = hi - lo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&a, &b| {
        centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
    });
    let (left, right) = order.split_at_mut(mid);
    build_node(tris, centroids, left, offset, nodes);
    let r = build_node(tris, centroids, right, offset + mid, nodes);
    nodes[index].start_or_right = r as u32;
    index
}

/// The closest intersection of a ray with a triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Ray parameter (distance, for a unit direction).
    pub t: f64,
    /// Triangle index.
    pub triangle: u32,
}

/// Möller-Trumbore ray/triangle test: the ray parameter of the hit, if in (t_min, t_max).
pub fn ray_triangle(
    tri: &TriangleGeometry,
    origin: DVec3,
    dir: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<f64> {
    let p = dir.cross(tri.e2);
    let det = tri.e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - tri.p0;
    let a = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&a) {
        return None;
    }
    let q = s.cross(tri.e1);
    let b = dir.dot(q) * inv;
    if b < 0.0 || a + b > 1.0 {
        return None;
    }
    let t = tri.e2.dot(q) * inv;
    (t > t_min && t < t_max).then_some(t)
}

impl SphereHierarchy {
    /// The closest hit of origin + t dir (unit dir) with t in (t_min, t_max).
    pub fn closest_hit(
        &self,
        tris: &[TriangleGeometry],
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<RayHit> {
        let mut best: Option<RayHit> = None;
        let mut stack: smallvec::SmallVec<[usize; 64]> = smallvec::smallvec![0];
        while let Some(ni) = stack.pop() {
            let node = &self.nodes[ni];
            let limit = best.map_or(t_max, |h| h.t);
            match node.sphere.ray_interval(origin, dir) {
                Some((a, b)) if b > t_min && a < limit => {}
                _ => continue,
            }
            if node.count > 0 {
                for &ti in self.leaf_triangles(node) {
                    let limit = best.map_or(t_max, |h| h.t);
                    if let Some(t) = ray_triangle(&tris[ti as usize], origin, dir, t_min, limit) {
                        best = Some(RayHit { t, triangle: ti });
                    }
                }
            } else {
                stack.push(node.start_or_right as usize);
                stack.push(ni + 1);
            }
        }
        best
    }
}
