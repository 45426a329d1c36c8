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

/// Default weight of the curvature floor of `raddiff_surface_radii_floored` (1% of the tangent
/// curvature 4E/D² of irradiance from a small source at distance D straight above).
pub const RADDIFF_CURVATURE_FLOOR_WEIGHT: f64 = 0.04;

/// `raddiff_surface_radii` with the robustness term (the Rust `gather::radii::surface_radii_floored`):
/// `floor_weight * |value| / floor_distance^2` is added to the magnitude of each tangent eigenvalue,
/// so a record whose estimated Hessian vanishes, or whose gather was black (`value` 0 with
/// `RADDIFF_ERROR_RELATIVE`), gets the finite radius `(4 error D^2 / (pi kappa))^(1/4)` instead of
/// `RADDIFF_MAX_RADIUS`. `floor_distance` (> 0, finite) is the gather's harmonic-mean hit distance
/// (`raddiff_gather_values.harmonic_mean_distance`); `floor_weight` (>= 0, finite) is kappa,
/// `RADDIFF_CURVATURE_FLOOR_WEIGHT` by default, 0 for no floor.
///
/// # Safety
/// As `raddiff_surface_radii`.
#[no_mangle]
pub unsafe extern "C" fn raddiff_surface_radii_floored(
    hessian: *const f64,
    normal: raddiff_vec3,
    value: f64,
    error: f64,
    mode: u32,
    max_anisotropy: f64,
    floor_distance: f64,
    floor_weight: f64,
    radii: *mut f64,
    axes: *mut raddiff_vec3,
) -> raddiff_status {
    guard(|| {
        let hessian = unsafe { hessian_from_c(hessian)? };
        let radii_out = unsafe { out_array(radii, "radii")? };
        let axes_out = unsafe { out_array(axes, "axes")? };
        let mode = mode_from_c(mode)?;
        let floor = radii::CurvatureFloor {
            distance: floor_distance,
            weight: floor_weight,
        };
        let r = radii::surface_radii_floored(
            hessian,
            normal.into(),
            value,
            error,
            mode,
            max_anisotropy,
            floor,
        )?;
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
