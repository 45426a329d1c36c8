//! The value of a strictly convex polygon's form factor (4 to 8 vertices) with `x` near its
//! plane, outside the part the tangent plane leaves visible: the robust path's near-plane split
//! ([`near_plane_value`]) without the rest of its set-up, as `near_plane::triangle` does for
//! triangles (read its module documentation first).
//!
//! For `Order::Value` in this configuration
//! [`evaluate`](crate::kernels::form_factor::robust::evaluate) validates the polygon (Newell's
//! plane, planarity, the O(m²) simplicity test), builds the generic machinery (growable vectors,
//! the fan's far-field test, full edge frames) and then uses only the split. This route replays the
//! decisions and operations of that evaluation which the split's result depends on, on fixed-size
//! arrays, so that it returns the robust path's bits, and declines (`None`) wherever the robust
//! path would not take the split for the value: `x` not near the plane, nothing clipped, the foot
//! of `x` inside the clipped loop, a sliver, or the split itself declining. Where the visible part
//! is far-field against its size (a small corner cut off, seen from afar), the robust path
//! integrates it by its far-field rule instead of the split: so does the route, on its loop, and
//! the derivative orders take the same rule's derivatives
//! ([`deferred_far_piece`](crate::kernels::form_factor::near_plane::far_piece::deferred_far_piece)).
//!
//! What differs from the triangle's replay: the plane is Newell's sum over every edge (as
//! [`Plane::new`] forms it; for a triangle it reduces to one cross product), validated for
//! planarity as the robust path does, and the clipped loop may have up to `2M` points (a plane
//! cuts a convex polygon twice, but the double-double heights of a polygon planar only to its
//! tolerance may change sign more often; the capacity is Sutherland-Hodgman's bound). Only
//! polygons [`convex_normal`] accepts are taken: those the robust validation certainly accepts
//! (simplicity included, so its O(m²) test is not replayed) and that are not slivers (neither
//! the sliver fan path nor `evaluate`'s sliver rule takes them).
//!
//! Its f64 screen runs in the portable build; the exact height, the clip, the frames and the split
//! are compiled a second time with AVX2 and FMA where the CPU has them, with the same bits (see
//! `near_plane::triangle`'s `split_fma`). The derivative orders run the same route through
//! [`clipped_polygon_value_and_loop`], which also hands out its loop for the clipped loop's
//! derivatives (`lambert::clipped_polygon::routed_polygon_derivs`). Its cost against the robust
//! path is in docs/kernels.md, "Hard regimes".

use glam::DVec3;

use crate::kernels::form_factor::clip::{clip_by_heights, next, ArrayOut, ClipVertex};
use crate::kernels::form_factor::convex::convex_normal;
use crate::kernels::form_factor::near_plane::clipped_loop::clipped_loop_value;
use crate::kernels::form_factor::near_plane::route_loop::{FarPiece, RouteLoop, CLIP_VERTEX_ZERO};
use crate::kernels::form_factor::near_plane::split::NEAR_PLANE_RATIO;
use crate::kernels::form_factor::plane::{exact_height_of, Plane, NEAR_PLANE_HEIGHT};
use crate::kernels::form_factor::validate::unit;
use crate::kernels::numeric::dd::{self, Dd3};

/// The value of [`polygon_form_factor`](crate::kernels::polygon_form_factor) for `Order::Value`
/// (form factor, dimensionless, in `[0, 1]`) of the `M` vertices `v` (4 to 8) when the robust
/// path would take it from its near-plane split, bit for bit; `None` when it would not (module
/// documentation), for polygons [`convex_normal`] does not accept, for coordinate differences
/// outside (1e-30, 1e30) and for invalid input, which the callers leave to the robust path.
/// `N = 2M`, the clipped loop's capacity.
// Not inlined: the callers that do not take it pay for the call's test only.
#[inline(never)]
pub(crate) fn polygon_value<const M: usize, const N: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
) -> Option<f64> {
    debug_assert!(N >= 2 * M);
    let s = screen(x, n, v)?;
    let mut points = [CLIP_VERTEX_ZERO; N];
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2_fma() {
        // SAFETY: `simd::avx2_fma` checked that the CPU has AVX2 and FMA.
        return unsafe {
            split_fma::<M, N>(x, v, &s, &mut points, &mut [], &mut [], &mut None, false)
        }
        .map(|(value, _, _)| value);
    }
    split::<M, N>(x, v, &s, &mut points, &mut [], &mut [], &mut None, false)
        .map(|(value, _, _)| value)
}

