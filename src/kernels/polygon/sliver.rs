//! Thin triangles (slivers) by an anisotropic tensor rule.
//!
//! A sliver's edge sum cancels by about its inverse aspect ratio, and the isotropic subdivision
//! of [`subdivided_quadrature`](super::subdivided_quadrature) bisects it into hundreds of long
//! pieces. But a sliver is thin in one direction only: across its width `w` the integrand varies
//! over a distance ~`d` (the distance of x), so a few Gauss points suffice there, and only the
//! long direction needs many points, graded by the distance of x.
//!
//! The triangle is split at the foot `f` of its apex `c` on its longest edge `ab` (both angles
//! at `a` and `b` are acute, so `f` lies on the edge) into `(a, f, c)` and `(b, c, f)`, each
//! Duffy-mapped from its vertex on the long edge: `r = r_p + s·(q₁ − p) + s·t·(q₂ − q₁)`, with
//! `q₁q₂` the short edge `fc`. Their `(2·area·N̂, 2·area·N̂·r)` are the shares `t_f` and `1 − t_f`
//! (`f = a + t_f·ab`) of the whole triangle's, taken from the exact differences; the shares go
//! into the pieces' weights, so that both pieces add to one set of sums, assembled once. The sums
//! run four nodes at a time ([`sums`]).
//!
//! Error bound (per direction; the tensor rule's error is at most their sum). The integrands
//! `(n·r)/‖r‖⁴ … (n·r) r rᵀ/‖r‖⁸` are analytic along any line except at the two complex zeros of
//! `‖r‖²`, where they have poles of order `k` ≤ 4 (2 for the value, 3 for the gradient, 4 for
//! the Hessian). An `m`-point Gauss rule on an interval whose normalized pole `z` lies on the
//! Bernstein ellipse of parameter `ρ` has error at most `(64/15) M_σ σ^{-2m} / (σ² − 1)` for any
//! `σ < ρ`, with `M_σ` the integrand's maximum on the ellipse `E_σ`, at most `(1 − σ/ρ)^{-k}`
//! times its real maximum (up to the scale of the interval). With `σ = ρ·2m/(2m + k)` (the
//! minimizer of `σ^{-2m}(1 − σ/ρ)^{-k}`), the thresholds below keep
//! `(64/15) (1 − σ/ρ)^{-4} σ^{-2m}` under 1e-15 (the factor `1/(σ² − 1)`, below 1/19 wherever
//! a rule is used, is left as a margin for the ratio of the integrand's maximum to its mean on
//! an interval): along, `ρ ≥` 17.8 (8 points), 13.2 (9), 10.4 (10), 8.6 (11), 7.3 (12),
//! 6.3 (13), 5.6 (14), 5.1 (15), 4.5 (16; 1.52e-15 there), 3.9 (18), 3.44 (20), 3.1 (22),
//! 2.84 (24); across, 3.2e4 (2 points), 1.2e3 (3), 230 (4), 18 (8) (`thresholds_along_keep_the_
//! error_bound` checks them against the bound). Along the length, intervals of `s` are bisected
//! until one of these rules applies (one interval unless x is closer than about half the length);
//! across, the pole of the line `t ↦ r(s, t)` is at least `D` (the distance of x to the piece)
//! from the segment of length `≤ w`. Every rule between 8 and 24 points is used: a seen-from-afar
//! piece (ρ ≈ 6 for x a length away) takes 13 or 14 points instead of 16, and a piece seen from
//! about its own length (ρ 2.84..4.5) one rule of 18 to 24 points instead of two halves of 12 to
//! 16 (the rules above 16 are even; the sums take nodes four at a time, so 13 to 16 points cost
//! the same four groups, and the smaller rules are kept for their thresholds' sake: the table is
//! the error bound's, unchanged). Each threshold is tested as its ellipse ([`semi_axes`]), which
//! needs no square root.
//!
//! One rule for every order. The value's poles have order 2, so the value alone could use lower
//! thresholds (13 points from ρ = 5.3 instead of 6.3, 16 from 3.9 instead of 4.5). But the value
//! must not depend on the order (the value of an `Order::Hessian` call is that of the
//! `Order::Value` call, bit for bit), so the derivative orders would need a second pass with the
//! value's rule, costing them more than the value saves; the thresholds are the Hessian's.
//!
//! Entry points: [`sliver_quadrature`] from `evaluate` (after its set-up) and
//! [`direct_sliver`] from `triangle_form_factor_in_range` (the same bits without the set-up).
//! x may be near the sliver's plane: the rule needs x far from the sliver compared with its width
//! only, and [`sliver_geometry`] takes the height from the exact triple product.

use std::sync::OnceLock;

use glam::DVec3;

use crate::kernels::numeric::dd::two_sum;

use super::{
    far_rule_of, gauss_legendre_16, gauss_legendre_2, gauss_legendre_3, gauss_legendre_4,
    gauss_legendre_5, gauss_legendre_6, gauss_legendre_8, legendre_rule, plane_height,
    triangle_plane, ClipVertex, Rule, RuleSums,
};
use crate::kernels::numeric::lanes::V3;
use crate::{Deriv3, Order};

mod clipped;
mod sums;

#[cfg(target_arch = "x86_64")]
pub(super) use sums::AvxSums;
use sums::PieceFrame;
pub(super) use sums::{GroupSums, PortableSums};

/// Most intervals along one piece before the sliver rule gives up (x too close to the sliver
/// compared with its length; the isotropic subdivision takes over).
const MAX_INTERVALS: usize = 48;

/// `(ρ, points)`: the Gauss rules along the length and the smallest Bernstein parameter at which
/// each is used (module documentation).
const ALONG: [(f64, usize); 13] = [
    (17.8, 8),
    (13.2, 9),
    (10.4, 10),
    (8.6, 11),
    (7.3, 12),
    (6.3, 13),
    (5.6, 14),
    (5.1, 15),
    (4.5, 16),
    (3.9, 18),
    (3.44, 20),
    (3.1, 22),
    (2.84, 24),
];
/// The same across the width.
const ACROSS: [(f64, usize); 4] = [(3.2e4, 2), (1.2e3, 3), (230.0, 4), (18.0, 8)];

