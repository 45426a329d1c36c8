//! The loop a near-plane route hands to the clipped loop's derivatives: its double-double clip
//! points, edge vectors and well-conditioned angles, and the far-field piece it deferred.

use glam::DVec3;

use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::edge::NEAR_LINE_SINE;
use crate::kernels::form_factor::near_plane::split::InPlaneEdge;
use crate::kernels::form_factor::quadrature::rules::Rule;
use crate::kernels::numeric::dd::Dd3;

pub(crate) const CLIP_VERTEX_ZERO: ClipVertex = ClipVertex {
    u: DVec3::ZERO,
    r: DVec3::ZERO,
    r_lo: DVec3::ZERO,
    on_line: false,
};

/// The clipped loop
/// [`clipped_triangle_value_and_loop`](crate::kernels::form_factor::near_plane::triangle::clipped_triangle_value_and_loop)
/// computed its value on, for the derivative orders, which use the same clip points instead of
/// clipping a second time: the first [`count`](RouteLoop::count) points, for `i` in 0..3 vertex `i`
/// when it is kept, then the crossing of edge `i → i + 1` when there is one. Filled in place by the
/// caller's frame. `N`: the capacity, 4 for a triangle (`near_plane::polygon`'s loops use `2M` for
/// `M` vertices, their points in the same order, for `i` in `0..M`).
pub(crate) struct RouteLoop<const N: usize = 4> {
    pub(crate) points: [ClipVertex; N],
    pub(crate) angles: [f64; N],
    pub(crate) edges: [DVec3; N],
    pub(crate) count: usize,
    /// Set where the visible part is far-field against its size and the value came from the
    /// robust path's far-field rule on the loop.
    pub(crate) far: Option<FarPiece>,
    /// Set by the caller before the route runs: where the far-field rule is taken, leave its value
    /// to
    /// [`deferred_far_piece`](crate::kernels::form_factor::near_plane::far_piece::deferred_far_piece),
    /// which sums it with the derivatives (one pass over the rule's nodes instead of two).
    pub(crate) defer_far: bool,
}

/// What the far-field rule on a route's loop needs for its derivatives: the rule, the unit
/// receiver normal and the polygon's unit normal (both as the robust path has them) and the exact
/// height of `x` over the plane.
#[derive(Clone, Copy)]
pub(crate) struct FarPiece {
    pub(crate) rule: Rule,
    pub(crate) n: DVec3,
    pub(crate) plane_normal: DVec3,
    pub(crate) h_p: f64,
}

/// The parts of [`EdgeFrame::with_exact_ends`](crate::kernels::form_factor::edge::EdgeFrame) that
/// [`near_plane_value`](crate::kernels::form_factor::near_plane::split::near_plane_value) reads, by
/// the same operations (the double-double cross product and abscissae when x is near the edge's
/// line), for its edge vector `e` (`edge_vector(a, b)`); `None` for a zero-length edge.
#[inline(always)]
pub(crate) fn in_plane_edge(a: &ClipVertex, b: &ClipVertex, e: DVec3) -> Option<InPlaneEdge> {
    let len = e.length();
    if len == 0.0 {
        return None;
    }
    let e_hat = e / len;
    let mut w = a.r.cross(e);
    let mut sa = a.r.dot(e_hat);
    let mut sb = sa + len;
    let bound = NEAR_LINE_SINE * len;
    if w.length_squared() < bound * bound * a.r.length_squared() {
        // `ExactEnds::cross`: r_a × r_b in double-double, rounded once.
        w = Dd3::from_parts(a.r, a.r_lo)
            .cross(&Dd3::from_parts(b.r, b.r_lo))
            .to_dvec3();
        sa = a.r.dot(e_hat) + a.r_lo.dot(e_hat);
        sb = b.r.dot(e_hat) + b.r_lo.dot(e_hat);
    }
    Some(InPlaneEdge {
        e_hat,
        len,
        w,
        sa,
        sb,
    })
}
