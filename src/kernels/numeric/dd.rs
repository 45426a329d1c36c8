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
mod tests;
