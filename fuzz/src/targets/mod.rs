//! The fuzz targets, one module each, and the decoder and checks they share.
//!
//! Compiled twice: as the `raddiff-fuzz` library (AFL++ binaries, `replay`) and, through a `#[path]`
//! module, inside the root crate's `tests/fuzz_regressions.rs`. So it uses nothing but `raddiff`
//! and `std`.
#![allow(dead_code)]

pub mod cache_irradiance;
pub mod cache_load;
pub mod cache_ops;
pub mod check;
pub mod decode;
pub mod gather_evaluate;
pub mod kernels;
pub mod radii;
pub mod scratch;
pub mod single_scatter;

/// What a fuzz input led to once every property held: whether the main call succeeded. The
/// regression test uses it to check that each corpus reaches both the success and the error paths.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// The entry point answered `RADDIFF_OK` (for sequences: at least one call did).
    Ok,
    /// The entry point refused the input with a status and a message (or returned NULL).
    Refused,
}

/// Target names, as used for `fuzz/corpus/<name>/` and `fuzz/regressions/<name>/`.
pub const NAMES: [&str; 7] = [
    "kernels",
    "radii",
    "gather_evaluate",
    "cache_ops",
    "cache_load",
    "cache_irradiance",
    "single_scatter",
];

/// The `run` function of a target by name.
pub fn by_name(name: &str) -> Option<fn(&[u8]) -> Outcome> {
    Some(match name {
        "kernels" => kernels::run,
        "radii" => radii::run,
        "gather_evaluate" => gather_evaluate::run,
        "cache_ops" => cache_ops::run,
        "cache_load" => cache_load::run,
        "cache_irradiance" => cache_irradiance::run,
        "single_scatter" => single_scatter::run,
        _ => return None,
    })
}
