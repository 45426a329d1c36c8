//! The solid angle's certified rung: Van Oosterom-Strackee in plain f64 with a running error
//! bound, in the manner of adaptive geometric predicates.
//!
//! It answers when the inputs are in the range where no rescaling is needed (distances
//! `|y_k − x|` in ([`S_MIN`], 1e30), hence coordinate differences in [1e-30, 1e30]; finite, `x` off
//! the plane and the vertices) and the first-order
//! bound of every rounding certifies the result within [`FAST_TOL`] (5e-13 value and gradient,
//! 5e-12 Hessian: 2-20x under the contract). Where only `A` fails its bound (`x` near the plane
//! relative to its distance, slivers) `A` and `N` are recomputed in double-double within this
//! rung; near an edge (`D` and `∇D` cancel) or out of range it declines and the robust rung
//! answers. Near a vertex nothing cancels (the difference to the nearby vertex is exact,
//! Sterbenz), so the rung stays. The bound is derived on [`solid_angle_fast`].

use glam::DVec3;

use super::hessian::{hessian_of_parts, Parts, Quotient};
use crate::kernels::numeric::atan2::atan2_upper;
use crate::kernels::numeric::dd::Dd3;
use crate::{Deriv3, Order};

/// Unit roundoff of f64.
const U: f64 = 0.5 * f64::EPSILON;
/// Error budgets of the fast path (value, gradient, Hessian; relative to the value, to the largest
/// gradient entry, to the largest Hessian entry). The accuracy contract is 1e-12 / 1e-12 / 1e-10 in
/// generic configurations (1e-10 / 1e-9 / 1e-8 in the hard regimes): the fast result is accepted
/// only when its error bound (itself pessimistic) is 2-20x below the strictest of these.
const FAST_TOL: [f64; 3] = [5e-13, 5e-13, 5e-12];
/// Above this relative error bound of the f64 triple product `A`, the fast path recomputes `A` and
/// `N` in double-double (x near the plane relative to its distance, or a sliver whose angle at `a`
/// is small) before certifying.
const FAST_A_TOL: f64 = 5e-14;
/// Smallest distance `|y_k − x|` the rung takes (the largest is 1e30): `√3·1e-30` rounded up, so
/// that the largest coordinate difference is above 1e-30 (a distance is at most √3 times it) and
/// the range check needs the three distances alone, not the nine differences.
const S_MIN: f64 = 1.75e-30;
/// Absolute error allowance for products that may be subnormal (inputs are restricted to
/// magnitudes in [1e-30, 1e30], where every other quantity bounded below is normal).
const TINY: f64 = 1e-290;

/// `(|a_y b_z| + |a_z b_y|, …)`: the componentwise magnitude bound of `a × b` (arguments already
/// absolute).
#[inline]
fn abs_cross(a: DVec3, b: DVec3) -> DVec3 {
    DVec3::new(
        a.y * b.z + a.z * b.y,
        a.z * b.x + a.x * b.z,
        a.x * b.y + a.y * b.x,
    )
}

#[inline]
fn l1(v: DVec3) -> f64 {
    v.x.abs() + v.y.abs() + v.z.abs()
}

