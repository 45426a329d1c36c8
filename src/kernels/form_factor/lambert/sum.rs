//! Certified value-only fast path of the point-to-triangle form factor and of its edge term:
//! Lambert's per-edge sum as the textbook writes it, with a running error bound.
//!
//! Per edge (`r_a = a − x`, `r_b = b − x`, `e = b − a`, `w = r_a × e` (= `r_a × r_b`), `s = ‖w‖`,
//! `c = r_a·r_b`):
//!
//! ```text
//! f = (1/2π) β (n·w)/s,   β = atan2(s, c) ∈ [0, π].
//! ```
//!
//! `w` is formed from the edge vector rather than as `r_a × r_b`: far away `r_a × r_b` loses
//! `distance/size` digits to cancellation, `r_a × e` does not.
//!
//! **Error bound** (u = 2⁻⁵³, first order in u; `L = ‖r_a‖‖e‖`, `p = L/s`, `P = ‖r_a‖‖r_b‖`).
//! Rounding `r_a`, `e` and the cross product gives `‖δw‖ ≤ 6uL`, so `|δ(n·w)| ≤ 6uL + 3us` and
//! `|δs| ≤ 6uL + 2us`; `|δc| ≤ 5uP`. With `s² + c² = P²` and `sin β = s/P ≤ β`, `|δβ| ≤ (|c|·|δs| +
//! s·|δc|)/P² + 2uβ ≤ (6p + 9)uβ` (atan2 within 2 ulp), so `g = β/s` is within `(12p + 12)u`
//! relatively and `|δf|·2π ≤ uβ(18p + 16)` (using `|n·w| ≤ s`). With `p ≤ 1 + |r_a·e|/s` the bound
//! needs only computed quantities: `|δf|·2π ≤ u(34β + 18|r_a·e|·g)`, used below as `u(36β +
//! 20|r_a·e|g)`. Summing three terms, renormalizing `n` and scaling add `5u Σ|f_i|` (`(m + 2)u
//! Σ|f_i|` for `m` edges). When the bound exceeds [`FAST_TOLERANCE`] times the result (x near an
//! edge's line, where `p` grows; a cancelling sum: near the polygon's plane), the caller falls back
//! to the robust path. Far away (every edge within `1/√20` of its distance) the value comes from
//! [`lambert::far`](crate::kernels::form_factor::lambert::far)'s rearrangement of the same sum,
//! which does not cancel.

use glam::{DMat3, DVec3};

use crate::kernels::form_factor::edge::INV_2PI;
use crate::kernels::form_factor::lambert::far::{far_sum, Far, FAR_RATIO2};
use crate::kernels::form_factor::tolerance::FAST_TOLERANCE;
use crate::kernels::form_factor::validate::{in_range, unit};
use crate::kernels::numeric::lanes::{Lane, Pair, V3};
use crate::{Deriv3, Order};

const U: f64 = 0.5 * f64::EPSILON;

/// One Lambert edge term times 2π, `β (n·w)/s`, and its error bound times 2π / u, from
/// `r_a`, `r_b`, `e = b − a` and `‖r_a‖²`.
#[inline]
pub(crate) fn edge(n: DVec3, ra: DVec3, rb: DVec3, e: DVec3, ra2: f64) -> (f64, f64) {
    let (f, err, _) = edge_and_angle(n, ra, rb, e, ra2);
    (f, err)
}

/// [`edge`] and the edge's angle `β` (for a derivative pass over the same edge that would
/// recompute it: [`edge_derivatives`]).
#[inline(always)]
pub(crate) fn edge_and_angle(
    n: DVec3,
    ra: DVec3,
    rb: DVec3,
    e: DVec3,
    ra2: f64,
) -> (f64, f64, f64) {
    let w = ra.cross(e);
    let s = w.length();
    let c = ra.dot(rb);
    let beta = s.atan2(c);
    let g = beta / s;
    // r_a·e = r_a·r_b − ‖r_a‖².
    (n.dot(w) * g, 36.0 * beta + 20.0 * (c - ra2).abs() * g, beta)
}

