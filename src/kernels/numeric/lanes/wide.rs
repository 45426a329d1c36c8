//! [`Wide`]: four `f64` lanes.

use std::arch::x86_64::*;
use std::ops::{Add, Mul, Neg, Sub};

use super::lane::{Lane, Lanes};

/// An AVX intrinsic call. SAFETY: `Wide` is used only inside functions compiled with AVX2 and
/// FMA, called after the CPU was checked for them (module documentation).
macro_rules! avx {
    ($e:expr) => {
        unsafe { $e }
    };
}

/// One AVX register. Only for code compiled with AVX2 and FMA enabled, after
/// [`avx2_fma`](crate::simd::avx2_fma) checked the CPU: the `_fma` twins of the sliver rule are
/// its only users.
#[derive(Clone, Copy)]
pub(crate) struct Wide(__m256d);

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
        let lane =
            |p: __m128d, l: bool| avx!(_mm_cvtsd_f64(if l { _mm_unpackhi_pd(p, p) } else { p }));
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
