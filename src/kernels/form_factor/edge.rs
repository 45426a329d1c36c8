//! The form factor's per-edge term with its gradient and Hessian in the edge's own frame: the
//! robust path's building block, for ordinary edges and for clip edges in the tangent plane.
//!
//! For a differential area at `x` with unit normal `n` and a polygon with vertices `v_i`
//! (`r_i = v_i − x`), the form factor is
//!
//! ```text
//! F(x) = (1/π) ∫_{Ω(P)} n·ω dω = (1/2π) Σ_i β_i n·(r_i × r_{i+1}) / ‖r_i × r_{i+1}‖,
//! ```
//!
//! `β_i` the angle between `r_i` and `r_{i+1}`. Each edge term is rewritten as a line integral
//! (Holzschuch and Sillion): with `e = v_{i+1} − v_i`, `w = r_i × e` (= `r_i × r_{i+1}`),
//! `I(x) = ∫₀¹ dt / ‖r_i + t e‖²` (= `β_i / ‖w‖`),
//!
//! ```text
//! f_i = (1/2π) (n·w) I,   ∇f_i = (1/2π) [(n × e) I + (n·w) ∇I],
//! Hf_i = (1/2π) [(n × e) ∇Iᵀ + ∇I (n × e)ᵀ + (n·w) HI],
//! ∇I = 2 ∫ r/‖r‖⁴ dt,   HI = −2 (∫ dt/‖r‖⁴) 𝟙 + 8 ∫ r rᵀ/‖r‖⁶ dt.
//! ```
//!
//! (This re-derives the thesis' eq. 6.5-6.6, whose printed form is garbled: the leading
//! "−(−1/2π)" and "norm γ_i" are extraction errors for 1/2π and the edge angle β_i.)
//! The integrals are evaluated in the edge's own frame (foot point `p`, direction `ê`, abscissae
//! `s_a`, `s_b`, distance `h` to the edge's line, [`EdgeFrame`]) with closed forms arranged to
//! avoid cancellation, and with convergent series in `(h/s)²` when `x` lies near the extension of
//! the edge's line (below [`AXIAL_RATIO`]), differenced between the ends in factored form so that
//! a short edge keeps its digits. Within a sine of [`NEAR_LINE_SINE`] of the line the frame is
//! built from the exact ends in double-double ([`ExactEnds`]). A clip edge lies in the tangent
//! plane, so its term is `±β/2π` in closed form, and [`clip_edge_derivs`] removes the `1/h` and
//! `1/h²` parts that would cancel as `x` approaches the clip line.
//!
//! Error: each term to a few ulps of its own size in every regime (the moments carry no
//! cancellation); what a sum of terms loses to cancellation is the callers' concern (the far
//! field, the near-plane split, quadrature).

use glam::{DMat3, DVec3};

use crate::error::{Error, Result};
use crate::kernels::numeric::dd;
use crate::{Deriv3, Order};

pub(crate) const INV_2PI: f64 = 0.5 * std::f64::consts::FRAC_1_PI;

/// Below this ratio `h / min(|s_a|, |s_b|)` (x near the extension of the edge's line, both
/// endpoints on the same side) the moments use series in `(h/s)²` instead of recurrences that
/// divide by `h²`. At the boundary the recurrences lose at most a factor `(1/0.25)⁴ = 256` in
/// relative precision; the series converge like `0.0625^k`.
const AXIAL_RATIO: f64 = 0.25;

/// Closed-form integrals along an edge, in the edge frame: `A_m = ∫ ds/ρ^{2m}`,
/// `B_m = ∫ s ds/ρ^{2m}`, `C_3 = ∫ s² ds/ρ⁶` over `s ∈ [s_a, s_b]`, `ρ² = s² + h²`.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct EdgeMoments {
    pub a1: f64,
    pub a2: f64,
    pub a3: f64,
    pub b2: f64,
    pub b3: f64,
    pub c3: f64,
}

/// An edge seen from the origin: `r(s) = p + s ê`, `s ∈ [s_a, s_a + len]`, `‖p‖ = h`, `p ⊥ ê`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct EdgeFrame {
    pub e_hat: DVec3,
    pub len: f64,
    pub p: DVec3,
    /// `r_a × e`.
    pub w: DVec3,
    pub h: f64,
    pub sa: f64,
    pub sb: f64,
}

/// Below this `‖w‖ / (‖r_a‖ ‖e‖)` (the sine of the angle between `r_a` and the edge), the f64 cross
/// product `w = r_a × e` has lost more than ~1% of its digits to the rounding of `r_a` and `e`, and
/// [`EdgeFrame::with_exact_ends`] recomputes it in double-double from the exact endpoints.
pub(crate) const NEAR_LINE_SINE: f64 = 1e-2;

