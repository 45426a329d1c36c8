use super::*;

#[test]
fn differences_and_products_are_exact() {
    // 2^-52 + 2^-110 needs 59 bits: f64 loses the small part, the pair keeps it.
    let d = Dd::diff(1.0 + f64::EPSILON, 1.0).add(Dd::new(2f64.powi(-110), 0.0));
    assert_eq!(d.hi, f64::EPSILON);
    assert_eq!(d.lo, 2f64.powi(-110));
    let third = Dd::new(1.0, 0.0).div(Dd::new(3.0, 0.0));
    let back = third.mul(Dd::new(3.0, 0.0)).sub(Dd::new(1.0, 0.0));
    assert!(back.to_f64().abs() < 1e-30);
    let two = Dd::new(2.0, 0.0).sqrt();
    assert!(two.mul(two).sub(Dd::new(2.0, 0.0)).to_f64().abs() < 1e-30);
}

/// `mul_f64` and `dot_f64` drop only terms that are exactly zero: the same values as `mul` and
/// `dot` with the f64 factor as an exact pair, bit for bit (a zero `lo` may change sign only).
#[test]
fn products_with_an_f64_match_the_general_ones_bit_for_bit() {
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = || {
        let state = crate::test_rng::step(&mut state);
        // Mantissa from the high bits, exponent spread over ±40 binades, random sign.
        let m = (state >> 11) as f64 / (1u64 << 53) as f64 + 0.5;
        let e = ((state >> 3) % 81) as i32 - 40;
        let s = if state & 1 == 0 { 1.0 } else { -1.0 };
        s * m * 2f64.powi(e)
    };
    let same = |a: Dd, b: Dd| a.hi.to_bits() == b.hi.to_bits() && a.lo == b.lo;
    for _ in 0..20_000 {
        let (hi, lo_seed, f) = (next(), next(), next());
        // A normalized pair (|lo| <= ulp(hi)/2), as the kernels build them.
        let a = Dd::new(hi, lo_seed * f64::EPSILON * 2f64.powi(-30) * hi.abs());
        let v = DVec3::new(f, next(), next());
        assert!(same(a.mul_f64(f), a.mul(Dd::new(f, 0.0))), "{a:?} * {f}");
        let b = Dd3::new(DVec3::new(hi, next(), next()), DVec3::ZERO).add(&Dd3 {
            x: a,
            y: Dd::new(next(), 0.0),
            z: Dd::new(next(), 0.0),
        });
        let general = b.dot(&Dd3::new(v, DVec3::ZERO));
        assert!(same(b.dot_f64(v), general), "{b:?} . {v}");
    }
    // Cancelling to zero: the pair is still exact.
    let a = Dd::new(3.0, 2f64.powi(-60));
    let z = a.mul_f64(0.0);
    assert_eq!((z.hi, z.lo), (0.0, 0.0));
}

/// `from_parts` is `new` for the pairs the kernels store (two-sum outputs of coordinate
/// differences, and double-double parts), bit for bit including the signs of zeros.
#[test]
fn from_parts_matches_new_on_two_sum_outputs() {
    let mut state = 0x853c_49e6_748f_ea9b_u64;
    let mut next = || {
        let state = crate::test_rng::step(&mut state);
        let m = (state >> 11) as f64 / (1u64 << 53) as f64 + 0.5;
        let e = ((state >> 3) % 61) as i32 - 30;
        let s = if state & 1 == 0 { 1.0 } else { -1.0 };
        // Zeros of both signs and equal operands too, where two-sum's signs are delicate.
        match (state >> 20) % 16 {
            0 => 0.0 * s,
            _ => s * m * 2f64.powi(e),
        }
    };
    let bits = |d: Dd3| [d.x.hi, d.x.lo, d.y.hi, d.y.lo, d.z.hi, d.z.lo].map(f64::to_bits);
    for k in 0..30_000 {
        let (v, x) = (
            DVec3::new(next(), next(), next()),
            DVec3::new(next(), next(), next()),
        );
        let x = if k % 5 == 0 { v } else { x };
        // As `Scaled` stores them: r = v − x rounded, r_lo its two-sum error.
        let pair = |a: f64, b: f64| two_sum(a, -b);
        let (px, py, pz) = (pair(v.x, x.x), pair(v.y, x.y), pair(v.z, x.z));
        let (hi, lo) = (DVec3::new(px.0, py.0, pz.0), DVec3::new(px.1, py.1, pz.1));
        assert_eq!(
            bits(Dd3::from_parts(hi, lo)),
            bits(Dd3::new(hi, lo)),
            "{v} {x}"
        );
        // As clip points store them: the parts of a double-double sum.
        let (h2, l2) = Dd3::new(hi, lo).add(&Dd3::diff(x, v)).split();
        assert_eq!(bits(Dd3::from_parts(h2, l2)), bits(Dd3::new(h2, l2)));
    }
    // Not a double-double (|lo| > ulp(hi)/2): `new` renormalizes, `from_parts` does not.
    let (hi, lo) = (DVec3::splat(1.0), DVec3::splat(0.75));
    assert_eq!(Dd3::new(hi, lo).x.hi, 1.75);
    assert_eq!(Dd3::from_parts(hi, lo).x.lo, 0.75);
}

#[test]
fn cross_product_of_nearly_parallel_vectors_keeps_its_digits() {
    let a = Dd3::diff(DVec3::new(1.0, 1e-9, 0.0), DVec3::ZERO);
    let b = Dd3::diff(DVec3::new(1.0 + f64::EPSILON, 1e-9, 0.0), DVec3::ZERO);
    let z = a.cross(&b).to_dvec3().z;
    // a.x b.y − a.y b.x = 1e-9 (1 − (1 + eps)) = −1e-9 eps, up to the rounding of 1e-9.
    assert!((z + 1e-9 * f64::EPSILON).abs() < 1e-40);
}
