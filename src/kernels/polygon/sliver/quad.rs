//! Lanes for the sliver rule's sums ([`sums`](super::sums)): the four nodes of a group in one AVX
//! register in the AVX2+FMA build ([`Wide`]), in two SSE2 registers in the portable build
//! ([`Pair`], the group's halves summed one after the other).
//!
//! Why: the sums' node loop is about 40% of a sliver's instructions. In the AVX2 build one
//! 256-bit instruction does what two 128-bit ones did, and one `vdivpd` serves four nodes. Both
//! round each lane as the scalar `f64` code would (no fused multiply-add), and the lanes are added
//! in one tree, `(l0 + l1) + (l2 + l3)`, in both builds ([`Lanes::total`], then the halves' sums
//! added in [`sums`](super::sums)), so the two builds give the same bits.

use crate::kernels::lanes::{Lane, Pair};

/// A few `f64` lanes operated on lane by lane, loaded from a group of four nodes.
pub(in crate::kernels::polygon) trait Lanes: Lane {
    /// The lanes `group[first..]` (two or four of them).
    fn load(group: &[f64; 4], first: usize) -> Self;
    /// The sum of the lanes: `l0 + l1`, or `(l0 + l1) + (l2 + l3)`.
    fn total(self) -> f64;
}

impl Lanes for Pair {
    #[inline(always)]
    fn load(group: &[f64; 4], first: usize) -> Self {
        Pair::new(group[first], group[first + 1])
    }
    #[inline(always)]
    fn total(self) -> f64 {
        self.get(0) + self.get(1)
    }
}

#[cfg(target_arch = "x86_64")]
pub(in crate::kernels::polygon) use wide::Wide;

/// One AVX register. Only for code compiled with AVX2 and FMA enabled, after
/// [`avx2_fma`](crate::simd::avx2_fma) checked the CPU: the `_fma` twins of the sliver rule are
/// its only users.
#[cfg(target_arch = "x86_64")]
mod wide {
    use std::arch::x86_64::*;
    use std::ops::{Add, Mul, Neg, Sub};

    use super::Lanes;
    use crate::kernels::lanes::Lane;

    /// An AVX intrinsic call. SAFETY: `Wide` is used only inside functions compiled with AVX2 and
    /// FMA, called after the CPU was checked for them (module documentation).
    macro_rules! avx {
        ($e:expr) => {
            unsafe { $e }
        };
    }

    #[derive(Clone, Copy)]
    pub(in crate::kernels::polygon) struct Wide(__m256d);

    impl Lanes for Wide {
        #[inline(always)]
        fn load(group: &[f64; 4], _first: usize) -> Self {
            Wide(avx!(_mm256_loadu_pd(group.as_ptr())))
        }
        #[inline(always)]
        fn total(self) -> f64 {
            let (lo, hi) = avx!((
                _mm256_castpd256_pd128(self.0),
                _mm256_extractf128_pd::<1>(self.0)
            ));
            let lane = |p: __m128d, l: bool| {
                avx!(_mm_cvtsd_f64(if l { _mm_unpackhi_pd(p, p) } else { p }))
            };
            (lane(lo, false) + lane(lo, true)) + (lane(hi, false) + lane(hi, true))
        }
    }

    impl Lane for Wide {
        #[inline(always)]
        fn splat(x: f64) -> Self {
            Wide(avx!(_mm256_set1_pd(x)))
        }
        #[inline(always)]
        fn abs(self) -> Self {
            Wide(avx!(_mm256_andnot_pd(_mm256_set1_pd(-0.0), self.0)))
        }
        #[inline(always)]
        fn recip(self) -> Self {
            Self::splat(1.0).div(self)
        }
        #[inline(always)]
        fn div(self, d: Self) -> Self {
            Wide(avx!(_mm256_div_pd(self.0, d.0)))
        }
    }

    impl Add for Wide {
        type Output = Wide;
        #[inline(always)]
        fn add(self, o: Wide) -> Wide {
            Wide(avx!(_mm256_add_pd(self.0, o.0)))
        }
    }
    impl Sub for Wide {
        type Output = Wide;
        #[inline(always)]
        fn sub(self, o: Wide) -> Wide {
            Wide(avx!(_mm256_sub_pd(self.0, o.0)))
        }
    }
    impl Mul for Wide {
        type Output = Wide;
        #[inline(always)]
        fn mul(self, o: Wide) -> Wide {
            Wide(avx!(_mm256_mul_pd(self.0, o.0)))
        }
    }
    impl Neg for Wide {
        type Output = Wide;
        #[inline(always)]
        fn neg(self) -> Wide {
            Wide(avx!(_mm256_xor_pd(self.0, _mm256_set1_pd(-0.0))))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::test_rng::lcg;

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
}
