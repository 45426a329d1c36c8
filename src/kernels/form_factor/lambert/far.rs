//! Certified far-field form of Lambert's sum for an unclipped polygon (a triangle or a convex
//! polygon checked by the caller), without cancellation when the polygon is small against its
//! distance, and without `atan2`.
//!
//! **Why.** Lambert's terms `β_i (n·w_i)/s_i` are each of size `σ ~ size/distance` while their sum
//! is of size `σ²`: summed as written they lose `distance/size` digits, and the running bound of
//! [`lambert::sum`](crate::kernels::form_factor::lambert::sum) rejects beyond ~25 sizes. Writing
//! `u_k = r_k/ρ_k` (`ρ_k = ‖r_k‖`), `σ_i = sin β_i = s_i/(ρ_i ρ_{i+1})` and `β_i/s_i = (1 +
//! ψ(σ_i))/(ρ_i ρ_{i+1})` with `ψ(σ) = arcsin(σ)/σ − 1` (β < π/2 here):
//!
//! ```text
//! 2π F = n·Σ_i β_i ŵ_i = n·Σ_i (u_i × u_{i+1}) + Σ_i ψ(σ_i) n·w_i/(ρ_i ρ_{i+1}),
//! Σ_i u_i × u_{i+1} = Σ_{k=1}^{m−2} Δ_k × Δ_{k+1},   Δ_k = u_k − u_0 = (d_k − u_0 q_k)/ρ_k,
//! d_k = v_k − v_0,   q_k = ρ_k − ρ_0 = d_k·(r_0 + r_k)/(ρ_0 + ρ_k).
//! ```
//!
//! The second line is exact (the terms `u_0 × ·` telescope); the `Δ_k` come from the vertex
//! differences `d_k` (no cancellation: a rounding of `r_k` only turns `u_0`, whose factor `q_k` is
//! small), so the fan sum carries relative errors of a few `u` whatever the distance, and the `ψ`
//! terms are a correction of relative size `σ²/6`. `ψ` is its Maclaurin series
//! `Σ_{k≥1} C(2k,k)/(4^k(2k+1)) σ^{2k}` (12 terms, all positive); the regime requires
//! `20 ‖e_i‖² ≤ ρ_{i+1}²` for every edge (`σ_i ≤ ‖e_i‖/ρ_{i+1}`, so `σ² ≤ 1/20`: the truncation is
//! below `0.1 u ψ`, and `r_i·r_{i+1} > 0`, the `arcsin` branch).
//!
//! **Error bound** (first order in `u = 2⁻⁵³`; `D_k = ‖d_k‖₁/ρ_k ≥ ‖d_k‖/ρ_k`,
//! `E_i = ‖e_i‖₁/ρ_{i+1}`). The computed `r_k`, `d_k` are within `u` componentwise and `ρ_k` within
//! `4u`; then `|δq_k| ≤ 12u‖d_k‖` (the dot product `d_k·(r_0 + r_k)` within `6u‖d_k‖(ρ_0 + ρ_k)`,
//! using `|q_k| ≤ ‖d_k‖`), `|δ(d_k − u_0 q_k)| ≤ 23u‖d_k‖` and `‖δΔ_k‖ ≤ 36u D_k` (with
//! `‖Δ_k‖ ≤ 2‖d_k‖/ρ_k`). The cross products round within `2u‖Δ_k‖₁‖Δ_{k+1}‖₁` (1-norms bound
//! `n·` of componentwise errors), the fan sum, the dot with `n` and `n`'s renormalization add
//! `(m + 3)u` times the same, so
//!
//! ```text
//! |δ main| ≤ u Σ_k [36 (D_k ‖Δ_{k+1}‖₁ + ‖Δ_k‖₁ D_{k+1}) + (m + 5) ‖Δ_k‖₁ ‖Δ_{k+1}‖₁].
//! ```
//!
//! Per edge, `w_i = r_i × e_i` is within `6uL` (`L = ρ_i‖e_i‖`, see `lambert`), so `σ_i²` is
//! within `(12L/s_i + 16)u` relatively, the Horner sum of positive terms within `27u` (with the
//! truncation), `d ln ψ/d ln σ² ≤ 1.2`, and with `|n·w_i|/(ρ_iρ_{i+1}) ≤ σ_i ≤ E_i`,
//! `L/(ρ_iρ_{i+1}) ≤ E_i`: `|δ corr_i| ≤ 84 u ψ_i E_i`. Summing the `m + 1` parts adds
//! `m u (|main| + Σ|corr_i|)`, the final scaling `2u|total|`. The result is accepted when the
//! bound is within [`FAST_TOLERANCE`] of `|total|` and
//! `|total| > 1e-250` (no subnormal intermediates that matter).

