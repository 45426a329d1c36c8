//! The value of a triangle's form factor with `x` near its plane, outside the part the tangent plane
//! leaves visible: the robust path's near-plane split ([`near_plane_value`]) without the rest of its
//! set-up.
//!
//! For `Order::Value` in this configuration [`evaluate`](super::evaluate) builds the generic
//! machinery (growable vectors, Newell's plane with its planarity check, the fan's far-field test,
//! full edge frames) and then uses only the split. This route replays exactly the decisions and the
//! operations of that evaluation which the split's result depends on, on fixed-size arrays, so that
//! it returns the robust path's bits (the gradient and Hessian orders, which take their value from
//! this route or the robust path's split, agree with it bit for bit), and declines (`None`) wherever the
//! robust path would not take the split for the value: `x` not near the plane, nothing clipped, the
//! foot of `x` inside the clipped loop, the far field, or the split itself declining.
//!
//! Its f64 screen runs in the portable build; what follows (the exact height and clip points in
//! double-double, the frames and the split) is compiled a second time with AVX2 and FMA where the
//! CPU has them (`RADDIFF_SIMD` caps it, see `simd`), with the same bits. Measured by callgrind on
//! `benches/kernels_regimes.rs`'s "1e-6 from the plane, outside" value: 6704 instructions per call
//! through the robust path, 5490 by this route portable, 4571 with FMA (docs/kernels.md, "Hard
//! regimes").
//!
//! The gradient and Hessian orders run the same route through
//! [`clipped_triangle_value_and_loop`], which also hands out what the clipped loop's derivatives
//! (`lambert_clipped_derivs`) would otherwise compute a second time: the clipped loop (its
//! double-double clip points), the vectors of the edges from a kept vertex to a clip point, and
//! the well-conditioned edges' angles (see `near_plane_value`).

use glam::DVec3;

use super::{
    edge_vector, exact_height_of, far_field_rule, foot_inside, near_plane_value, next,
    triangle_plane, ClipVertex, InPlaneEdge, Plane, NEAR_PLANE_HEIGHT, NEAR_PLANE_RATIO,
    SPLIT_VALUE_LIMIT,
};
use crate::kernels::form_factor::NEAR_LINE_SINE;
use crate::kernels::lambert;
use crate::kernels::numeric::dd::{self, Dd3};

/// The value of [`triangle_form_factor`](crate::kernels::triangle_form_factor) for
/// `Order::Value` (form factor, dimensionless, in `[0, 1]`) when the robust path would take it from
/// its near-plane split, bit for bit; `None` when it would not (see the module documentation), and
/// for input outside the unscaled range of
/// [`triangle_form_factor_in_range`](super::triangle_form_factor_in_range) (coordinate differences
/// in (1e-30, 1e30)) or invalid input, which the callers leave to the robust path.
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
    let n = lambert::unit(n)?;
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
    // Spelled out: the iterator chain of `triangle_form_factor_in_range` cost ~100 instructions.
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

pub(super) const CLIP_VERTEX_ZERO: ClipVertex = ClipVertex {
    u: DVec3::ZERO,
    r: DVec3::ZERO,
    r_lo: DVec3::ZERO,
    on_line: false,
};

/// The clipped loop [`clipped_triangle_value_and_loop`] computed its value on, for the derivative
/// orders, which use the same clip points instead of clipping a second time: the first
/// [`count`](RouteLoop::count) points, for `i` in 0..3 vertex `i` when it is kept, then the
/// crossing of edge `i → i + 1` when there is one. Filled in place by the caller's frame (a
/// returned loop was copied, ~60 instructions).
/// `N`: the capacity, 4 for a triangle (`near_plane_polygon`'s loops use `2M` for `M` vertices,
/// their points in the same order, for `i` in `0..M`).
pub(crate) struct RouteLoop<const N: usize = 4> {
    pub(super) points: [ClipVertex; N],
    pub(super) angles: [f64; N],
    pub(super) edges: [DVec3; N],
    pub(super) count: usize,
    /// Set where the visible part is far-field against its size and the value came from the
    /// robust path's far-field rule on the loop.
    pub(super) far: Option<FarPiece>,
    /// Set by the caller before the route runs: where the far-field rule is taken, leave its
    /// value to [`deferred_far_piece`](super::deferred_far_piece), which sums it with the
    /// derivatives (one pass over the rule's nodes instead of two).
    pub(crate) defer_far: bool,
}

