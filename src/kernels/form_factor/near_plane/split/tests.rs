use super::*;
use crate::kernels::form_factor::quadrature::rules::gauss_legendre_16;

/// The closed form of [`near_plane_deficit`] against a composite 16-point Gauss rule (64
/// panels in ψ) of its defining integral `∫ ε cos²ψ/(1 + ε cos²ψ) dψ`, whose terms are positive
/// (no cancellation): for `ε` from 1e-2 down to 1e-24 and edges on one side of the foot, across
/// it and far along their line, the difference is within a few ulps of `ε` (the scale of the
/// two angle differences it subtracts), far below the O(h_P) value it enters.
#[test]
fn near_plane_deficit_matches_its_integral() {
    for (d, sa, sb) in [
        (1.0, -0.7, 2.3),
        (0.3, 0.1, 0.4),
        (0.05, 1.0, 3.0),
        (2.0, -5.0, -1.5),
        (1e-3, -1.0, 1e-2),
    ] {
        for k in 1..=12 {
            let h = d * 10f64.powi(-k) * 0.9;
            let eps = (h / d) * (h / d);
            let (pa, pb) = ((sa / d).atan(), (sb / d).atan());
            let panels = 64;
            let mut reference = 0.0;
            for p in 0..panels {
                let (lo, hi) = (
                    pa + (pb - pa) * p as f64 / panels as f64,
                    pa + (pb - pa) * (p + 1) as f64 / panels as f64,
                );
                for &(t, w) in gauss_legendre_16() {
                    let c = (lo + t * (hi - lo)).cos();
                    let c2e = eps * c * c;
                    reference += w * (hi - lo) * c2e / (1.0 + c2e);
                }
            }
            let got = near_plane_deficit(d, h * h, sa, sb, pb - pa);
            let want_spread =
                (sb / (d * d + h * h).sqrt()).atan() - (sa / (d * d + h * h).sqrt()).atan();
            assert!((got.spread - want_spread).abs() <= 8.0 * f64::EPSILON * (pa.abs() + pb.abs()));
            let got = got.g;
            let bound = 8.0 * f64::EPSILON * eps * (pa.abs() + pb.abs() + 1.0);
            assert!(
                (got - reference).abs() <= bound,
                "d={d} h={h:e} s=[{sa}, {sb}]: {got:e} vs {reference:e}"
            );
            assert!(got > 0.0);
        }
    }
}

/// [`tangent_excess`] against the plain difference `β(D) − cβ(cD)` where that has nothing to
/// cancel (`c` up to 0.7, and `P ≤ 0`), and against the first terms of its expansion in `D`,
/// `(1 − c²) D L/P`, as the receiver turns head-on (`1 − c` down to 1e-12) for `D` small.
#[test]
fn tangent_excess_against_direct_and_series() {
    let beta = |t: f64, len: f64, p: f64| (t * len).atan2(t * t + p);
    for (d, len, p) in [
        (1e-3, 0.8, 0.3),
        (1e-6, 2.0, 1.5),
        (0.2, 1.0, 0.05),
        (1e-3, 1.0, -0.2),
    ] {
        for c in [0.0, 0.3, 0.7] {
            let direct = beta(d, len, p) - c * beta(c * d, len, p);
            let got = tangent_excess(d, len, p, c, 1.0 - c * c).0;
            assert!(
                (got - direct).abs() <= 1e-14 * direct.abs(),
                "d={d} L={len} P={p} c={c}: {got:e} vs {direct:e}"
            );
        }
    }
    let (d, len, p) = (1e-9, 0.8, 0.3);
    for k in 2..=12 {
        let nt2 = 10f64.powi(-k);
        let c = (1.0 - nt2).sqrt();
        // β(t) = tL/P − O(t³): the O(D³) remainder is ~1e-18 relative here.
        let series = nt2 * d * len / p;
        let got = tangent_excess(d, len, p, c, nt2).0;
        assert!(
            (got - series).abs() <= 1e-14 * series,
            "1 − c² = {nt2:e}: {got:e} vs {series:e}"
        );
    }
}
