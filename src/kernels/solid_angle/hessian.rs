//! The Hessian of `Ω = 2 atan2(A, D)`, the one formula both rungs of the solid angle evaluate.
//!
//! With `a = ∇A`, `d = ∇D`, `g = A² + D²` (`HA = 0`: `A` is linear in `x`) and
//! `HD = (Σc) 𝟙 + S U Uᵀ − Σ_k w_k u_k u_kᵀ` from the per-vertex [`Parts`],
//!
//! `HΩ = 2[−A HD/g − (2AD(aaᵀ − ddᵀ) + (D² − A²)(adᵀ + daᵀ))/g²] = −2A HD/g − (G vᵀ + v Gᵀ)`,
//!
//! where `G = 2(D a − A d)/g = ∇Ω` is the gradient the caller has already computed and
//! `v = (A a + D d)/g` (expand `G vᵀ + v Gᵀ`: the `aaᵀ` and `ddᵀ` terms carry `±2AD/g²`, the
//! `adᵀ` and `daᵀ` terms `(D² − A²)/g²`). The rank-two part is then two products per entry, with
//! no `1/g²` (which underflows for lengths ≳ 1e25). Only the six distinct entries are evaluated,
//! each written so that `(i, j)` and `(j, i)` give the same bits: the result is exactly symmetric.

use glam::{DMat3, DVec3};

/// The per-vertex pieces of Van Oosterom-Strackee that both evaluations compute: `r_k = y_k − x`,
/// `s_k = |r_k|`, their reciprocals, `p_k` (`p_0 = s_1 s_2 + r_1·r_2`, cyclic) and
/// `c_k = p_k/s_k + s_{k+1} + s_{k+2}`.
pub(super) struct Parts {
    pub(super) r: [DVec3; 3],
    pub(super) s: [f64; 3],
    pub(super) inv_s: [f64; 3],
    pub(super) p: [f64; 3],
    pub(super) c: [f64; 3],
}

/// `Ω = 2 atan2(A, D)` as a quotient: `A`, `D`, `1/g` with `g = A² + D²`, `a = ∇A`, `d = ∇D`, and
/// the gradient `∇Ω = 2(D a − A d)/g`, which both rungs return and the Hessian is built from.
pub(super) struct Quotient {
    pub(super) a_num: f64,
    pub(super) d_den: f64,
    pub(super) inv_g: f64,
    pub(super) grad_a: DVec3,
    pub(super) grad_d: DVec3,
    pub(super) gradient: DVec3,
}

impl Quotient {
    /// The quotient of `A`, `D`, their sum of squares `g` and their gradients, with `1/g` and
    /// `∇Ω`.
    #[inline(always)]
    pub(super) fn new(a_num: f64, d_den: f64, g: f64, grad_a: DVec3, grad_d: DVec3) -> Self {
        let inv_g = 1.0 / g;
        Quotient {
            a_num,
            d_den,
            inv_g,
            grad_a,
            grad_d,
            gradient: (grad_a * d_den - grad_d * a_num) * (2.0 * inv_g),
        }
    }
}

/// Hessian of `Ω = 2 atan2(A, D)`: `−2A HD/g − (G vᵀ + v Gᵀ)` (see the module documentation).
#[inline(always)]
pub(super) fn hessian_of_parts(parts: &Parts, quotient: &Quotient) -> DMat3 {
    let Parts { r, s, inv_s, p, c } = parts;
    let &Quotient {
        a_num,
        d_den,
        inv_g,
        grad_a,
        grad_d,
        gradient,
    } = quotient;
    let s_sum = s[0] + s[1] + s[2];
    // Written out: array maps and closures were left out of line.
    let u = [
        (r[0] * inv_s[0]).to_array(),
        (r[1] * inv_s[1]).to_array(),
        (r[2] * inv_s[2]).to_array(),
    ];
    let u_sum = (r[0] * inv_s[0] + r[1] * inv_s[1] + r[2] * inv_s[2]).to_array();
    let weight = [
        s_sum + p[0] * inv_s[0],
        s_sum + p[1] * inv_s[1],
        s_sum + p[2] * inv_s[2],
    ];
    let c_sum = c[0] + c[1] + c[2];
    let v = (grad_a * a_num + grad_d * d_den) * inv_g;
    // Symmetric to the bit (`HessianTerms::entry`): the upper triangle gives the matrix.
    let h = HessianTerms {
        u,
        u_sum,
        weight,
        c_sum,
        s_sum,
        hd_scale: -2.0 * a_num * inv_g,
        gradient: gradient.to_array(),
        v: v.to_array(),
    };
    let entry = |i: usize, j: usize| h.entry(i, j);
    let (xx, yy, zz) = (entry(0, 0), entry(1, 1), entry(2, 2));
    let (xy, xz, yz) = (entry(0, 1), entry(0, 2), entry(1, 2));
    DMat3::from_cols(
        DVec3::new(xx, xy, xz),
        DVec3::new(xy, yy, yz),
        DVec3::new(xz, yz, zz),
    )
}

/// The scalars of [`hessian_of_parts`]' entries.
struct HessianTerms {
    u: [[f64; 3]; 3],
    u_sum: [f64; 3],
    weight: [f64; 3],
    c_sum: f64,
    s_sum: f64,
    /// `−2A/g`.
    hd_scale: f64,
    gradient: [f64; 3],
    v: [f64; 3],
}

impl HessianTerms {
    /// Entry (i, j) of `−(2A/g) HD − (G vᵀ + v Gᵀ)`, `HD = (Σc) 𝟙 + S U Uᵀ − Σ_k w_k u_k u_kᵀ`.
    /// Every term is symmetric in (i, j) to the bit (products of two factors, scalars applied
    /// after them, `G vᵀ + v Gᵀ` a sum of the two orders).
    #[inline(always)]
    fn entry(&self, i: usize, j: usize) -> f64 {
        let Self {
            u,
            u_sum,
            weight,
            gradient,
            v,
            ..
        } = self;
        let diagonal = if i == j { self.c_sum } else { 0.0 };
        let mut hd = diagonal + u_sum[i] * u_sum[j] * self.s_sum;
        for k in 0..3 {
            hd -= u[k][i] * u[k][j] * weight[k];
        }
        hd * self.hd_scale - (gradient[i] * v[j] + v[i] * gradient[j])
    }
}