/// The value of [`edge_form_factor`](crate::kernels::form_factor::edge_form_factor) by Lambert's
/// formula when its error bound is within [`FAST_TOLERANCE`] of the result; `None` otherwise or for
/// invalid input.
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn edge_value(x: DVec3, n: DVec3, a: DVec3, b: DVec3) -> Option<f64> {
    let (ra, rb) = (a - x, b - x);
    if !(in_range(ra) && in_range(rb)) {
        return None;
    }
    let n = unit(n)?;
    let scale = INV_2PI;
    let (f, err) = edge(n, ra, rb, b - a, ra.length_squared());
    // One more rounding for the product with n's renormalization, two for the final scaling.
    if !(U * (err + 3.0 * f.abs()) <= FAST_TOLERANCE * f.abs()) {
        return None;
    }
    Some(f * scale)
}

/// The unit normal, `r_k = v_k − x` and `‖r_k‖²` of a polygon the fast paths may take: every
/// `r_k` in range and every vertex certainly above the tangent plane (nothing to clip); `None`
/// otherwise or for a normal outside the unit tolerance.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn unclipped<const M: usize>(
    x: DVec3,
    n: DVec3,
    v: &[DVec3; M],
) -> Option<(DVec3, [DVec3; M], [f64; M])> {
    let r: [DVec3; M] = std::array::from_fn(|k| v[k] - x);
    if !r.iter().all(|rk| in_range(*rk)) {
        return None;
    }
    let n = unit(n)?;
    // Heights over the tangent plane: above 8u·(|n|·|r|) the exact height is positive (see the
    // robust fast path), so nothing is clipped.
    for rk in &r {
        if !(n.dot(*rk) > 8.0 * f64::EPSILON * n.abs().dot(rk.abs())) {
            return None;
        }
    }
    // from_fn, not map: the map did not inline here.
    Some((n, r, std::array::from_fn(|k| r[k].length_squared())))
}

/// The triangle case of [`unclipped`] (both triangle fast paths share it).
#[inline(always)]
fn unclipped_triangle(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<(DVec3, [DVec3; 3], [f64; 3])> {
    unclipped(x, n, &v)
}

/// `2π` times the signed form factor of an unclipped polygon (`unclipped`'s output): the far-field
/// form ([`lambert::far`](crate::kernels::form_factor::lambert::far)) when every edge is small
/// against its distance, otherwise Lambert's sum with its running bound (`(m + 2)u Σ|f_i|` for
/// summing `m` terms, renormalizing `n` and scaling). `None` when the chosen form is not certified.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn certified_sum<const M: usize>(
    n: DVec3,
    v: &[DVec3; M],
    r: &[DVec3; M],
    r2: &[f64; M],
) -> Option<f64> {
    if let Some(total) = certified_far_value(n, v, r, r2) {
        return Some(total);
    }
    let (mut sum, mut magnitude, mut err) = (0.0, 0.0, 0.0);
    for i in 0..M {
        let j = (i + 1) % M;
        let (f, e) = edge(n, r[i], r[j], v[j] - v[i], r2[i]);
        sum += f;
        magnitude += f.abs();
        err += e;
    }
    let err = U * (err + (M as f64 + 2.0) * magnitude);
    (err <= FAST_TOLERANCE * sum.abs()).then_some(sum)
}

/// The value of [`triangle_form_factor`](crate::kernels::form_factor::triangle_form_factor) by
/// Lambert's sum (or its far-field form) when every vertex is certainly above the tangent plane
/// (nothing clipped) and the running error bound is within [`FAST_TOLERANCE`] of the result; `None`
/// otherwise or for invalid input.
pub(crate) fn triangle_value(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<f64> {
    triangle_value_inlined(x, n, v)
}

/// [`triangle_value`] inlined into its caller (the C ABI's value order, whose arguments should
/// not go through memory between two calls).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn triangle_value_inlined(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<f64> {
    let (n, r, r2) = unclipped_triangle(x, n, v)?;
    let e0 = v[1] - v[0];
    let sum = if FAR_RATIO2 * e0.length_squared() <= r2[1] {
        certified_sum(n, &v, &r, &r2)?
    } else {
        // Lambert's sum written out (certified_sum's near branch, same bits): the generic loop is
        // slower on a triangle (docs/kernels.md).
        let (f0, e0) = edge(n, r[0], r[1], e0, r2[0]);
        let (f1, e1) = edge(n, r[1], r[2], v[2] - v[1], r2[1]);
        let (f2, e2) = edge(n, r[2], r[0], v[0] - v[2], r2[2]);
        let sum = f0 + f1 + f2;
        let magnitude = f0.abs() + f1.abs() + f2.abs();
        if !(U * (e0 + e1 + e2 + 5.0 * magnitude) <= FAST_TOLERANCE * sum.abs()) {
            return None;
        }
        sum
    };
    // The sum's sign is the triangle's orientation as seen from x; the form factor is two-sided.
    Some((sum.abs() * INV_2PI).min(1.0))
}

