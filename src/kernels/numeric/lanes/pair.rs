//! [`Pair`]: two `f64` lanes.

use super::lane::{Lane, Lanes};

#[cfg(target_arch = "x86_64")]
pub(crate) use sse2::Pair;

#[cfg(not(target_arch = "x86_64"))]
pub(crate) use array::Pair;

/// Two `f64` lanes, operated on lane by lane: one SSE2 register on x86-64 (written with its
/// intrinsics: left to itself, LLVM paired the components of one edge instead of the two edges and
/// spent the saving on shuffles), a plain array elsewhere. `max` follows `maxpd` on x86-64 (a NaN
/// in either lane gives the second operand); callers use it only on values whose NaN they reject
/// anyway.
#[cfg(target_arch = "x86_64")]
mod sse2 {
    use std::arch::x86_64::*;
    use std::ops::{Add, Mul, Neg, Sub};

    /// An SSE2 intrinsic call. SAFETY: SSE2 is part of the x86-64 baseline, so every x86-64 CPU
    /// has it (the intrinsics are `unsafe` only for their `#[target_feature]` attribute).
    macro_rules! sse2 {
        ($e:expr) => {
            unsafe { $e }
        };
    }

    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Pair(__m128d);

    impl Pair {
        #[inline(always)]
        pub(crate) fn new(a: f64, b: f64) -> Self {
            Pair(sse2!(_mm_setr_pd(a, b)))
        }
        /// Lane `l` (0 or 1).
        #[inline(always)]
        pub(crate) fn get(self, l: usize) -> f64 {
            if l == 0 {
                sse2!(_mm_cvtsd_f64(self.0))
            } else {
                sse2!(_mm_cvtsd_f64(_mm_unpackhi_pd(self.0, self.0)))
            }
        }
        #[inline(always)]
        pub(crate) fn splat(x: f64) -> Self {
            Pair(sse2!(_mm_set1_pd(x)))
        }
        #[inline(always)]
        pub(crate) fn div(self, d: Self) -> Self {
            Pair(sse2!(_mm_div_pd(self.0, d.0)))
        }
        #[inline(always)]
        pub(crate) fn sqrt(self) -> Self {
            Pair(sse2!(_mm_sqrt_pd(self.0)))
        }
        #[inline(always)]
        pub(crate) fn abs(self) -> Self {
            Pair(sse2!(_mm_andnot_pd(_mm_set1_pd(-0.0), self.0)))
        }
        #[inline(always)]
        pub(crate) fn max(self, o: Self) -> Self {
            Pair(sse2!(_mm_max_pd(self.0, o.0)))
        }
    }

    impl Add for Pair {
        type Output = Pair;
        #[inline(always)]
        fn add(self, o: Pair) -> Pair {
            Pair(sse2!(_mm_add_pd(self.0, o.0)))
        }
    }
    impl Sub for Pair {
        type Output = Pair;
        #[inline(always)]
        fn sub(self, o: Pair) -> Pair {
            Pair(sse2!(_mm_sub_pd(self.0, o.0)))
        }
    }
    impl Mul for Pair {
        type Output = Pair;
        #[inline(always)]
        fn mul(self, o: Pair) -> Pair {
            Pair(sse2!(_mm_mul_pd(self.0, o.0)))
        }
    }
    impl Neg for Pair {
        type Output = Pair;
        #[inline(always)]
        fn neg(self) -> Pair {
            Pair(sse2!(_mm_xor_pd(self.0, _mm_set1_pd(-0.0))))
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod array {
    use std::ops::{Add, Mul, Neg, Sub};

    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Pair([f64; 2]);

    impl Pair {
        #[inline(always)]
        pub(crate) fn new(a: f64, b: f64) -> Self {
            Pair([a, b])
        }
        #[inline(always)]
        pub(crate) fn get(self, l: usize) -> f64 {
            self.0[l]
        }
        #[inline(always)]
        pub(crate) fn splat(x: f64) -> Self {
            Pair([x, x])
        }
        #[inline(always)]
        fn map2(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
            Pair([f(self.0[0], o.0[0]), f(self.0[1], o.0[1])])
        }
        #[inline(always)]
        pub(crate) fn div(self, d: Self) -> Self {
            self.map2(d, |a, b| a / b)
        }
        #[inline(always)]
        pub(crate) fn sqrt(self) -> Self {
            Pair(self.0.map(f64::sqrt))
        }
        #[inline(always)]
        pub(crate) fn abs(self) -> Self {
            Pair(self.0.map(f64::abs))
        }
        #[inline(always)]
        pub(crate) fn max(self, o: Self) -> Self {
            self.map2(o, f64::max)
        }
    }

    impl Add for Pair {
        type Output = Pair;
        #[inline(always)]
        fn add(self, o: Pair) -> Pair {
            self.map2(o, |a, b| a + b)
        }
    }
    impl Sub for Pair {
        type Output = Pair;
        #[inline(always)]
        fn sub(self, o: Pair) -> Pair {
            self.map2(o, |a, b| a - b)
        }
    }
    impl Mul for Pair {
        type Output = Pair;
        #[inline(always)]
        fn mul(self, o: Pair) -> Pair {
            self.map2(o, |a, b| a * b)
        }
    }
    impl Neg for Pair {
        type Output = Pair;
        #[inline(always)]
        fn neg(self) -> Pair {
            Pair(self.0.map(|a| -a))
        }
    }
}

impl Lane for Pair {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Pair::splat(x)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Pair::abs(self)
    }
    #[inline(always)]
    fn recip(self) -> Self {
        Pair::splat(1.0).div(self)
    }
    #[inline(always)]
    fn div(self, d: Self) -> Self {
        Pair::div(self, d)
    }
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
