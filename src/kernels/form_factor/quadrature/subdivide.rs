//! Subdivided quadrature: the fan triangles bisected until each piece is far-field, each piece
//! integrated by the far-field rule four nodes at a time.

use glam::DVec3;
use smallvec::SmallVec;

use crate::kernels::form_factor::clip::ClipVertex;
#[cfg(target_arch = "x86_64")]
use crate::kernels::form_factor::quadrature::lanes::AvxSums;
use crate::kernels::form_factor::quadrature::lanes::{rule_piece_sums, GroupSums, PortableSums};
use crate::kernels::form_factor::quadrature::rules::far_field_rule;
use crate::kernels::form_factor::quadrature::tensor::{accumulate, fan_geometry};
use crate::{Deriv3, Order};

/// A triangle awaiting quadrature, with its [`fan_geometry`].
type Piece = ([ClipVertex; 3], (DVec3, f64));

/// Most triangles [`subdivided_quadrature`] may use before giving up.
pub(crate) const MAX_PIECES: usize = 256;
/// The same for x near the polygon's plane with part of the polygon clipped away and the foot of x
/// outside the visible part, when
/// [`near_plane_value`](crate::kernels::form_factor::near_plane::split::near_plane_value) declines:
/// x also within `10 h_P` of an edge line, or the split's own parts cancelling (a small corner cut
/// off). There the edge sum's O(1) terms sum to the O(h_P) value, and graded refinement towards x
/// takes up to ~1500 pieces at h_P = 1e-6. Elsewhere in this configuration the split takes the
/// value in closed form (the cancellation is not intrinsic: see
/// [`near_plane_value`](crate::kernels::form_factor::near_plane::split::near_plane_value)).
pub(crate) const MAX_PIECES_NEAR_PLANE: usize = 4096;

/// The fan triangles of the loop, bisected along their longest edge until each is far from x
/// (centroid distance ≥
/// [`FAR_FIELD_RATIO`](crate::kernels::form_factor::quadrature::rules::FAR_FIELD_RATIO) × radius),
/// then integrated by
/// [`triangle_rule`](crate::kernels::form_factor::quadrature::tensor::triangle_rule)'s rule, four
/// nodes at a time. For polygons whose edge sum cancels (slivers, x near the plane) while x is not
/// close to them. `None` if that would take more than `max_pieces` triangles.
pub(crate) fn subdivided_quadrature(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
    exact: bool,
    max_pieces: usize,
) -> Option<Deriv3> {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2_fma() {
        // SAFETY: `simd::avx2_fma` checked that the CPU has AVX2 and FMA.
        return unsafe { subdivided_quadrature_fma(verts, n, order, exact, max_pieces) };
    }
    subdivided_quadrature_with::<PortableSums>(verts, n, order, exact, max_pieces)
}

/// [`subdivided_quadrature`] compiled with AVX2 and FMA: four nodes per register in the pieces'
/// sums, and fused double-double products in their exact fan geometry, with the portable build's
/// bits (the lanes round and are added as there; the fused product is correctly rounded either
/// way and Rust fuses nothing else).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn subdivided_quadrature_fma(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
    exact: bool,
    max_pieces: usize,
) -> Option<Deriv3> {
    subdivided_quadrature_with::<AvxSums>(verts, n, order, exact, max_pieces)
}

#[inline(always)]
fn subdivided_quadrature_with<S: GroupSums>(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
    exact: bool,
    max_pieces: usize,
) -> Option<Deriv3> {
    match order {
        Order::Value => subdivide::<S, false, false>(verts, n, exact, max_pieces),
        Order::Gradient => subdivide::<S, true, false>(verts, n, exact, max_pieces),
        Order::Hessian => subdivide::<S, true, true>(verts, n, exact, max_pieces),
    }
}

/// [`subdivided_quadrature`]'s bisection, with the pieces' sums as asked.
#[inline(always)]
fn subdivide<S: GroupSums, const GRADIENT: bool, const HESSIAN: bool>(
    verts: &[ClipVertex],
    n: DVec3,
    exact: bool,
    max_pieces: usize,
) -> Option<Deriv3> {
    let order = match (GRADIENT, HESSIAN) {
        (false, _) => Order::Value,
        (true, false) => Order::Gradient,
        (true, true) => Order::Hessian,
    };
    let n_lanes = crate::kernels::numeric::lanes::V3::<S::Lane>::splat(n);
    // Each piece carries its (2·area·N̂, 2·area·N̂·r_a): bisection halves both exactly, so the
    // pieces inherit the accuracy of the fan triangles' geometry.
    let mut stack: SmallVec<[Piece; 16]> = SmallVec::new();
    for k in 1..verts.len() - 1 {
        let (a, b, c) = (verts[0], verts[k], verts[k + 1]);
        stack.push(([a, b, c], fan_geometry(&a, &b, &c, exact)));
    }
    let mut out = Deriv3::constant(0.0);
    let mut pieces = 0;
    while let Some((t, geometry)) = stack.pop() {
        let centroid = (t[0].r + t[1].r + t[2].r) / 3.0;
        let radius = t
            .iter()
            .map(|v| (v.r - centroid).length())
            .fold(0.0, f64::max);
        if let Some(rule) = far_field_rule(centroid.length(), radius) {
            pieces += 1;
            if pieces > max_pieces {
                return None;
            }
            let sums = rule_piece_sums::<S, GRADIENT, HESSIAN>(&t[0], &t[1], &t[2], &n_lanes, rule);
            accumulate(&mut out, sums.assemble(n, geometry, order));
            continue;
        }
        if stack.len() + pieces >= max_pieces {
            return None;
        }
        // bisect the longest edge (keeps the orientation of both halves)
        let len = |i: usize| (t[(i + 1) % 3].u - t[i].u).length_squared();
        let i = (0..3)
            .max_by(|&p, &q| len(p).total_cmp(&len(q)))
            .unwrap_or(0);
        let (p, q, o) = (t[i], t[(i + 1) % 3], t[(i + 2) % 3]);
        let m = ClipVertex {
            u: (p.u + q.u) * 0.5,
            r: (p.r + q.r) * 0.5,
            r_lo: DVec3::ZERO,
            on_line: false,
        };
        let half = (geometry.0 * 0.5, geometry.1 * 0.5);
        stack.push(([p, m, o], half));
        stack.push(([m, q, o], half));
    }
    Some(out)
}

#[cfg(test)]
mod tests;