/// `sin β = s/‖r_a‖‖r_b‖` of an edge above which its derivative terms are charged at their size in
/// the cancellation test: its Hessian has terms up to `β/s³` and `(w×e)(w×e)ᵀ/s⁵` that cancel like
/// `1/sin³β` as `x` approaches the extension of the edge's line (`β → 0`) or `1/sin β` near the
/// segment (the gradient like `1/sin²β`), which is at most `4³` (`4²`) here.
const DERIV_MIN_SINE: f64 = 0.25;

/// Smallest `sin β` of an edge the derivative fast path takes. Below [`DERIV_MIN_SINE`] an edge's
/// gradient (Hessian) is charged in the cancellation test at its size times the growth of its
/// rounding errors relative to there, `1/(16 sin²β)` (`(1/(16 sin²β))^{3/2}`), so the accepted
/// error stays what [`CANCELLATION`] accepts at `DERIV_MIN_SINE` (the clipped loop's rule,
/// [`clipped_derivs`](crate::kernels::form_factor::lambert::clipped_derivs)). Edges seen under a
/// small angle are the common case from a few sizes away, where the robust edge sum would answer
/// otherwise; the floor keeps the charge below `8³`.
const DERIV_FLOOR_SINE: f64 = 1.0 / 32.0;

/// One Lambert edge term times 2π with its derivatives, its value error bound times 2π / u, and
/// whether `sin β ≥ DERIV_MIN_SINE`. With `k = w × e`, `m = r_a + r_b`, `P = s² + c²`,
/// `Q = ‖e‖²𝟙 − e eᵀ` and `I = β/s` (derivatives w.r.t. x: `∇w·δ = e × δ`, `∇s = k/s`,
/// `∇c = −m`, `∇k = Q`):
///
/// ```text
/// ∇β = (c k/s + s m)/P,   ∇I = ∇β/s − β k/s³ = a_q k + m/P,   a_q = (c/P − I)/s²,
/// Hβ = [c Q/s − c k kᵀ/s³ − 2s 𝟙]/P − [2c k kᵀ/s + (s − c²/s)(m kᵀ + k mᵀ) − 2sc m mᵀ]/P²,
/// HI = Hβ/s − (∇β kᵀ + k ∇βᵀ)/s³ − β Q/s³ + 3β k kᵀ/s⁵,
/// 2π∇f = (n × e) I + (n·w) ∇I,   2π Hf = (n × e)∇Iᵀ + ∇I (n × e)ᵀ + (n·w) HI.
/// ```
///
/// The arithmetic is [`edge_terms`] on one lane; polygons run it on two edges at a time.
#[inline]
fn edge_derivs(
    n: DVec3,
    ra: DVec3,
    rb: DVec3,
    e: DVec3,
    ra2: f64,
    order: Order,
) -> (Terms, f64, bool) {
    let (n, ra, rb, e) = (
        V3::from_dvec(n),
        V3::from_dvec(ra),
        V3::from_dvec(rb),
        V3::from_dvec(e),
    );
    let w = ra.cross(e);
    let s2 = w.dot(w);
    let s = s2.sqrt();
    let c = ra.dot(rb);
    let t = edge_terms(n, ra, rb, e, ra2, (w, s2, s, c, s.atan2(c)), order);
    let d = Terms {
        value: t.value,
        gradient: t.gradient.to_dvec(),
        hessian: t.hessian,
    };
    (d, t.err, steep(s2, t.p))
}