/// [`polygon_value`] with the exact signed height `h_P` of `x` over the polygon's plane (along
/// Newell's normal, positive when it points away from `x`; in the units of `v`), which orients the
/// derivative orders' loop as the robust edge sum is oriented, and with the clipped loop it
/// computed the value on, written to `out` (unspecified where it declines), for those orders, which
/// take its points (the double-double clip points), the vectors of its edges from a kept vertex to
/// a clip point (or back) and its well-conditioned edges' angles (see `near_plane_value`) instead
/// of computing them a second time. The loop's points are, for `i` in `0..M`, vertex `i` when it is
/// kept, then the crossing of edge `i → i + 1` when there is one (`clip`'s order). Also returned:
/// the unit normal ([`validate::unit`](crate::kernels::form_factor::validate::unit)) and `r_k = v_k
/// − x`, which the derivative orders' loop takes rather than forming them again.
#[inline(always)]
pub(crate) fn clipped_polygon_value_and_loop<const M: usize, const N: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
    out: &mut RouteLoop<N>,
) -> Option<(f64, f64, DVec3, [DVec3; M])> {
    debug_assert!(N >= 2 * M);
    let s = screen(x, n, v)?;
    let RouteLoop {
        points,
        angles,
        edges,
        count,
        far,
        defer_far,
    } = out;
    let defer_far = *defer_far;
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2_fma() {
        // SAFETY: `simd::avx2_fma` checked that the CPU has AVX2 and FMA.
        let (value, h_p, k) =
            unsafe { split_fma::<M, N>(x, v, &s, points, angles, edges, far, defer_far) }?;
        *count = k;
        return Some((value, h_p, s.n, s.r));
    }
    let (value, h_p, k) = split::<M, N>(x, v, &s, points, angles, edges, far, defer_far)?;
    *count = k;
    Some((value, h_p, s.n, s.r))
}

/// What [`screen`] hands to [`split`].
struct Screened<const M: usize> {
    r: [DVec3; M],
    u: [DVec3; M],
    /// The unit receiver normal.
    n: DVec3,
    plane: Plane,
}

/// The robust path's decisions that need no double-double arithmetic, and a cheap f64 test of
/// the split's edge-line limit; `None` where the route declines.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN declines
fn screen<const M: usize>(x: DVec3, n: DVec3, v: &[DVec3; M]) -> Option<Screened<M>> {
    if !(x.is_finite() && v.iter().all(|vk| vk.is_finite())) {
        return None;
    }
    let r: [DVec3; M] = crate::kernels::numeric::array::array_from(|k| v[k] - x);
    let u: [DVec3; M] = crate::kernels::numeric::array::array_from(|k| v[k] - v[0]);
    // Two loops, in the chain's order: the chained iterator's fold was an out-of-line call.
    let mut largest = 0.0f64;
    for d in &r {
        largest = largest.max(d.abs().max_element());
    }
    for d in &u[1..] {
        largest = largest.max(d.abs().max_element());
    }
    if !(largest > 1e-30 && largest < 1e30) {
        return None;
    }
    let n = unit(n)?;
    // Nothing can be clipped when every rounded height over the tangent plane is positive beyond
    // its rounding bound: the robust path would not take the split.
    if r.iter()
        .all(|rk| n.dot(*rk) > 8.0 * f64::EPSILON * n.abs().dot(rk.abs()))
    {
        return None;
    }
    // `Plane::new`'s Newell sum.
    let mut nn = DVec3::ZERO;
    for i in 0..M {
        nn += u[i].cross(u[next(i, M)]);
    }
    // Far from the plane, declined before the validation: the height's decision below, on
    // `r_0` for the nearest vertex and twice its limit, which covers the rounding of the unit
    // normal and the polygon's tolerated non-planarity (2.5e-9 of its extent, `convex_normal`)
    // by orders of magnitude. Squared, without roots (NaN passes, to be refused next).
    let length2: [f64; M] = crate::kernels::numeric::array::array_from(|k| r[k].length_squared());
    let r_max2 = length2.iter().fold(0.0, |m: f64, &l| m.max(l));
    let side = nn.dot(r[0]);
    if side * side > 4.0 * NEAR_PLANE_HEIGHT * NEAR_PLANE_HEIGHT * nn.length_squared() * r_max2 {
        return None;
    }
    convex_normal(v)?;
    // `Plane::new`'s extent (the max of the roots is the root of the max), and its validation
    // without the simplicity test, which `convex_normal` certifies.
    let extent = u
        .iter()
        .map(|uk| uk.length_squared())
        .fold(0.0, f64::max)
        .sqrt();
    let plane = Plane::validated(&u, nn, extent, false).ok()?;
    if plane.is_very_thin() {
        return None;
    }
    // The first nearest vertex, as `evaluate`'s `min_by` picks it.
    let mut nearest = 0;
    for k in 1..M {
        if length2[k] < length2[nearest] {
            nearest = k;
        }
    }
    let nearest = r[nearest];
    let h_rounded = plane.normal.dot(nearest);
    let r_max = r_max2.sqrt();
    if !(h_rounded.abs() > 4.0 * f64::EPSILON * r_max
        && h_rounded.abs() < NEAR_PLANE_HEIGHT * r_max)
    {
        return None;
    }
    // The split declines when x's foot is within 10 |h_P| of the line of an edge of the clipped
    // loop off the tangent plane: those lie on the lines of the polygon's edges that keep a
    // vertex above it. Tested here in f64 before the double-double set-up; a decline only sends
    // the call to the robust path, which takes the same decisions exactly.
    for i in 0..M {
        let j = next(i, M);
        if n.dot(r[i]) < 0.0 && n.dot(r[j]) < 0.0 {
            continue;
        }
        let e = u[j] - u[i];
        if !(h_rounded.abs() * e.length()
            < NEAR_PLANE_RATIO * plane.normal.dot(r[i].cross(e)).abs())
        {
            return None;
        }
    }
    Some(Screened { r, u, n, plane })
}