/// The `points`-point Gauss-Legendre rule on [0, 1] (2, 3, 4, 8..=16, 18, 20, 22, 24), computed
/// once.
fn rule(points: usize) -> &'static [(f64, f64)] {
    macro_rules! cached {
        ($n:literal) => {{
            static RULE: OnceLock<[(f64, f64); $n]> = OnceLock::new();
            &RULE.get_or_init(legendre_rule::<$n>)[..]
        }};
    }
    match points {
        2 => gauss_legendre_2(),
        3 => gauss_legendre_3(),
        4 => gauss_legendre_4(),
        8 => gauss_legendre_8(),
        9 => cached!(9),
        10 => cached!(10),
        11 => cached!(11),
        12 => cached!(12),
        13 => cached!(13),
        14 => cached!(14),
        15 => cached!(15),
        18 => cached!(18),
        20 => cached!(20),
        22 => cached!(22),
        24 => cached!(24),
        _ => gauss_legendre_16(),
    }
}

/// The rules of [`ALONG`] and [`ACROSS`] and their thresholds as ellipses, built once: one
/// look-up per sliver instead of one per rule used, and no square root per decision.
struct Rules {
    /// The rules by their number of points (empty elsewhere).
    by_points: [&'static [(f64, f64)]; 25],
    /// The rules along by their number of points, as the sums take them ([`sums::quads`]).
    quads: [&'static [[[f64; 4]; 2]]; 25],
    /// [`ALONG`] as `(1/a², 1/b², points)` with `a`, `b` the semi-axes of the threshold's
    /// ellipse ([`semi_axes`]).
    along: [(f64, f64, usize); ALONG.len()],
    /// [`ACROSS`] as `(b, points)`: on the imaginary axis the ellipse is crossed at `±i·b`.
    across: [(f64, usize); ACROSS.len()],
}

fn rules() -> &'static Rules {
    static RULES: OnceLock<Rules> = OnceLock::new();
    RULES.get_or_init(|| {
        let mut by_points: [&'static [(f64, f64)]; 25] = [&[]; 25];
        for &(_, points) in ALONG.iter().chain(&ACROSS) {
            by_points[points] = rule(points);
        }
        let mut quads: [&'static [[[f64; 4]; 2]]; 25] = [&[]; 25];
        for &(_, points) in &ALONG {
            // Built once per process and kept for it.
            quads[points] = Box::leak(sums::quads(by_points[points]).into_boxed_slice());
        }
        Rules {
            by_points,
            quads,
            along: ALONG.map(|(rho, points)| {
                let (a, b) = semi_axes(rho);
                (1.0 / (a * a), 1.0 / (b * b), points)
            }),
            across: ACROSS.map(|(rho, points)| (semi_axes(rho).1, points)),
        }
    })
}

/// The far-field rules ([`FAR_FIELD_RULES`](super::FAR_FIELD_RULES): 3, 4, 5, 6 and 8 points)
/// as the sums take them ([`sums::quads`]), by their number of points, built once.
fn far_quads(points: usize) -> &'static [[[f64; 4]; 2]] {
    static QUADS: OnceLock<[&'static [[[f64; 4]; 2]]; 9]> = OnceLock::new();
    QUADS.get_or_init(|| {
        let mut quads: [&'static [[[f64; 4]; 2]]; 9] = [&[]; 9];
        for rule in [
            gauss_legendre_3(),
            gauss_legendre_4(),
            gauss_legendre_5(),
            gauss_legendre_6(),
            gauss_legendre_8(),
        ] {
            // Built once per process and kept for it.
            quads[rule.len()] = Box::leak(sums::quads(rule).into_boxed_slice());
        }
        quads
    })[points]
}

/// The sums of the far-field `rule` (`n`x`n` Gauss-Legendre points, Duffy-mapped) over the
/// triangle `(a, b, c)` (relative to x, as [`triangle_rule`](super::triangle_rule) parametrizes
/// it: `r_a + s·(u_b − u_a) + s·t·(u_c − u_b)`), four nodes at a time: the subdivided
/// quadrature's pieces, whose node loop is most of the robust path's cost where it integrates
/// (x near a polygon's plane with a small or thin visible part). The same rule and integrand as
/// `triangle_rule`, summed lane by lane (so rounded in another order); the order of the
/// operations does not depend on `GRADIENT` or `HESSIAN`, nor on the build (module
/// documentation of [`sums`]).
#[inline(always)]
pub(super) fn rule_piece_sums<S: GroupSums, const GRADIENT: bool, const HESSIAN: bool>(
    a: &ClipVertex,
    b: &ClipVertex,
    c: &ClipVertex,
    n: &V3<S::Lane>,
    rule: Rule,
) -> RuleSums {
    let frame = PieceFrame {
        r_p: a.r,
        ab: b.u - a.u,
        bc: c.u - b.u,
        part: 1.0,
    };
    let mut sums = S::new();
    sums.add::<GRADIENT, HESSIAN>(&frame, n, (0.0, 1.0, far_quads(rule.0.len())), rule.0);
    sums.total()
}

/// The semi-axes `(a, b) = ((ρ + 1/ρ)/2, (ρ − 1/ρ)/2)` of the Bernstein ellipse of parameter
/// `ρ > 1` for [−1, 1] (foci ±1). The ellipses of larger parameters enclose it, so a point
/// `z = re + i·im` has a parameter of at least `ρ` exactly when `re²/a² + im²/b² ≥ 1`: the rules
/// are chosen by that test, without the parameter's square roots.
fn semi_axes(rho: f64) -> (f64, f64) {
    (0.5 * (rho + 1.0 / rho), 0.5 * (rho - 1.0 / rho))
}

/// [`evaluate`](super::evaluate)'s sliver branch for a triangle given by `u` (relative to its
/// first vertex), `r` (relative to x) and `r_lo` (`r + r_lo` exact), without the set-up that
/// branch does not use: the same decisions from the same rounded quantities (plane, height,
/// far-field switch), so the result has the robust path's bits. Every vertex above the tangent
/// plane by more than the rounding of `n·r` certifies that the clip keeps the triangle as it is
/// (the uncut rule); otherwise the triangle is clipped as `evaluate` clips it and the visible part
/// takes [`clipped_sliver_quadrature`] and the clip line's Hessian term ([`clipped`]). `None`
/// whenever the robust path would do anything else (x near the plane or near the sliver, a
/// zero-area triangle, an uncut far-field sliver, a non-finite result); the caller then takes
/// that path.
pub(super) fn direct_sliver(
    u: &[DVec3; 3],
    r: &[DVec3; 3],
    r_lo: &[DVec3; 3],
    n: DVec3,
    order: Order,
) -> Option<Deriv3> {
    let plane = triangle_plane(u)?;
    if !plane.is_very_thin() {
        return None;
    }
    // x not near the plane (so not in it either).
    let h_p = plane_height(r, &plane)?;
    // `clip` compares the exact heights n·(r + r_lo) with zero; the rounded n·r is within
    // ~4ε‖r‖ of them (‖n‖ = 1 + O(ε)), so a margin of 1e-13‖r‖ certifies every sign.
    let above = |v: &DVec3| {
        let h = n.dot(*v);
        h > 0.0 && h * h > 1e-26 * v.length_squared()
    };
    if !r.iter().all(above) {
        // Cut, `evaluate` takes the rule whatever the far-field switch says.
        return clipped::clipped_sliver(u, r, r_lo, n, order, &plane, h_p);
    }
    // Uncut, a far-field rule goes to `evaluate`.
    if far_rule_of(r).is_some() {
        return None;
    }
    let verts = [0, 1, 2].map(|k| ClipVertex {
        u: u[k],
        r: r[k],
        r_lo: r_lo[k],
        on_line: false,
    });
    // As `evaluate` finishes: the sign of the height, then the clamp of the value.
    crate::kernels::form_factor::oriented(sliver_quadrature(&verts, n, order)?, h_p)
}

/// The signed form factor of a sliver triangle (x origin of the `r`; nothing clipped) by the
/// anisotropic rule, or `None` when x is too close to it for the rule (the width is not small
/// against the distance, or the length needs more than [`MAX_INTERVALS`] intervals).
pub(super) fn sliver_quadrature(verts: &[ClipVertex], n: DVec3, order: Order) -> Option<Deriv3> {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2_fma() {
        // SAFETY: `simd::avx2_fma` checked that the CPU has AVX2 and FMA.
        return unsafe { sliver_quadrature_fma(verts, n, order) };
    }
    sliver_quadrature_with::<PortableSums>(verts, n, order)
}

/// The signed form factor of a sliver cut by the receiver's tangent plane, from its visible part
/// `verts` (the clipped loop, x origin of the `r`, the clip points exact in double-double): the
/// sum of the rule over the loop's fan triangles from its first vertex
/// ([`clipped::fan_triangle`]); `None` when the rule declines any piece (the caller then takes
/// the robust path).
///
/// The integrand's factor `n·r` vanishes on the clip line, so the derivatives of the clipped
/// integral are the integrals of the derivatives over the fixed visible part, except for the
/// Hessian's term from the clip line's motion, which the caller adds (`clip_line_hessian`, with
/// [`visible_plane`]). The fan pieces of a sliver are slivers (their widths at most the
/// sliver's), and the clip points' double-double parts give each piece's geometry
/// ([`sliver_geometry`]) to a few ulps, as for the uncut sliver. The fan's signed sum is the
/// integral over the loop for any simple loop (each piece's sign comes from its own
/// orientation), and every piece is checked by the rule to keep x away from it.
pub(super) fn clipped_sliver_quadrature(
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

/// [`clipped_sliver_quadrature`] compiled with AVX2 and FMA (as [`sliver_quadrature_fma`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn clipped_sliver_quadrature_fma(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
) -> Option<(Deriv3, FanGeometry)> {
    clipped_sliver_quadrature_with::<AvxSums>(verts, n, order)
}

#[inline(always)]
fn clipped_sliver_quadrature_with<S: GroupSums>(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
) -> Option<(Deriv3, FanGeometry)> {
    let mut total = Deriv3::constant(0.0);
    let mut geometry = FanGeometry::default();
    for k in 1..verts.len().checked_sub(1)? {
        let (d, g) = clipped::fan_triangle::<S>(&verts[0], &verts[k], &verts[k + 1], n, order)?;
        super::accumulate(&mut total, d);
        geometry.add(g);
    }
    Some((total, geometry))
}

/// The sums over a loop's fan triangles of their [`sliver_geometry`] `(2·area·N̂, 2·area·N̂·r)`:
/// the loop's plane ([`FanGeometry::plane`]).
#[derive(Clone, Copy, Default)]
pub(super) struct FanGeometry {
    normal: DVec3,
    volume: f64,
}

impl FanGeometry {
    #[inline(always)]
    fn add(&mut self, (normal, volume): (DVec3, f64)) {
        self.normal += normal;
        self.volume += volume;
    }

    /// The unit normal and `|h_P|` ([`visible_plane`]); `None` for zero area.
    #[inline(always)]
    pub(super) fn plane(&self) -> Option<(DVec3, f64)> {
        let twice_area = self.normal.length();
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN declines
        if !(twice_area > 0.0) {
            return None;
        }
        Some((self.normal / twice_area, self.volume.abs() / twice_area))
    }
}

/// The unit normal of the loop `verts` (x origin of the `r`, the parts `r + r_lo` exact) and
/// `|h_P|`, the distance of x from its plane, from the fan triangles' exact geometry
/// ([`sliver_geometry`]); `None` for a loop of zero area. For the clip line's Hessian term of a
/// clipped sliver, `∝ |h_P| / ‖n_t‖`: the polygon's Newell normal, from rounded edge vectors, errs
/// by ~ε/aspect in direction, and so do `n_t` and the height taken with it. Inlined, so that the
/// clipped sliver's FMA build fuses its exact products ([`clipped`]).
#[inline(always)]
pub(super) fn visible_plane(verts: &[ClipVertex]) -> Option<(DVec3, f64)> {
    let mut geometry = FanGeometry::default();
    for k in 1..verts.len().checked_sub(1)? {
        // `N·r` is the same at every point of the plane: each piece's from its first vertex.
        geometry.add(sliver_geometry(&verts[0], &verts[k], &verts[k + 1]));
    }
    geometry.plane()
}

/// [`sliver_quadrature`] compiled with AVX2 and FMA: the geometry's exact products are fused
/// instead of calls to `fma`, and the sums take four nodes per AVX register ([`AvxSums`])
/// instead of two SSE2 registers. The same bits: the fused product is correctly rounded either way, the
/// lanes round as the portable ones and are added in the same tree ([`sums`]), and Rust fuses
/// nothing else (unit-tested).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn sliver_quadrature_fma(verts: &[ClipVertex], n: DVec3, order: Order) -> Option<Deriv3> {
    sliver_quadrature_with::<AvxSums>(verts, n, order)
}

#[inline(always)]
fn sliver_quadrature_with<S: GroupSums>(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
) -> Option<Deriv3> {
    if verts.len() != 3 {
        return None;
    }
    let len = |i: usize| (verts[(i + 1) % 3].u - verts[i].u).length_squared();
    let i = (0..3).max_by(|&p, &q| len(p).total_cmp(&len(q)))?;
    let (a, b, c) = (&verts[i], &verts[(i + 1) % 3], &verts[(i + 2) % 3]);
    let ab = b.u - a.u;
    let share = ((c.u - a.u).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    // The foot's rounding moves it by ~ε·length, which changes the integrand by ~ε·length/d;
    // the pieces' areas are the exact shares of the exact geometry.
    let f = ClipVertex {
        u: a.u + share * ab,
        r: a.r + share * (b.r - a.r),
        r_lo: DVec3::ZERO,
        on_line: false,
    };
    // Both pieces are checked before the geometry is formed: declining is then cheap.
    let table = rules();
    let mut pieces = [None, None];
    for (slot, (p, q1, q2, part)) in pieces
        .iter_mut()
        .zip([(a, &f, c, share), (b, c, &f, 1.0 - share)])
    {
        if part > 0.0 {
            *slot = Some((ThinPiece::new(p, q1, q2, table)?, part));
        }
    }
    let sums = match order {
        Order::Value => rule_sums::<S, false, false>(&pieces, n),
        Order::Gradient => rule_sums::<S, true, false>(&pieces, n),
        Order::Hessian => rule_sums::<S, true, true>(&pieces, n),
    }?;
    Some(sums.assemble(n, sliver_geometry(a, b, c), order))
}

/// Both pieces' sums, the pieces' shares of the whole triangle's geometry in their weights (so
/// that one assembly serves both), with the derivatives' sums as asked. `None` when a piece needs
/// more than [`MAX_INTERVALS`] intervals.
#[inline(always)]
fn rule_sums<S: GroupSums, const GRADIENT: bool, const HESSIAN: bool>(
    pieces: &[Option<(ThinPiece, f64)>; 2],
    n: DVec3,
) -> Option<RuleSums> {
    let n = V3::<S::Lane>::splat(n);
    let mut sums = S::new();
    for (piece, part) in pieces.iter().flatten() {
        piece.integrate::<S, GRADIENT, HESSIAN>(&mut sums, &n, *part)?;
    }
    Some(sums.total())
}

/// `(2·area·N̂, 2·area·N̂·r_a)` of the triangle `(a, b, c)` from the exact differences
/// (`r + r_lo`), each to a few ulps: a sliver's normal from rounded edge vectors would have lost
/// ~`log10(1/aspect)` digits. `N = (b − a) × (c − a)` with the edge vectors split into a leading
/// part and its remainder: the leading parts' products are exact (two-product) and the remainder
/// terms, ~ε of them, need only f64. Then `N·r_a` (the triple product `det(r_a, r_b, r_c)`) is a
/// compensated dot product, accurate to a few ulps while it cancels by less than ~1e15: x off the
/// plane by more than ~1e-15 of its distance (closer, `evaluate` takes x as in the plane).
#[inline(always)]
fn sliver_geometry(a: &ClipVertex, b: &ClipVertex, c: &ClipVertex) -> (DVec3, f64) {
    // q − a as a leading part and its remainder: two-sum per component on r, plus the r_lo.
    let edge = |q: &ClipVertex| {
        let (x, y) = (q.r, -a.r);
        let d = x + y;
        let yy = d - x;
        (d, ((x - (d - yy)) + (y - yy)) + (q.r_lo - a.r_lo))
    };
    let ((e1, l1), (e2, l2)) = (edge(b), edge(c));
    // One component of e1 × e2: e1[i]·e2[j] − e1[j]·e2[i], as leading part and remainder.
    let component = |i: usize, j: usize| {
        let (p, pe) = two_prod(e1[i], e2[j]);
        let (q, qe) = two_prod(e1[j], e2[i]);
        let (s, se) = two_sum(p, -q);
        let rest = (pe - qe) + ((e1[i] * l2[j] + l1[i] * e2[j]) - (e1[j] * l2[i] + l1[j] * e2[i]));
        two_sum(s, se + rest)
    };
    let (x, y, z) = (component(1, 2), component(2, 0), component(0, 1));
    let (hi, lo) = (DVec3::new(x.0, y.0, z.0), DVec3::new(x.1, y.1, z.1));
    // Σ N_k r_k with N = hi + lo, r_a = r + r_lo: the leading products summed exactly (two-sum
    // chain), the remainder products in f64.
    let (mut sum, mut err) = two_prod(hi.x, a.r.x);
    for k in 1..3 {
        let (p, pe) = two_prod(hi[k], a.r[k]);
        let (s, se) = two_sum(sum, p);
        sum = s;
        err += pe + se;
    }
    err += hi.dot(a.r_lo) + lo.dot(a.r);
    (hi + lo, sum + err)
}

/// `a·b = p + err` exactly (no overflow or underflow).
#[inline(always)]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// One piece `(p, q₁, q₂)` with `q₁q₂` short, Duffy-mapped from `p`, and its rules.
struct ThinPiece {
    r_p: DVec3,
    pq1: DVec3,
    q1q2: DVec3,
    /// The parameter of the foot of x on the spine `p + s·spine`.
    s_foot: f64,
    /// A lower bound on the distance of the t-lines' poles from the spine's line, over the
    /// spine's length.
    pole_over_length: f64,
    t_rule: &'static [(f64, f64)],
    rules: &'static Rules,
}

impl ThinPiece {
    /// `None` when x is too close to the piece for the rule.
    #[inline(always)]
    fn new(
        p: &ClipVertex,
        q1: &ClipVertex,
        q2: &ClipVertex,
        rules: &'static Rules,
    ) -> Option<ThinPiece> {
        let (pq1, q1q2) = (q1.u - p.u, q2.u - q1.u);
        let spine = pq1 + 0.5 * q1q2;
        let length = spine.length();
        let width = q1q2.length();
        // x relative to the spine p + s·spine: foot parameter and distance from the line.
        let s_foot = -p.r.dot(spine) / (length * length);
        let line_distance = p.r.cross(spine).length() / length;
        let segment_distance = (p.r + s_foot.clamp(0.0, 1.0) * spine).length();
        // Across: every t-line has length ≤ width and lies ≥ segment_distance − width from x.
        let across_distance = segment_distance - width;
        if across_distance.is_nan() || across_distance <= 0.0 {
            return None;
        }
        // Normalized to [−1, 1] the pole is at i·2·across_distance/width or farther.
        let t_points = rules
            .across
            .iter()
            .find(|&&(b, _)| 2.0 * across_distance >= b * width)?
            .1;
        // Along: the poles of the t-lines are within `width` of the spine's.
        let pole_distance = line_distance - width;
        if pole_distance.is_nan() || pole_distance <= 0.0 {
            return None;
        }
        Some(ThinPiece {
            r_p: p.r,
            pq1,
            q1q2,
            s_foot,
            pole_over_length: pole_distance / length,
            t_rule: rules.by_points[t_points],
            rules,
        })
    }

    /// The Gauss rule along `s ∈ [s0, s1]` if one applies (module documentation).
    #[inline(always)]
    fn along_points(&self, s0: f64, s1: f64) -> Option<usize> {
        // The pole normalized to the interval, [s0, s1] → [−1, 1].
        let (mid, scale) = (0.5 * (s0 + s1), 2.0 / (s1 - s0));
        let (re, im) = ((self.s_foot - mid) * scale, self.pole_over_length * scale);
        let (re2, im2) = (re * re, im * im);
        // The first rule whose ellipse leaves the pole outside. A linear search: its branches
        // are predicted and speculated past, where the branch-free bisection of
        // `partition_point` (half the tests) put its chain of loads and compares on the set-up's
        // latency (+10% time on a triangle sliver, callgrind -2%).
        self.rules
            .along
            .iter()
            .find(|&&(ia2, ib2, _)| re2 * ia2 + im2 * ib2 >= 1.0)
            .map(|r| r.2)
    }

    /// Adds the tensor rule on `s ∈ [s0, s1]` with `points` along to `sums`.
    #[inline(always)]
    fn interval<S: GroupSums, const GRADIENT: bool, const HESSIAN: bool>(
        &self,
        sums: &mut S,
        frame: &PieceFrame,
        n: &V3<S::Lane>,
        (s0, s1): (f64, f64),
        points: usize,
    ) {
        let along = (s0, s1, self.rules.quads[points]);
        // A fixed-length rule across lets the inlined loop unroll it (the same operations).
        match self.t_rule {
            &[t0, t1] => sums.add::<GRADIENT, HESSIAN>(frame, n, along, &[t0, t1]),
            t_rule => sums.add::<GRADIENT, HESSIAN>(frame, n, along, t_rule),
        }
    }

    /// Adds the piece's share `part` of the form factor's sums to `sums`; `None` when the length
    /// needs more than [`MAX_INTERVALS`] intervals. Intervals are bisected until a rule applies
    /// (depth first, right half first).
    #[inline(always)]
    fn integrate<S: GroupSums, const GRADIENT: bool, const HESSIAN: bool>(
        &self,
        sums: &mut S,
        n: &V3<S::Lane>,
        part: f64,
    ) -> Option<()> {
        let frame = PieceFrame {
            r_p: self.r_p,
            ab: self.pq1,
            bc: self.q1q2,
            part,
        };
        // x far compared with the length (the usual case): one interval, no stack to set up.
        if let Some(points) = self.along_points(0.0, 1.0) {
            self.interval::<S, GRADIENT, HESSIAN>(sums, &frame, n, (0.0, 1.0), points);
            return Some(());
        }
        let mut stack: [(f64, f64); MAX_INTERVALS] = [(0.0, 0.0); MAX_INTERVALS];
        stack[0] = (0.0, 0.5);
        stack[1] = (0.5, 1.0);
        let (mut top, mut used) = (2, 0);
        while top > 0 {
            top -= 1;
            let (s0, s1) = stack[top];
            if let Some(points) = self.along_points(s0, s1) {
                self.interval::<S, GRADIENT, HESSIAN>(sums, &frame, n, (s0, s1), points);
                used += 1;
                continue;
            }
            if top + used + 2 > MAX_INTERVALS {
                return None;
            }
            let mid = 0.5 * (s0 + s1);
            stack[top] = (s0, mid);
            stack[top + 1] = (mid, s1);
            top += 2;
        }
        Some(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::{fan_geometry, subdivided_quadrature};
    use super::*;

    fn vertex(v: DVec3, x: DVec3) -> ClipVertex {
        ClipVertex {
            u: v,
            r: v - x,
            r_lo: DVec3::ZERO,
            on_line: false,
        }
    }

    /// The table holds every rule used, and each rule along integrates the polynomials it should
    /// (degree ≤ 2m − 1) on [0, 1].
    #[test]
    fn rules_along_integrate_their_polynomials() {
        for &(_, m) in &ACROSS {
            assert_eq!(rules().by_points[m].len(), m);
        }
        for &(_, m) in &ALONG {
            let r = rules().by_points[m];
            assert_eq!(r.len(), m);
            for degree in 0..2 * m as i32 {
                let q: f64 = r.iter().map(|&(s, w)| w * s.powi(degree)).sum();
                let exact = 1.0 / (degree + 1) as f64;
                // powi rounds once per factor, and a node's rounding moves s^d by d ulps
                let tolerance = 1e-15 * (degree + 1) as f64 * exact;
                assert!(
                    (q - exact).abs() <= tolerance,
                    "{m} points, degree {degree}: {q}"
                );
            }
        }
    }

    /// The Bernstein-ellipse parameter of the point `z = re + i·im` for the interval [−1, 1]: the
    /// sum of the semi-axes of the ellipse with foci ±1 through `z`.
    fn bernstein(re: f64, im: f64) -> f64 {
        let (im2, lo, hi) = (im * im, re - 1.0, re + 1.0);
        let a = 0.5 * ((lo * lo + im2).sqrt() + (hi * hi + im2).sqrt());
        a + (a * a - 1.0).max(0.0).sqrt()
    }

    /// The `ρ` of a piece's whole length.
    fn rho_whole(piece: &ThinPiece) -> f64 {
        bernstein((piece.s_foot - 0.5) / 0.5, piece.pole_over_length / 0.5)
    }

    /// The ellipse tests choose the rules that the Bernstein parameter `ρ` (from its square
    /// roots) chooses, along and across, for poles on both sides of every threshold: each random
    /// point is classified by both wherever its `ρ` is not within 1e-12 of a threshold.
    #[test]
    fn ellipse_tests_choose_the_rules_of_the_bernstein_parameter() {
        let mut state = 1821;
        let mut compared = 0;
        for _ in 0..20_000 {
            let mut c = || lcg(&mut state);
            let re = 10f64.powf(2.0 * c() - 1.0) * if c() < 0.5 { -1.0 } else { 1.0 };
            let im = 10f64.powf(2.0 * c() - 1.0);
            let rho = bernstein(re, im);
            let near = |r: f64| (rho / r - 1.0).abs() < 1e-12;
            if ALONG.iter().any(|&(r, _)| near(r)) {
                continue;
            }
            let expected = ALONG.iter().find(|(r, _)| rho >= *r).map(|r| r.1);
            let (re2, im2) = (re * re, im * im);
            let chosen = rules()
                .along
                .iter()
                .find(|&&(ia2, ib2, _)| re2 * ia2 + im2 * ib2 >= 1.0)
                .map(|r| r.2);
            assert_eq!(chosen, expected, "{re} {im}");
            // Across: x beside the segment, at `im` half-widths.
            let im = 10f64.powf(6.0 * c());
            let rho = bernstein(0.0, im);
            if ACROSS.iter().any(|&(r, _)| (rho / r - 1.0).abs() < 1e-12) {
                continue;
            }
            let expected = ACROSS.iter().find(|(r, _)| rho >= *r).map(|r| r.1);
            let chosen = rules().across.iter().find(|&&(b, _)| im >= b).map(|r| r.1);
            assert_eq!(chosen, expected, "{im}");
            compared += 1;
        }
        assert!(compared > 19_000, "{compared}");
    }

    /// Continuity at every switch along: x below a cap at the distance where the first piece's
    /// `ρ` crosses each threshold, on both sides (1e-9 apart), against the isotropic subdivision
    /// (an independent rule) and against each other (the jump of the error).
    #[test]
    fn switches_along_are_continuous() {
        let n = DVec3::new(0.1, -0.2, 1.0).normalize();
        let tri = [DVec3::ZERO, DVec3::X, DVec3::new(0.5, 1e-6, 0.0)];
        let at = |depth: f64| {
            let x = DVec3::new(0.4, 0.3 * depth, -depth);
            tri.map(|v| vertex(v, x))
        };
        let first_piece = |t: &[ClipVertex; 3]| {
            let ab = t[1].u - t[0].u;
            let share = (t[2].u - t[0].u).dot(ab) / ab.length_squared();
            let f = ClipVertex {
                u: t[0].u + share * ab,
                r: t[0].r + share * (t[1].r - t[0].r),
                r_lo: DVec3::ZERO,
                on_line: false,
            };
            ThinPiece::new(&t[0], &f, &t[2], rules()).unwrap()
        };
        let mut seen = 0;
        for &(threshold, points) in &ALONG {
            // ρ grows with the depth of x: bisect for the depth where it meets the threshold.
            let (mut lo, mut hi) = (1e-3f64, 1e3f64);
            for _ in 0..200 {
                let mid = (lo * hi).sqrt();
                if rho_whole(&first_piece(&at(mid))) < threshold {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let mut errors = Vec::new();
            for depth in [hi * (1.0 - 1e-9), hi * (1.0 + 1e-9)] {
                let t = at(depth);
                let piece = first_piece(&t);
                let chosen = ALONG
                    .iter()
                    .find(|(r, _)| rho_whole(&piece) >= *r)
                    .map(|r| r.1);
                errors.push(chosen);
                let d = sliver_quadrature(&t, n, Order::Hessian).unwrap();
                let r = subdivided_quadrature(&t, n, Order::Hessian, true, 100_000).unwrap();
                let max = |m: glam::DMat3| {
                    m.to_cols_array()
                        .iter()
                        .fold(0.0, |a: f64, v| a.max(v.abs()))
                };
                let e = [
                    (d.value - r.value) / r.value.abs(),
                    ((d.gradient - r.gradient).abs().max_element())
                        / r.gradient.abs().max_element(),
                    max(d.hessian - r.hessian) / max(r.hessian),
                ];
                assert!(
                    e[0].abs() <= 2e-14 && e[1] <= 2e-14 && e[2] <= 1e-13,
                    "{points} points at ρ = {threshold}: {e:?}"
                );
            }
            // the switch happens there: the finer rule below, this one above
            let below = errors[0].unwrap_or(usize::MAX);
            assert!(below > points && errors[1] == Some(points), "{errors:?}");
            seen += 1;
        }
        assert_eq!(seen, ALONG.len());
    }

    /// The sliver's geometry agrees with the double-double fan geometry (an independent
    /// evaluation from the same exact differences) to a few ulps of `‖N‖` and of `N·r_a`, for
    /// apex 1e-4..1e-12 of the length and x 1e-6..1e2 lengths from the plane.
    #[test]
    fn sliver_geometry_matches_the_double_double_fan_geometry() {
        let mut state = 1817;
        for _ in 0..2000 {
            let mut c = || lcg(&mut state);
            let scale = 10f64.powf(6.0 * c() - 3.0);
            let a = DVec3::new(c(), c(), c()) * scale;
            let b = a + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize() * scale;
            let perp = (b - a).any_orthonormal_vector();
            let apex = a + (b - a) * c() + perp * (scale * 10f64.powf(-4.0 - 8.0 * c()));
            let normal = (b - a).cross(perp).normalize();
            let x = (a + b) * 0.5
                + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * scale
                + normal * (scale * 10f64.powf(-6.0 + 8.0 * c()));
            let exact = |v: DVec3| {
                let r = v - x;
                let err = |p: f64, q: f64| crate::kernels::numeric::dd::two_sum(p, -q).1;
                ClipVertex {
                    u: v - a,
                    r,
                    r_lo: DVec3::new(err(v.x, x.x), err(v.y, x.y), err(v.z, x.z)),
                    on_line: false,
                }
            };
            let t = [exact(a), exact(b), exact(apex)];
            let (n1, c1) = sliver_geometry(&t[0], &t[1], &t[2]);
            let (n2, c2) = fan_geometry(&t[0], &t[1], &t[2], true);
            assert!(
                (n1 - n2).length() <= 4.0 * f64::EPSILON * n2.length(),
                "{n1} {n2}"
            );
            assert!(
                (c1 - c2).abs() <= 8.0 * f64::EPSILON * c2.abs(),
                "{c1} {c2}"
            );
        }
    }

    use crate::test_rng::lcg;

    /// A sliver of length `scale` (1e-3..1e3) with its apex 1e-5..1e-12 of the length off the
    /// long edge, from `c`'s uniform draws: `(scale, [a, b, apex])`.
    fn random_sliver(c: &mut impl FnMut() -> f64) -> (f64, [DVec3; 3]) {
        let scale = 10f64.powf(6.0 * c() - 3.0);
        let a = DVec3::new(c(), c(), c()) * scale;
        let b = a + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize() * scale;
        let perp = (b - a).any_orthonormal_vector();
        let height = 10f64.powf(-5.0 - 7.0 * c());
        let apex = a + (b - a) * (1.2 * c() - 0.1) + perp * (height * scale);
        (scale, [a, b, apex])
    }

    /// The direct entry gives `evaluate`'s bits whenever it answers, and answers for slivers seen
    /// from afar, clipped or not: slivers with apex 1e-5..1e-12 of their length, x from 1e-7 (where
    /// the rule declines) to 10 lengths away, receiver normals that clip the sliver or graze a
    /// vertex.
    #[test]
    fn direct_entry_gives_the_bits_of_evaluate() {
        let mut state = 1818;
        let (mut taken, mut declined, mut clipped_taken) = (0, 0, 0);
        for k in 0..4000 {
            let mut c = || lcg(&mut state);
            let (scale, [a, b, apex]) = random_sliver(&mut c);
            let v = [a, b, apex];
            // Mostly 1e-3..10 lengths away, sometimes closer. Within ~1e-2 lengths x is usually
            // within 1e-3·r_max of the plane, which the robust path handles (declined here).
            let exponent = if k % 5 == 0 {
                -7.0 + 4.0 * c()
            } else {
                -3.0 + 4.0 * c()
            };
            let distance = 10f64.powf(exponent) * scale;
            let x = (a + b) * 0.5 + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * distance;
            let mut random_unit = || DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize();
            let n = match k % 4 {
                // every vertex above the tangent plane (if one of 100 tries finds such a normal)
                0 | 1 => (0..100)
                    .map(|_| random_unit())
                    .find(|n| v.iter().all(|vk| n.dot(*vk - x) > 0.0))
                    .unwrap_or(DVec3::Z),
                2 => random_unit(),
                // grazing: the tangent plane through a vertex (up to rounding)
                _ => (a - x).any_orthonormal_vector(),
            };
            let r = v.map(|vk| vk - x);
            let u = [DVec3::ZERO, v[1] - v[0], v[2] - v[0]];
            let err = |p: f64, q: f64| crate::kernels::numeric::dd::two_sum(p, -q).1;
            let r_lo = v.map(|vk| DVec3::new(err(vk.x, x.x), err(vk.y, x.y), err(vk.z, x.z)));
            let scaled = super::super::Scaled {
                u: super::super::Points::from_slice(&u),
                r: super::super::Points::from_slice(&r),
                r_lo: super::super::Points::from_slice(&r_lo),
                inv_scale: 1.0,
            };
            for order in [Order::Value, Order::Gradient, Order::Hessian] {
                let Some(direct) = direct_sliver(&u, &r, &r_lo, n, order) else {
                    declined += 1;
                    continue;
                };
                taken += 1;
                clipped_taken += usize::from(r.iter().any(|rk| n.dot(*rk) <= 0.0));
                let robust = super::super::evaluate(&scaled, n, order).unwrap();
                let bits = |d: &Deriv3| {
                    let mut b = vec![d.value.to_bits()];
                    b.extend(d.gradient.to_array().map(f64::to_bits));
                    b.extend(d.hessian.to_cols_array().map(f64::to_bits));
                    b
                };
                assert_eq!(bits(&direct), bits(&robust), "{k} {order:?}");
            }
        }
        assert!(
            taken > 2000 && declined > 1000 && clipped_taken > 1000,
            "{taken} {declined} {clipped_taken}"
        );
    }

    /// The AVX2+FMA build of the rule gives the portable build's bits, on slivers with apex
    /// 1e-5..1e-12 of their length, sizes 1e-3..1e3 and x 1e-3..10 lengths away, at every order
    /// (and answers for most of them).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn fma_twin_keeps_the_bits() {
        if !crate::simd::avx2_fma() {
            return;
        }
        let mut state = 1820;
        let mut answered = 0;
        // The rules along chosen for the whole of the first piece: every one is exercised.
        let mut used = [false; 25];
        for _ in 0..3000 {
            let mut c = || lcg(&mut state);
            let (scale, [a, b, apex]) = random_sliver(&mut c);
            let x = (a + b) * 0.5
                + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5)
                    * (scale * 10f64.powf(4.0 * c() - 3.0));
            let n = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize();
            let t = [a, b, apex].map(|v| vertex(v, x));
            let ab = t[1].u - t[0].u;
            let share = ((t[2].u - t[0].u).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
            let f = ClipVertex {
                u: t[0].u + share * ab,
                r: t[0].r + share * (t[1].r - t[0].r),
                r_lo: DVec3::ZERO,
                on_line: false,
            };
            if let Some(points) =
                ThinPiece::new(&t[0], &f, &t[2], rules()).and_then(|p| p.along_points(0.0, 1.0))
            {
                used[points] = true;
            }
            for order in [Order::Value, Order::Gradient, Order::Hessian] {
                let portable = sliver_quadrature_with::<PortableSums>(&t, n, order);
                // SAFETY: checked above that the CPU has AVX2 and FMA.
                let fused = unsafe { sliver_quadrature_fma(&t, n, order) };
                let bits = |d: &Deriv3| {
                    let mut b = vec![d.value.to_bits()];
                    b.extend(d.gradient.to_array().map(f64::to_bits));
                    b.extend(d.hessian.to_cols_array().map(f64::to_bits));
                    b
                };
                assert_eq!(portable.as_ref().map(bits), fused.as_ref().map(bits));
                answered += usize::from(portable.is_some());
            }
        }
        assert!(answered > 6000, "{answered}");
        for &(_, points) in &ALONG {
            assert!(used[points], "{points} points along never chosen");
        }
    }

    /// Each threshold along keeps the module's bound `(64/15) (1 − σ/ρ)^{-4} σ^{-2m}` (Hessian
    /// poles, `σ = ρ·2m/(2m + 4)`) under 1e-15 (1.52e-15 at 16 points), and is within 3%
    /// of the smallest `ρ` that does: the table is the bound's, not a guess.
    #[test]
    fn thresholds_along_keep_the_error_bound() {
        let bound = |rho: f64, m: usize| {
            let m2 = 2.0 * m as f64;
            let sigma = rho * m2 / (m2 + 4.0);
            64.0 / 15.0 * (1.0 - sigma / rho).powi(-4) * sigma.powf(-m2)
        };
        for &(rho, m) in &ALONG {
            let limit = if m == 16 { 1.52e-15 } else { 1e-15 };
            assert!(
                bound(rho, m) <= limit,
                "{m} points at {rho}: {:e}",
                bound(rho, m)
            );
            assert!(
                bound(rho / 1.03, m) > 1e-15,
                "{m} points: {rho} is far from the bound"
            );
        }
    }

    /// The sliver rule is taken for a cap and a needle seen from afar, agrees with the isotropic
    /// subdivision (an independent rule) to 1e-12, and declines when x is within a width of it.
    #[test]
    fn sliver_rule_agrees_with_the_subdivision_and_declines_near_x() {
        let n = DVec3::new(0.1, -0.2, 1.0).normalize();
        let x = DVec3::new(0.4, 0.1, -0.7);
        for apex in [DVec3::new(0.5, 1e-6, 0.0), DVec3::new(1.0, 1e-6, 0.0)] {
            let t = [DVec3::ZERO, DVec3::X, apex].map(|v| vertex(v, x));
            let d = sliver_quadrature(&t, n, Order::Hessian).expect("sliver rule declined");
            let r = subdivided_quadrature(&t, n, Order::Hessian, true, 100_000).unwrap();
            assert!(
                (d.value - r.value).abs() <= 1e-12 * r.value.abs(),
                "{d:?} {r:?}"
            );
            let g = r.gradient.abs().max_element();
            assert!((d.gradient - r.gradient).abs().max_element() <= 1e-12 * g);
            let max = |m: glam::DMat3| {
                m.to_cols_array()
                    .iter()
                    .fold(0.0, |a: f64, v| a.max(v.abs()))
            };
            assert!(max(d.hessian - r.hessian) <= 1e-11 * max(r.hessian));
        }
        // x 1e-7 above the cap's middle: the width is not small against the distance
        let near = DVec3::new(0.5, 5e-7, -1e-7);
        let t = [DVec3::ZERO, DVec3::X, DVec3::new(0.5, 1e-6, 0.0)].map(|v| vertex(v, near));
        assert!(sliver_quadrature(&t, n, Order::Value).is_none());
    }
}