/// `2π` times one Lambert edge term's gradient and Hessian (entries `[xx, yy, zz, xy, xz, yz]`,
/// zero below [`Order::Hessian`]) and its `sin²β` (the caller chooses its own floor: see
/// [`DERIV_MIN_SINE`]), for the clipped-triangle derivative path, whose loop is not a polygon of
/// input vertices. `angle` is the edge's `β` when it has already been computed, NaN otherwise: by
/// [`edge_and_angle`] for these inputs (the same bits as recomputing it), or by the near-plane
/// split where that is well conditioned (within a few ulps of the true angle, not bit-consistent
/// with `atan2(s, c)` of these rounded inputs: see `near_plane::split::near_plane_value`).
#[inline(always)]
pub(crate) fn edge_derivatives(
    n: DVec3,
    ra: DVec3,
    rb: DVec3,
    e: DVec3,
    angle: f64,
    order: Order,
) -> (DVec3, [f64; 6], f64) {
    let (ra, rb, e) = (V3::from_dvec(ra), V3::from_dvec(rb), V3::from_dvec(e));
    let w = ra.cross(e);
    let s2 = w.dot(w);
    let s = s2.sqrt();
    let c = ra.dot(rb);
    let ra2 = ra.dot(ra);
    let beta = if angle.is_nan() { s.atan2(c) } else { angle };
    let t = edge_terms(V3::from_dvec(n), ra, rb, e, ra2, (w, s2, s, c, beta), order);
    (t.gradient.to_dvec(), t.hessian, s2 / t.p)
}

/// Whether `sin β ≥ DERIV_MIN_SINE`, from `s²` and `P = s² + c²`.
#[inline(always)]
fn steep(s2: f64, p: f64) -> bool {
    s2 >= DERIV_MIN_SINE * DERIV_MIN_SINE * p
}

/// [`edge_derivs`]' terms per lane ([`Lane`]: one edge or two side by side), and its `P`.
struct LaneTerms<L> {
    value: L,
    gradient: V3<L>,
    hessian: [L; 6],
    err: L,
    p: L,
}

/// [`edge_derivs`] per lane from `w = r_a × e`, `s² = w·w`, `s`, `c = r_a·r_b` and
/// `β = atan2(s, c)` (computed by the caller, which calls `atan2` per lane). Every lane rounds as
/// the one-lane (`f64`) instance does: the value is `edge`'s, bit for bit.
#[inline(always)]
fn edge_terms<L: Lane>(
    n: V3<L>,
    ra: V3<L>,
    rb: V3<L>,
    e: V3<L>,
    ra2: L,
    (w, s2, s, c, beta): (V3<L>, L, L, L, L),
    order: Order,
) -> LaneTerms<L> {
    let k = L::splat;
    // Divided as `edge` divides: the value must have the same bits whatever the order asked for.
    let g = beta.div(s);
    let nw = n.dot(w);
    let p = s2 + c * c;
    let mut t = LaneTerms {
        value: nw * g,
        gradient: V3::splat(DVec3::ZERO),
        hessian: [k(0.0); 6],
        err: k(36.0) * beta + k(20.0) * (c - ra2).abs() * g,
        p,
    };
    if order.gradient() {
        let kv = w.cross(e);
        let m = ra + rb;
        let inv_p = p.recip();
        let inv_s2 = s2.recip();
        // ∇I = a_q k + m/P with a_q = (c/P − I)/s²: the bracket is I (sin 2β/2β − 1), which
        // cancels at most ~24x for sin β ≥ DERIV_MIN_SINE, as ∇β/s − β k/s³ did; fewer
        // operations.
        let a_q = (c * inv_p - g) * inv_s2;
        let grad_i = kv.scale(a_q) + m.scale(inv_p);
        let nxe = n.cross(e);
        t.gradient = nxe.scale(g) + grad_i.scale(nw);
        if order.hessian() {
            // HI collected on 𝟙, e eᵀ, k kᵀ, m kᵀ + k mᵀ, m mᵀ (Q = ‖e‖²𝟙 − e eᵀ; the
            // (m kᵀ + k mᵀ) coefficients of Hβ/s and of the ∇β kᵀ term sum to −2/P²), then
            // 2π Hf = diag 𝟙 + (X kᵀ + k Xᵀ) + (Y mᵀ + m Yᵀ) − (n·w) a_q e eᵀ with
            // X = a_q (n×e) − 2(n·w)/P² m + (n·w) a_kk/2 k and Y = (n×e)/P + (n·w) c/P² m:
            // two symmetric products instead of five.
            let a_kk = -(k(3.0) * a_q + k(2.0) * c * inv_p * inv_p) * inv_s2;
            let diag = nw * (a_q * e.dot(e) - k(2.0) * inv_p);
            let nw_p2 = nw * inv_p * inv_p;
            let xv = nxe.scale(a_q) - m.scale(k(2.0) * nw_p2) + kv.scale(k(0.5) * nw * a_kk);
            let yv = nxe.scale(inv_p) + m.scale(nw_p2 * c);
            let de = e.scale(nw * a_q);
            let dia =
                |x: L, kk: L, y: L, mm: L, d: L, ee: L| (x * kk + y * mm) * k(2.0) - d * ee + diag;
            let off = |xi: L, xj: L, ki: L, kj: L, yi: L, yj: L, mi: L, mj: L, di: L, ej: L| {
                xi * kj + ki * xj + yi * mj + mi * yj - di * ej
            };
            let (x, y) = (xv, yv);
            t.hessian = [
                dia(x.x, kv.x, y.x, m.x, de.x, e.x),
                dia(x.y, kv.y, y.y, m.y, de.y, e.y),
                dia(x.z, kv.z, y.z, m.z, de.z, e.z),
                off(x.x, x.y, kv.x, kv.y, y.x, y.y, m.x, m.y, de.x, e.y),
                off(x.x, x.z, kv.x, kv.z, y.x, y.z, m.x, m.z, de.x, e.z),
                off(x.y, x.z, kv.y, kv.z, y.y, y.z, m.y, m.z, de.y, e.z),
            ];
        }
    }
    t
}

