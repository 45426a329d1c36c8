//! Thin triangles (slivers) by an anisotropic tensor rule.
//!
//! A sliver's edge sum cancels by about its inverse aspect ratio, and the isotropic subdivision of
//! [`subdivided_quadrature`](crate::kernels::form_factor::quadrature::subdivide::subdivided_quadrature)
//! bisects it into hundreds of long pieces. But a sliver is thin in one direction only: across its
//! width `w` the integrand varies over a distance ~`d` (the distance of x), so a few Gauss points
//! suffice there, and only the long direction needs many points, graded by the distance of x.
//!
//! The triangle is split at the foot `f` of its apex `c` on its longest edge `ab` (both angles at
//! `a` and `b` are acute, so `f` lies on the edge) into `(a, f, c)` and `(b, c, f)`, each
//! Duffy-mapped from its vertex on the long edge: `r = r_p + s·(q₁ − p) + s·t·(q₂ − q₁)`, with
//! `q₁q₂` the short edge `fc`. Their `(2·area·N̂, 2·area·N̂·r)` are the shares `t_f` and `1 − t_f`
//! (`f = a + t_f·ab`) of the whole triangle's, taken from the exact differences; the shares go into
//! the pieces' weights, so that both pieces add to one set of sums, assembled once. The sums run
//! four nodes at a time ([`quadrature::lanes`](crate::kernels::form_factor::quadrature::lanes)).
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
//! [`direct_sliver`](crate::kernels::form_factor::sliver::direct::direct_sliver) from
//! `triangle_form_factor_in_range` (the same bits without the set-up). x may be near the sliver's
//! plane: the rule needs x far from the sliver compared with its width only, and
//! [`sliver_geometry`] takes the height from the exact triple product.

use std::sync::OnceLock;

use glam::DVec3;

use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::quadrature::lanes;
#[cfg(target_arch = "x86_64")]
use crate::kernels::form_factor::quadrature::lanes::AvxSums;
use crate::kernels::form_factor::quadrature::lanes::{GroupSums, PieceFrame, PortableSums};
use crate::kernels::form_factor::quadrature::rules::{
    gauss_legendre_16, gauss_legendre_2, gauss_legendre_3, gauss_legendre_4, gauss_legendre_8,
    legendre_rule,
};
use crate::kernels::form_factor::quadrature::tensor::RuleSums;
use crate::kernels::form_factor::sliver::geometry::sliver_geometry;
use crate::kernels::numeric::lanes::V3;
use crate::{Deriv3, Order};

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
pub(crate) fn rule(points: usize) -> &'static [(f64, f64)] {
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
pub(crate) struct Rules {
    /// The rules by their number of points (empty elsewhere).
    pub(crate) by_points: [&'static [(f64, f64)]; 25],
    /// The rules along by their number of points, as the sums take them
    /// ([`quadrature::lanes::quads`](crate::kernels::form_factor::quadrature::lanes::quads)).
    pub(crate) quads: [&'static [[[f64; 4]; 2]]; 25],
    /// [`ALONG`] as `(1/a², 1/b², points)` with `a`, `b` the semi-axes of the threshold's
    /// ellipse ([`semi_axes`]).
    pub(crate) along: [(f64, f64, usize); ALONG.len()],
    /// [`ACROSS`] as `(b, points)`: on the imaginary axis the ellipse is crossed at `±i·b`.
    pub(crate) across: [(f64, usize); ACROSS.len()],
}

pub(crate) fn rules() -> &'static Rules {
    static RULES: OnceLock<Rules> = OnceLock::new();
    RULES.get_or_init(|| {
        let mut by_points: [&'static [(f64, f64)]; 25] = [&[]; 25];
        for &(_, points) in ALONG.iter().chain(&ACROSS) {
            by_points[points] = rule(points);
        }
        let mut quads: [&'static [[[f64; 4]; 2]]; 25] = [&[]; 25];
        for &(_, points) in &ALONG {
            // Built once per process and kept for it.
            quads[points] = Box::leak(lanes::quads(by_points[points]).into_boxed_slice());
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

/// The semi-axes `(a, b) = ((ρ + 1/ρ)/2, (ρ − 1/ρ)/2)` of the Bernstein ellipse of parameter
/// `ρ > 1` for [−1, 1] (foci ±1). The ellipses of larger parameters enclose it, so a point
/// `z = re + i·im` has a parameter of at least `ρ` exactly when `re²/a² + im²/b² ≥ 1`: the rules
/// are chosen by that test, without the parameter's square roots.
fn semi_axes(rho: f64) -> (f64, f64) {
    (0.5 * (rho + 1.0 / rho), 0.5 * (rho - 1.0 / rho))
}

/// The signed form factor of a sliver triangle (x origin of the `r`; nothing clipped) by the
/// anisotropic rule, or `None` when x is too close to it for the rule (the width is not small
/// against the distance, or the length needs more than [`MAX_INTERVALS`] intervals).
pub(crate) fn sliver_quadrature(verts: &[ClipVertex], n: DVec3, order: Order) -> Option<Deriv3> {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2_fma() {
        // SAFETY: `simd::avx2_fma` checked that the CPU has AVX2 and FMA.
        return unsafe { sliver_quadrature_fma(verts, n, order) };
    }
    sliver_quadrature_with::<PortableSums>(verts, n, order)
}

/// [`sliver_quadrature`] compiled with AVX2 and FMA: the geometry's exact products are fused
/// instead of calls to `fma`, and the sums take four nodes per AVX register ([`AvxSums`]) instead
/// of two SSE2 registers. The same bits: the fused product is correctly rounded either way, the
/// lanes round as the portable ones and are added in the same tree
/// ([`quadrature::lanes`](crate::kernels::form_factor::quadrature::lanes)), and Rust fuses nothing
/// else (unit-tested).
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
pub(crate) fn rule_sums<S: GroupSums, const GRADIENT: bool, const HESSIAN: bool>(
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

/// One piece `(p, q₁, q₂)` with `q₁q₂` short, Duffy-mapped from `p`, and its rules.
pub(crate) struct ThinPiece {
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
    pub(crate) fn new(
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
        // latency (slower on a triangle sliver despite fewer tests).
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
mod tests;
