//! The properties every target checks, as panicking assertions (a panic is what AFL++ records as a
//! crash, and what the regression test reports).
use std::ffi::CStr;

use raddiff::ffi::{raddiff_last_error, raddiff_status, raddiff_vec3};

/// The bit pattern written into every output before a call: a NaN with a payload that no
/// computation produces, so "untouched" is a bitwise comparison. (Functions, not constants:
/// `from_bits` is `const` only from Rust 1.83, above the crate's MSRV.)
pub fn sentinel() -> f64 {
    f64::from_bits(0x7ff4_dead_beef_0001)
}

/// The f32 sentinel (a NaN payload, likewise).
pub fn sentinel_f32() -> f32 {
    f32::from_bits(0x7fa1_2345)
}

/// A vector of sentinels.
pub fn sentinel3() -> raddiff_vec3 {
    raddiff_vec3 {
        x: sentinel(),
        y: sentinel(),
        z: sentinel(),
    }
}

/// Checks a returned status: never `RADDIFF_ERROR_PANIC` (a caught panic is a bug), and every
/// failure leaves a message. Returns whether the call succeeded.
pub fn status(call: &str, status: raddiff_status) -> bool {
    match status {
        raddiff_status::RADDIFF_OK => true,
        raddiff_status::RADDIFF_ERROR_PANIC => {
            panic!("{call}: RADDIFF_ERROR_PANIC: {}", last_error())
        }
        other => {
            let message = last_error();
            assert!(!message.is_empty(), "{call}: {other:?} without a message");
            false
        }
    }
}

/// Checks a constructor's result: NULL comes with a message that is not a caught panic.
pub fn constructed<T>(call: &str, ptr: *mut T) -> bool {
    if ptr.is_null() {
        let message = last_error();
        assert!(!message.is_empty(), "{call}: NULL without a message");
        assert!(
            !message.contains("internal panic"),
            "{call}: caught panic: {message}"
        );
        false
    } else {
        true
    }
}

/// The thread's last error message.
pub fn last_error() -> String {
    // SAFETY: raddiff_last_error returns a NUL-terminated string valid until the next call.
    unsafe { CStr::from_ptr(raddiff_last_error()) }
        .to_string_lossy()
        .into_owned()
}

/// Every value finite (after `RADDIFF_OK` on finite input).
pub fn finite(call: &str, what: &str, values: &[f64]) {
    if let Some((i, v)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        panic!("{call}: RADDIFF_OK with non-finite {what}[{i}] = {v} (all: {values:?})");
    }
}

/// Every f32 value finite (after `RADDIFF_OK`).
pub fn finite_f32(call: &str, what: &str, values: &[f32]) {
    if let Some((i, v)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        panic!("{call}: RADDIFF_OK with non-finite {what}[{i}] = {v} (all: {values:?})");
    }
}

/// Every value still the sentinel (after a failure).
pub fn untouched(call: &str, what: &str, values: &[f64]) {
    if let Some((i, v)) = values
        .iter()
        .enumerate()
        .find(|(_, v)| v.to_bits() != sentinel().to_bits())
    {
        panic!("{call}: failed but wrote {what}[{i}] = {v}");
    }
}

/// Every f32 value still the sentinel (after a failure).
pub fn untouched_f32(call: &str, what: &str, values: &[f32]) {
    if let Some((i, v)) = values
        .iter()
        .enumerate()
        .find(|(_, v)| v.to_bits() != sentinel_f32().to_bits())
    {
        panic!("{call}: failed but wrote {what}[{i}] = {v}");
    }
}

/// The components of vectors, for the checks above.
pub fn flat(v: &[raddiff_vec3]) -> Vec<f64> {
    v.iter().flat_map(|v| [v.x, v.y, v.z]).collect()
}
