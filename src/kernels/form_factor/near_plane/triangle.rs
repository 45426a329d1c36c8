//! The value of a triangle's form factor with `x` near its plane, outside the part the tangent plane
//! leaves visible: the robust path's near-plane split ([`near_plane_value`]) without the rest of its
//! set-up.
//!
//! For `Order::Value` in this configuration
//! [`evaluate`](crate::kernels::form_factor::robust::evaluate) builds the generic machinery
//! (growable vectors, Newell's plane with its planarity check, the fan's far-field test, full edge
//! frames) and then uses only the split. This route replays exactly the decisions and the
//! operations of that evaluation which the split's result depends on, on fixed-size arrays, so that
//! it returns the robust path's bits (the gradient and Hessian orders, which take their value from
//! this route or the robust path's split, agree with it bit for bit), and declines (`None`)
//! wherever the robust path would not take the split for the value: `x` not near the plane, nothing
//! clipped, the foot of `x` inside the clipped loop, the far field, or the split itself declining.
//!
//! Its f64 screen runs in the portable build; what follows (the exact height and clip points in
//! double-double, the frames and the split) is compiled a second time with AVX2 and FMA where the
//! CPU has them (`RADDIFF_SIMD` caps it, see `simd`), with the same bits. Its cost against the
//! robust path is in docs/kernels.md, "Hard regimes".
//!
//! The gradient and Hessian orders run the same route through
//! [`clipped_triangle_value_and_loop`], which also hands out what the clipped loop's derivatives
//! (`lambert::clipped_derivs`) would otherwise compute a second time: the clipped loop (its
//! double-double clip points), the vectors of the edges from a kept vertex to a clip point, and
//! the well-conditioned edges' angles (see `near_plane_value`).

use glam::DVec3;

use crate::kernels::form_factor::clip::{clip_by_heights, next, ArrayOut, ClipVertex};
use crate::kernels::form_factor::near_plane::clipped_loop::clipped_loop_value;
use crate::kernels::form_factor::near_plane::route_loop::{FarPiece, RouteLoop, CLIP_VERTEX_ZERO};
use crate::kernels::form_factor::near_plane::split::NEAR_PLANE_RATIO;
use crate::kernels::form_factor::plane::{
    exact_height_of, triangle_plane, Plane, NEAR_PLANE_HEIGHT,
};
use crate::kernels::form_factor::validate::unit;
use crate::kernels::numeric::dd::{self, Dd3};

