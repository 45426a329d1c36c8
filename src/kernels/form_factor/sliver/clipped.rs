//! The clipped sliver's direct entry: `evaluate`'s clipped sliver branch without its set-up.

use glam::DVec3;

use crate::kernels::form_factor::clip::{clip, ClipVertex, TriangleLoop};
use crate::kernels::form_factor::clip_line::clip_line_hessian;
use crate::kernels::form_factor::plane::Plane;
#[cfg(target_arch = "x86_64")]
use crate::kernels::form_factor::quadrature::lanes::AvxSums;
use crate::kernels::form_factor::quadrature::lanes::{GroupSums, PortableSums};
use crate::kernels::form_factor::quadrature::tensor::accumulate;
use crate::kernels::form_factor::sliver::geometry::{sliver_geometry, FanGeometry};
use crate::kernels::form_factor::sliver::rule::{rule_sums, rules, ThinPiece};
use crate::{Deriv3, Order};

/// The form factor of a sliver triangle (`u`, `r`, `r_lo` as for
/// [`direct_sliver`](crate::kernels::form_factor::sliver::direct::direct_sliver)) that the
/// receiver's tangent plane may cut, with `plane` and `h_p` as `evaluate` takes them (x not near
/// the plane): the same clip, rule, sign, clip-line term and clamp as `evaluate`, so the same bits.
/// `None` when nothing is cut after all (a vertex within the rounding margin of the tangent plane
/// but above it), when the rule declines, or when the result or the clip-line term fails; the
/// caller then takes `evaluate`, which answers (or fails) as it always has.
pub(crate) fn clipped_sliver(
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
    clipped_sliver_with::<PortableSums>(u, r, r_lo, n, order, plane, h_p)
}

/// [`clipped_sliver`] compiled with AVX2 and FMA: the clip's double-double heights and points and
/// the visible plane's exact products take fused instructions instead of calls to `fma` (a large
/// share of the clipped value's work), and the sums take four nodes per AVX register. The same
/// bits: the fused product is correctly rounded either way, the sums' lanes round as the portable
/// ones and are added in the same tree, and Rust fuses nothing else (unit-tested).
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
    clipped_sliver_with::<AvxSums>(u, r, r_lo, n, order, plane, h_p)
}

#[inline(always)]
fn clipped_sliver_with<S: GroupSums>(
    u: &[DVec3; 3],
    r: &[DVec3; 3],
    r_lo: &[DVec3; 3],
    n: DVec3,
    order: Order,
    plane: &Plane,
    h_p: f64,
) -> Option<Deriv3> {
    let mut clipped = TriangleLoop::new();
    if !clip(u, r, r_lo, n, &mut clipped) {
        return None;
    }
    let verts = clipped.as_slice();
    if verts.len() < 3 {
        return Some(Deriv3::constant(0.0));
    }
    let (mut d, geometry) = clipped_sliver_quadrature_with::<S>(verts, n, order)?;
    // As `evaluate` finishes: the sign (of every field, zeros included), the clip line's term,
    // the clamp; only the fields the order computes can be non-finite.
    if h_p < 0.0 {
        d.value = -d.value;
        d.gradient = -d.gradient;
        d.hessian = -d.hessian;
    }
    if order.hessian() {
        let sliver_plane = geometry.plane();
        let (plane_n, height) = sliver_plane.unwrap_or((plane.normal, h_p));
        let exact = sliver_plane.is_some();
        d.hessian += clip_line_hessian(verts, n, plane_n, height, exact, false).ok()?;
    }
    d.value = d.value.clamp(0.0, 1.0);
    let finite = d.value.is_finite()
        && (!order.gradient() || d.gradient.is_finite())
        && (!order.hessian() || d.hessian.is_finite());
    finite.then_some(d)
}