/// What the far-field rule on a route's loop needs for its derivatives: the rule, the unit
/// receiver normal and the polygon's unit normal (both as the robust path has them) and the exact
/// height of `x` over the plane.
#[derive(Clone, Copy)]
pub(crate) struct FarPiece {
    pub(super) rule: super::Rule,
    pub(super) n: DVec3,
    pub(super) plane_normal: DVec3,
    pub(super) h_p: f64,
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

/// [`split`] with the loop it clipped (in `loop_`) and its length, and, where `angles` and
/// `edges` have entries, its edges' angles (see `near_plane_value`) and vectors (the clip
/// edge's from `near_plane_value`). Where the visible part is far-field against its size, the
/// robust path's far-field rule on the loop instead of the split, with `far` set; with
/// `defer_far` that rule's value is left to [`deferred_far_piece`](super::deferred_far_piece)
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
    // Written out: `v.map` was left out of line in the derivative orders' build (~70
    // instructions).
    let r_lo = [r_lo_of(v[0]), r_lo_of(v[1]), r_lo_of(v[2])];
    let h_p = exact_height_of(&r, &r_lo, plane.twice_area);
    let count = clip_triangle(&u, &r, &r_lo, n, loop_)?;
    let verts = &loop_[..count];
    let centroid = verts.iter().map(|v| v.r).sum::<DVec3>() / count as f64;
    let radius = verts
        .iter()
        .map(|v| (v.r - centroid).length_squared())
        .fold(0.0, f64::max)
        .sqrt();
    if let Some(rule) = far_field_rule(centroid.length(), radius) {
        let value = super::far_piece_value(verts, n, plane.normal, h_p, rule, far, defer_far)?;
        return Some((value, count));
    }
    if foot_inside(verts, plane.normal, h_p) {
        return None;
    }
    let mut frames = [None; 4];
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
        plane.normal,
        h_p,
        SPLIT_VALUE_LIMIT,
        angles,
        edges,
    )?
    .0;
    super::visible_value(value, h_p).map(|value| (value, count))
}

/// [`clip`](super::clip) for a triangle, on a fixed array (the same operations, so the same
/// vertices): the loop in `out` and its length, `None` when nothing is cut away or fewer than
/// three vertices remain.
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
    // Written out: `[0, 1, 2].map` of the products did not inline (~450 instructions).
    let d = [
        exact[0].dot_f64(n),
        exact[1].dot_f64(n),
        exact[2].dot_f64(n),
    ];
    let mut loop_out = super::ArrayOut { verts: out, len: 0 };
    let cut = super::clip_by_heights(u, r, r_lo, |k| exact[k], &d, &mut loop_out);
    let count = loop_out.len;
    (cut && count >= 3).then_some(count)
}