/// The fast evaluation of the (signed or unsigned) solid angle with a running error bound, in the
/// manner of adaptive geometric predicates: `None` when the inputs are outside the range it handles
/// (non-finite, distances `|y_k − x|` outside ([`S_MIN`], 1e30), `x` on the plane or at a vertex) or
/// when the bound cannot certify the result to [`FAST_TOL`]; the caller then takes the robust path.
///
/// It is the robust path's formulation without its exact rescaling (not needed in that range) and
/// without its validation by error values (a few comparisons instead). `A` and `N` come from the
/// edges at `a` in f64, or in double-double when their f64 bound exceeds [`FAST_A_TOL`]; `D`, `∇D`
/// and `HD` are f64 (the robust path refines them only near an edge, where the bound fails).
///
/// The bound, with `u` the unit roundoff (derived by counting roundings per term, each term bounded
/// by its magnitude; the constants are rounded up):
/// * `|δA| ≤ 9u·|r_0|·(|e_1|⊠|e_2|)` (⊠ the cross product of magnitudes, the permanent of the
///   determinant), `‖δN‖₁ ≤ 4u·‖|e_1|⊠|e_2|‖₁`; after the double-double recomputation
///   `|δA| ≤ 2u|A| + 64u²·(permanent)`;
/// * `|δD| ≤ 64u·s_0 s_1 s_2` (each of the four terms of `D` is at most `s_0 s_1 s_2`),
///   `‖δ∇D‖₁ ≤ 200u·Σ s_i s_j`, entries of `δHD` ≤ `40u·(4 Σ s_i s_j/s_k + 14 Σ s_k)`;
/// * with `g = A² + D²` and `Δ = (|δA| + |δD|)/√g` (which bounds the perturbation of the angle
///   `atan2(A, D)` and the relative perturbation of `√g`), the value's error is at most
///   `2(|D||δA| + |A||δD|)/g` plus the last bits of `atan2` (the inline polynomial
///   [`atan2_upper`], within 2 ulps of libm's); the gradient `2(cos θ ∇A − sin θ ∇D)/√g` and the
///   Hessian `−(2A/g) HD − (G vᵀ + v Gᵀ)` are bounded term by term the same way (see the code).
///   The Hessian's bound reuses the gradient's: the rank-two part is built from the computed
///   gradient `G`.
#[inline(always)]
pub(super) fn solid_angle_fast(
    x: DVec3,
    y: [DVec3; 3],
    order: Order,
    signed: bool,
) -> Option<Deriv3> {
    let parts = certified_parts(x, y, signed)?;
    if !order.gradient() {
        return Some(Deriv3::constant(certified_value(&parts)?));
    }
    // The derivatives first and the value's `atan2` last: its polynomial is a chain of dependent
    // operations, which then overlaps what follows the call instead of delaying the derivatives.
    let mut out = certified_derivs(&parts, order)?;
    out.value = certified_value(&parts)?;
    Some(out)
}

/// What the certified fast path computes for every order before `atan2`: the parts of
/// `Ω = 2 atan2(A, D)` and their error bounds, which the value and the derivatives use.
pub(super) struct CertifiedParts {
    r: [DVec3; 3],
    s: [f64; 3],
    normal: DVec3,
    a_num: f64,
    d_den: f64,
    /// `r_0·r_1`, `r_1·r_2`, `r_2·r_0`.
    dots: [f64; 3],
    /// `A² + D²`.
    g: f64,
    err_a: f64,
    err_n: f64,
    err_d: f64,
}

/// The parts of [`solid_angle_fast`] every order computes; `None` where the inputs are out of its
/// range or `A`'s sign is uncertain. Written on components, with glam's operation order (`dot` is
/// `(x·x' + y·y') + z·z'`, `cross` glam's, `length` the square root of `dot`), so that every
/// quantity has the bits glam's expressions give; the range tests compare the components' moduli
/// directly (for finite input the same decisions as glam's `max_element` and `f64::min`; NaN fails
/// them, and non-finite input goes to the robust path either way).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(super) fn certified_parts(x: DVec3, y: [DVec3; 3], signed: bool) -> Option<CertifiedParts> {
    let r = [y[0] - x, y[1] - x, y[2] - x];
    let dot = |a: DVec3, b: DVec3| a.x * b.x + a.y * b.y + a.z * b.z;
    let s = [
        dot(r[0], r[0]).sqrt(),
        dot(r[1], r[1]).sqrt(),
        dot(r[2], r[2]).sqrt(),
    ];
    // NaN and infinities fail this too, and so do differences whose squares overflow.
    let in_range = |v: f64| v > S_MIN && v < 1e30;
    if !(in_range(s[0]) && in_range(s[1]) && in_range(s[2])) {
        return None;
    }
    let e1 = y[1] - y[0];
    let e2 = y[2] - y[0];
    let mut normal = DVec3::new(
        e1.y * e2.z - e2.y * e1.z,
        e1.z * e2.x - e2.z * e1.x,
        e1.x * e2.y - e2.x * e1.y,
    );
    let perm_n = abs_cross(e1.abs(), e2.abs());
    let perm_a = dot(r[0].abs(), perm_n);
    let mut a_num = dot(r[0], normal);
    let mut err_a = 9.0 * U * perm_a + TINY;
    let mut err_n = 4.0 * U * (perm_n.x + perm_n.y + perm_n.z) + TINY;
    if !(err_a <= FAST_A_TOL * a_num.abs()) {
        (a_num, normal, err_a, err_n) = exact_triple_product(x, y, perm_a, perm_n);
    }
    // On the plane (or a sign that rounding could flip): the robust path's limits apply.
    if !(err_a < 0.5 * a_num.abs()) {
        return None;
    }
    if !signed && a_num < 0.0 {
        a_num = -a_num;
        normal = -normal;
    }

    let d01 = dot(r[0], r[1]);
    let d12 = dot(r[1], r[2]);
    let d20 = dot(r[2], r[0]);
    let s012 = s[0] * s[1] * s[2];
    let d_den = s012 + d01 * s[2] + d12 * s[0] + d20 * s[1];
    let err_d = 64.0 * U * s012;
    let g = a_num * a_num + d_den * d_den;
    Some(CertifiedParts {
        r,
        s,
        normal,
        a_num,
        d_den,
        dots: [d01, d12, d20],
        g,
        err_a,
        err_n,
        err_d,
    })
}

