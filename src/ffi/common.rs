//! Shared C types, status codes, the thread-local last-error message and the call guard.

use std::cell::RefCell;
use std::ffi::{c_char, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

use glam::{DMat2, DMat3, DVec2, DVec3};

use crate::{Deriv2, Deriv3, Error, Order};

/// Major version of the library this header belongs to.
pub const RADDIFF_VERSION_MAJOR: u32 = 0;
/// Minor version of the library this header belongs to.
pub const RADDIFF_VERSION_MINOR: u32 = 1;
/// Patch version of the library this header belongs to.
pub const RADDIFF_VERSION_PATCH: u32 = 0;

/// Compute the value only.
pub const RADDIFF_ORDER_VALUE: u32 = 0;
/// Compute the value and the gradient.
pub const RADDIFF_ORDER_GRADIENT: u32 = 1;
/// Compute the value, the gradient and the Hessian.
pub const RADDIFF_ORDER_HESSIAN: u32 = 2;

/// Outcome of a fallible call. `RADDIFF_OK` is 0; on any other code, `raddiff_last_error()` says why
/// and no output was written.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum raddiff_status {
    /// Success.
    RADDIFF_OK = 0,
    /// A required pointer was NULL.
    RADDIFF_ERROR_NULL_POINTER = 1,
    /// Non-finite input, bad size or bad enum value.
    RADDIFF_ERROR_INVALID_ARGUMENT = 2,
    /// The quantity is undefined for this configuration.
    RADDIFF_ERROR_DEGENERATE = 3,
    /// Nothing matched (for example no cache record covers a point).
    RADDIFF_ERROR_NOT_FOUND = 4,
    /// A file operation failed.
    RADDIFF_ERROR_IO = 5,
    /// A file failed validation.
    RADDIFF_ERROR_CORRUPT = 6,
    /// A Rust panic was caught at the boundary (a bug in raddiff: please report it).
    RADDIFF_ERROR_PANIC = 7,
    /// A caller's callback (the `raddiff_trace_fn` of `raddiff_cache_irradiance`) returned
    /// non-zero: the request was abandoned and nothing was inserted.
    RADDIFF_ERROR_CALLBACK = 8,
}

/// A 3D vector or point.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct raddiff_vec3 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
    /// z component.
    pub z: f64,
}

/// A 2D vector or point.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct raddiff_vec2 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
}

/// Value, gradient and Hessian (row-major, symmetric) with respect to a 3D point.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct raddiff_deriv3 {
    /// The value.
    pub value: f64,
    /// The gradient (0 when not requested).
    pub gradient: [f64; 3],
    /// The Hessian, row-major (0 when not requested).
    pub hessian: [f64; 9],
}

/// Value, gradient and Hessian (row-major, symmetric) with respect to a 2D point.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct raddiff_deriv2 {
    /// The value.
    pub value: f64,
    /// The gradient (0 when not requested).
    pub gradient: [f64; 2],
    /// The Hessian, row-major (0 when not requested).
    pub hessian: [f64; 4],
}

impl raddiff_vec3 {
    /// The vector of an argument passed by value, read one component at a time.
    ///
    /// A C caller passes `raddiff_vec3` arguments in memory, written with its own store widths. A
    /// wider load that spans two of those stores cannot take its data from them (store-to-load
    /// forwarding) and waits until they reach the cache, about a dozen cycles each, which the
    /// compiler's 16-byte loads of `(y, z)` pairs did on every call (seen in `benches/c`). Volatile
    /// reads keep every load at the width of one component, which every caller's stores cover.
    #[inline(always)]
    pub(crate) fn read(&self) -> DVec3 {
        // SAFETY: `self` is a reference to an initialized value.
        unsafe {
            DVec3::new(
                std::ptr::read_volatile(&self.x),
                std::ptr::read_volatile(&self.y),
                std::ptr::read_volatile(&self.z),
            )
        }
    }
}

impl From<raddiff_vec3> for DVec3 {
    fn from(v: raddiff_vec3) -> Self {
        DVec3::new(v.x, v.y, v.z)
    }
}

impl From<DVec3> for raddiff_vec3 {
    fn from(v: DVec3) -> Self {
        raddiff_vec3 {
            x: v.x,
            y: v.y,
            z: v.z,
        }
    }
}

