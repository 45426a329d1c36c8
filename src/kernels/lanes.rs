//! Arithmetic written once for one edge (`f64`) or two edges side by side ([`Pair`]), for the
//! derivative fast path of Lambert's sum ([`lambert`](super::lambert)).
//!
//! Why: without AVX a `DVec3` fills one and a half SSE2 registers, and the per-edge derivative
//! arithmetic (cross products, six Hessian entries) spent as many instructions on shuffles and
//! register copies as on arithmetic. Two edges in the two lanes of a register need no shuffles:
//! every operation of [`V3<Pair>`] is one packed instruction for both edges. Each lane rounds
//! exactly as the scalar code does (same operations in the same order, no fused multiply-add), so
//! a lane's results are bit for bit the `f64` instantiation's.

use std::ops::{Add, Mul, Neg, Sub};

use glam::DVec3;

/// A number per lane: `f64` (one edge) or [`Pair`] (two edges).
pub(super) trait Lane:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    fn splat(x: f64) -> Self;
    /// `|self|` per lane.
    fn abs(self) -> Self;
    /// `1 / self` per lane.
    fn recip(self) -> Self;
    /// `self / d` per lane.
    fn div(self, d: Self) -> Self;
}

impl Lane for f64 {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn recip(self) -> Self {
        1.0 / self
    }
    #[inline(always)]
    fn div(self, d: Self) -> Self {
        self / d
    }
}

pub(super) use pair::Pair;

/// Two `f64` lanes, operated on lane by lane: one SSE2 register on x86-64 (written with its
/// intrinsics: left to itself, LLVM paired the components of one edge instead of the two edges and
/// spent the saving on shuffles), a plain array elsewhere. `max` follows `maxpd` on x86-64 (a NaN
/// in either lane gives the second operand); callers use it only on values whose NaN they reject
/// anyway.
#[cfg(target_arch = "x86_64")]
mod pair {
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
    pub(in super::super) struct Pair(__m128d);

    impl Pair {
        #[inline(always)]
        pub(in super::super) fn new(a: f64, b: f64) -> Self {
            Pair(sse2!(_mm_setr_pd(a, b)))
        }
        /// Lane `l` (0 or 1).
        #[inline(always)]
        pub(in super::super) fn get(self, l: usize) -> f64 {
            if l == 0 {
                sse2!(_mm_cvtsd_f64(self.0))
            } else {
                sse2!(_mm_cvtsd_f64(_mm_unpackhi_pd(self.0, self.0)))
            }
        }
        #[inline(always)]
        pub(in super::super) fn splat(x: f64) -> Self {
            Pair(sse2!(_mm_set1_pd(x)))
        }
        #[inline(always)]
        pub(in super::super) fn div(self, d: Self) -> Self {
            Pair(sse2!(_mm_div_pd(self.0, d.0)))
        }
        #[inline(always)]
        pub(in super::super) fn sqrt(self) -> Self {
            Pair(sse2!(_mm_sqrt_pd(self.0)))
        }
        #[inline(always)]
        pub(in super::super) fn abs(self) -> Self {
            Pair(sse2!(_mm_andnot_pd(_mm_set1_pd(-0.0), self.0)))
        }
        #[inline(always)]
        pub(in super::super) fn max(self, o: Self) -> Self {
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
mod pair {
    use std::ops::{Add, Mul, Neg, Sub};

    #[derive(Clone, Copy, Debug)]
    pub(in super::super) struct Pair([f64; 2]);

    impl Pair {
        #[inline(always)]
        pub(in super::super) fn new(a: f64, b: f64) -> Self {
            Pair([a, b])
        }
        #[inline(always)]
        pub(in super::super) fn get(self, l: usize) -> f64 {
            self.0[l]
        }
        #[inline(always)]
        pub(in super::super) fn splat(x: f64) -> Self {
            Pair([x, x])
        }
        #[inline(always)]
        fn map2(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
            Pair([f(self.0[0], o.0[0]), f(self.0[1], o.0[1])])
        }
        #[inline(always)]
        pub(in super::super) fn div(self, d: Self) -> Self {
            self.map2(d, |a, b| a / b)
        }
        #[inline(always)]
        pub(in super::super) fn sqrt(self) -> Self {
            Pair(self.0.map(f64::sqrt))
        }
        #[inline(always)]
        pub(in super::super) fn abs(self) -> Self {
            Pair(self.0.map(f64::abs))
        }
        #[inline(always)]
        pub(in super::super) fn max(self, o: Self) -> Self {
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

/// A 3-vector per lane, with glam's operation order (so `V3<f64>` rounds as `DVec3` does).
#[derive(Clone, Copy, Debug)]
pub(super) struct V3<L> {
    pub x: L,
    pub y: L,
    pub z: L,
}

impl<L: Lane> V3<L> {
    #[inline(always)]
    pub(super) fn splat(v: DVec3) -> Self {
        V3 {
            x: L::splat(v.x),
            y: L::splat(v.y),
            z: L::splat(v.z),
        }
    }
    #[inline(always)]
    pub(super) fn dot(self, o: Self) -> L {
        (self.x * o.x) + (self.y * o.y) + (self.z * o.z)
    }
    #[inline(always)]
    pub(super) fn cross(self, o: Self) -> Self {
        V3 {
            x: self.y * o.z - o.y * self.z,
            y: self.z * o.x - o.z * self.x,
            z: self.x * o.y - o.x * self.y,
        }
    }
    #[inline(always)]
    pub(super) fn scale(self, s: L) -> Self {
        V3 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

impl V3<f64> {
    #[inline(always)]
    pub(super) fn from_dvec(v: DVec3) -> Self {
        V3 {
            x: v.x,
            y: v.y,
            z: v.z,
        }
    }
    #[inline(always)]
    pub(super) fn to_dvec(self) -> DVec3 {
        DVec3::new(self.x, self.y, self.z)
    }
}

impl V3<Pair> {
    /// `a` in lane 0, `b` in lane 1.
    #[inline(always)]
    pub(super) fn pair(a: DVec3, b: DVec3) -> Self {
        V3 {
            x: Pair::new(a.x, b.x),
            y: Pair::new(a.y, b.y),
            z: Pair::new(a.z, b.z),
        }
    }
    /// Lane `l` (0 or 1).
    #[inline(always)]
    pub(super) fn lane(self, l: usize) -> DVec3 {
        DVec3::new(self.x.get(l), self.y.get(l), self.z.get(l))
    }
}

impl<L: Lane> Add for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        V3 {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
}

impl<L: Lane> Sub for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        V3 {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
