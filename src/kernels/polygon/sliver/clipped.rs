//! The clipped sliver's direct entry: `evaluate`'s clipped sliver branch without its set-up.

use glam::DVec3;

use super::super::{clip, clip_line_hessian, ClipVertex, Plane, TriangleLoop};
#[cfg(target_arch = "x86_64")]
use super::AvxSums;
use super::{
    clipped_sliver_quadrature_with, rule_sums, rules, sliver_geometry, GroupSums, PortableSums,
    ThinPiece,
};
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
    clipped_sliver_with::<PortableSums>(u, r, r_lo, n, order, plane, h_p)
}

/// [`clipped_sliver`] compiled with AVX2 and FMA: the clip's double-double heights and points and
/// the visible plane's exact products take fused instructions instead of calls to `fma` (a fifth
/// of the clipped value's instructions), and the sums take four nodes per AVX register. The same
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
/// [`sliver_quadrature`](super::sliver_quadrature), split at the foot of the vertex opposite the
/// longest edge, except where that foot lies within the vertex's height of an end of the edge.
/// There the piece at that end is no longer than it is wide, but it would cost a whole rule, and
/// the triangle is one thin piece from the other end instead (its short edge, the opposite one, at
/// most √2 times the height). Every fan triangle touching the clip edge of a cut sliver is such a
/// triangle: the clip edge is as short as the sliver is wide, and the foot of its far vertex on
/// the long side lies at its end. A quadrilateral visible part takes three pieces instead of four.
#[inline(always)]
pub(super) fn fan_triangle<S: GroupSums>(
    v0: &ClipVertex,
    v1: &ClipVertex,
    v2: &ClipVertex,
    n: DVec3,
    order: Order,
) -> Option<(Deriv3, (DVec3, f64))> {
    // The longest edge (the last of equals), by reference: choosing it with `%` and copying the
    // vertices cost ~150 instructions per triangle.
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

#[cfg(test)]
mod tests {
    use super::super::super::triangle_plane;
    use super::*;
    use crate::test_rng::lcg;

    /// The AVX2+FMA builds of the clipped entry and of the visible part's rule give the portable
    /// builds' bits, on slivers (apex 1e-5..1e-12 of the length, sizes 1e-3..1e3) cut by random
    /// tangent planes through x 1e-3..10 lengths away, at every order (and answer for most).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn fma_twins_keep_the_bits() {
        if !crate::simd::avx2_fma() {
            return;
        }
        let bits = |d: &Deriv3| {
            let mut b = vec![d.value.to_bits()];
            b.extend(d.gradient.to_array().map(f64::to_bits));
            b.extend(d.hessian.to_cols_array().map(f64::to_bits));
            b
        };
        let mut state = 1828;
        let (mut answered, mut cut) = (0, 0);
        for _ in 0..3000 {
            let mut c = || lcg(&mut state);
            let scale = 10f64.powf(6.0 * c() - 3.0);
            let a = DVec3::new(c(), c(), c()) * scale;
            let b = a + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize() * scale;
            let perp = (b - a).any_orthonormal_vector();
            let apex =
                a + (b - a) * (1.2 * c() - 0.1) + perp * (10f64.powf(-5.0 - 7.0 * c()) * scale);
            let x = (a + b) * 0.5
                + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5)
                    * (scale * 10f64.powf(4.0 * c() - 3.0));
            let n = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize();
            let v = [a, b, apex];
            let r = v.map(|vk| vk - x);
            let u = [DVec3::ZERO, b - a, apex - a];
            let err = |p: f64, q: f64| crate::kernels::numeric::dd::two_sum(p, -q).1;
            let r_lo = v.map(|vk| DVec3::new(err(vk.x, x.x), err(vk.y, x.y), err(vk.z, x.z)));
            let Some(plane) = triangle_plane(&u) else {
                continue;
            };
            let mut clipped = TriangleLoop::new();
            if !clip(&u, &r, &r_lo, n, &mut clipped) || clipped.len < 3 {
                continue;
            }
            cut += 1;
            let h_p = plane.normal.dot(r[0]);
            for order in [Order::Value, Order::Gradient, Order::Hessian] {
                let loop_ = clipped.as_slice();
                let portable = clipped_sliver_quadrature_with::<PortableSums>(loop_, n, order);
                // SAFETY: checked above that the CPU has AVX2 and FMA.
                let fused = unsafe { super::super::clipped_sliver_quadrature_fma(loop_, n, order) };
                assert_eq!(
                    portable.as_ref().map(|(d, _)| bits(d)),
                    fused.as_ref().map(|(d, _)| bits(d))
                );
                let portable =
                    clipped_sliver_with::<PortableSums>(&u, &r, &r_lo, n, order, &plane, h_p);
                // SAFETY: as above.
                let fused = unsafe { clipped_sliver_fma(&u, &r, &r_lo, n, order, &plane, h_p) };
                assert_eq!(portable.as_ref().map(bits), fused.as_ref().map(bits));
                answered += usize::from(portable.is_some());
            }
        }
        assert!(cut > 1000 && answered > 2000, "{cut} {answered}");
    }
}