impl EdgeFrame {
    /// `None` for a zero-length edge.
    pub(crate) fn new(r_a: DVec3, e: DVec3) -> Option<Self> {
        Self::with_exact_ends(r_a, e, None)
    }

    /// As [`EdgeFrame::new`]; when `x` is near the edge's line and `ends` gives the endpoints
    /// relative to `x` exactly (as unevaluated sums `hi + lo`), `w`, `h` and `p` are taken from a
    /// double-double cross product instead of the rounded `r_a × e`.
    pub(crate) fn with_exact_ends(r_a: DVec3, e: DVec3, ends: Option<&ExactEnds>) -> Option<Self> {
        let len = e.length();
        if len == 0.0 {
            return None;
        }
        let e_hat = e / len;
        let mut w = r_a.cross(e);
        let mut sa = r_a.dot(e_hat);
        let mut sb = sa + len;
        let mut p = r_a - sa * e_hat;
        if let Some(ends) = ends {
            let bound = NEAR_LINE_SINE * len;
            if w.length_squared() < bound * bound * r_a.length_squared() {
                w = ends.cross();
                // w = p × e, so e × w = p ‖e‖² (no cancellation once w is accurate).
                p = e.cross(w) / (len * len);
                // x near the line is often near an endpoint too, where `s_a + L` cancels.
                sa = ends.a[0].dot(e_hat) + ends.a[1].dot(e_hat);
                sb = ends.b[0].dot(e_hat) + ends.b[1].dot(e_hat);
            }
        }
        let h = w.length() / len;
        Some(EdgeFrame {
            e_hat,
            len,
            p,
            w,
            h,
            sa,
            sb,
        })
    }

    /// The moments up to what `order` needs (`A_1`; `A_2, B_2`; `A_3, B_3, C_3`).
    pub(crate) fn moments(&self, order: Order) -> Result<EdgeMoments> {
        let (sa, sb, h, len) = (self.sa, self.sb, self.h, self.len);
        let mut m = EdgeMoments::default();
        let h2 = h * h;
        let d = h2 + sa * sb; // r_a · r_b
        let axial = sa * sb > 0.0 && h < AXIAL_RATIO * sa.abs().min(sb.abs());
        if axial {
            // x near the extension of the edge's line: β ≈ hL/(s_a s_b) is tiny and every
            // h²-recurrence would cancel. tan β = hL/D with D > 0, and β/h = (L/D) atan(X)/X.
            let xx = h * len / d;
            m.a1 = len / d * atan_over(xx);
        } else {
            if h == 0.0 {
                return Err(Error::Degenerate(
                    "the point lies on the edge: the edge term is undefined".into(),
                ));
            }
            m.a1 = (h * len).atan2(d) / h;
        }
        if !order.gradient() {
            return Ok(m);
        }
        let ra2 = sa * sa + h2;
        let rb2 = sb * sb + h2;
        let rab2 = ra2 * rb2;
        m.b2 = len * (sa + sb) / (2.0 * rab2);
        let (near, far) = if sa.abs() < sb.abs() {
            (sa.abs(), sb.abs())
        } else {
            (sb.abs(), sa.abs())
        };
        if axial {
            m.a2 = axial_a2(near, far, len, h);
        } else {
            // [s/ρ²]_a^b = L (h² − s_a s_b) / (ρ_a² ρ_b²), factored so it cannot cancel.
            m.a2 = (len * (h2 - sa * sb) / rab2 + m.a1) / (2.0 * h2);
        }
        if !order.hessian() {
            return Ok(m);
        }
        m.b3 = len * (sa + sb) * (ra2 + rb2) / (4.0 * rab2 * rab2);
        if axial {
            m.a3 = axial_a3(near, far, len, h);
        } else {
            // [s/ρ⁴]_a^b = L (h⁴ − 2 s_a s_b h² − s_a s_b (s_a² + s_a s_b + s_b²)) / (ρ_a⁴ ρ_b⁴).
            let bracket = h2 * h2 - 2.0 * sa * sb * h2 - sa * sb * (sa * sa + sa * sb + sb * sb);
            m.a3 = (len * bracket / (rab2 * rab2) + 3.0 * m.a2) / (4.0 * h2);
        }
        m.c3 = m.a2 - h2 * m.a3;
        Ok(m)
    }
}

/// `atan(x)/x`, 1 at 0.
fn atan_over(x: f64) -> f64 {
    if x.abs() < 1e-8 {
        1.0 - x * x / 3.0
    } else {
        x.atan() / x
    }
}

