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
//! `|δs| ≤ 6uL + 2us`; `|δc| ≤ 5uP`. With `s² + c² = P²` and `sin β = s/P ≤ β`,
//! `|δβ| ≤ (|c|·|δs| + s·|δc|)/P² + 2uβ ≤ (6p + 9)uβ` (atan2 within 2 ulp), so `g = β/s` is within
//! `(12p + 12)u` relatively and `|δf|·2π ≤ uβ(18p + 16)` (using `|n·w| ≤ s`). With
//! `p ≤ 1 + |r_a·e|/s` the bound needs only computed quantities: `|δf|·2π ≤ u(34β + 18|r_a·e|·g)`,
//! used below as `u(36β + 20|r_a·e|g)`. Summing three terms, renormalizing `n` and scaling add
//! `5u Σ|f_i|` (`(m + 2)u Σ|f_i|` for `m` edges). When the bound exceeds [`FAST_TOLERANCE`] times
//! the result (x near an edge's line, where `p` grows; a cancelling sum: near the polygon's plane),
//! the caller falls back to the robust path. Far away (every edge within `1/√20` of its distance)
//! the value comes from [`lambert_far`]'s rearrangement of the same sum, which does not cancel.

use glam::{DMat3, DVec3};

use super::lambert_far::{self, Far};
use super::numeric::lanes::{Lane, Pair, V3};
use super::polygon;
use crate::{Deriv3, Order};

pub(super) const INV_2PI: f64 = 0.5 * std::f64::consts::FRAC_1_PI;
const U: f64 = 0.5 * f64::EPSILON;

/// Largest certified relative error of an accepted result (the generic accuracy contract is 1e-12;
/// the margin absorbs the second-order terms the bound omits).
pub(crate) const FAST_TOLERANCE: f64 = 5e-13;

/// `r` with every component's magnitude at most in (1e-30, 1e30) — products of up to four such
/// factors stay far from overflow, and from underflow relative to the largest — and finite.
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(super) fn in_range(r: DVec3) -> bool {
    let m = r.abs().max_element();
    m > 1e-30 && m < 1e30
}

/// The renormalized unit normal, `None` outside the kernels' unit tolerance (or NaN). Divided as
/// the robust path divides, so that normals within the tolerance give the same bits.
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(super) fn unit(n: DVec3) -> Option<DVec3> {
    let len = n.length();
    // n / 1 is n: skip the three divisions for normals whose computed length is exactly 1.
    ((len - 1.0).abs() <= polygon::NORMAL_TOLERANCE).then(|| if len == 1.0 { n } else { n / len })
}

/// One Lambert edge term times 2π, `β (n·w)/s`, and its error bound times 2π / u, from
/// `r_a`, `r_b`, `e = b − a` and `‖r_a‖²`.
#[inline]
pub(super) fn edge(n: DVec3, ra: DVec3, rb: DVec3, e: DVec3, ra2: f64) -> (f64, f64) {
    let (f, err, _) = edge_and_angle(n, ra, rb, e, ra2);
    (f, err)
}

