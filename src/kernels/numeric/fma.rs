//! A multiply-add that is fused or not by a compile-time flag, for code compiled twice: once
//! portable (`FMA = false`: `a * b + c`, two roundings) and once inside a function with the AVX2
//! and FMA target features (`FMA = true`: one correctly rounded `a·b + c`). Rust never fuses on its
//! own, so the flag alone decides which rounding a lane gets.

/// `a·b + c`, fused (one rounding) when `FMA`, else `a * b + c` (two roundings).
#[inline(always)]
pub(crate) fn fmadd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}