/// `A_2 = ∫ dσ/(σ² + h²)²` over `[near, far]` (`far − near = len`, `h ≤ near/4`): the tails
/// `∫_s^∞ = T₂((h/s)²)/s³`, `T₂(y) = Σ_k (−1)^k (k+1) y^k / (2k+3)`, differenced in factored
/// form. Their plain difference cancels by `~near/len` (1.6e-8 relative for an edge 1e-8 of its
/// distance long, the error once blamed on a short edge's frame); here
/// `T₂(y_n)/n³ − T₂(y_f)/f³ = (y_n − y_f) T₂[y_n, y_f]/n³ + T₂(y_f)(1/n³ − 1/f³)` with
/// `y_n − y_f = y_n (1 + q) len/f` and `1/n³ − 1/f³ = (1 + q + q²) len/(n³ f)` (`q = n/f`) adds
/// two terms, the smaller (of opposite sign) at most ~0.3 of the other: a few ulps at every length.
fn axial_a2(near: f64, far: f64, len: f64, h: f64) -> f64 {
    let (y_n, y_f) = ((h / near) * (h / near), (h / far) * (h / far));
    let (t, slope) = axial_series::<20>(y_n, y_f, |k| (k + 1.0) / (2.0 * k + 3.0));
    let q = near / far;
    let inv = 1.0 / near;
    len / far * (inv * inv * inv) * (y_n * (1.0 + q) * slope + t * (1.0 + q * (1.0 + q)))
}

/// `A_3 = ∫ dσ/(σ² + h²)³` over `[near, far]` as [`axial_a2`]: tails `T₃((h/s)²)/s⁵` with
/// `T₃(y) = Σ_k (−1)^k (k+1)(k+2)/2 · y^k / (2k+5)`, and
/// `1/n⁵ − 1/f⁵ = (1 + q + q² + q³ + q⁴) len/(n⁵ f)`.
fn axial_a3(near: f64, far: f64, len: f64, h: f64) -> f64 {
    let (y_n, y_f) = ((h / near) * (h / near), (h / far) * (h / far));
    let (t, slope) =
        axial_series::<22>(y_n, y_f, |k| 0.5 * (k + 1.0) * (k + 2.0) / (2.0 * k + 5.0));
    let q = near / far;
    let inv = 1.0 / near;
    let inv5 = inv * inv * inv * inv * inv;
    let powers = 1.0 + q * (1.0 + q * (1.0 + q * (1.0 + q)));
    len / far * inv5 * (y_n * (1.0 + q) * slope + t * powers)
}

/// `(P(y_f), (P(y_n) − P(y_f))/(y_n − y_f))` for `P(y) = Σ_{k<K} (−1)^k c(k) y^k`: Horner's rule at
/// `y_f` and its divided difference alongside (`D_k = D_{k+1} y_n + P_{k+1}(y_f)`), which never
/// subtracts the two values (`y ≤ 1/16`, the terms fall like `16^{-k}`).
#[inline]
fn axial_series<const K: usize>(y_n: f64, y_f: f64, c: impl Fn(f64) -> f64) -> (f64, f64) {
    let (mut p, mut slope) = (0.0, 0.0);
    for k in (0..K).rev() {
        let kf = k as f64;
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        slope = slope * y_n + p;
        p = p * y_f + sign * c(kf);
    }
    (p, slope)
}

/// `a bᵀ + b aᵀ`.
pub(crate) fn sym_outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x + b * a.x, a * b.y + b * a.y, a * b.z + b * a.z)
}

/// `a aᵀ`.
pub(crate) fn outer_self(a: DVec3) -> DMat3 {
    DMat3::from_cols(a * a.x, a * a.y, a * a.z)
}

/// The edge term of an edge lying on the clip line (in the tangent plane through x), with the
/// motion of the clip line folded in.
///
/// In the tangent plane `q = n × ê` is the in-plane normal of the edge, `p = (q·p) q`, `ν = −q·p`.
/// Substituting these in the general term, the gradient becomes `(−[s/ρ²] q − 2 (q·p) B_2 ê)/2π`
/// and the Hessian `(−2 (q·p) [s/ρ⁴] (q qᵀ − ê êᵀ) + 2 (B_2 − 4h² B_3)(q êᵀ + ê qᵀ))/2π` once the
/// clip-line term `n nᵀ |h_P| A_2/(π‖n_t‖)` (with `|h_P| = h ‖n_t‖`) has cancelled the `n nᵀ`
/// part. The general expressions reach these as differences of terms of size `1/h` (`1/h²`) when x
/// is near the clip line, which is where the clip line always passes when x is near the plane.
pub(crate) fn clip_edge_term(
    r_a: DVec3,
    e: DVec3,
    n: DVec3,
    order: Order,
    ends: Option<&ExactEnds>,
) -> Result<Deriv3> {
    let Some(f) = EdgeFrame::with_exact_ends(r_a, e, ends) else {
        return Ok(Deriv3::constant(0.0));
    };
    let m = f.moments(Order::Value)?;
    let nu = n.dot(f.w) / f.len;
    let mut out = Deriv3::constant(INV_2PI * nu * m.a1);
    if !order.gradient() {
        return Ok(out);
    }
    let (gradient, hessian) = clip_edge_derivs(&f, n, order.hessian());
    out.gradient = INV_2PI * gradient;
    if order.hessian() {
        out.hessian = hessian * INV_2PI;
    }
    Ok(out)
}

