//! The value of a near-plane route's clipped loop, shared by the triangle's and the polygon's
//! routes once each has clipped its shape into fixed arrays: the far-field rule where the loop is
//! far against its size, a decline where the foot of `x` lies inside it, and otherwise the
//! near-plane split ([`near_plane_value`]) made visible. The same decisions and operations as the
//! robust path's, so the routes return its bits.

use glam::DVec3;

use crate::kernels::form_factor::clip::{edge_vector, next, ClipVertex};
use crate::kernels::form_factor::near_plane::far_piece::far_piece_value;
use crate::kernels::form_factor::near_plane::route_loop::{in_plane_edge, FarPiece};
use crate::kernels::form_factor::near_plane::split::{
    foot_inside, near_plane_value, SPLIT_VALUE_LIMIT,
};
use crate::kernels::form_factor::orient::visible_value;
use crate::kernels::form_factor::quadrature::rules::far_field_rule;

/// The form factor (dimensionless, in `[0, 1]`) of the clipped loop `verts` (at most `N`
/// vertices, relative to `x`) seen from `x` with unit normal `n`, for the plane of unit normal
/// `plane_normal` at exact signed height `h_p`; `None` where the route declines (the foot of `x`
/// inside the loop, the split declining, a non-finite value). Where `angles` and `edges` have
/// entries, the loop's edges' angles (see [`near_plane_value`]) and vectors (none for the clip
/// edge, which `near_plane_value` writes). Where the loop is far-field against its size, the
/// far-field rule's value instead, with `far` set; with `defer_far` that value is left to
/// [`deferred_far_piece`](crate::kernels::form_factor::near_plane::far_piece::deferred_far_piece)
/// and NaN is returned.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn clipped_loop_value<const N: usize>(
    verts: &[ClipVertex],
    n: DVec3,
    plane_normal: DVec3,
    h_p: f64,
    angles: &mut [f64],
    edges: &mut [DVec3],
    far: &mut Option<FarPiece>,
    defer_far: bool,
) -> Option<f64> {
    let count = verts.len();
    let centroid = verts.iter().map(|v| v.r).sum::<DVec3>() / count as f64;
    let radius = verts
        .iter()
        .map(|v| (v.r - centroid).length_squared())
        .fold(0.0, f64::max)
        .sqrt();
    if let Some(rule) = far_field_rule(centroid.length(), radius) {
        return far_piece_value(verts, n, plane_normal, h_p, rule, far, defer_far);
    }
    if foot_inside(verts, plane_normal, h_p) {
        return None;
    }
    // `edge_frames` with something cut: none for the clip edges.
    let mut frames = [None; N];
    for (i, frame) in frames[..count].iter_mut().enumerate() {
        let (a, b) = (&verts[i], &verts[next(i, count)]);
        if !(a.on_line && b.on_line) {
            let e = edge_vector(a, b);
            if let Some(edge) = edges.get_mut(i) {
                *edge = e;
            }
            *frame = in_plane_edge(a, b, e);
        }
    }
    let value = near_plane_value(
        verts,
        &frames[..count],
        n,
        plane_normal,
        h_p,
        SPLIT_VALUE_LIMIT,
        angles,
        edges,
    )?
    .0;
    visible_value(value, h_p)
}
