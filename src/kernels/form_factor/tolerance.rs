//! Tolerances shared by several of the form factor's paths: the error bound a certified result
//! must meet, and how far an edge sum may cancel before the robust path integrates instead.

use crate::kernels::form_factor::plane::Plane;

/// Largest certified relative error of an accepted result (the generic accuracy contract is 1e-12;
/// the margin absorbs the second-order terms the bound omits).
pub(crate) const FAST_TOLERANCE: f64 = 5e-13;

/// Above this ratio of `Σ|edge term|` to `|Σ edge term|` (the edge sum has lost more than ~1e4 ulps
/// to cancellation),
/// [`subdivided_quadrature`](crate::kernels::form_factor::quadrature::subdivide::subdivided_quadrature)
/// is tried instead.
pub(crate) const CANCELLATION_LIMIT: f64 = 1e2;

/// [`CANCELLATION_LIMIT`] for slivers (`2·area < 1e-2·extent²`) with x neither near their plane nor
/// clipping them, whose edge sum cancels by about the inverse aspect ratio: each edge term is
/// accurate to a few ulps, so the sum's relative error is a few ulps times the cancellation ratio
/// (measured on the slivers of `tests/form_factor_accuracy.rs` with the limit lifted: value errors
/// 0.1-5.1 ε·ratio, gradient and Hessian (relative to their largest entry) within 10 ε·ratio over
/// ratios 1e3-4e7). Slivers are a hard regime (contract 1e-10 / 1e-9 / 1e-8): at 1e4 the edge sum
/// is within ~6e-12, and
/// [`subdivided_quadrature`](crate::kernels::form_factor::quadrature::subdivide::subdivided_quadrature),
/// 100x slower, is only needed beyond (aspect below ~1e-4).
pub(crate) const THIN_CANCELLATION_LIMIT: f64 = 1e4;

/// The cancellation the edge sum may have before the quadrature is tried instead.
pub(crate) fn cancellation_limit(plane: &Plane, near_plane_or_cut: bool) -> f64 {
    if plane.is_thin() && !near_plane_or_cut {
        THIN_CANCELLATION_LIMIT
    } else {
        CANCELLATION_LIMIT
    }
}