/// `2π` times the gradient and (when `hessian`, else zero) the Hessian of [`clip_edge_term`] from
/// the edge's frame (only `e_hat`, `len`, `p`, `h`, `sa`, `sb` are read). No division by `h`:
/// bounded as `x` approaches the clip line, and changed only by `O(δ)` when the frame's inputs
/// move by `δ` (the derivative fast path for clipped triangles relies on both).
#[inline]
pub(crate) fn clip_edge_derivs(f: &EdgeFrame, n: DVec3, hessian: bool) -> (DVec3, DMat3) {
    let (sa, sb, h, len) = (f.sa, f.sb, f.h, f.len);
    let h2 = h * h;
    let ra2 = sa * sa + h2;
    let rb2 = sb * sb + h2;
    let rab2 = ra2 * rb2;
    let q = n.cross(f.e_hat);
    let qp = q.dot(f.p);
    let b2 = len * (sa + sb) / (2.0 * rab2);
    let s_rho2 = len * (h2 - sa * sb) / rab2;
    let gradient = -s_rho2 * q - 2.0 * qp * b2 * f.e_hat;
    if !hessian {
        return (gradient, DMat3::ZERO);
    }
    let b3 = len * (sa + sb) * (ra2 + rb2) / (4.0 * rab2 * rab2);
    let bracket = h2 * h2 - 2.0 * sa * sb * h2 - sa * sb * (sa * sa + sa * sb + sb * sb);
    let s_rho4 = len * bracket / (rab2 * rab2);
    let hess = (outer_self(q) - outer_self(f.e_hat)) * (-2.0 * qp * s_rho4)
        + sym_outer(q, f.e_hat) * (2.0 * (b2 - 4.0 * h2 * b3));
    (gradient, hess)
}

/// The edge term for `r_a = a − x` and `e = b − a` (in any consistent length unit), unit `n`.
pub(crate) fn edge_term(r_a: DVec3, e: DVec3, n: DVec3, order: Order) -> Result<Deriv3> {
    edge_term_exact(r_a, e, n, order, None)
}

/// [`edge_term`], with the exact endpoints (when known) for `x` near the edge's line.
pub(crate) fn edge_term_exact(
    r_a: DVec3,
    e: DVec3,
    n: DVec3,
    order: Order,
    ends: Option<&ExactEnds>,
) -> Result<Deriv3> {
    let Some(f) = EdgeFrame::with_exact_ends(r_a, e, ends) else {
        return Ok(Deriv3::constant(0.0));
    };
    frame_term(&f, n, order)
}

/// The edge term from its frame (see [`edge_term_exact`]).
pub(crate) fn frame_term(f: &EdgeFrame, n: DVec3, order: Order) -> Result<Deriv3> {
    let m = f.moments(order)?;
    // ν = n·w / L = n·(p × ê): the edge's lever arm about n.
    let nu = n.dot(f.w) / f.len;
    let mut out = Deriv3::constant(INV_2PI * nu * m.a1);
    if !order.gradient() {
        return Ok(out);
    }
    let n_x_e = n.cross(f.e_hat);
    // ∇I · L / 2 = p A_2 + ê B_2
    let g = f.p * m.a2 + f.e_hat * m.b2;
    out.gradient = INV_2PI * (n_x_e * m.a1 + 2.0 * nu * g);
    if order.hessian() {
        let curv =
            outer_self(f.p) * m.a3 + sym_outer(f.p, f.e_hat) * m.b3 + outer_self(f.e_hat) * m.c3;
        let hi = DMat3::IDENTITY * (-2.0 * m.a2) + curv * 8.0;
        out.hessian = (sym_outer(n_x_e, g) * 2.0 + hi * nu) * INV_2PI;
    }
    Ok(out)
}

/// The endpoints of an edge relative to `x`, each exactly `hi + lo` (from an error-free difference
/// of the input coordinates).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ExactEnds {
    pub a: [DVec3; 2],
    pub b: [DVec3; 2],
}

impl ExactEnds {
    /// `r_a × r_b` (= `r_a × e`) in double-double, rounded once.
    fn cross(&self) -> DVec3 {
        let a = dd::Dd3::from_parts(self.a[0], self.a[1]);
        let b = dd::Dd3::from_parts(self.b[0], self.b[1]);
        a.cross(&b).to_dvec3()
    }
}

#[cfg(test)]
mod tests;
