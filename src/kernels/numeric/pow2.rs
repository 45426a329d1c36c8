//! Exact scaling by powers of two: the kernels rescale their inputs so that the largest coordinate
//! is near 1, which keeps products of up to a dozen lengths (`1/g²` of the solid angle's Hessian)
//! away from overflow and underflow. Multiplying by a power of two changes no significand, so the
//! rescaled computation rounds as the unscaled one would have wherever that one stayed in range.

/// Power-of-two factors `(f1, f2)` with `extent · f1 · f2 ∈ [0.5, 1)`, each factor a normal number,
/// so scaling by them is exact (barring subnormal results).
pub(crate) fn pow2_scale(extent: f64) -> (f64, f64) {
    let mut e = extent;
    let mut pre = 0i32;
    if e < f64::MIN_POSITIVE {
        e *= 2f64.powi(600);
        pre = 600;
    }
    let exp = ((e.to_bits() >> 52) & 0x7ff) as i32 - 1022 - pre; // extent ∈ [2^(exp−1), 2^exp)
    let half = -exp / 2;
    (2f64.powi(half), 2f64.powi(-exp - half))
}

/// `2^k` for `k` in the normal exponent range.
pub(crate) fn pow2(k: i32) -> f64 {
    let k = k.clamp(-1022, 1023);
    f64::from_bits(((k + 1023) as u64) << 52)
}

/// Binary exponent of a positive finite `v` (clamped to the normal range).
pub(crate) fn exponent(v: f64) -> i32 {
    (((v.to_bits() >> 52) & 0x7ff) as i32 - 1023).max(-1022)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pow2_scale_brings_extent_near_one() {
        for e in [1e-320, 1e-300, 1e-5, 0.5, 1.0, 3.0, 1e300, f64::MAX] {
            let (f1, f2) = pow2_scale(e);
            let v = e * f1 * f2;
            assert!((0.5..1.0).contains(&v), "{e} -> {v}");
        }
    }
}
