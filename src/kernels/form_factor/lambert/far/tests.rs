use super::*;

#[test]
fn psi_matches_arcsin() {
    // Where arcsin(σ)/σ − 1 loses few digits (σ ~ 0.2), the series must agree to the
    // rounding of the direct formula; far below, to relative 1e-15 of ψ ~ σ²/6.
    for s in [0.2236f64, 0.2, 0.1, 0.05] {
        let direct = s.asin() / s - 1.0;
        let series = psi(s * s);
        assert!(
            (series - direct).abs() < 4.0 * f64::EPSILON,
            "{s}: {series} {direct}"
        );
    }
    // Tiny σ: the leading terms σ²/6 + 3σ⁴/40 are exact to rounding.
    let s: f64 = 1e-4;
    let lead = s * s / 6.0 + 3.0 * s.powi(4) / 40.0;
    assert!((psi(s * s) - lead).abs() <= 1e-15 * lead);
}