/// `Ω = 2θ`, `θ = atan2(A, D)`, when its error bound is within [`FAST_TOL`]; `None` otherwise.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(super) fn certified_value(parts: &CertifiedParts) -> Option<f64> {
    let &CertifiedParts {
        a_num,
        d_den,
        g,
        err_a,
        err_d,
        ..
    } = parts;
    // `atan2_upper` is within 2 ulps of libm's `atan2` (itself within 1), inline and without
    // branches; the angle's sign is `A`'s.
    let theta = atan2_upper::<false>(a_num.abs(), d_den).copysign(a_num);
    // |δθ| ≤ (|D||δA| + |A||δD|)/g (+ 8u|θ| for the 3 ulps of atan2 and the rounding of g).
    if !(d_den.abs() * err_a + a_num.abs() * err_d
        <= (0.5 * FAST_TOL[0] - 8.0 * U) * theta.abs() * g)
    {
        return None;
    }
    Some(2.0 * theta)
}

/// `A` and `N` of [`certified_parts`] from the exact differences in double-double (no rescaling
/// needed in its range), with their error bounds: x near the plane, or a sliver. Out of line: rare,
/// and its registers would crowd the common path.
#[cold]
#[inline(never)]
fn exact_triple_product(
    x: DVec3,
    y: [DVec3; 3],
    perm_a: f64,
    perm_n: DVec3,
) -> (f64, DVec3, f64, f64) {
    let ra = Dd3::diff(y[0], x);
    let n = Dd3::diff(y[1], y[0]).cross(&Dd3::diff(y[2], y[0]));
    let a_num = ra.dot(&n).to_f64();
    let normal = n.to_dvec3();
    let err_a = 2.0 * U * a_num.abs() + 64.0 * U * U * perm_a + TINY;
    let err_n = 2.0 * U * l1(normal) + 64.0 * U * U * (perm_n.x + perm_n.y + perm_n.z) + TINY;
    (a_num, normal, err_a, err_n)
}

