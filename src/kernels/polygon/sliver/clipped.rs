//! The clipped sliver's direct entry: `evaluate`'s clipped sliver branch without its set-up.

use glam::DVec3;

use super::super::{clip, clip_line_hessian, ClipLoop, ClipVertex, Plane};
use super::{clipped_sliver_quadrature, visible_plane};
use crate::{Deriv3, Order};

/// The form factor of a sliver triangle (`u`, `r`, `r_lo` as for
/// [`direct_sliver`](super::direct_sliver)) that the receiver's tangent plane may cut, with
/// `plane` and `h_p` as `evaluate` takes them (x not near the plane): the same clip, rule, sign,
/// clip-line term and clamp as `evaluate`, so the same bits. `None` when nothing is cut after all
/// (a vertex within the rounding margin of the tangent plane but above it), when the rule
/// declines, or when the result or the clip-line term fails; the caller then takes `evaluate`,
/// which answers (or fails) as it always has.
pub(super) fn clipped_sliver(
    u: &[DVec3; 3],
    r: &[DVec3; 3],
    r_lo: &[DVec3; 3],
    n: DVec3,
    order: Order,
    plane: &Plane,
    h_p: f64,
) -> Option<Deriv3> {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2_fma() {
        // SAFETY: `simd::avx2_fma` checked that the CPU has AVX2 and FMA.
        return unsafe { clipped_sliver_fma(u, r, r_lo, n, order, plane, h_p) };
    }
    clipped_sliver_with(u, r, r_lo, n, order, plane, h_p)
}

/// [`clipped_sliver`] compiled with AVX2 and FMA: the clip's double-double heights and points and
/// the visible plane's exact products take fused instructions instead of calls to `fma` (a fifth
/// of the clipped value's instructions). The same bits: the fused product is correctly rounded
/// either way, and Rust fuses nothing else (unit-tested).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn clipped_sliver_fma(
    u: &[DVec3; 3],
    r: &[DVec3; 3],
    r_lo: &[DVec3; 3],
    n: DVec3,
    order: Order,
    plane: &Plane,
    h_p: f64,
) -> Option<Deriv3> {
    clipped_sliver_with(u, r, r_lo, n, order, plane, h_p)
}

#[inline(always)]
fn clipped_sliver_with(
    u: &[DVec3; 3],
    r: &[DVec3; 3],
    r_lo: &[DVec3; 3],
    n: DVec3,
    order: Order,
    plane: &Plane,
    h_p: f64,
) -> Option<Deriv3> {
    let mut clipped = ClipLoop::new();
    if !clip(u, r, r_lo, n, &mut clipped) {
        return None;
    }
    let verts: &[ClipVertex] = &clipped;
    if verts.len() < 3 {
        return Some(Deriv3::constant(0.0));
    }
    let mut d = crate::kernels::form_factor::oriented(
        clipped_sliver_quadrature(verts, n, order)?,
        h_p,
    )?;
    if order.hessian() {
        // `evaluate` adds the term after the sign and before the clamp, which touches the value
        // only: the same sum.
        let sliver_plane = visible_plane(verts);
        let (plane_n, height) = sliver_plane.unwrap_or((plane.normal, h_p));
        d.hessian += clip_line_hessian(verts, n, plane_n, height, sliver_plane.is_some()).ok()?;
        if !d.is_finite() {
            return None;
        }
    }
    Some(d)
}