/// An edge term's value, gradient and symmetric Hessian by its six distinct entries
/// `[xx, yy, zz, xy, xz, yz]` (assembled and summed on these: a third fewer operations than on
/// full matrices).
#[derive(Clone, Copy)]
struct Terms {
    value: f64,
    gradient: DVec3,
    hessian: [f64; 6],
}

impl Terms {
    /// Whether every entry is finite (then so is the result [`Terms::scaled`] gives with a finite
    /// scale of at most 1). Inline, on products by zero (NaN exactly for a NaN or infinite entry).
    #[inline(always)]
    fn is_finite(&self) -> bool {
        let h = &self.hessian;
        let zero = |a: f64, b: f64| a * 0.0 + b * 0.0;
        let z = zero(self.value, self.gradient.x)
            + zero(self.gradient.y, self.gradient.z)
            + zero(h[0], h[1])
            + zero(h[2], h[3])
            + zero(h[4], h[5]);
        z == 0.0
    }

    /// The full result with `value`, derivatives scaled by `scale` (a zero Hessian stays zero).
    fn scaled(&self, value: f64, scale: f64) -> Deriv3 {
        let h = self.hessian.map(|e| e * scale);
        Deriv3 {
            value,
            gradient: self.gradient * scale,
            hessian: DMat3::from_cols(
                DVec3::new(h[0], h[3], h[4]),
                DVec3::new(h[3], h[1], h[5]),
                DVec3::new(h[4], h[5], h[2]),
            ),
        }
    }
}

/// `‖·‖_∞` of the derivative part of `d` at `order` (gradient, and Hessian when asked).
#[inline]
fn deriv_size(d: &Terms, order: Order) -> (f64, f64) {
    let h = if order.hessian() {
        d.hessian.iter().fold(0.0f64, |m, e| m.max(e.abs()))
    } else {
        0.0
    };
    (d.gradient.abs().max_element(), h)
}