/// The rule on one fan triangle `(a, b, c)` of a clipped sliver's visible part: as
/// [`sliver_quadrature`](crate::kernels::form_factor::sliver::rule::sliver_quadrature), split at
/// the foot of the vertex opposite the longest edge, except where that foot lies within the
/// vertex's height of an end of the edge. There the piece at that end is no longer than it is wide,
/// but it would cost a whole rule, and the triangle is one thin piece from the other end instead
/// (its short edge, the opposite one, at most √2 times the height). Every fan triangle touching the
/// clip edge of a cut sliver is such a triangle: the clip edge is as short as the sliver is wide,
/// and the foot of its far vertex on the long side lies at its end. A quadrilateral visible part
/// takes three pieces instead of four.
#[inline(always)]
pub(crate) fn fan_triangle<S: GroupSums>(
    v0: &ClipVertex,
    v1: &ClipVertex,
    v2: &ClipVertex,
    n: DVec3,
    order: Order,
) -> Option<(Deriv3, (DVec3, f64))> {
    // The longest edge (the last of equals), by reference: no `%` and no copy of the vertices.
    let edges = [v1.u - v0.u, v2.u - v1.u, v0.u - v2.u];
    let [l0, l1, l2] = edges.map(|e| e.length_squared());
    let i = if l0 > l1 && l0 > l2 {
        0
    } else if l1 > l2 {
        1
    } else {
        2
    };
    let (a, b, c) = [(v0, v1, v2), (v1, v2, v0), (v2, v0, v1)][i];
    let ab = edges[i];
    let ab2 = ab.length_squared();
    let ac = c.u - a.u;
    let share = (ac.dot(ab) / ab2).clamp(0.0, 1.0);
    let height2 = ac.cross(ab).length_squared() / ab2;
    let table = rules();
    let mut pieces = [None, None];
    if share * share * ab2 <= height2 {
        pieces[0] = Some((ThinPiece::new(b, c, a, table)?, 1.0));
    } else if (1.0 - share) * (1.0 - share) * ab2 <= height2 {
        pieces[0] = Some((ThinPiece::new(a, b, c, table)?, 1.0));
    } else {
        let f = ClipVertex {
            u: a.u + share * ab,
            r: a.r + share * (b.r - a.r),
            r_lo: DVec3::ZERO,
            on_line: false,
        };
        pieces = [
            Some((ThinPiece::new(a, &f, c, table)?, share)),
            Some((ThinPiece::new(b, c, &f, table)?, 1.0 - share)),
        ];
    }
    let sums = match order {
        Order::Value => rule_sums::<S, false, false>(&pieces, n),
        Order::Gradient => rule_sums::<S, true, false>(&pieces, n),
        Order::Hessian => rule_sums::<S, true, true>(&pieces, n),
    }?;
    let geometry = sliver_geometry(a, b, c);
    Some((sums.assemble(n, geometry, order), geometry))
}

/// The signed form factor of a sliver cut by the receiver's tangent plane, from its visible part
/// `verts` (the clipped loop, x origin of the `r`, the clip points exact in double-double): the sum
/// of the rule over the loop's fan triangles from its first vertex
/// ([`clipped::fan_triangle`](crate::kernels::form_factor::sliver::clipped::fan_triangle)); `None`
/// when the rule declines any piece (the caller then takes the robust path).
///
/// The integrand's factor `n·r` vanishes on the clip line, so the derivatives of the clipped
/// integral are the integrals of the derivatives over the fixed visible part, except for the
/// Hessian's term from the clip line's motion, which the caller adds (`clip_line_hessian`, with
/// [`visible_plane`](crate::kernels::form_factor::sliver::geometry::visible_plane)). The fan pieces
/// of a sliver are slivers (their widths at most the sliver's), and the clip points' double-double
/// parts give each piece's geometry ([`sliver_geometry`]) to a few ulps, as for the uncut sliver.
/// The fan's signed sum is the integral over the loop for any simple loop (each piece's sign comes
/// from its own orientation), and every piece is checked by the rule to keep x away from it.
pub(crate) fn clipped_sliver_quadrature(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
) -> Option<(Deriv3, FanGeometry)> {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2_fma() {
        // SAFETY: `simd::avx2_fma` checked that the CPU has AVX2 and FMA.
        return unsafe { clipped_sliver_quadrature_fma(verts, n, order) };
    }
    clipped_sliver_quadrature_with::<PortableSums>(verts, n, order)
}

/// [`clipped_sliver_quadrature`] compiled with AVX2 and FMA (as the sliver rule's
/// `sliver_quadrature_fma`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn clipped_sliver_quadrature_fma(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
) -> Option<(Deriv3, FanGeometry)> {
    clipped_sliver_quadrature_with::<AvxSums>(verts, n, order)
}

#[inline(always)]
pub(crate) fn clipped_sliver_quadrature_with<S: GroupSums>(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
) -> Option<(Deriv3, FanGeometry)> {
    let mut total = Deriv3::constant(0.0);
    let mut geometry = FanGeometry::default();
    for k in 1..verts.len().checked_sub(1)? {
        let (d, g) = fan_triangle::<S>(&verts[0], &verts[k], &verts[k + 1], n, order)?;
        accumulate(&mut total, d);
        geometry.add(g);
    }
    Some((total, geometry))
}

#[cfg(test)]
mod tests;
