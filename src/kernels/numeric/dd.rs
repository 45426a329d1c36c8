//! Double-double arithmetic (`hi + lo`, ~106 significant bits) from the error-free transformations
//! two-sum and two-product (fused multiply-add). The kernels use it only for the few quantities
//! that are near-singular in their inputs (heights over a plane or an edge line, exact coordinate
//! differences), so the generic paths keep plain `f64` speed. Every operation is forced inline:
//! callers compiled with FMA enabled (see `near_plane::triangle`) then get the fused multiply-add
//! as one instruction instead of a call per product.

use glam::DVec3;

/// `a + b = s + err` exactly.
#[inline(always)]
pub(crate) fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// A double-double number `hi + lo` with `|lo| <= ulp(hi)/2`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Dd {
    pub hi: f64,
    pub lo: f64,
}

impl Dd {
    /// `hi + lo`, renormalized.
    #[inline(always)]
    pub(crate) fn new(hi: f64, lo: f64) -> Dd {
        let (hi, lo) = two_sum(hi, lo);
        Dd { hi, lo }
    }

    /// `a − b` exactly.
    #[inline(always)]
    pub(crate) fn diff(a: f64, b: f64) -> Dd {
        Dd::new(a, -b)
    }

    #[inline(always)]
    pub(crate) fn add(self, o: Dd) -> Dd {
        let (s, e) = two_sum(self.hi, o.hi);
        let e = e + self.lo + o.lo;
        let hi = s + e;
        Dd {
            hi,
            lo: e - (hi - s),
        }
    }

    #[inline(always)]
    pub(crate) fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }

    #[inline(always)]
    pub(crate) fn sub(self, o: Dd) -> Dd {
        self.add(o.neg())
    }

    #[inline(always)]
    pub(crate) fn mul(self, o: Dd) -> Dd {
        let p = self.hi * o.hi;
        let e = self.hi.mul_add(o.hi, -p) + (self.hi * o.lo + self.lo * o.hi);
        let hi = p + e;
        Dd {
            hi,
            lo: e - (hi - p),
        }
    }

    /// Product with a plain `f64`: [`Dd::mul`] with `o.lo = 0`, without its two zero-valued
    /// terms (it gives the same bits up to the sign of a zero `lo`).
    #[inline(always)]
    pub(crate) fn mul_f64(self, f: f64) -> Dd {
        let p = self.hi * f;
        let e = self.hi.mul_add(f, -p) + self.lo * f;
        let hi = p + e;
        Dd {
            hi,
            lo: e - (hi - p),
        }
    }

    #[inline(always)]
    pub(crate) fn div(self, o: Dd) -> Dd {
        let q1 = self.hi / o.hi;
        let rem = self.sub(o.mul(Dd { hi: q1, lo: 0.0 }));
        let q2 = rem.hi / o.hi;
        Dd::new(q1, q2)
    }

    /// Square root (one Newton correction of the f64 root); 0 for non-positive input.
    #[inline(always)]
    pub(crate) fn sqrt(self) -> Dd {
        if self.hi <= 0.0 {
            return Dd { hi: 0.0, lo: 0.0 };
        }
        let s = self.hi.sqrt();
        let p = s * s;
        let e = s.mul_add(s, -p);
        let corr = ((self.hi - p) - e + self.lo) / (2.0 * s);
        let hi = s + corr;
        Dd {
            hi,
            lo: corr - (hi - s),
        }
    }

    /// Multiplication by a power of two (exact).
    #[inline(always)]
    pub(crate) fn scale(self, f: f64) -> Dd {
        Dd {
            hi: self.hi * f,
            lo: self.lo * f,
        }
    }

    #[inline(always)]
    pub(crate) fn to_f64(self) -> f64 {
        self.hi + self.lo
    }
}

/// A 3-vector of double-double components.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Dd3 {
    pub x: Dd,
    pub y: Dd,
    pub z: Dd,
}

impl Dd3 {
    /// `hi + lo` componentwise, renormalized.
    #[inline(always)]
    pub(crate) fn new(hi: DVec3, lo: DVec3) -> Dd3 {
        Dd3 {
            x: Dd::new(hi.x, lo.x),
            y: Dd::new(hi.y, lo.y),
            z: Dd::new(hi.z, lo.z),
        }
    }

