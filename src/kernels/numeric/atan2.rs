//! `atan2` for angles in `[0, π]` as a branch-free polynomial, for code that runs in SIMD lanes.
//!
//! std's `f64::atan2` is a libm call, which a vectorized loop cannot contain. [`atan2_upper`]
//! reduces the angle of `(|x|, y)` to `|z| ≤ tan(π/8)` with one division, evaluates
//! `atan z = z + z³ P(z²)` by Estrin's scheme, and reflects for `x < 0`; the three reductions are
//! selects, not branches, so every lane runs the same instructions. Users: the batch solid angle
//! (`batch::solid_angle_lanes`) and the gather's edge batches.
//!
//! Error: within 2 ulps of `f64::atan2` wherever `y ≥ 0` and `(x, y) ≠ (0, 0)`, subnormal and
//! huge arguments included (`tests` below, against libm on a sweep of angles and magnitudes).

use super::fma::fmadd;

/// `tan(π/8)`, `tan(3π/8)`.
const TAN_PI_8: f64 = 0.414_213_562_373_095_03;
const TAN_3PI_8: f64 = 2.414_213_562_373_095;

/// `(atan(z) − z)/z³` as a polynomial in `t = z²` on `[0, tan²(π/8)]`, highest degree first
/// (Chebyshev interpolant of degree 10 computed at 50 digits; absolute error 3.2e-17, i.e. below
/// 1e-16 relative to the value, which is about −1/3).
const ATAN_POLY: [f64; 11] = [
    -0.019_176_887_119_062_26,
    0.039_231_658_295_587_19,
    -0.050_854_497_379_402_6,
    0.058_581_489_128_022_1,
    -0.066_645_114_473_819_48,
    0.076_921_831_908_260_87,
    -0.090_909_045_781_239_03,
    0.111_111_110_152_563_61,
    -0.142_857_142_846_665_42,
    0.199_999_999_999_955_2,
    -0.333_333_333_333_333_3,
];

/// `atan2(y, x)` for `y ≥ 0` (an angle in `[0, π]`), without branches or table lookups, so that it
/// vectorises. The angle of `(|x|, y)` is reduced to `|z| ≤ tan(π/8)` by one division (`y/|x|`,
/// `(y − |x|)/(y + |x|)` about π/4, or `−|x|/y` about π/2) and `atan z = z + z³ P(z²)`; then
/// reflected for `x < 0`. Within 2 ulps of `f64::atan2` over the whole domain (tested, including
/// subnormal and huge arguments). `(0, 0)` gives NaN (callers exclude it).
#[inline(always)]
pub(crate) fn atan2_upper<const FMA: bool>(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let a = x.abs();
    let low = y <= TAN_PI_8 * a;
    let high = y >= TAN_3PI_8 * a;
    let (num, den, base) = if low {
        (y, a, 0.0)
    } else if high {
        (-a, y, FRAC_PI_2)
    } else {
        (y - a, y + a, FRAC_PI_4)
    };
    let z = num / den;
    let t = z * z;
    let c = &ATAN_POLY;
    // Estrin's scheme: P = c₀t¹⁰ + t⁸e₀ + t⁶e₁ + t⁴e₂ + t²e₃ + e₄ with e_k = c_{2k+1} t + c_{2k+2}.
    // The five pairs are independent, so the chain of dependent operations is about half as long
    // as Horner's (the value is at the end of its callers' critical path).
    let t2 = t * t;
    let t4 = t2 * t2;
    let e0 = fmadd::<FMA>(c[1], t, c[2]);
    let e1 = fmadd::<FMA>(c[3], t, c[4]);
    let e2 = fmadd::<FMA>(c[5], t, c[6]);
    let e3 = fmadd::<FMA>(c[7], t, c[8]);
    let e4 = fmadd::<FMA>(c[9], t, c[10]);
    let high = fmadd::<FMA>(fmadd::<FMA>(c[0], t2, e0), t2, e1); // c₀t⁴ + e₀t² + e₁
    let middle = fmadd::<FMA>(e2, t2, e3); // e₂t² + e₃
    let p = fmadd::<FMA>(fmadd::<FMA>(high, t4, middle), t2, e4);
    let phi = base + fmadd::<FMA>(z * t, p, z);
    if x < 0.0 {
        PI - phi
    } else {
        phi
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::lcg;

    /// Distance in units in the last place between two finite doubles of the same sign.
    fn ulps(a: f64, b: f64) -> u64 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    /// Within 2 ulps of libm's `atan2` on random angles in `[0, π]` at magnitudes from the
    /// subnormal range to near `f64::MAX`, on both axes and in both builds (plain and fused).
    #[test]
    fn within_two_ulps_of_libm() {
        let mut state = 31;
        for _ in 0..20_000 {
            let angle = std::f64::consts::PI * lcg(&mut state);
            let magnitude = 10f64.powf(-315.0 + 622.0 * lcg(&mut state));
            let (y, x) = (magnitude * angle.sin(), magnitude * angle.cos());
            if y < 0.0 || (x == 0.0 && y == 0.0) || !(x.is_finite() && y.is_finite()) {
                continue;
            }
            let expected = y.atan2(x);
            for got in [atan2_upper::<false>(y, x), atan2_upper::<true>(y, x)] {
                let e = ulps(got, expected);
                assert!(
                    e <= 2,
                    "atan2({y:e}, {x:e}) = {got:e}, libm {expected:e}: {e} ulps"
                );
            }
        }
        for (y, x) in [
            (0.0, 1.0),
            (0.0, -1.0),
            (1.0, 0.0),
            (5e-324, 1.0),
            (1.0, -5e-324),
        ] {
            assert!(
                ulps(atan2_upper::<false>(y, x), y.atan2(x)) <= 2,
                "({y:e}, {x:e})"
            );
        }
    }
}