impl From<raddiff_vec2> for DVec2 {
    fn from(v: raddiff_vec2) -> Self {
        DVec2::new(v.x, v.y)
    }
}

impl From<DVec2> for raddiff_vec2 {
    fn from(v: DVec2) -> Self {
        raddiff_vec2 { x: v.x, y: v.y }
    }
}

/// Row-major 3x3 from a glam (column-major) matrix.
pub(crate) fn mat3_to_row_major(m: DMat3) -> [f64; 9] {
    m.transpose().to_cols_array()
}

/// glam matrix from a row-major 3x3.
pub(crate) fn mat3_from_row_major(a: &[f64; 9]) -> DMat3 {
    DMat3::from_cols_array(a).transpose()
}

fn mat2_to_row_major(m: DMat2) -> [f64; 4] {
    m.transpose().to_cols_array()
}

/// A value with zero gradient and Hessian (the value order's output).
#[inline]
pub(crate) fn value_only(value: f64) -> raddiff_deriv3 {
    raddiff_deriv3 {
        value,
        ..raddiff_deriv3::default()
    }
}

impl From<Deriv3> for raddiff_deriv3 {
    fn from(d: Deriv3) -> Self {
        raddiff_deriv3 {
            value: d.value,
            gradient: d.gradient.to_array(),
            hessian: mat3_to_row_major(d.hessian),
        }
    }
}

impl From<Deriv2> for raddiff_deriv2 {
    fn from(d: Deriv2) -> Self {
        raddiff_deriv2 {
            value: d.value,
            gradient: d.gradient.to_array(),
            hessian: mat2_to_row_major(d.hessian),
        }
    }
}

impl Error {
    pub(crate) fn status(&self) -> raddiff_status {
        match self {
            Error::InvalidArgument(_) => raddiff_status::RADDIFF_ERROR_INVALID_ARGUMENT,
            Error::Degenerate(_) => raddiff_status::RADDIFF_ERROR_DEGENERATE,
            Error::NotFound(_) => raddiff_status::RADDIFF_ERROR_NOT_FOUND,
            Error::Io(_) => raddiff_status::RADDIFF_ERROR_IO,
            Error::Corrupt(_) => raddiff_status::RADDIFF_ERROR_CORRUPT,
            Error::Callback(_) => raddiff_status::RADDIFF_ERROR_CALLBACK,
        }
    }
}

/// Failure inside an FFI wrapper: a library error, or an argument problem found at the boundary.
pub(crate) enum FfiError {
    Lib(Error),
    Null(&'static str),
}

impl From<Error> for FfiError {
    fn from(e: Error) -> Self {
        FfiError::Lib(e)
    }
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_last_error(message: &str) {
    // Interior NULs cannot appear in a C string: replace them rather than lose the message.
    let c = CString::new(message.replace('\0', " ")).unwrap_or_default();
    LAST_ERROR.with(|slot| *slot.borrow_mut() = c);
}

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_string()
    }
}

/// Runs an FFI body: catches panics, records the message of any failure, and maps it to a status.
///
/// Inlined into every entry point with the body, so that a successful call costs the body alone:
/// the unwinding landing pad adds no instructions on the path that does not unwind, and the
/// failures are reported out of line ([`failed`], [`panicked`]).
#[inline(always)]
pub(crate) fn guard<F>(body: F) -> raddiff_status
where
    F: FnOnce() -> Result<(), FfiError>,
{
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => raddiff_status::RADDIFF_OK,
        Ok(Err(e)) => failed(e),
        Err(payload) => panicked(payload),
    }
}

/// Records the message of a failed call and returns its status.
#[cold]
#[inline(never)]
fn failed(e: FfiError) -> raddiff_status {
    match e {
        FfiError::Lib(e) => {
            set_last_error(&e.to_string());
            e.status()
        }
        FfiError::Null(name) => {
            set_last_error(&format!("null pointer: {name} must not be NULL"));
            raddiff_status::RADDIFF_ERROR_NULL_POINTER
        }
    }
}

/// Records the message of a caught panic.
#[cold]
#[inline(never)]
fn panicked(payload: Box<dyn std::any::Any + Send>) -> raddiff_status {
    set_last_error(&format!(
        "internal panic (please report): {}",
        panic_message(payload.as_ref())
    ));
    raddiff_status::RADDIFF_ERROR_PANIC
}

