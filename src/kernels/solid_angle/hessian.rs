//! The Hessian of `Ω = 2 atan2(A, D)`, the one formula both rungs of the solid angle evaluate.
//!
//! `HΩ = 2[−A HD/g − (2AD(aaᵀ − ddᵀ) + (D² − A²)(adᵀ + daᵀ))/g²]` with `a = ∇A`, `d = ∇D`,
//! `g = A² + D²` (`HA = 0`: `A` is linear in `x`) and `HD = (Σc) 𝟙 + S U Uᵀ − Σ_k w_k u_k u_kᵀ`
//! from the per-vertex [`Parts`]. Only the six distinct entries are evaluated, each written so
//! that `(i, j)` and `(j, i)` give the same bits: the result is exactly symmetric.

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

/// Hessian of `Ω = 2 atan2(A, D)` from the parts, `A`, `D`, `1/(A² + D²)` and the gradients of
/// `A` and `D`: `HΩ = 2[−A HD/g − (2AD(aaᵀ − ddᵀ) + (D² − A²)(adᵀ + daᵀ))/g²]`, `a = ∇A`,
/// `d = ∇D` (`HA = 0`: A is linear in x).
#[inline(always)]
pub(super) fn hessian_of_parts(
    parts: &Parts,
    a_num: f64,
    d_den: f64,
    inv_g: f64,
    grad_a: DVec3,
    grad_d: DVec3,
) -> DMat3 {
    let Parts { r, s, inv_s, p, c } = parts;
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
    let inv_g2 = inv_g * inv_g;
    let q = 2.0 * d_den * a_num * inv_g2;
    let m = (d_den * d_den - a_num * a_num) * inv_g2;
    let (ga, gd) = (grad_a.to_array(), grad_d.to_array());
    // Symmetric to the bit (`HessianTerms::entry`): the upper triangle gives the matrix.
    let h = HessianTerms {
        u,
        u_sum,
        weight,
        c_sum,
        s_sum,
        a_over_g: -a_num * inv_g,
        q,
        m,
        ga,
        gd,
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
    /// `−A/g`.
    a_over_g: f64,
    q: f64,
    m: f64,
    ga: [f64; 3],
    gd: [f64; 3],
}

impl HessianTerms {
    /// Entry (i, j) of `2[−(A/g) HD − (aaᵀ − ddᵀ) q − (adᵀ + daᵀ) m]`, `HD = (Σc) 𝟙 + S U Uᵀ −
    /// Σ_k w_k u_k u_kᵀ`. Every term is symmetric in (i, j) to the bit (products of two factors,
    /// scalars applied after them, `adᵀ + daᵀ` a sum of the two orders).
    #[inline(always)]
    fn entry(&self, i: usize, j: usize) -> f64 {
        let Self {
            u,
            u_sum,
            weight,
            ga,
            gd,
            ..
        } = self;
        let diagonal = if i == j { self.c_sum } else { 0.0 };
        let mut hd = diagonal + u_sum[i] * u_sum[j] * self.s_sum;
        for k in 0..3 {
            hd -= u[k][i] * u[k][j] * weight[k];
        }
        (hd * self.a_over_g
            - (ga[i] * ga[j] - gd[i] * gd[j]) * self.q
            - (ga[i] * gd[j] + ga[j] * gd[i]) * self.m)
            * 2.0
    }
}