/// Value, gradient (and Hessian at [`Order::Hessian`]) of
/// [`triangle_form_factor`](crate::kernels::form_factor::triangle_form_factor) by the analytic
/// derivatives of Lambert's sum, for `order` above [`Order::Value`]: [`certified_derivs`] for three
/// vertices.
#[inline]
pub(crate) fn triangle_derivs(x: DVec3, n: DVec3, v: [DVec3; 3], order: Order) -> Option<Deriv3> {
    let (n, r, r2) = unclipped_triangle(x, n, v)?;
    certified_derivs(n, &v, &r, &r2, order)
}

/// Value, gradient (and Hessian at [`Order::Hessian`]) of the form factor of an unclipped polygon
/// (`unclipped`'s output, any `M ≥ 3`) by the analytic derivatives of Lambert's sum
/// ([`edge_derivs`] per edge), for `order` above [`Order::Value`]. Taken when Lambert's value is
/// certified (as in [`certified_sum`]'s near branch: `u(Σ err_i + (M + 2) Σ|f_i|)` within
/// [`FAST_TOLERANCE`]), every edge has `sin β ≥ DERIV_FLOOR_SINE`, and neither the gradient nor
/// the Hessian sum cancels by more than [`CANCELLATION`] (summed max-norms of the edge terms'
/// parts, each charged with its rounding growth below [`DERIV_MIN_SINE`], against the max-norm of
/// their sum); `None` otherwise.
///
/// The value is the one [`certified_sum`] gives, bit for bit, so that it does not depend on the
/// order asked for: its far form where that sum takes it ([`certified_far_value`]), otherwise
/// this same Lambert sum, summed in the same order.
/// Derivatives are per unit length (gradient) and per squared length (Hessian), signed so that
/// the form factor is two-sided (the sum's sign is the polygon's orientation as seen from `x`).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn certified_derivs<const M: usize>(
    n: DVec3,
    v: &[DVec3; M],
    r: &[DVec3; M],
    r2: &[f64; M],
    order: Order,
) -> Option<Deriv3> {
    // One copy per order, so that the per-edge order tests fold away in the inlined edge terms.
    match order {
        Order::Value => derivs_at(n, v, r, r2, Order::Value),
        Order::Gradient => derivs_at(n, v, r, r2, Order::Gradient),
        Order::Hessian => derivs_at(n, v, r, r2, Order::Hessian),
    }
}

/// [`certified_derivs`] at one order.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn derivs_at<const M: usize>(
    n: DVec3,
    v: &[DVec3; M],
    r: &[DVec3; M],
    r2: &[f64; M],
    order: Order,
) -> Option<Deriv3> {
    let mut sum = Terms {
        value: 0.0,
        gradient: DVec3::ZERO,
        hessian: [0.0; 6],
    };
    let (mut magnitude, mut err, mut is_steep) = (0.0, 0.0, true);
    let (mut g_mag, mut h_mag) = (0.0, 0.0);
    let n2 = V3::<Pair>::splat(n);
    // Edges i and i + 1 in the two lanes; for odd M the last pair's second lane repeats edge 0
    // (with a stand-in angle, no atan2) and is ignored. Every sum below runs over the edges in
    // order, as certified_sum's does (the value must be its bits).
    for i in (0..M).step_by(2) {
        let (i1, lanes) = if i + 1 < M { (i + 1, 2) } else { (0, 1) };
        let (j, j1) = ((i + 1) % M, (i1 + 1) % M);
        let ra = V3::pair(r[i], r[i1]);
        let rb = V3::pair(r[j], r[j1]);
        let e = V3::pair(v[j] - v[i], v[j1] - v[i1]);
        let w = ra.cross(e);
        let s2 = w.dot(w);
        let s = s2.sqrt();
        let c = ra.dot(rb);
        let beta1 = if lanes == 2 {
            s.get(1).atan2(c.get(1))
        } else {
            1.0
        };
        let beta = Pair::new(s.get(0).atan2(c.get(0)), beta1);
        let ra2 = Pair::new(r2[i], r2[i1]);
        let t = edge_terms(n2, ra, rb, e, ra2, (w, s2, s, c, beta), order);
        // The max-norms of each edge's gradient and Hessian, for the cancellation test.
        let g_size = if order.gradient() {
            let g = &t.gradient;
            g.x.abs().max(g.y.abs()).max(g.z.abs())
        } else {
            Pair::splat(0.0)
        };
        let h_size = if order.hessian() {
            let h = t.hessian.map(|hk| hk.abs());
            h[0].max(h[1]).max(h[2]).max(h[3]).max(h[4]).max(h[5])
        } else {
            Pair::splat(0.0)
        };
        for l in 0..lanes {
            let f = t.value.get(l);
            sum.value += f;
            sum.gradient += t.gradient.lane(l);
            for (a, hk) in sum.hessian.iter_mut().zip(&t.hessian) {
                *a += hk.get(l);
            }
            magnitude += f.abs();
            err += t.err.get(l);
            let (edge_s2, edge_p) = (s2.get(l), t.p.get(l));
            is_steep &= edge_s2 >= DERIV_FLOOR_SINE * DERIV_FLOOR_SINE * edge_p;
            // The growth of the edge's rounding errors below DERIV_MIN_SINE, relative to there.
            let growth = if steep(edge_s2, edge_p) {
                1.0
            } else {
                edge_p / (16.0 * edge_s2)
            };
            g_mag += growth * g_size.get(l);
            if order.hessian() {
                h_mag += growth * growth.sqrt() * h_size.get(l);
            }
        }
    }
    let err = U * (err + (M as f64 + 2.0) * magnitude);
    if !(is_steep && err <= FAST_TOLERANCE * sum.value.abs()) {
        return None;
    }
    let total = deriv_size(&sum, order);
    if !(g_mag <= CANCELLATION * total.0 && h_mag <= CANCELLATION * total.1) {
        return None;
    }
    if !sum.is_finite() {
        return None;
    }
    // Orientation as seen from x: the form factor is two-sided.
    let scale = INV_2PI.copysign(sum.value);
    Some(sum.scaled(
        (certified_far_value(n, v, r, r2).unwrap_or(sum.value).abs() * INV_2PI).min(1.0),
        scale,
    ))
}