use glam::DVec3;

use crate::kernels::form_factor::tolerance::FAST_TOLERANCE;

const U: f64 = 0.5 * f64::EPSILON;

/// `C(2k,k)/(4^k (2k+1))`, `k = 1..=12`: `arcsin(σ)/σ − 1 = Σ_k PSI[k−1] σ^{2k}`.
const PSI: [f64; 12] = [
    1.0 / 6.0,
    3.0 / 40.0,
    5.0 / 112.0,
    35.0 / 1152.0,
    63.0 / 2816.0,
    231.0 / 13312.0,
    143.0 / 10240.0,
    6435.0 / 557056.0,
    12155.0 / 1245184.0,
    46189.0 / 5505024.0,
    88179.0 / 12058624.0,
    676039.0 / 104857600.0,
];

/// Smallest `ρ_{i+1}² / ‖e_i‖²` of the far regime (`σ² ≤ 1/20`). The derivative fast path, which
/// takes edges down to `sin β = 1/32`, then takes the far form's value, as the value path does.
pub(crate) const FAR_RATIO2: f64 = 20.0;

/// Outcome of [`far_sum`].
pub(crate) enum Far {
    /// Some edge is not small against its distance: use Lambert's sum.
    Near,
    /// Far, but the bound is not within the tolerance (or the input is extreme).
    Declined,
    /// `2π` times the signed form factor.
    Certified(f64),
}

/// `ψ(σ) = arcsin(σ)/σ − 1` from `t = σ² ≤ 1/20` (Horner).
#[inline(always)]
pub(crate) fn psi(t: f64) -> f64 {
    let mut p = PSI[11];
    for c in PSI[..11].iter().rev() {
        p = p * t + c;
    }
    p * t
}

#[inline(always)]
fn norm1(v: DVec3) -> f64 {
    let a = v.abs();
    a.x + a.y + a.z
}

/// The far-field sum for the polygon `v` (unit normal `n`, `r_k = v_k − x` in range, `rho2` their
/// squared lengths, every vertex above the tangent plane, checked by the caller). See the module
/// documentation for the formula and its bound.
// Not inlined: the callers' near path (Lambert's sum) stays as small as before the far form.
#[inline(never)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn far_sum<const M: usize>(
    n: DVec3,
    v: &[DVec3; M],
    r: &[DVec3; M],
    rho2: &[f64; M],
) -> Far {
    let e: [DVec3; M] = std::array::from_fn(|i| v[(i + 1) % M] - v[i]);
    for i in 0..M {
        if !(FAR_RATIO2 * e[i].length_squared() <= rho2[(i + 1) % M]) {
            return Far::Near;
        }
    }
    let rho: [f64; M] = rho2.map(f64::sqrt);
    let inv: [f64; M] = rho.map(|p| 1.0 / p);
    // Δ_k = u_k − u_0 from the vertex differences (Δ_0 = 0), and D_k = ‖d_k‖₁/ρ_k.
    let mut delta = [DVec3::ZERO; M];
    let mut dn = [0.0; M];
    for k in 1..M {
        let d = v[k] - v[0];
        let q = d.dot(r[0] + r[k]) / (rho[0] + rho[k]);
        delta[k] = (d - r[0] * (q * inv[0])) * inv[k];
        dn[k] = norm1(d) * inv[k];
    }
    let mut area = DVec3::ZERO;
    let (mut b_prop, mut b_round) = (0.0, 0.0);
    for k in 1..M - 1 {
        area += delta[k].cross(delta[k + 1]);
        let (a, b) = (norm1(delta[k]), norm1(delta[k + 1]));
        b_prop += dn[k] * b + a * dn[k + 1];
        b_round += a * b;
    }
    let main = n.dot(area);
    let (mut corr, mut corr_mag, mut b_corr) = (0.0, 0.0, 0.0);
    for i in 0..M {
        let j = (i + 1) % M;
        let w = r[i].cross(e[i]);
        let pp = inv[i] * inv[j];
        let p = psi(w.length_squared() * (pp * pp));
        let c = p * (n.dot(w) * pp);
        corr += c;
        corr_mag += c.abs();
        b_corr += p * norm1(e[i]) * inv[j];
    }
    let total = main + corr;
    let m = M as f64;
    let err = U
        * (36.0 * b_prop
            + (m + 5.0) * b_round
            + 84.0 * b_corr
            + m * (main.abs() + corr_mag)
            + 2.0 * total.abs());
    if err <= FAST_TOLERANCE * total.abs() && total.abs() > 1e-250 {
        Far::Certified(total)
    } else {
        Far::Declined
    }
}

#[cfg(test)]
mod tests;