    /// `hi + lo` componentwise for pairs that are already a double-double's parts (`hi` the
    /// rounded sum `hi + lo`, as two-sum and the double-double operations leave them): the bits
    /// of [`Dd3::new`] for such pairs (signed zeros included) with two additions per component
    /// instead of a two-sum. For other pairs `hi + lo` is still the exact sum but `lo` is left as
    /// it is (not renormalized).
    #[inline(always)]
    pub(crate) fn from_parts(hi: DVec3, lo: DVec3) -> Dd3 {
        // With hi = fl(hi + lo), two-sum returns hi itself (and zeros as hi + lo does) and lo up
        // to the sign of a zero, which it always returns positive: `lo + 0.0`.
        let part = |h: f64, l: f64| Dd {
            hi: h + l,
            lo: l + 0.0,
        };
        Dd3 {
            x: part(hi.x, lo.x),
            y: part(hi.y, lo.y),
            z: part(hi.z, lo.z),
        }
    }

    /// [`Dd3::from_parts`] (the same bits) with `lo + 0.0` written as a select: in an AVX2+FMA
    /// build (the clipped sliver's `clip`) LLVM packs `(h + l, l + 0.0)` into one addition whose
    /// zero lane it makes by a register-to-register `vmovq`, which valgrind 3.19 cannot run (the
    /// CI runs the unit tests under memcheck). The select costs the portable paths a few
    /// instructions, so only `clip` takes it.
    #[inline(always)]
    pub(crate) fn from_parts_unpacked(hi: DVec3, lo: DVec3) -> Dd3 {
        let part = |h: f64, l: f64| Dd {
            hi: h + l,
            lo: if l == 0.0 { 0.0 } else { l },
        };
        Dd3 {
            x: part(hi.x, lo.x),
            y: part(hi.y, lo.y),
            z: part(hi.z, lo.z),
        }
    }

    /// `a − b` exactly.
    #[inline(always)]
    pub(crate) fn diff(a: DVec3, b: DVec3) -> Dd3 {
        Dd3::new(a, -b)
    }

    #[inline(always)]
    pub(crate) fn cross(&self, o: &Dd3) -> Dd3 {
        Dd3 {
            x: self.y.mul(o.z).sub(self.z.mul(o.y)),
            y: self.z.mul(o.x).sub(self.x.mul(o.z)),
            z: self.x.mul(o.y).sub(self.y.mul(o.x)),
        }
    }

    #[inline(always)]
    pub(crate) fn add(&self, o: &Dd3) -> Dd3 {
        Dd3 {
            x: self.x.add(o.x),
            y: self.y.add(o.y),
            z: self.z.add(o.z),
        }
    }

    #[inline(always)]
    pub(crate) fn sub(&self, o: &Dd3) -> Dd3 {
        Dd3 {
            x: self.x.sub(o.x),
            y: self.y.sub(o.y),
            z: self.z.sub(o.z),
        }
    }

    /// Product with a double-double scalar.
    #[inline(always)]
    pub(crate) fn scale(&self, f: Dd) -> Dd3 {
        Dd3 {
            x: self.x.mul(f),
            y: self.y.mul(f),
            z: self.z.mul(f),
        }
    }

    /// Multiplication by a power of two (exact).
    #[inline(always)]
    pub(crate) fn scale_pow2(&self, f: f64) -> Dd3 {
        Dd3 {
            x: self.x.scale(f),
            y: self.y.scale(f),
            z: self.z.scale(f),
        }
    }

    #[inline(always)]
    pub(crate) fn dot(&self, o: &Dd3) -> Dd {
        self.x.mul(o.x).add(self.y.mul(o.y)).add(self.z.mul(o.z))
    }

    /// `self · v` for an f64 vector.
    #[inline(always)]
    pub(crate) fn dot_f64(&self, v: DVec3) -> Dd {
        // `dot` with `Dd3::new(v, 0)` (an exact, renormalization-free pair) spelled with
        // `mul_f64`: the same sums of the same products, about half the operations.
        self.x
            .mul_f64(v.x)
            .add(self.y.mul_f64(v.y))
            .add(self.z.mul_f64(v.z))
    }

    /// The leading parts (`hi`) and the remainders (`lo`).
    #[inline(always)]
    pub(crate) fn split(&self) -> (DVec3, DVec3) {
        (
            DVec3::new(self.x.hi, self.y.hi, self.z.hi),
            DVec3::new(self.x.lo, self.y.lo, self.z.lo),
        )
    }

    #[inline(always)]
    pub(crate) fn to_dvec3(self) -> DVec3 {
        DVec3::new(self.x.to_f64(), self.y.to_f64(), self.z.to_f64())
    }
}

#[cfg(test)]
mod tests {
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
}