/// [`edge`] and the edge's angle `β` (for a derivative pass over the same edge that would
/// recompute it: [`edge_derivatives`]).
#[inline(always)]
pub(super) fn edge_and_angle(
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

/// The value of [`edge_form_factor`](super::edge_form_factor) by Lambert's formula when its error
/// bound is within [`FAST_TOLERANCE`] of the result; `None` otherwise or for invalid input.
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
pub(super) fn unclipped<const M: usize>(
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
    // from_fn, not map: the map was an out-of-line call (callgrind).
    Some((n, r, std::array::from_fn(|k| r[k].length_squared())))
}

/// The triangle case of [`unclipped`] (both triangle fast paths share it).
#[inline(always)]
fn unclipped_triangle(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<(DVec3, [DVec3; 3], [f64; 3])> {
    unclipped(x, n, &v)
}

/// `2π` times the signed form factor of an unclipped polygon (`unclipped`'s output): the far-field
/// form ([`lambert_far`]) when every edge is small against its distance, otherwise Lambert's sum
/// with its running bound (`(m + 2)u Σ|f_i|` for summing `m` terms, renormalizing `n` and
/// scaling). `None` when the chosen form is not certified.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(super) fn certified_sum<const M: usize>(
    n: DVec3,
    v: &[DVec3; M],
    r: &[DVec3; M],
    r2: &[f64; M],
) -> Option<f64> {
    // The far form only when the first edge is already small against its distance: one test
    // keeps Lambert's cost for nearby polygons (measured: the full far test first cost ~15 ns).
    if lambert_far::FAR_RATIO2 * (v[1] - v[0]).length_squared() <= r2[1] {
        match lambert_far::far_sum(n, v, r, r2) {
            Far::Certified(total) => return Some(total),
            // Lambert's bound is wider than the far form's only for unusual shapes: try it.
            Far::Declined | Far::Near => {}
        }
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

/// The value of [`triangle_form_factor`](super::triangle_form_factor) by Lambert's sum (or its
/// far-field form) when every vertex is certainly above the tangent plane (nothing clipped) and
/// the running error bound is within [`FAST_TOLERANCE`] of the result; `None` otherwise or for
/// invalid input.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn triangle_value(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<f64> {
    let (n, r, r2) = unclipped_triangle(x, n, v)?;
    let e0 = v[1] - v[0];
    let sum = if lambert_far::FAR_RATIO2 * e0.length_squared() <= r2[1] {
        certified_sum(n, &v, &r, &r2)?
    } else {
        // Lambert's sum written out (certified_sum's near branch, same bits): the generic loop
        // measured ~10 ns slower on the benchmarked triangle.
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

/// Smallest `sin β = s/‖r_a‖‖r_b‖` of an edge at which the derivative fast path is used: its
/// Hessian has terms up to `β/s³` and `(w×e)(w×e)ᵀ/s⁵` that cancel like `1/sin³β` as `x`
/// approaches the extension of the edge's line (`β → 0`) or `1/sin β` near the segment.
const DERIV_MIN_SINE: f64 = 0.25;

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
/// input vertices. `angle` is the edge's `β` when it has already been computed, NaN otherwise:
/// by [`edge_and_angle`] for these inputs (the same bits as recomputing it), or by the
/// near-plane split where that is well conditioned (within a few ulps of the true angle, not
/// bit-consistent with `atan2(s, c)` of these rounded inputs: see `polygon::near_plane_value`).
#[inline(always)]
pub(super) fn edge_derivatives(
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
    /// scale of at most 1). Inline, on products by zero (NaN exactly for a NaN or infinite entry):
    /// `Deriv3::is_finite` was an out-of-line call of ~30 instructions.
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
/// [`triangle_form_factor`](super::triangle_form_factor) by the analytic derivatives of Lambert's
/// sum, for `order` above [`Order::Value`]: [`certified_derivs`] for three vertices.
#[inline]
pub(crate) fn triangle_derivs(x: DVec3, n: DVec3, v: [DVec3; 3], order: Order) -> Option<Deriv3> {
    let (n, r, r2) = unclipped_triangle(x, n, v)?;
    certified_derivs(n, &v, &r, &r2, order)
}

/// Value, gradient (and Hessian at [`Order::Hessian`]) of the form factor of an unclipped polygon
/// (`unclipped`'s output, any `M ≥ 3`) by the analytic derivatives of Lambert's sum
/// ([`edge_derivs`] per edge), for `order` above [`Order::Value`]. Taken when Lambert's value is
/// certified (as in [`certified_sum`]'s near branch: `u(Σ err_i + (M + 2) Σ|f_i|)` within
/// [`FAST_TOLERANCE`]), every edge has `sin β ≥ DERIV_MIN_SINE` (no cancelling near-line terms)
/// and neither the gradient nor the Hessian sum cancels by more than [`CANCELLATION`] (summed
/// max-norms of the edge terms' parts against the max-norm of their sum); `None` otherwise.
///
/// The value is the one [`certified_sum`] gives, bit for bit, so that it does not depend on the
/// order asked for: that sum's far form needs `20‖e_i‖² ≤ ‖r_{i+1}‖²` on every edge, hence
/// `sin β_i ≤ ‖e_i‖/‖r_{i+1}‖ ≤ 1/√20 < DERIV_MIN_SINE`, which this path declines, and otherwise
/// it is this same Lambert sum, summed in the same order.
/// Derivatives are per unit length (gradient) and per squared length (Hessian), signed so that
/// the form factor is two-sided (the sum's sign is the polygon's orientation as seen from `x`).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(super) fn certified_derivs<const M: usize>(
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
            is_steep &= steep(s2.get(l), t.p.get(l));
            g_mag += g_size.get(l);
            h_mag += h_size.get(l);
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
    Some(sum.scaled((sum.value.abs() * INV_2PI).min(1.0), scale))
}

/// Value and derivatives of [`edge_form_factor`](super::edge_form_factor) by the analytic
/// derivatives of Lambert's term, for `order` above [`Order::Value`], when the value is certified
/// and `sin β ≥ DERIV_MIN_SINE`; `None` otherwise.
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
pub(super) const CANCELLATION: f64 = 1e2;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::{edge_form_factor, polygon_form_factor};
    use crate::test_rng::lcg;
    use glam::DMat3;

    const TRI: [DVec3; 3] = [
        DVec3::new(-0.4, -0.3, 1.0),
        DVec3::new(0.7, -0.1, 1.2),
        DVec3::new(0.0, 0.8, 0.9),
    ];

    fn n() -> DVec3 {
        DVec3::new(0.2, -0.1, 1.0).normalize()
    }

    fn robust(x: DVec3, n: DVec3) -> f64 {
        polygon_form_factor(x, n, &TRI, Order::Value).unwrap().value
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    /// The triangle's unit normal (pointing to +z).
    fn normal() -> DVec3 {
        (TRI[1] - TRI[0]).cross(TRI[2] - TRI[0]).normalize()
    }

    #[test]
    fn generic_triangle_agrees_with_the_robust_path() {
        for (k, x) in [
            DVec3::ZERO,
            DVec3::new(0.3, -0.2, 0.1),
            DVec3::new(-0.5, 0.4, -0.6),
            DVec3::new(0.1, 0.1, 0.8),
        ]
        .into_iter()
        .enumerate()
        {
            let f = triangle_value(x, n(), TRI).unwrap_or_else(|| panic!("case {k} declined"));
            let r = robust(x, n());
            assert!(rel(f, r) < 1e-14, "case {k}: {f} vs {r}");
            // Either orientation gives the same two-sided value.
            let g = triangle_value(x, n(), [TRI[0], TRI[2], TRI[1]]).unwrap();
            assert!(rel(g, f) < 1e-15);
        }
    }

    /// Walks x(t) from t0 towards t1 geometrically (receiver normal `nr`): the fast path must agree
    /// with the robust one within 1e-12 while it accepts (also at the last accepted step, where its
    /// certificate is nearly exhausted) and, once it declines, not accept again. Returns the last
    /// accepted and the first declined t (NaN when it never declines).
    fn walk(nr: DVec3, x_of: impl Fn(f64) -> DVec3, t0: f64, t1: f64) -> (f64, f64) {
        let steps = 400;
        let mut last_ok = None;
        let mut declined = None;
        for k in 0..=steps {
            let t = t0 * (t1 / t0).powf(k as f64 / steps as f64);
            let x = x_of(t);
            match triangle_value(x, nr, TRI) {
                Some(f) => {
                    let r = robust(x, nr);
                    let e = rel(f, r);
                    assert!(e < 1e-12, "t = {t:e}: fast {f} robust {r} ({e:e})");
                    assert!(declined.is_none(), "re-accepted at t = {t:e}");
                    // The public kernel returns the certified value.
                    let p = crate::kernels::triangle_form_factor(
                        x,
                        nr,
                        TRI[0],
                        TRI[1],
                        TRI[2],
                        Order::Value,
                    );
                    assert_eq!(p.unwrap().value, f);
                    last_ok = Some(t);
                }
                None => {
                    declined.get_or_insert(t);
                }
            }
        }
        (
            last_ok.expect("never accepted"),
            declined.unwrap_or(f64::NAN),
        )
    }

    #[test]
    fn switches_off_near_an_edge_line() {
        // x approaches the line through TRI[0], TRI[1] diagonally from outside and below the
        // triangle; the receiver faces the triangle's plane, so no vertex is ever clipped.
        let (a, b) = (TRI[0], TRI[1]);
        let mid = (a + b) * 0.5;
        let out = (b - a).cross(normal()).normalize();
        let (ok, off) = walk(normal(), |t| mid + (out - normal()) * t, 1.0, 1e-14);
        assert!(ok > 1e-4 && ok < 1e-1 && off < ok, "{ok:e} {off:e}");
    }

    #[test]
    fn switches_off_towards_the_plane_and_far_away() {
        // x moves along the triangle's normal towards its plane from outside its projection ...
        let c = (TRI[0] + TRI[1] + TRI[2]) / 3.0;
        let side = c + (TRI[0] - c) * 1.5;
        let (ok, _) = walk(normal(), |t| side - normal() * t, 1.0, 1e-14);
        assert!(ok > 1e-3 && ok < 1.0, "{ok:e}");
        // ... and away along -n: Lambert's edge sum cancels like (size/d)² against terms like
        // size/d, but from ~4.5 sizes on every edge is in the far form's regime, which does not
        // cancel: certified all the way (1e8 sizes).
        let (ok, off) = walk(n(), |t| c - n() * t, 2.0, 1e8);
        assert!(ok == 1e8 && off.is_nan(), "{ok:e} {off:e}");
    }

    /// Lambert's sum alone (the certificate before the far form existed), for comparison.
    fn lambert_only(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<f64> {
        let (n, r, r2) = unclipped_triangle(x, n, v)?;
        let (mut sum, mut mag, mut err) = (0.0, 0.0, 0.0);
        for i in 0..3 {
            let j = (i + 1) % 3;
            let (f, e) = edge(n, r[i], r[j], v[j] - v[i], r2[i]);
            sum += f;
            mag += f.abs();
            err += e;
        }
        (U * (err + 5.0 * mag) <= FAST_TOLERANCE * sum.abs()).then_some(sum.abs() * INV_2PI)
    }

    #[test]
    fn small_triangles_far_away_are_certified() {
        // Mesh-light-like triangles (size ~1e-2, random shape and orientation) seen from 1 to 1e3
        // sizes, along random directions, the receiver's normal random within 60° of the view
        // direction: wherever the fast path accepts it agrees with the robust path, and past 5
        // sizes it accepts everywhere but for the thinnest views.
        let mut st = 7u64;
        let rnd = |st: &mut u64| DVec3::new(lcg(st), lcg(st), lcg(st)) * 2.0 - DVec3::ONE;
        let (mut far_steps, mut far_ok, mut old_ok, mut worst) = (0, 0, 0, 0.0f64);
        for _ in 0..40 {
            let c = rnd(&mut st);
            let size = 0.01;
            let tri = [0, 1, 2].map(|_| c + rnd(&mut st) * size);
            let dir = rnd(&mut st).normalize();
            let tilt = rnd(&mut st) * 0.5;
            for k in 0..=60 {
                let t = 10f64.powf(k as f64 / 20.0);
                let x = c + dir * (t * size);
                let nr = (-dir + tilt).normalize();
                let got = triangle_value(x, nr, tri);
                if let Some(f) = got {
                    let r = polygon::form_factor(x, nr, &tri, Order::Value)
                        .unwrap()
                        .value;
                    let e = rel(f, r);
                    worst = worst.max(e);
                    assert!(e < 1e-12, "t = {t:e}: {f} vs {r} ({e:e})");
                }
                if t >= 5.0 && tri.iter().all(|v| nr.dot(*v - x) > 0.0) {
                    far_steps += 1;
                    far_ok += got.is_some() as usize;
                    old_ok += lambert_only(x, nr, tri).is_some() as usize;
                }
            }
        }
        println!(
            "far walks: {far_ok}/{far_steps} certified (Lambert alone {old_ok}), worst {worst:e}"
        );
        assert!(
            far_ok as f64 >= 0.9 * far_steps as f64,
            "{far_ok}/{far_steps}"
        );
        assert!(old_ok < far_ok / 2, "{old_ok} vs {far_ok}");
    }

    #[test]
    fn declines_when_clipped_or_invalid() {
        // TRI[2] below the tangent plane.
        let x = TRI[2] + DVec3::new(0.0, 0.0, 0.01);
        assert!(triangle_value(x, DVec3::Z, TRI).is_none());
        assert!(triangle_value(DVec3::ZERO, n() * 1.1, TRI).is_none());
        assert!(triangle_value(DVec3::NAN, n(), TRI).is_none());
        assert!(triangle_value(DVec3::splat(1e31), n(), TRI).is_none());
        assert!(edge_value(DVec3::NAN, n(), TRI[0], TRI[1]).is_none());
    }

    #[test]
    fn edge_term_agrees_and_declines_near_its_line() {
        let (a, b) = (TRI[0], TRI[1]);
        let slow = |x: DVec3| {
            // The robust edge term without its fast paths: a polygon-free check through the
            // public kernel would take this very path, so compare with the frame evaluation.
            let scaled = crate::kernels::polygon::Scaled::new(x, &[a, b]).unwrap();
            let ends = scaled.exact_ends(0, 1);
            let d = super::super::form_factor::edge_term_exact(
                scaled.r[0],
                scaled.u[1] - scaled.u[0],
                n(),
                Order::Value,
                Some(&ends),
            )
            .unwrap();
            scaled.finish(d, Order::Value).unwrap().value
        };
        let mid = (a + b) * 0.5;
        let off = (b - a).cross(n()).normalize();
        let mut declined = false;
        for k in 0..=300 {
            let t = 10f64.powf(-(k as f64) / 30.0);
            let x = mid + off * t;
            match edge_value(x, n(), a, b) {
                Some(f) => {
                    assert!(!declined);
                    assert!(rel(f, slow(x)) < 1e-12, "t = {t:e}");
                    let pub_f = edge_form_factor(x, n(), a, b, Order::Value).unwrap().value;
                    assert_eq!(pub_f, f);
                }
                None => declined = true,
            }
        }
        assert!(declined);
        assert!(edge_value(mid + off, n(), a, b).is_some());
    }

    /// Relative difference normalized by the largest entry, as the accuracy tests measure it.
    fn rel_d(a: &Deriv3, b: &Deriv3) -> (f64, f64, f64) {
        let g = (a.gradient - b.gradient).abs().max_element() / b.gradient.abs().max_element();
        let hm = |m: DMat3| {
            m.x_axis
                .abs()
                .max(m.y_axis.abs())
                .max(m.z_axis.abs())
                .max_element()
        };
        let h = hm(a.hessian - b.hessian) / hm(b.hessian);
        (rel(a.value, b.value), g, h)
    }

    /// Receiver normal, path x(t), first and last t.
    type Walk = (DVec3, Box<dyn Fn(f64) -> DVec3>, f64, f64);

    #[test]
    fn triangle_derivatives_agree_with_the_robust_path_until_they_switch_off() {
        let c = (TRI[0] + TRI[1] + TRI[2]) / 3.0;
        let (a, b) = (TRI[0], TRI[1]);
        let mid = (a + b) * 0.5;
        let out = (b - a).cross(normal()).normalize();
        let side = c + (TRI[0] - c) * 1.5;
        let paths: [Walk; 4] = [
            (n(), Box::new(move |t| c - n() * t), 0.05, 1e8),
            (
                normal(),
                Box::new(move |t| mid + (out - normal()) * t),
                1.0,
                1e-12,
            ),
            (normal(), Box::new(move |t| side - normal() * t), 1.0, 1e-12),
            (n(), Box::new(|t| DVec3::new(0.3, -0.2, 0.1) * t), 1.0, 1e3),
        ];
        for (k, (nr, x_of, t0, t1)) in paths.iter().enumerate() {
            let mut accepted = 0;
            for step in 0..=200 {
                let t = t0 * (t1 / t0).powf(step as f64 / 200.0);
                let x = x_of(t);
                for order in [Order::Gradient, Order::Hessian] {
                    if let Some(d) = triangle_derivs(x, *nr, TRI, order) {
                        accepted += 1;
                        let r = polygon_form_factor(x, *nr, &TRI, order).unwrap();
                        let (ev, eg, eh) = rel_d(&d, &r);
                        let eh = if order.hessian() { eh } else { 0.0 };
                        assert!(
                            ev < 1e-12 && eg < 1e-12 && eh < 1e-11,
                            "path {k} t = {t:e} {order:?}: {ev:e} {eg:e} {eh:e}"
                        );
                        let p = crate::kernels::triangle_form_factor(x, *nr, a, b, TRI[2], order);
                        assert_eq!(p.unwrap(), d);
                        // The value is the Value order's, bit for bit.
                        assert_eq!(Some(d.value), triangle_value(x, *nr, TRI), "t = {t:e}");
                        if !order.hessian() {
                            assert_eq!(d.hessian, DMat3::ZERO);
                        }
                    }
                }
            }
            assert!(accepted > 0, "path {k} never accepted");
        }
    }

    #[test]
    fn edge_derivatives_agree_with_finite_differences_and_the_robust_path() {
        let (a, b) = (TRI[0], TRI[1]);
        let x = DVec3::new(0.2, 0.1, -0.3);
        let d = edge_derivs_checked(x, n(), a, b, Order::Hessian).unwrap();
        let r = crate::kernels::form_factor::edge_form_factor_fast(x, n(), a, b, Order::Hessian)
            .unwrap();
        let (ev, eg, eh) = rel_d(&d, &r);
        assert!(
            ev < 1e-14 && eg < 1e-13 && eh < 1e-13,
            "{ev:e} {eg:e} {eh:e}"
        );
        // Central differences of the certified value (h = 1e-4: truncation ~1e-8).
        let h = 1e-4;
        let f = |p: DVec3| edge_value(p, n(), a, b).unwrap();
        for i in 0..3 {
            let dx = DVec3::AXES[i] * h;
            let fd = (f(x + dx) - f(x - dx)) / (2.0 * h);
            assert!((fd - d.gradient[i]).abs() < 1e-7, "grad {i}");
            let gd = |p: DVec3| {
                edge_derivs_checked(p, n(), a, b, Order::Gradient)
                    .unwrap()
                    .gradient
            };
            let col = (gd(x + dx) - gd(x - dx)) / (2.0 * h);
            assert!(
                (col - d.hessian.col(i)).abs().max_element() < 1e-7,
                "hess col {i}"
            );
        }
        // Near its line the derivative path declines while the value path may still accept.
        let mid = (a + b) * 0.5;
        let off = (b - a).cross(n()).normalize();
        assert!(edge_derivs_checked(mid + off * 1e-3, n(), a, b, Order::Hessian).is_none());
        assert!(
            edge_derivs_checked(mid + (b - a) * 2.0 + off * 1e-3, n(), a, b, Order::Hessian)
                .is_none()
        );
    }

    #[test]
    fn the_benchmarked_generic_edge_is_certified() {
        // benches/kernels_b.rs "edge term": the first edge of its generic triangle.
        let x = DVec3::new(0.1, -0.2, 0.05);
        let f = edge_value(x, n(), TRI[0], TRI[1]).expect("declined");
        let d = edge_derivs_checked(x, n(), TRI[0], TRI[1], Order::Hessian).expect("declined");
        let r = crate::kernels::form_factor::edge_form_factor_fast(
            x,
            n(),
            TRI[0],
            TRI[1],
            Order::Hessian,
        )
        .unwrap();
        assert!(rel(f, r.value) < 1e-14 && rel(d.value, r.value) < 1e-14);
    }
}