/// The parts of [`EdgeFrame::with_exact_ends`](crate::kernels::form_factor::EdgeFrame) that
/// [`near_plane_value`] reads, by the same operations (the double-double cross product and
/// abscissae when x is near the edge's line), for its edge vector `e` (`edge_vector(a, b)`);
/// `None` for a zero-length edge.
#[inline(always)]
pub(super) fn in_plane_edge(a: &ClipVertex, b: &ClipVertex, e: DVec3) -> Option<InPlaneEdge> {
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

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::kernels::polygon::form_factor;
    use crate::Order;

    use crate::test_rng::lcg;

    /// A random configuration near the triangle's plane: a triangle of size `scale` (offset from
    /// the origin), `x` at a random in-plane point (inside or outside, near edges and vertices
    /// too) lifted by `±10^-(1..13)` sizes, and a receiver normal tilted by 2-88 degrees from the
    /// plane's, so that the tangent plane usually cuts the triangle.
    fn configuration(state: &mut u64, scale: f64) -> (DVec3, DVec3, [DVec3; 3]) {
        let mut c = || lcg(state);
        let offset = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * 10.0 * scale;
        let mut p = || DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * scale + offset;
        let v = [p(), p(), p()];
        let mut c = || lcg(state);
        let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        // Barycentric coordinates in [-1, 2): outside more often than inside.
        let (a, b) = (3.0 * c() - 1.0, 3.0 * c() - 1.0);
        let mut foot = v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b;
        if c() < 0.2 {
            // On an edge's line or at a vertex, where the split declines.
            let k = (3.0 * c()) as usize % 3;
            foot = v[k] + (v[(k + 1) % 3] - v[k]) * (3.0 * c() - 1.0) * f64::from(c() < 0.5);
        }
        let side = if c() < 0.5 { -1.0 } else { 1.0 };
        let x = foot + plane_n * side * scale * 10f64.powf(-1.0 - 12.0 * c());
        let tilt = (2.0 + 86.0 * c()).to_radians();
        let t = plane_n.any_orthonormal_vector();
        let phi = 6.3 * c();
        let t = t * phi.cos() + plane_n.cross(t) * phi.sin();
        let n = (plane_n * tilt.cos() + t * tilt.sin()).normalize();
        let n = if c() < 0.5 { n } else { -n };
        (x, n, v)
    }

    /// Wherever the route answers it returns the robust evaluation's bits, with and without FMA, and
    /// it answers wherever the robust evaluation takes its near-plane split for the value; the
    /// entry point's value is the same at every order.
    #[test]
    fn the_route_returns_the_robust_bits() {
        let mut state = 5;
        let (mut taken, mut robust_split) = (0, 0);
        let (mut far_taken, mut robust_far) = (0, 0);
        for k in 0..20000 {
            let scale = [1e-3, 1.0, 1e3][k % 3];
            let (x, n, v) = configuration(&mut state, scale);
            let got = triangle_value(x, n, v);
            assert_eq!(
                got.map(f64::to_bits),
                screen(x, n, v)
                    .and_then(|s| split(x, v, &s))
                    .map(f64::to_bits),
                "{k}: dispatch vs portable"
            );
            let Ok(want) = form_factor(x, n, &v, Order::Value) else {
                assert!(got.is_none(), "{k}");
                continue;
            };
            if let Some(f) = got {
                taken += 1;
                assert_eq!(f.to_bits(), want.value.to_bits(), "{k}: {x:?} {n:?} {v:?}");
            }
            // The entry point's value does not depend on the order (the route serves the value
            // order where Lambert's certified sums decline).
            let entry = |order| crate::kernels::triangle_form_factor(x, n, v[0], v[1], v[2], order);
            if let (Ok(value), Ok(hessian)) = (entry(Order::Value), entry(Order::Hessian)) {
                assert_eq!(value.value.to_bits(), hessian.value.to_bits(), "{k}: order");
            }
            // Wherever the robust path takes its split, the route answers; where it takes its
            // far-field rule on the clipped loop, the route answers unless its edge-line screen
            // (the split's decline, tested before the far-field test) declines first.
            let split = robust_takes_the_split(x, n, &v, false);
            let split_or_far = robust_takes_the_split(x, n, &v, true);
            assert!(!split || got.is_some(), "{k}: the split, but not the route");
            assert!(got.is_none() || split_or_far, "{k}: the route, but neither");
            robust_split += usize::from(split);
            robust_far += usize::from(split_or_far && !split);
            far_taken += usize::from(got.is_some() && !split);
        }
        assert!(
            far_taken * 10 >= robust_far * 9,
            "far {far_taken} of {robust_far}"
        );
        println!(
            "route taken in {taken} of 20000 configurations ({robust_split} robust splits, \
             {far_taken} of {robust_far} far-field rules)"
        );
        assert!(taken > 2000, "{taken}");
    }

    /// The entry point's value on both sides of the switch in `t` between the route answering (at
    /// `t0`) and declining (at `t1`), bisected until the two points are adjacent (their `x` a few
    /// ulps apart; `n` fixed): the two sides (the route, and the robust path's edge sum or
    /// quadrature) agree to 1e-12 of the value beyond the first-order change `∇F·Δx` (the
    /// gradient from the robust path on the declining side). Returns that excess, relative.
    fn across_the_switch(
        x_of: &dyn Fn(f64) -> DVec3,
        n: DVec3,
        v: [DVec3; 3],
        (mut t0, mut t1): (f64, f64),
    ) -> f64 {
        let route = |t: f64| triangle_value(x_of(t), n, v);
        assert!(
            route(t0).is_some() && route(t1).is_none(),
            "no switch in [{t0}, {t1}]"
        );
        for _ in 0..200 {
            let mid = 0.5 * (t0 + t1);
            if mid == t0 || mid == t1 {
                break;
            }
            if route(mid).is_some() {
                t0 = mid;
            } else {
                t1 = mid;
            }
        }
        let entry = |t: f64, order| {
            let x = x_of(t);
            crate::kernels::triangle_form_factor(x, n, v[0], v[1], v[2], order).unwrap()
        };
        let (a, b) = (entry(t0, Order::Value).value, entry(t1, Order::Gradient));
        let change = b.gradient.dot(x_of(t1) - x_of(t0));
        ((b.value - a - change).abs() - 1e-9 * change.abs()).max(0.0) / a
    }

    /// Continuity where the route starts or stops answering, for fat random triangles at scales
    /// 1e-3..1e3 and tilts 10-80 degrees: x's foot approaching an edge line outside the triangle
    /// (the split's limit `|h_P| = 0.1 d_e`, 1e-5 and 1e-8 sizes from the plane) and x rising
    /// through the near-plane limit (`|h_P| = 1e-3 r_max`) outside the triangle.
    #[test]
    fn continuous_where_the_route_switches() {
        let mut state = 17;
        let mut worst = [0.0f64; 2];
        for k in 0..24 {
            let scale = [1e-3, 1.0, 1e3][k % 3];
            let mut c = || lcg(&mut state);
            let v = [
                DVec3::new(0.0, 0.0, 1.0),
                DVec3::new(1.0, 0.1 * c(), 1.2),
                DVec3::new(0.2 + 0.3 * c(), 0.9, 0.8),
            ]
            .map(|p| p * scale);
            let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            let e = (v[1] - v[0]).normalize();
            // Away from the triangle, beside edge (0, 1), past its midpoint.
            let out = plane_n.cross(e);
            let out = if out.dot(v[2] - v[0]) > 0.0 {
                -out
            } else {
                out
            };
            let base = v[0] + (v[1] - v[0]) * (0.3 + 0.4 * c());
            let centroid = (v[0] + v[1] + v[2]) / 3.0;
            let tilt = (10.0 + 70.0 * c()).to_radians();
            // The receiver tilted about the line from `base` to the centroid, so that its
            // tangent plane cuts the triangle along that line.
            let across = plane_n.cross((centroid - base).normalize());
            let n = (plane_n * tilt.cos() + across * tilt.sin()).normalize();
            // (a) The foot towards the edge line, h_P fixed.
            let h = [1e-5, 1e-8][k % 2] * scale;
            let x_of = |d: f64| base + out * (d * scale) + plane_n * h;
            let d = h / scale;
            worst[0] = worst[0].max(across_the_switch(&x_of, n, v, (100.0 * d, 3.0 * d)));
            // (b) x rising at a foot 0.2 sizes outside, through 1e-3 of r_max.
            let foot = base + out * (0.2 * scale);
            let x_of = |t: f64| foot + plane_n * (t * scale);
            worst[1] = worst[1].max(across_the_switch(&x_of, n, v, (5e-4, 2e-3)));
        }
        println!(
            "jumps beyond the first-order change at the route's switches: edge line {:.1e}, \
             height 1e-3 {:.1e}",
            worst[0], worst[1]
        );
        assert!(worst.iter().all(|w| *w <= 1e-12), "{worst:?}");
    }

    /// Whether `evaluate` takes its near-plane split for the value of this configuration (its
    /// decisions, through the route's own steps but with the robust path's `clip` and frames).
    /// Also the polygon route's reference (`near_plane_polygon`), hence over any vertex count;
    /// with `far_counts` also where it takes its far-field rule on the clipped loop instead (a
    /// far-field visible part), which the polygon route replays.
    pub(in crate::kernels::polygon) fn robust_takes_the_split(
        x: DVec3,
        n: DVec3,
        v: &[DVec3],
        far_counts: bool,
    ) -> bool {
        use super::super::{clip, edge_frames, exact_height, ClipLoop, Frames, Plane, Scaled};
        let Ok(scaled) = Scaled::new(x, v) else {
            return false;
        };
        let Ok(plane) = Plane::new(&scaled.u) else {
            return false;
        };
        let Ok(n) = super::super::unit_normal(n) else {
            return false;
        };
        let r_max = scaled.r.iter().map(|r| r.length()).fold(0.0, f64::max);
        let nearest = scaled
            .r
            .iter()
            .min_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))
            .copied()
            .unwrap();
        let h = plane.normal.dot(nearest);
        if h.abs() <= 4.0 * f64::EPSILON * r_max || h.abs() >= NEAR_PLANE_HEIGHT * r_max {
            return false;
        }
        let h_p = exact_height(&scaled, plane.twice_area);
        let mut loop_ = ClipLoop::new();
        if !clip(&scaled.u, &scaled.r, &scaled.r_lo, n, &mut loop_) || loop_.len() < 3 {
            return false;
        }
        let centroid = loop_.iter().map(|v| v.r).sum::<DVec3>() / loop_.len() as f64;
        let radius = loop_
            .iter()
            .map(|v| (v.r - centroid).length())
            .fold(0.0, f64::max);
        if far_field_rule(centroid.length(), radius).is_some() {
            return far_counts;
        }
        if foot_inside(&loop_, plane.normal, h_p) {
            return false;
        }
        let mut frames = Frames::new();
        edge_frames(&loop_, true, &mut frames);
        near_plane_value(
            &loop_,
            &frames,
            n,
            plane.normal,
            h_p,
            SPLIT_VALUE_LIMIT,
            &mut [],
            &mut [],
        )
        .is_some()
    }
}
