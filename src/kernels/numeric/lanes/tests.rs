use super::*;
use crate::test_rng::lcg;
use glam::DVec3;

#[test]
fn pair_lanes_round_as_scalar_and_glam() {
    let (a, b) = (DVec3::new(0.3, -1.7, 2.9), DVec3::new(1e-3, 4.1, -0.6));
    let (c, d) = (DVec3::new(-2.2, 0.7, 1.3), DVec3::new(5.5, -0.01, 0.25));
    let p = V3::pair(a, c).cross(V3::pair(b, d));
    assert_eq!(p.lane(0), a.cross(b));
    assert_eq!(p.lane(1), c.cross(d));
    let q = V3::pair(a, c).dot(V3::pair(b, d));
    assert_eq!([q.get(0), q.get(1)], [a.dot(b), c.dot(d)]);
    let s = V3::from_dvec(a).cross(V3::from_dvec(b)).to_dvec();
    assert_eq!(s, a.cross(b));
    let lanes = |p: Pair| [p.get(0), p.get(1)];
    assert_eq!(lanes(Pair::new(2.0, 9.0).sqrt()), [2f64.sqrt(), 3.0]);
    let q = Pair::new(1.0, 4.0).div(Pair::new(3.0, 7.0));
    assert_eq!(lanes(q), [1.0 / 3.0, 4.0 / 7.0]);
    let m = Pair::new(-1.0, 4.0).abs().max(Pair::new(0.5, 5.0));
    assert_eq!(lanes(m), [1.0, 5.0]);
    assert_eq!(lanes(-Pair::new(0.0, -2.5)), [-0.0, 2.5]);
    assert_eq!(lanes(Pair::splat(1.0).recip()), [1.0, 1.0]);
}

/// Every operation of [`Pair`] (both halves of a group) and of [`Wide`] (where the CPU has AVX2
/// and FMA) rounds each lane as the scalar `f64` code does, and the lanes are added as
/// `(l0 + l1) + (l2 + l3)`: checked bit for bit against scalar arithmetic on random operands
/// of mixed signs and magnitudes 1e-150..1e150.
#[test]
fn lanes_round_as_scalar_code() {
    // The group's lanes as the sums add them: one register (`firsts` = [0]), or two halves
    // summed apart ([0, 2]).
    fn ops<L: Lanes>(a: &[f64; 4], b: &[f64; 4], firsts: &[usize]) -> [f64; 7] {
        let each = |f: &dyn Fn(L, L) -> L| {
            let part = |first| f(L::load(a, first), L::load(b, first)).total();
            firsts[1..]
                .iter()
                .fold(part(firsts[0]), |sum, &first| sum + part(first))
        };
        [
            each(&|x, y| x + y),
            each(&|x, y| x - y),
            each(&|x, y| x * y),
            each(&|x, y| x.div(y)),
            each(&|_, y| y.recip()),
            each(&|x, _| (-x).abs()),
            each(&|_, _| L::splat(a[0])),
        ]
    }
    fn scalar(a: &[f64; 4], b: &[f64; 4]) -> [f64; 7] {
        let tree = |f: &dyn Fn(usize) -> f64| (f(0) + f(1)) + (f(2) + f(3));
        [
            tree(&|l| a[l] + b[l]),
            tree(&|l| a[l] - b[l]),
            tree(&|l| a[l] * b[l]),
            tree(&|l| a[l] / b[l]),
            tree(&|l| 1.0 / b[l]),
            tree(&|l| a[l].abs()),
            (a[0] + a[0]) + (a[0] + a[0]),
        ]
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn wide_ops(a: &[f64; 4], b: &[f64; 4]) -> [f64; 7] {
        ops::<Wide>(a, b, &[0])
    }
    let mut state = 1829;
    for _ in 0..2000 {
        let mut c = || {
            let sign = if lcg(&mut state) < 0.5 { -1.0 } else { 1.0 };
            sign * 10f64.powf(300.0 * lcg(&mut state) - 150.0)
        };
        let a = [c(), c(), c(), c()];
        let b = [c(), c(), c(), c()];
        let expected = scalar(&a, &b).map(f64::to_bits);
        assert_eq!(ops::<Pair>(&a, &b, &[0, 2]).map(f64::to_bits), expected);
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx2_fma() {
            // SAFETY: checked just above that the CPU has AVX2 and FMA.
            let wide = unsafe { wide_ops(&a, &b) };
            assert_eq!(wide.map(f64::to_bits), expected);
        }
    }
}
