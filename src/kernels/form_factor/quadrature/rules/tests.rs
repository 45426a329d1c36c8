use super::*;
use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::quadrature::tensor::far_field;
use crate::kernels::form_factor::robust::form_factor;
use crate::Order;

/// A-priori bound on the relative quadrature error of [`triangle_rule`] with `points`x`points`
/// Gauss-Legendre points, for a triangle within `rho` (radius over distance, `ρ < 1`) of x, as
/// `[value, gradient, Hessian]` (the value relative to itself, the derivatives relative to their
/// natural scale, which their largest entry reaches within a factor ~2).
///
/// Derivation. The Duffy-mapped tensor rule integrates polynomials of total degree
/// `D = 2·points − 2` over the triangle exactly (a degree-`k` polynomial maps to degree `k + 1` in
/// `s`, `k` in `t`). The integrands are `L·g` and `g'`, with `L = n·r ≥ 0` on the visible part
/// (linear) and `g`, `g'` of the form `P_p(r)/(r·r)^j` (`p ≤ 2`). Along any real line
/// `c + τ û` through the centroid `c`, `r·r = (τ − τ₁)(τ − τ₂)` with `|τ₁| = |τ₂| = d`, so `g` is
/// analytic for `|τ| < d` and, on the circle `|τ| = σd`, `|g| ≤ (1 + σ)^p d^p / ((1 − σ) d)^{2j}`.
/// Cauchy's estimate bounds the Taylor remainder beyond degree `m` for `|τ| ≤ R` by that maximum
/// times `(ρ/σ)^{m+1} / (1 − ρ/σ)`. The rule is exact on `L·P_{D−1}g` (positive weights, summing to
/// the area, and `Q(L) = ∫L`), so `|Q(Lg) − ∫Lg| ≤ 2 ∫L · max|g − P_{D−1}g|`; likewise
/// `|Q(g') − ∫g'| ≤ 2·area·max|g' − P_D g'|`. With `∫L ≤ area·d(1 + ρ)` and the integrands at least
/// their values at distance `d(1 + ρ)`:
///
/// ```text
/// value:    2 (1+ρ)⁴ (1−σ)⁻⁴ (ρ/σ)^D / (1 − ρ/σ)
/// gradient: √3 (1+ρ)⁴ [8 (1+ρ)(1+σ)(1−σ)⁻⁶ (ρ/σ)^D + 2 (1−σ)⁻⁴ (ρ/σ)^{D+1}] / (1 − ρ/σ)
/// Hessian:  (1+ρ)⁵ [48 (1+ρ)(1+σ)²(1−σ)⁻⁸ (ρ/σ)^D + 16 (1+σ)(1−σ)⁻⁶ (ρ/σ)^{D+1}
///                   + 8 (1+ρ)(1−σ)⁻⁶ (ρ/σ)^D] / (1 − ρ/σ)
/// ```
///
/// minimized over `σ ∈ (ρ, 1)` (the gradient's scale is `|4(n·r̂) r̂ − n| ≥ 1`, its largest entry
/// `≥ 1/√3` of it; the Hessian's `24 (n·r̂) r̂r̂ᵀ − 4(n r̂ᵀ + r̂ nᵀ) − 4 (n·r̂) 𝟙` has an entry of at
/// least 1). Fan triangles of a non-convex polygon can overlap with opposite signs, which
/// multiplies the bound by `Σ|area_k| / area`.
/// Only the unit tests evaluate it (to check [`FAR_FIELD_RULES`]); the kernel uses the ratios.
pub(crate) fn far_field_error_bound(points: usize, rho: f64) -> [f64; 3] {
    let d = (2 * points - 2) as i32;
    let mut best = [f64::INFINITY; 3];
    for k in 1..1000 {
        let s = k as f64 / 1000.0;
        if s <= rho {
            continue;
        }
        let q = rho / s;
        let (qd, qd1, tail) = (q.powi(d), q.powi(d + 1), 1.0 / (1.0 - q));
        let (p, m) = (1.0 + rho, 1.0 - s);
        let value = 2.0 * p.powi(4) * m.powi(-4) * qd * tail;
        let gradient = 3f64.sqrt()
            * p.powi(4)
            * (8.0 * p * (1.0 + s) * m.powi(-6) * qd + 2.0 * m.powi(-4) * qd1)
            * tail;
        let hessian = p.powi(5)
            * (48.0 * p * (1.0 + s).powi(2) * m.powi(-8) * qd
                + 16.0 * (1.0 + s) * m.powi(-6) * qd1
                + 8.0 * p * m.powi(-6) * qd)
            * tail;
        for (b, e) in best.iter_mut().zip([value, gradient, hessian]) {
            *b = b.min(e);
        }
    }
    best
}