/// The gradient and Hessian part of [`solid_angle_fast`], with their error bounds (the value is
/// left at 0); `None` where a bound fails.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn certified_derivs(parts: &CertifiedParts, order: Order) -> Option<Deriv3> {
    let &CertifiedParts {
        r,
        s,
        normal,
        a_num,
        d_den,
        dots: [d01, d12, d20],
        g,
        err_a,
        err_n,
        err_d,
    } = parts;
    let mut out = Deriv3::constant(0.0);
    let inv_s = s.map(|v| 1.0 / v);
    let p = [s[1] * s[2] + d12, s[2] * s[0] + d20, s[0] * s[1] + d01];
    let c = [
        p[0] * inv_s[0] + s[1] + s[2],
        p[1] * inv_s[1] + s[2] + s[0],
        p[2] * inv_s[2] + s[0] + s[1],
    ];
    let grad_d = -(r[0] * c[0] + r[1] * c[1] + r[2] * c[2]);
    let quotient = Quotient::new(a_num, d_den, g, -normal, grad_d);
    let inv_g = quotient.inv_g;
    out.gradient = quotient.gradient;

    // Perturbation bounds: |δθ| ≤ Δθ, |δ√g|/√g ≤ Δg (first order; the checks keep them ≪ 1).
    let (aa, dd) = (a_num.abs(), d_den.abs());
    let delta_theta = (dd * err_a + aa * err_d) * inv_g;
    let delta_g = (aa * err_a + dd * err_d) * inv_g;
    let q = s[0] * s[1] + s[1] * s[2] + s[2] * s[0];
    let err_g = 200.0 * U * q;
    let (n1, g1) = (l1(normal), l1(grad_d));
    // ∇Ω = 2(cos θ ∇A − sin θ ∇D)/√g with cos θ = D/√g, sin θ = A/√g.
    let v_mag = aa * n1 + dd * g1;
    let grad_bound = 2.0
        * inv_g
        * (delta_theta * v_mag
            + dd * err_n
            + aa * err_g
            + (delta_g + 8.0 * U) * (dd * n1 + aa * g1));
    let g_max = out.gradient.abs().max_element();
    if !(grad_bound <= FAST_TOL[1] * g_max) {
        return None;
    }

    if order.hessian() {
        let s_sum = s[0] + s[1] + s[2];
        out.hessian = hessian_of_parts(&Parts { r, s, inv_s, p, c }, &quotient);
        let w = s[1] * s[2] * inv_s[0] + s[2] * s[0] * inv_s[1] + s[0] * s[1] * inv_s[2];
        let hd_mag = 4.0 * w + 14.0 * s_sum;
        // HΩ = −(2A/g) HD − (G vᵀ + v Gᵀ), G = ∇Ω, v = (A a + D d)/g, a = ∇A, d = ∇D
        // (`hessian_of_parts`). Each entry's error is at most the sum of
        // * `HD`'s part: (2/g)[(δθ|D| + Δg|A|) hd_mag + |A| |δHD|], |δHD| ≤ 40u·hd_mag, with
        //   `−2A/g = −2 sin θ/√g` perturbed by (2/g)(δθ|D| + Δg|A|), and 32u|A| hd_mag for its
        //   product and the entry's last sums (72u in all);
        // * the rank-two part: 2(|δG| |v| + |G| |δv|), where |δG| ≤ `grad_bound` (the gradient's
        //   certified bound covers the computed G the Hessian uses), |v| ≤ V = (|A| ‖a‖₁ +
        //   |D| ‖d‖₁)/g, |G| ≤ max|G| + `grad_bound`, and |δv| ≤ (‖a‖₁|δA| + |A| ‖δN‖₁ +
        //   ‖d‖₁|δD| + |D| ‖δ∇D‖₁)/g + V(2Δg + 16u): the perturbation of the inputs, of 1/g, and
        //   the rounding of v (7u) and of the two products and their sum (3u of 2 max|G| V).
        let v_bound = v_mag * inv_g;
        let delta_v = (n1 * err_a + aa * err_n + g1 * err_d + dd * err_g) * inv_g
            + v_bound * (2.0 * delta_g + 16.0 * U);
        let hess_bound = 2.0
            * (inv_g * hd_mag * (delta_theta * dd + (delta_g + 72.0 * U) * aa)
                + grad_bound * v_bound
                + (g_max + grad_bound) * delta_v);
        // The Hessian is symmetric (`hessian_of_parts`): its upper triangle has every entry. The
        // largest modulus as a tree of three levels rather than a chain of six; a NaN entry is
        // either skipped or fails the comparison, and the finiteness test rejects it either way.
        let h = &out.hessian;
        let larger = |a: f64, b: f64| if a > b { a } else { b };
        let h_max = larger(
            larger(
                larger(h.x_axis.x.abs(), h.y_axis.y.abs()),
                larger(h.z_axis.z.abs(), h.y_axis.x.abs()),
            ),
            larger(h.z_axis.x.abs(), h.z_axis.y.abs()),
        );
        if !(hess_bound <= FAST_TOL[2] * h_max) {
            return None;
        }
    }
    derivatives_finite(&out).then_some(out)
}

/// Whether the derivatives of a result whose Hessian is symmetric are all finite, from the
/// gradient and the Hessian's upper triangle (the value is set later, from `atan2` of finite
/// parts), without a comparison per entry: their sum is finite when every one is (or overflows, a
/// false "no" that only sends the call to the robust rung), and infinite or NaN when one is
/// (`inf + x` is `inf` for finite `x`, `inf − inf` and NaN terms give NaN); `s − s` is zero
/// exactly for a finite `s`.
#[inline(always)]
#[allow(clippy::eq_op)] // `s − s` is the test: zero for finite `s` only
fn derivatives_finite(d: &Deriv3) -> bool {
    let (g, h) = (d.gradient, &d.hessian);
    let sum = ((g.x + g.y) + (g.z + h.x_axis.x))
        + ((h.y_axis.y + h.z_axis.z) + (h.y_axis.x + h.z_axis.x))
        + h.z_axis.y;
    sum - sum == 0.0
}
