//! A bounding volume hierarchy over parallelograms: binned surface-area-heuristic build, flattened
//! depth-first nodes, ordered stack traversal for closest hits and early-out shadow rays.
//!
//! The demo scenes have tens of primitives; a general BVH crate would pull a second linear-algebra
//! stack into the build for no gain, so this is the small one the scenes need (the Embree example
//! shows the production path).

use glam::DVec3;

use crate::geometry::{Hit, Parallelogram, Ray};

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: first primitive index in `order`; interior: index of the second child (the first child
    /// follows the node).
    start_or_right: u32,
    /// Number of primitives of a leaf, 0 for an interior node.
    count: u32,
    /// Split axis of an interior node (decides which child to visit first).
    axis: u8,
}

pub struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
    prims: Vec<Parallelogram>,
}

const MAX_LEAF: usize = 2;
const BINS: usize = 12;

fn surface_area(lo: DVec3, hi: DVec3) -> f64 {
    let d = (hi - lo).max(DVec3::ZERO);
    2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
}

impl Bvh {
    pub fn new(prims: Vec<Parallelogram>) -> Self {
        let bounds: Vec<(DVec3, DVec3)> = prims.iter().map(|p| p.bounds()).collect();
        let mut order: Vec<u32> = (0..prims.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * prims.len().max(1));
        if !prims.is_empty() {
            build(&bounds, &mut order, 0, prims.len(), &mut nodes);
        }
        Bvh {
            nodes,
            order,
            prims,
        }
    }

    pub fn primitive(&self, i: usize) -> &Parallelogram {
        &self.prims[i]
    }

    pub fn primitive_count(&self) -> usize {
        self.prims.len()
    }

    /// Closest hit with distance in (t_min, t_max).
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut t_far = t_max;
        self.traverse(ray, t_min, &mut t_far, &mut |i, r, tmin, tfar| {
            if let Some((d, s, t)) = self.prims[i].intersect(r, tmin, *tfar) {
                *tfar = d;
                best = Some(Hit {
                    distance: d,
                    primitive: i,
                    s,
                    t,
                });
            }
            false
        });
        best
    }

    /// Whether anything lies on the ray within (t_min, t_max).
    pub fn occluded(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        let mut t_far = t_max;
        let mut hit = false;
        self.traverse(ray, t_min, &mut t_far, &mut |i, r, tmin, tfar| {
            hit = self.prims[i].intersect(r, tmin, *tfar).is_some();
            hit
        });
        hit
    }

    /// Visits leaves front to back; `visit` returns true to stop.
    fn traverse(
        &self,
        ray: &Ray,
        t_min: f64,
        t_far: &mut f64,
        visit: &mut dyn FnMut(usize, &Ray, f64, &mut f64) -> bool,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = DVec3::ONE / ray.direction;
        let negative = [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0];
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node_index = stack[top];
            let node = &self.nodes[node_index as usize];
            if !slab(node.lo, node.hi, ray.origin, inv, t_min, *t_far) {
                continue;
            }
            if node.count > 0 {
                let start = node.start_or_right as usize;
                for &p in &self.order[start..start + node.count as usize] {
                    if visit(p as usize, ray, t_min, t_far) {
                        return;
                    }
                }
            } else {
                let left = node_index + 1;
                let right = node.start_or_right;
                // Push the far child first so the near one is visited first.
                if negative[node.axis as usize] {
                    stack[top] = left;
                    stack[top + 1] = right;
                } else {
                    stack[top] = right;
                    stack[top + 1] = left;
                }
                top += 2;
            }
        }
    }
}

#[inline]
fn slab(lo: DVec3, hi: DVec3, origin: DVec3, inv: DVec3, t_min: f64, t_max: f64) -> bool {
    let t0 = (lo - origin) * inv;
    let t1 = (hi - origin) * inv;
    let near = t0.min(t1);
    let far = t0.max(t1);
    // NaN from 0 * inf (origin on a slab plane, axis-parallel ray) is dropped by max/min.
    let enter = near.max_element().max(t_min);
    let exit = far.min_element().min(t_max);
    enter <= exit * (1.0 + 4.0 * f64::EPSILON)
}

fn build(
    bounds: &[(DVec3, DVec3)],
    order: &mut [u32],
    start: usize,
    end: usize,
    nodes: &mut Vec<Node>,
) -> u32 {
    let index = nodes.len() as u32;
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let (mut clo, mut chi) = (lo, hi);
    for &p in &order[start..end] {
        let (a, b) = bounds[p as usize];
        lo = lo.min(a);
        hi = hi.max(b);
        let c = 0.5 * (a + b);
        clo = clo.min(c);
        chi = chi.max(c);
    }
    nodes.push(Node {
        lo,
        hi,
        start_or_right: start as u32,
        count: (end - start) as u32,
        axis: 0,
    });
    let count = end - start;
    if count <= MAX_LEAF {
        return index;
    }
    // Binned SAH over the centroid bounds' longest axis.
    let extent = chi - clo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mut split = start + count / 2;
    if extent[axis] > 0.0 {
        let bin_of = |p: u32| {
            let (a, b) = bounds[p as usize];
            let c = 0.5 * (a[axis] + b[axis]);
            (((c - clo[axis]) / extent[axis] * BINS as f64) as usize).min(BINS - 1)
        };
        let mut bin_bounds = [(DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)); BINS];
        let mut bin_count = [0usize; BINS];
        for &p in &order[start..end] {
            let b = bin_of(p);
            bin_count[b] += 1;
            bin_bounds[b].0 = bin_bounds[b].0.min(bounds[p as usize].0);
            bin_bounds[b].1 = bin_bounds[b].1.max(bounds[p as usize].1);
        }
        let mut best = (f64::INFINITY, 0);
        for cut in 1..BINS {
            let grow = |range: std::ops::Range<usize>| {
                let mut l = DVec3::splat(f64::INFINITY);
                let mut h = DVec3::splat(f64::NEG_INFINITY);
                let mut n = 0;
                for i in range {
                    l = l.min(bin_bounds[i].0);
                    h = h.max(bin_bounds[i].1);
                    n += bin_count[i];
                }
                (surface_area(l, h), n)
            };
            let (al, nl) = grow(0..cut);
            let (ar, nr) = grow(cut..BINS);
            if nl == 0 || nr == 0 {
                continue;
            }
            let cost = al * nl as f64 + ar * nr as f64;
            if cost < best.0 {
                best = (cost, cut);
            }
        }
        if best.0.is_finite() {
            let slice = &mut order[start..end];
            slice.sort_by_key(|&p| bin_of(p) >= best.1);
            split = start + slice.iter().filter(|&&p| bin_of(p) < best.1).count();
        }
    }
    if split == start || split == end {
        split = start + count / 2;
    }
    build(bounds, order, start, split, nodes);
    let right = build(bounds, order, split, end, nodes);
    let node = &mut nodes[index as usize];
    node.start_or_right = right;
    node.count = 0;
    node.axis = axis as u8;
    index
}