/// The switch ratios of [`FAR_FIELD_RULES`] above 16 satisfy the documented tolerances of
/// [`far_field_error_bound`] (1e-14 value and gradient, 1e-12 Hessian) at the switch, and so
/// beyond it (the bound grows with ρ); the next cheaper rule would not (each ratio is within
/// 10 % of the smallest the bound allows).
#[test]
fn far_field_switches_satisfy_the_a_priori_bound() {
    let tolerance = [1e-14, 1e-14, 1e-12];
    let fits = |points: usize, ratio: f64| {
        far_field_error_bound(points, 1.0 / ratio)
            .iter()
            .zip(tolerance)
            .all(|(e, t)| *e <= t)
    };
    for (ratio, points) in FAR_FIELD_RULES {
        if ratio > FAR_FIELD_RATIO {
            assert!(fits(points, ratio), "{points} points at {ratio}");
            assert!(!fits(points, ratio / 1.1), "{points} points at {ratio}/1.1");
        }
        // The rule returned at and just below each switch.
        let rule = far_field_rule(ratio, 1.0).unwrap();
        assert_eq!(rule.0.len(), points);
    }
    for w in FAR_FIELD_RULES.windows(2) {
        let below = far_field_rule(w[0].0 * (1.0 - 1e-15), 1.0).unwrap();
        assert_eq!(below.0.len(), w[1].1);
    }
    assert!(far_field_rule(FAR_FIELD_RATIO * (1.0 - 1e-15), 1.0).is_none());
    assert!(far_field_rule(f64::NAN, 1.0).is_none());
    // The 8x8 rule between 16 and 31 radii is kept on measurement, not on this bound.
    let at_16 = far_field_error_bound(8, 1.0 / 16.0);
    assert!(at_16[0] > 1e-14 && at_16[0] < 1e-12, "{at_16:?}");
    assert!(at_16[2] > 1e-12 && at_16[2] < 1e-8, "{at_16:?}");
    assert!(fits(8, 31.0));
}

/// The bound against the measured quadrature error of the value of a flat-on triangle (the
/// exact form factor of a parallel receiver from the edge sum at a moderate distance where it
/// does not cancel): the bound holds, and overestimates.
#[test]
fn far_field_bound_holds_for_each_rule() {
    let tri = [
        DVec3::new(-0.4, -0.3, 0.0),
        DVec3::new(0.7, -0.1, 0.0),
        DVec3::new(0.0, 0.8, 0.0),
    ];
    let c = (tri[0] + tri[1] + tri[2]) / 3.0;
    let radius = tri.iter().map(|v| (*v - c).length()).fold(0.0, f64::max);
    let n = DVec3::new(0.3, 0.1, 1.0).normalize();
    for (points, rule) in [
        (3, gauss_legendre_3()),
        (4, gauss_legendre_4()),
        (5, gauss_legendre_5()),
        (6, gauss_legendre_6()),
    ] {
        // Close enough that the error is well above rounding: 2-4 radii.
        for ratio in [2.0, 3.0, 4.0] {
            let x = c - DVec3::new(0.2, -0.1, 1.0).normalize() * (ratio * radius);
            let verts: Vec<ClipVertex> = tri
                .iter()
                .map(|v| ClipVertex {
                    u: *v - tri[0],
                    r: *v - x,
                    r_lo: DVec3::ZERO,
                    on_line: false,
                })
                .collect();
            let got = far_field(&verts, n, Order::Value, false, Rule(rule)).value;
            let reference = form_factor(x, n, &tri, Order::Value).unwrap().value;
            let err = (got.abs() - reference).abs() / reference;
            let bound = far_field_error_bound(points, 1.0 / ratio)[0];
            assert!(
                err <= bound,
                "{points} points, ratio {ratio}: {err:e} > {bound:e}"
            );
            assert!(
                err > 1e-15,
                "{points} points, ratio {ratio}: error {err:e} at rounding"
            );
        }
    }
}
