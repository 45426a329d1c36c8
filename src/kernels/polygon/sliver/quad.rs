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