/// Like [`guard`] for constructors: returns the value or NULL, with the message recorded.
pub(crate) fn guard_ptr<T, F>(body: F) -> *mut T
where
    F: FnOnce() -> Result<*mut T, FfiError>,
{
    let mut out = std::ptr::null_mut();
    let status = guard(|| {
        out = body()?;
        Ok(())
    });
    if status == raddiff_status::RADDIFF_OK {
        out
    } else {
        std::ptr::null_mut()
    }
}

/// Turns an output pointer into a reference, or reports which argument was NULL.
///
/// # Safety
/// `ptr` must be NULL or valid for writes of one `T`.
pub(crate) unsafe fn out_ref<'a, T>(
    ptr: *mut T,
    name: &'static str,
) -> Result<&'a mut T, FfiError> {
    ptr.as_mut().ok_or(FfiError::Null(name))
}

/// Turns an input pointer into a reference, or reports which argument was NULL.
///
/// # Safety
/// `ptr` must be NULL or valid for reads of one `T`.
pub(crate) unsafe fn in_ref<'a, T>(ptr: *const T, name: &'static str) -> Result<&'a T, FfiError> {
    ptr.as_ref().ok_or(FfiError::Null(name))
}

/// Turns an input array into a slice, or reports which argument was NULL. A zero-length array may
/// be NULL.
///
/// # Safety
/// `ptr` must be NULL or valid for reads of `len` values of `T`.
pub(crate) unsafe fn in_slice<'a, T>(
    ptr: *const T,
    len: usize,
    name: &'static str,
) -> Result<&'a [T], FfiError> {
    if len == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(FfiError::Null(name));
    }
    Ok(std::slice::from_raw_parts(ptr, len))
}

/// Turns an in-out array into a mutable slice, or reports which argument was NULL. A zero-length
/// array may be NULL.
///
/// # Safety
/// `ptr` must be NULL or valid for reads and writes of `len` values of `T`, and not aliased.
pub(crate) unsafe fn inout_slice<'a, T>(
    ptr: *mut T,
    len: usize,
    name: &'static str,
) -> Result<&'a mut [T], FfiError> {
    if len == 0 {
        return Ok(&mut []);
    }
    if ptr.is_null() {
        return Err(FfiError::Null(name));
    }
    Ok(std::slice::from_raw_parts_mut(ptr, len))
}

/// Parses a C `order` argument.
pub(crate) fn order_from_c(order: u32) -> Result<Order, FfiError> {
    Ok(Order::try_from(order)?)
}

/// Message of the last failed raddiff call on this thread, or "" if none failed yet.
///
/// The pointer stays valid until the next raddiff call on the same thread.
#[no_mangle]
pub extern "C" fn raddiff_last_error() -> *const c_char {
    LAST_ERROR.with(|slot| slot.borrow().as_ptr())
}

/// The library version as "MAJOR.MINOR.PATCH" (static storage).
#[no_mangle]
pub extern "C" fn raddiff_version() -> *const c_char {
    static VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), "\0");
    VERSION.as_ptr().cast()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn version_macros_match_the_crate_version() {
        let expected =
            format!("{RADDIFF_VERSION_MAJOR}.{RADDIFF_VERSION_MINOR}.{RADDIFF_VERSION_PATCH}");
        assert_eq!(expected, crate::VERSION);
    }

    #[test]
    fn row_major_round_trip() {
        let m = DMat3::from_cols_array(&[1., 2., 3., 4., 5., 6., 7., 8., 9.]);
        let r = mat3_to_row_major(m);
        // glam column 0 is (1,2,3): so row 0 is (1,4,7).
        assert_eq!(&r[0..3], &[1., 4., 7.]);
        assert_eq!(mat3_from_row_major(&r), m);
    }

    #[test]
    fn panics_become_a_status_and_a_message() {
        let status = guard(|| panic!("boom"));
        assert_eq!(status, raddiff_status::RADDIFF_ERROR_PANIC);
        let msg = unsafe { std::ffi::CStr::from_ptr(raddiff_last_error()) };
        assert!(msg.to_str().unwrap().contains("boom"));
    }
}
