//! C wrappers for record radii from Hessians.

use super::common::*;
use crate::gather::radii::{self, ErrorMode};

/// `error` bounds the integrated absolute error over the record.
pub const RADDIFF_ERROR_ABSOLUTE: u32 = 0;
/// `error` bounds the integrated error divided by `|value|`.
pub const RADDIFF_ERROR_RELATIVE: u32 = 1;
/// Largest radius the radii functions return (caller's length unit), e.g. for a zero Hessian.
pub const RADDIFF_MAX_RADIUS: f64 = 1e30;

fn mode_from_c(mode: u32) -> Result<ErrorMode, FfiError> {
    Ok(ErrorMode::try_from(mode)?)
}

/// Reads a row-major 3x3 matrix from a C `const double[9]`.
///
/// # Safety
/// `ptr` must be NULL or valid for reads of 9 doubles.
unsafe fn hessian_from_c(ptr: *const f64) -> Result<glam::DMat3, FfiError> {
    let s = in_slice(ptr, 9, "hessian")?;
    let mut a = [0.0; 9];
    a.copy_from_slice(s);
    Ok(mat3_from_row_major(&a))
}

/// Turns a C output array of `N` values into a mutable array reference.
///
/// # Safety
/// `ptr` must be NULL or valid for writes of `N` values of `T`.
unsafe fn out_array<'a, T, const N: usize>(
    ptr: *mut T,
    name: &'static str,
) -> Result<&'a mut [T; N], FfiError> {
    out_ref(ptr.cast::<[T; N]>(), name)
}

/// Elliptical surface record from a 3x3 Hessian (see the Rust `gather::radii::surface_radii`): the
/// Hessian (row-major) is projected on the tangent plane of the unit `normal` and eigen-decomposed;
/// `radii[0] <= radii[1]` are the semi-axes along the world-space unit tangents `axes[0..2]`, chosen so
/// that the integrated second-order error over the ellipse equals the tolerance (`error`, or
/// `error * |value|` for `RADDIFF_ERROR_RELATIVE`). `max_anisotropy >= 1` caps `radii[1]/radii[0]`.
/// A vanishing Hessian gives `RADDIFF_MAX_RADIUS`.
///
/// # Safety
/// `hessian` must be NULL or point to 9 readable doubles; `radii` to 2 writable doubles and `axes` to
/// 2 writable `raddiff_vec3` (or be NULL, which is reported).
#[no_mangle]
pub unsafe extern "C" fn raddiff_surface_radii(
    hessian: *const f64,
    normal: raddiff_vec3,
    value: f64,
    error: f64,
    mode: u32,
    max_anisotropy: f64,
    radii: *mut f64,
    axes: *mut raddiff_vec3,
) -> raddiff_status {
    guard(|| {
        let hessian = unsafe { hessian_from_c(hessian)? };
        let radii_out = unsafe { out_array(radii, "radii")? };
        let axes_out = unsafe { out_array(axes, "axes")? };
        let mode = mode_from_c(mode)?;
        let r = radii::surface_radii(hessian, normal.into(), value, error, mode, max_anisotropy)?;
        *radii_out = r.radii;
        *axes_out = r.axes.map(Into::into);
        Ok(())
    })
}

/// Ellipsoidal media record from a 3x3 Hessian (row-major; see the Rust `gather::radii::volume_radii`):
/// semi-axes `radii[0] <= radii[1] <= radii[2]` along the orthonormal `axes[0..3]`, chosen so that the
/// integrated second-order error over the ellipsoid equals the tolerance. `max_anisotropy >= 1` caps
/// `radii[2]/radii[0]`. A vanishing Hessian gives `RADDIFF_MAX_RADIUS`.
///
/// # Safety
/// `hessian` must be NULL or point to 9 readable doubles; `radii` to 3 writable doubles and `axes` to
/// 3 writable `raddiff_vec3` (or be NULL, which is reported).
#[no_mangle]
pub unsafe extern "C" fn raddiff_volume_radii(
    hessian: *const f64,
    value: f64,
    error: f64,
    mode: u32,
    max_anisotropy: f64,
    radii: *mut f64,
    axes: *mut raddiff_vec3,
) -> raddiff_status {
    guard(|| {
        let hessian = unsafe { hessian_from_c(hessian)? };
        let radii_out = unsafe { out_array(radii, "radii")? };
        let axes_out = unsafe { out_array(axes, "axes")? };
        let mode = mode_from_c(mode)?;
        let r = radii::volume_radii(hessian, value, error, mode, max_anisotropy)?;
        *radii_out = r.radii;
        *axes_out = r.axes.map(Into::into);
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn max_radius_constant_matches_the_rust_api() {
        assert_eq!(super::RADDIFF_MAX_RADIUS, crate::gather::radii::MAX_RADIUS);
    }
}
