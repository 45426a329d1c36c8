//! Input validation shared by the form factor's paths: the receiver normal (unit length within
//! [`NORMAL_TOLERANCE`], renormalized) and the range of coordinate differences the paths without
//! rescaling accept.

use glam::DVec3;

use crate::error::{ensure_finite3, Error, Result};

/// Relative tolerance on `‖n‖ − 1` before `n` is rejected (it is renormalized otherwise).
pub(crate) const NORMAL_TOLERANCE: f64 = 1e-6;

/// Validates a receiver normal: finite, unit within [`NORMAL_TOLERANCE`]; returns it renormalized.
pub(crate) fn unit_normal(n: DVec3) -> Result<DVec3> {
    ensure_finite3(n, "n")?;
    unit(n).ok_or_else(|| {
        Error::InvalidArgument(format!(
            "n must be a unit vector (|n| = {}, tolerance {NORMAL_TOLERANCE:e})",
            n.length()
        ))
    })
}

/// `r` with every component's magnitude at most in (1e-30, 1e30) — products of up to four such
/// factors stay far from overflow, and from underflow relative to the largest — and finite.
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn in_range(r: DVec3) -> bool {
    let m = r.abs().max_element();
    m > 1e-30 && m < 1e30
}

/// The renormalized unit normal, `None` outside the kernels' unit tolerance (or NaN). Divided as
/// the robust path divides, so that normals within the tolerance give the same bits.
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn unit(n: DVec3) -> Option<DVec3> {
    let len = n.length();
    // n / 1 is n: skip the three divisions for normals whose computed length is exactly 1.
    ((len - 1.0).abs() <= NORMAL_TOLERANCE).then(|| if len == 1.0 { n } else { n / len })
}

// ------------------------------------------------------------------------------------------------
// Fast paths.

/// Coordinate differences the fast paths accept (outside, the robust path's exact power-of-two
/// rescaling is needed to keep intermediate products in range).
pub(crate) const FAST_RANGE: (f64, f64) = (1e-30, 1e30);

/// `‖v‖_∞` of the differences, `None` outside [`FAST_RANGE`] (NaN and infinities included).
#[inline]
pub(crate) fn in_fast_range<'a>(vs: impl IntoIterator<Item = &'a DVec3>) -> Option<()> {
    let m = vs
        .into_iter()
        .fold(0.0f64, |m, v| m.max(v.abs().max_element()));
    (m > FAST_RANGE.0 && m < FAST_RANGE.1).then_some(())
}
