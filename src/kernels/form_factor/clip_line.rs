//! The Hessian term of the moving clip line: where the tangent plane cuts the polygon, the clip
//! line moves with `x` and adds `n nᵀ (|h_P| / (π ‖n_t‖)) ∫ ds/‖y − x‖⁴` along it to the Hessian.

use std::f64::consts::FRAC_1_PI;

use glam::{DMat3, DVec3};

use crate::error::Result;
use crate::kernels::form_factor::clip::{edge_vector, next, ClipVertex};
use crate::kernels::form_factor::edge::{outer_self, EdgeFrame};
use crate::kernels::form_factor::sliver::geometry::visible_plane;
use crate::Order;

/// The Hessian term from the motion of the clip line ℓ:
/// `n nᵀ (|h_P| / (π ‖n_t‖)) ∫_{P∩ℓ} ds/‖r‖⁴`, with `P∩ℓ` the oriented clip edges (bridges of
/// non-convex polygons traverse ℓ twice in opposite directions and cancel).
///
/// With `exact_edges` the clip edges come from the clip points' exact differences
/// ([`edge_vector`]) instead of their rounded `u`, whose difference errs by ~ε·extent: a sliver's
/// clip edge spans its width, so that error is ~ε/aspect of its length (2.5e-6 of the Hessian for
/// apex 1e-9 of the length, `tests/form_factor_clipped_slivers.rs`), and `∫ ds/‖r‖⁴` is the
/// closed form's `A_2` ([`EdgeFrame::moments`], a few ulps also on such short edges seen from
/// near their line's extension, where its series once cancelled to 3.8e-8). With `local_planes`
/// each clip edge takes `|h_P| / ‖n_t‖` from the plane of the triangle it forms with the loop's
/// next vertex (`plane_n`, `h_p` only where that triangle is degenerate): a thin polygon's rounded
/// vertices twist its plane by ~ε/aspect, which cost 5.3e-9 of the Hessian with the plane of the
/// whole loop (a 6-vertex visible loop 1e-7 wide, `tests/form_factor_polygon_slivers.rs`; 5.9e-15
/// with the edge's own plane). A clipped triangle's loop is planar (its clip points lie on its
/// edges to double-double): `plane_n`, `h_p` from its exact fan geometry serve every clip edge.
/// Inlined, as [`clip`](crate::kernels::form_factor::clip::clip).
#[inline(always)]
pub(crate) fn clip_line_hessian(
    verts: &[ClipVertex],
    n: DVec3,
    plane_n: DVec3,
    h_p: f64,
    exact_edges: bool,
    local_planes: bool,
) -> Result<DMat3> {
    let n_t = n - n.dot(plane_n) * plane_n;
    let nt_len = n_t.length();
    let along = (n_t / nt_len).cross(plane_n);
    let count = verts.len();
    let mut integral = 0.0;
    for i in 0..count {
        let (a, b) = (verts[i], verts[next(i, count)]);
        if !(a.on_line && b.on_line) {
            continue;
        }
        let e = if exact_edges {
            edge_vector(&a, &b)
        } else {
            b.u - a.u
        };
        let Some(frame) = EdgeFrame::new(a.r, e) else {
            continue;
        };
        let a2 = frame.moments(Order::Gradient)?.a2;
        if !exact_edges {
            integral += a2.copysign(e.dot(along));
            continue;
        }
        if !local_planes {
            integral += a2.copysign(e.dot(along)) * (h_p.abs() / nt_len);
            continue;
        }
        // The plane at the clip edge: the triangle of the edge and the loop's next vertex. A thin
        // polygon's rounded vertices twist its plane by ~ε/aspect radians (1e-9 for a width of
        // 1e-7 of the length), and `|h_P| / ‖n_t‖` follows the plane where the line moves.
        let c = verts[next(next(i, count), count)];
        let (local_n, local_h) = visible_plane(&[a, b, c]).unwrap_or((plane_n, h_p));
        let local_t = n - n.dot(local_n) * local_n;
        let local_len = local_t.length();
        let local_along = (local_t / local_len).cross(local_n);
        integral += a2.copysign(e.dot(local_along)) * (local_h.abs() / local_len);
    }
    if integral == 0.0 {
        return Ok(DMat3::ZERO);
    }
    if exact_edges {
        return Ok(outer_self(n) * (FRAC_1_PI * integral));
    }
    Ok(outer_self(n) * (h_p.abs() * FRAC_1_PI / nt_len * integral))
}