/// [`split`] compiled with FMA: only the double-double products' exact error terms are fused
/// (Rust does not contract `a * b + c`), so the bits are those of the portable build.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
unsafe fn split_fma<const M: usize, const N: usize>(
    x: DVec3,
    v: &[DVec3; M],
    s: &Screened<M>,
    points: &mut [ClipVertex; N],
    angles: &mut [f64],
    edges: &mut [DVec3],
    far: &mut Option<FarPiece>,
    defer_far: bool,
) -> Option<(f64, f64, usize)> {
    split::<M, N>(x, v, s, points, angles, edges, far, defer_far)
}

/// The exact height, the clip (into `points`), the remaining decisions and the split itself: the
/// value, the exact height and the loop's length; where `angles` and `edges` have entries, the
/// loop's edges' angles (see `near_plane_value`) and the vectors of its edges (the clip edge's from
/// `near_plane_value`). Where the visible part is far-field, the far-field rule's value instead,
/// and `far` set; with `defer_far` that rule's value is left to
/// [`deferred_far_piece`](crate::kernels::form_factor::near_plane::far_piece::deferred_far_piece)
/// (the derivative orders) and the value returned is NaN.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn split<const M: usize, const N: usize>(
    x: DVec3,
    v: &[DVec3; M],
    s: &Screened<M>,
    points: &mut [ClipVertex; N],
    angles: &mut [f64],
    edges: &mut [DVec3],
    far: &mut Option<FarPiece>,
    defer_far: bool,
) -> Option<(f64, f64, usize)> {
    let Screened { r, u, n, plane } = s;
    let n = *n;
    let err = |a: f64, b: f64| dd::two_sum(a, -b).1;
    let r_lo: [DVec3; M] =
        std::array::from_fn(|k| DVec3::new(err(v[k].x, x.x), err(v[k].y, x.y), err(v[k].z, x.z)));
    let h_p = exact_height_of(r, &r_lo, plane.twice_area);
    let count = clip_polygon(u, r, &r_lo, n, points)?;
    let value = clipped_loop_value::<N>(
        &points[..count],
        n,
        plane.normal,
        h_p,
        angles,
        edges,
        far,
        defer_far,
    )?;
    Some((value, h_p, count))
}

/// [`clip`](crate::kernels::form_factor::clip::clip) on fixed arrays (the same operations, so the
/// same vertices): the loop in `out` (capacity `N ≥ 2M`, Sutherland-Hodgman's bound) and its
/// length, `None` when nothing is cut away or fewer than three vertices remain.
#[inline(always)]
fn clip_polygon<const M: usize, const N: usize>(
    u: &[DVec3; M],
    r: &[DVec3; M],
    r_lo: &[DVec3; M],
    n: DVec3,
    out: &mut [ClipVertex; N],
) -> Option<usize> {
    let exact: [Dd3; M] = std::array::from_fn(|k| Dd3::from_parts(r[k], r_lo[k]));
    let d: [dd::Dd; M] = std::array::from_fn(|k| exact[k].dot_f64(n));
    let mut loop_out = ArrayOut { verts: out, len: 0 };
    let cut = clip_by_heights(u, r, r_lo, |k| exact[k], &d, &mut loop_out);
    let count = loop_out.len;
    (cut && count >= 3).then_some(count)
}

#[cfg(test)]
mod tests;
