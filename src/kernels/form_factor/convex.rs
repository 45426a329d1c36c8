//! The certified convexity test of the Lambert paths for polygons of 4 to 8 vertices: polygons
//! the robust path's validation certainly accepts, strictly convex, with Newell's normal.

use glam::DVec3;

/// A quarter of the robust path's planarity tolerance (1e-8 of the extent).
const PLANARITY: f64 = 0.25e-8;
/// `(2·area / extent²)²` below which a polygon is a sliver: these fast paths decline it (far above
/// the robust path's zero-area limit, `2·area ≤ 1e-13 extent²`) and
/// [`very_thin_polygon_form_factor`](crate::kernels::form_factor::sliver::fan::very_thin_polygon_form_factor)
/// may take it, on the same rounded Newell normal and extent, so that the two never both accept
/// (the sliver path's result needs no Lambert value). `1.01e-10`: the robust path's sliver
/// threshold (`2·area < 1e-5 extent²`), squared, with a margin for the rounding of the normal.
pub(crate) const SLIVER_AREA2: f64 = 1.01e-10;
/// Smallest edge length and turn sine, relative (see the module documentation).
const MARGIN: f64 = 1e-3;

/// Whether the polygon is certainly accepted by the robust path's validation and strictly convex
/// (see the module documentation).
#[inline(always)]
pub(crate) fn convex_and_valid<const M: usize>(v: &[DVec3; M]) -> bool {
    convex_normal(v).is_some()
}

/// Newell's normal `N = Σ d_k × d_{k+1}` (twice the area times the unit normal, right-handed
/// with the vertex order) of a polygon that [`convex_and_valid`] accepts; `None` otherwise.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn convex_normal<const M: usize>(v: &[DVec3; M]) -> Option<DVec3> {
    let d: [DVec3; M] = std::array::from_fn(|k| v[k] - v[0]);
    let e: [DVec3; M] = std::array::from_fn(|i| v[(i + 1) % M] - v[i]);
    // The fan's cross products d_k × d_{k+1} (k = 1..M−2) serve Newell's normal and the monotone
    // fan test; the one for k = 1 is also the half-plane test's d_1 × d_2.
    let fan: [DVec3; M] = std::array::from_fn(|k| {
        if k >= 1 && k + 1 < M {
            d[k].cross(d[k + 1])
        } else {
            DVec3::ZERO
        }
    });
    let mut normal = DVec3::ZERO;
    for f in &fan[1..M - 1] {
        normal += *f;
    }
    let nn = normal.length_squared();
    let extent2 = d[1..]
        .iter()
        .map(|dk| dk.length_squared())
        .fold(0.0, f64::max);
    // Slivers first (the zero-area limit included), then edge lengths: declined before the
    // planarity and turn tests, which they would pass only to fail later.
    if !(nn >= SLIVER_AREA2 * extent2 * extent2) {
        return None;
    }
    let e2: [f64; M] = std::array::from_fn(|i| e[i].length_squared());
    let m2 = MARGIN * MARGIN;
    if !e2.iter().all(|&l2| l2 >= m2 * extent2) {
        return None;
    }
    for k in 1..M {
        let h = d[k].dot(normal);
        if !(h * h <= PLANARITY * PLANARITY * extent2 * nn) {
            return None;
        }
        if k + 1 < M && !(fan[k].dot(normal) > 0.0) {
            return None;
        }
        if k > 2 && !(d[1].cross(d[k]).dot(normal) > 0.0) {
            return None;
        }
    }
    for i in 0..M {
        let p = (i + M - 1) % M;
        let t = e[p].cross(e[i]).dot(normal);
        if !(t > 0.0 && t * t >= m2 * e2[p] * e2[i] * nn) {
            return None;
        }
    }
    Some(normal)
}