/// `2π` times the signed form factor by Lambert's far form ([`far_sum`]) when [`certified_sum`]
/// takes it: every edge small against its distance (so every `sin β ≤ 1/√20`) and the far form
/// certified; `None` otherwise, where Lambert's sum is the value. The derivative path takes its
/// value from here too, so that the value does not depend on the order asked for.
#[inline(always)]
fn certified_far_value<const M: usize>(
    n: DVec3,
    v: &[DVec3; M],
    r: &[DVec3; M],
    r2: &[f64; M],
) -> Option<f64> {
    // The far form only when the first edge is already small against its distance: one test
    // keeps Lambert's cost for nearby polygons (the full far test first would not). Lambert's
    // bound is wider than the far form's only for unusual shapes, so a declined far form leaves
    // the value to Lambert's sum.
    if FAR_RATIO2 * (v[1] - v[0]).length_squared() <= r2[1] {
        if let Far::Certified(total) = far_sum(n, v, r, r2) {
            return Some(total);
        }
    }
    None
}

/// Value and derivatives of [`edge_form_factor`](crate::kernels::form_factor::edge_form_factor) by
/// the analytic derivatives of Lambert's term, for `order` above [`Order::Value`], when the value
/// is certified and `sin β ≥ DERIV_MIN_SINE`; `None` otherwise.
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn edge_derivs_checked(
    x: DVec3,
    n: DVec3,
    a: DVec3,
    b: DVec3,
    order: Order,
) -> Option<Deriv3> {
    let (ra, rb) = (a - x, b - x);
    if !(in_range(ra) && in_range(rb)) {
        return None;
    }
    let n = unit(n)?;
    let scale = INV_2PI;
    let (d, err, steep) = edge_derivs(n, ra, rb, b - a, ra.length_squared(), order);
    if !(steep && U * (err + 3.0 * d.value.abs()) <= FAST_TOLERANCE * d.value.abs()) {
        return None;
    }
    let out = d.scaled(d.value * scale, scale);
    out.is_finite().then_some(out)
}

/// Largest ratio of the summed magnitudes of the edge terms' derivatives to the magnitude of their
/// sum accepted by the derivative fast path (as the robust path's value cancellation limit).
pub(crate) const CANCELLATION: f64 = 1e2;

#[cfg(test)]
mod tests;
