//! Four lanes for the sliver rule's sums ([`sums`](super::sums)): two SSE2 registers in the
//! portable build ([`TwoPairs`]), one AVX register in the AVX2+FMA build ([`Wide`]).
//!
//! Why: the sums' node loop is about 40% of a sliver's instructions. In the AVX2 build one
//! 256-bit instruction does what two 128-bit ones did, and one `vdivpd` serves four nodes. Both
//! types round each lane as the scalar `f64` code would (no fused multiply-add), and
//! [`Quad::total`] adds the four lanes in one tree for both, so the two builds give the same bits.

use std::ops::{Add, Mul, Neg, Sub};

use crate::kernels::lanes::{Lane, Pair};

/// Four `f64` lanes operated on lane by lane.
pub(super) trait Quad: Lane {
    /// The lanes `[l0, l1, l2, l3]`.
    fn from_array(lanes: &[f64; 4]) -> Self;
    /// `(l0 + l1) + (l2 + l3)`, the same tree in every build.
    fn total(self) -> f64;
}

/// Two [`Pair`]s: lanes 0 and 1 in `lo`, 2 and 3 in `hi`.
#[derive(Clone, Copy)]
pub(super) struct TwoPairs {
    lo: Pair,
    hi: Pair,
}

impl Quad for TwoPairs {
    #[inline(always)]
    fn from_array(l: &[f64; 4]) -> Self {
        TwoPairs {
            lo: Pair::new(l[0], l[1]),
            hi: Pair::new(l[2], l[3]),
        }
    }
    #[inline(always)]
    fn total(self) -> f64 {
        (self.lo.get(0) + self.lo.get(1)) + (self.hi.get(0) + self.hi.get(1))
    }
}

impl Lane for TwoPairs {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        TwoPairs {
            lo: Pair::splat(x),
            hi: Pair::splat(x),
        }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        TwoPairs {
            lo: self.lo.abs(),
            hi: self.hi.abs(),
        }
    }
    #[inline(always)]
    fn recip(self) -> Self {
        Self::splat(1.0).div(self)
    }
    #[inline(always)]
    fn div(self, d: Self) -> Self {
        TwoPairs {
            lo: self.lo.div(d.lo),
            hi: self.hi.div(d.hi),
        }
    }
}

macro_rules! two_pairs_op {
    ($trait:ident, $f:ident) => {
        impl $trait for TwoPairs {
            type Output = TwoPairs;
            #[inline(always)]
            fn $f(self, o: TwoPairs) -> TwoPairs {
                TwoPairs {
                    lo: self.lo.$f(o.lo),
                    hi: self.hi.$f(o.hi),
                }
            }
        }
    };
}
two_pairs_op!(Add, add);
two_pairs_op!(Sub, sub);
two_pairs_op!(Mul, mul);

impl Neg for TwoPairs {
    type Output = TwoPairs;
    #[inline(always)]
    fn neg(self) -> TwoPairs {
        TwoPairs {
            lo: -self.lo,
            hi: -self.hi,
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use wide::Wide;

/// One AVX register. Only for code compiled with AVX2 and FMA enabled, after
/// [`avx2_fma`](crate::simd::avx2_fma) checked the CPU: the `_fma` twins of the sliver rule are
/// its only users.
#[cfg(target_arch = "x86_64")]
mod wide {
    use std::arch::x86_64::*;
    use std::ops::{Add, Mul, Neg, Sub};

    use super::Quad;
    use crate::kernels::lanes::Lane;

    /// An AVX intrinsic call. SAFETY: `Wide` is used only inside functions compiled with AVX2 and
    /// FMA, called after the CPU was checked for them (module documentation).
    macro_rules! avx {
        ($e:expr) => {
            unsafe { $e }
        };
    }

    #[derive(Clone, Copy)]
    pub(in super::super) struct Wide(__m256d);

    impl Quad for Wide {
        #[inline(always)]
        fn from_array(l: &[f64; 4]) -> Self {
            Wide(avx!(_mm256_loadu_pd(l.as_ptr())))
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

    /// Every operation of [`TwoPairs`] rounds each lane as the scalar `f64` code does, and
    /// [`Quad::total`] adds the lanes as `(l0 + l1) + (l2 + l3)`: checked bit for bit against
    /// scalar arithmetic on random operands of mixed signs and magnitudes 1e-150..1e150, and the
    /// AVX build ([`Wide`], where the CPU has AVX2 and FMA) against the same scalars.
    #[test]
    fn lanes_round_as_scalar_code() {
        fn ops<L: Quad>(a: &[f64; 4], b: &[f64; 4]) -> [f64; 7] {
            let (x, y) = (L::from_array(a), L::from_array(b));
            [
                (x + y).total(),
                (x - y).total(),
                (x * y).total(),
                x.div(y).total(),
                y.recip().total(),
                (-x).abs().total(),
                L::splat(a[0]).total(),
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
            ops::<Wide>(a, b)
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
            assert_eq!(ops::<TwoPairs>(&a, &b).map(f64::to_bits), expected);
            #[cfg(target_arch = "x86_64")]
            if crate::simd::avx2_fma() {
                // SAFETY: checked just above that the CPU has AVX2 and FMA.
                let wide = unsafe { wide_ops(&a, &b) };
                assert_eq!(wide.map(f64::to_bits), expected);
            }
        }
    }
}
