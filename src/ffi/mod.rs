//! The C ABI: thin `extern "C"` wrappers over the Rust API, exported through `include/raddiff.h`.
//!
//! Conventions (`docs/c-abi.md`): every fallible call returns a [`raddiff_status`]; the message of
//! the last failed call on a thread is available from [`raddiff_last_error`]; outputs are written
//! only on success; panics are caught and reported as `RADDIFF_ERROR_PANIC`; every pointer is
//! NULL-checked; non-finite inputs are rejected. This module holds no logic beyond argument
//! conversion: the computation lives in the Rust modules.
#![allow(non_camel_case_types)]

mod batch;
mod cache;
mod common;
mod evaluation;
mod form_factor;
mod gather;
mod irradiance;
mod irradiance_near_far;
mod kernels;
mod near_far;
mod radii;
mod scatter;

pub use batch::*;
pub use cache::*;
pub use common::*;
pub use evaluation::*;
pub use form_factor::*;
pub use gather::*;
pub use irradiance::*;
pub use irradiance_near_far::*;
pub use kernels::*;
pub use near_far::*;
pub use radii::*;
pub use scatter::*;