/// The value of [`triangle_form_factor`](crate::kernels::triangle_form_factor) for `Order::Value`
/// (form factor, dimensionless, in `[0, 1]`) when the robust path would take it from its near-plane
/// split, bit for bit; `None` when it would not (see the module documentation), and for input
/// outside the unscaled range of
/// [`triangle_form_factor_in_range`](crate::kernels::form_factor::robust::triangle_form_factor_in_range)
/// (coordinate differences in (1e-30, 1e30)) or invalid input, which the callers leave to the
/// robust path.
// Not inlined: the callers that do not take it pay for the call's test only.
#[inline(never)]
pub(crate) fn triangle_value(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<f64> {
    let s = screen(x, n, v)?;
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2_fma() {
        // SAFETY: `simd::avx2_fma` checked that the CPU has AVX2 and FMA.
        return unsafe { split_fma(x, v, &s) };
    }
    split(x, v, &s)
}

/// What [`screen`] hands to [`split`].
struct Screened {
    r: [DVec3; 3],
    u: [DVec3; 3],
    /// The unit receiver normal.
    n: DVec3,
    plane: Plane,
}

/// The robust path's decisions that need no double-double arithmetic (in its order), and a cheap
/// f64 test of the split's edge-line limit; `None` where the route declines.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN declines
fn screen(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<Screened> {
    let n = unit(n)?;
    screen_with(x, n, v, false)
}

/// [`screen`] for the unit normal `n = lambert::unit(n_in)?` already computed; `clipped` when
/// the caller has found, by the same test, some height over the tangent plane not certainly
/// positive (the test is then skipped: its outcome is known).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN declines
fn screen_with(x: DVec3, n: DVec3, v: [DVec3; 3], clipped: bool) -> Option<Screened> {
    if !(x.is_finite() && v.iter().all(|vk| vk.is_finite())) {
        return None;
    }
    let r = v.map(|vk| vk - x);
    let u = [DVec3::ZERO, v[1] - v[0], v[2] - v[0]];
    // Spelled out rather than an iterator chain, which did not inline on this hot path.
    let largest = (r[0].abs().max(r[1].abs()))
        .max(r[2].abs().max(u[1].abs().max(u[2].abs())))
        .max_element();
    if !(largest > 1e-30 && largest < 1e30) {
        return None;
    }
    // Nothing can be clipped when every rounded height over the tangent plane is positive beyond
    // its rounding bound (as in the fast paths): the common case leaves before any
    // double-double arithmetic. (The robust path normalizes `n` before its range check; both
    // decline, so the order does not matter.)
    if !clipped
        && r.iter()
            .all(|rk| n.dot(*rk) > 8.0 * f64::EPSILON * n.abs().dot(rk.abs()))
    {
        return None;
    }
    let plane = triangle_plane(&u)?;
    // The first nearest vertex, as `evaluate`'s `min_by` picks it.
    let mut nearest = r[0];
    for rk in &r[1..] {
        if rk.length_squared() < nearest.length_squared() {
            nearest = *rk;
        }
    }
    let h_rounded = plane.normal.dot(nearest);
    // One root for r_max: the root of the largest square is the largest root.
    let r_max = r
        .iter()
        .map(|rk| rk.length_squared())
        .fold(0.0, f64::max)
        .sqrt();
    if !(h_rounded.abs() > 4.0 * f64::EPSILON * r_max
        && h_rounded.abs() < NEAR_PLANE_HEIGHT * r_max)
    {
        return None;
    }
    // The split declines when x's foot is within 10 |h_P| of the line of an edge of the clipped
    // loop (x near an edge line, or near a clip vertex): those edges lie on the lines of the
    // triangle's edges that keep a vertex above the tangent plane. Tested here in f64 on the
    // triangle's edges, before the double-double set-up; a decline only sends the call to the
    // robust path, which takes the same decisions exactly.
    for i in 0..3 {
        let j = next(i, 3);
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

/// [`split`] compiled with FMA: the double-double products (exact height, clip points) become
/// single instructions instead of calls to `fma`. The fused product's error term is exact either
/// way, and nothing else is fused (Rust does not contract `a * b + c`), so the bits are those of
/// the portable build.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn split_fma(x: DVec3, v: [DVec3; 3], s: &Screened) -> Option<f64> {
    split(x, v, s)
}

/// The exact height, the clip, the remaining decisions and the split itself.
#[inline(always)]
fn split(x: DVec3, v: [DVec3; 3], s: &Screened) -> Option<f64> {
    let mut loop_ = [CLIP_VERTEX_ZERO; 4];
    split_loop(x, v, s, &mut loop_, &mut [], &mut [], &mut None, false).map(|(value, _)| value)
}

impl<const N: usize> RouteLoop<N> {
    #[inline(always)]
    pub(crate) fn new() -> RouteLoop<N> {
        RouteLoop {
            points: [CLIP_VERTEX_ZERO; N],
            angles: [f64::NAN; N],
            edges: [DVec3::ZERO; N],
            count: 0,
            far: None,
            defer_far: false,
        }
    }

    /// The vector of the edge from point `k` to the next where one of its ends is a clip point
    /// and the other not, and of the clip edge, where both are: one rounding of the exact
    /// difference of the ends (double-double).
    #[inline(always)]
    pub(crate) fn edge(&self, k: usize) -> DVec3 {
        self.edges[k]
    }

    /// The angle `β` the edge from point `k` to the next subtends at x where the split computed
    /// it (the edges off the tangent plane, see `near_plane_value`), NaN otherwise.
    #[inline(always)]
    pub(crate) fn angles(&self) -> [f64; N] {
        self.angles
    }

    /// The angle of [`angles`](RouteLoop::angles) of the edge from point `k` to the next.
    #[inline(always)]
    pub(crate) fn angle(&self, k: usize) -> f64 {
        self.angles[k]
    }

    /// The number of points.
    #[inline(always)]
    pub(crate) fn count(&self) -> usize {
        self.count
    }

    /// Point `k` relative to `x`: `(r, r_lo)` with `r + r_lo` exact and `r` its rounding (for a
    /// clip point, the double-double clip point: on the triangle's edge line and at the exact
    /// crossing of the tangent plane to ~u² relative).
    #[inline(always)]
    pub(crate) fn point(&self, k: usize) -> (DVec3, DVec3) {
        (self.points[k].r, self.points[k].r_lo)
    }

    /// Whether the value came from the far-field rule on the loop.
    #[inline(always)]
    pub(crate) fn is_far(&self) -> bool {
        self.far.is_some()
    }

    /// Whether point `k` is a clip point.
    #[inline(always)]
    pub(crate) fn is_clip_point(&self, k: usize) -> bool {
        self.points[k].on_line
    }
}

/// [`triangle_value`] with the clipped loop it computed the value on, written to `out`, for a
/// configuration where the caller has found the tangent plane to clip the triangle: `unit` is
/// `lambert::unit(n)` (the caller's `Some`) and some height `unit·(v_k − x)` is not above
/// `8ε (|unit|·|v_k − x|)` (the test [`triangle_value`] starts with, whose outcome is then
/// known). The same decisions and operations, so the same value bits and `None` exactly where
/// [`triangle_value`] declines (then `out` is unspecified). Inlined into the caller (the
/// derivative orders' clipped path, itself compiled twice, portable and with FMA, which give the
/// same bits as [`split_fma`] explains).
#[inline(always)]
pub(crate) fn clipped_triangle_value_and_loop(
    x: DVec3,
    unit: DVec3,
    v: [DVec3; 3],
    out: &mut RouteLoop,
) -> Option<f64> {
    let s = screen_with(x, unit, v, true)?;
    let (value, count) = split_loop(
        x,
        v,
        &s,
        &mut out.points,
        &mut out.angles,
        &mut out.edges,
        &mut out.far,
        out.defer_far,
    )?;
    out.count = count;
    Some(value)
}

/// [`split`] with the loop it clipped (in `loop_`) and its length, and, where `angles` and `edges`
/// have entries, its edges' angles (see `near_plane_value`) and vectors (the clip edge's from
/// `near_plane_value`). Where the visible part is far-field against its size, the robust path's
/// far-field rule on the loop instead of the split, with `far` set; with `defer_far` that rule's
/// value is left to
/// [`deferred_far_piece`](crate::kernels::form_factor::near_plane::far_piece::deferred_far_piece)
/// (the derivative orders) and the value returned is NaN.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn split_loop(
    x: DVec3,
    v: [DVec3; 3],
    s: &Screened,
    loop_: &mut [ClipVertex; 4],
    angles: &mut [f64],
    edges: &mut [DVec3],
    far: &mut Option<FarPiece>,
    defer_far: bool,
) -> Option<(f64, usize)> {
    let Screened { r, u, n, plane } = s;
    let (r, u, n) = (*r, *u, *n);
    let err = |a: f64, b: f64| dd::two_sum(a, -b).1;
    let r_lo_of = |vk: DVec3| DVec3::new(err(vk.x, x.x), err(vk.y, x.y), err(vk.z, x.z));
    // Written out: `v.map` was left out of line in the derivative orders' build.
    let r_lo = [r_lo_of(v[0]), r_lo_of(v[1]), r_lo_of(v[2])];
    let h_p = exact_height_of(&r, &r_lo, plane.twice_area);
    let count = clip_triangle(&u, &r, &r_lo, n, loop_)?;
    let value = clipped_loop_value::<4>(
        &loop_[..count],
        n,
        plane.normal,
        h_p,
        angles,
        edges,
        far,
        defer_far,
    )?;
    Some((value, count))
}

/// [`clip`](crate::kernels::form_factor::clip::clip) for a triangle, on a fixed array (the same
/// operations, so the same vertices): the loop in `out` and its length, `None` when nothing is cut
/// away or fewer than three vertices remain.
#[inline(always)]
fn clip_triangle(
    u: &[DVec3; 3],
    r: &[DVec3; 3],
    r_lo: &[DVec3; 3],
    n: DVec3,
    out: &mut [ClipVertex; 4],
) -> Option<usize> {
    let exact = [
        Dd3::from_parts(r[0], r_lo[0]),
        Dd3::from_parts(r[1], r_lo[1]),
        Dd3::from_parts(r[2], r_lo[2]),
    ];
    // Written out: `[0, 1, 2].map` of the products did not inline.
    let d = [
        exact[0].dot_f64(n),
        exact[1].dot_f64(n),
        exact[2].dot_f64(n),
    ];
    let mut loop_out = ArrayOut { verts: out, len: 0 };
    let cut = clip_by_heights(u, r, r_lo, |k| exact[k], &d, &mut loop_out);
    let count = loop_out.len;
    (cut && count >= 3).then_some(count)
}

#[cfg(test)]
pub(crate) mod tests;
