//! # raddiff
//!
//! Derivatives of light transport for renderers, and a radiance cache built on them.
//!
//! * [`kernels`]: closed-form value, gradient and 3x3 Hessian with respect to a point
//!   (transmittance, triangle solid angle, point-to-polygon form factors, flatland segment form factor).
//! * [`gather`]: stratified direction layouts a renderer traces, and irradiance with its gradients and
//!   Hessians from what those rays found.
//! * [`cache`]: a thread-safe radiance cache with anisotropic records, interpolation and persistence.
//! * [`scatter`]: single scattering through refractive triangle meshes.
//! * `ffi`: the C ABI (`include/raddiff.h`), a thin skin over the above.
//!
//! Conventions: all computation is in `f64`; positions are in the caller's length unit L; gradients
//! are per L and Hessians per L²; Hessians are symmetric 3x3 (row-major in the C ABI). Every public
//! function rejects non-finite input with [`Error::InvalidArgument`] and never returns NaN or Inf:
//! configurations where a quantity is undefined give a documented limit or [`Error::Degenerate`].

#![warn(missing_docs)]

pub mod cache;
mod deriv;
mod error;
pub mod ffi;
pub mod gather;
pub mod kernels;
pub mod scatter;
mod simd;
#[cfg(test)]
mod test_rng;

pub use deriv::{Deriv2, Deriv3, Order};
pub use error::{Error, Result};
/// The `glam` version raddiff's API is written in (`DVec3`, `DMat3`, ...): use `raddiff::glam`
/// instead of adding `glam` at exactly this version to your own manifest.
pub use glam;

/// The crate version, "MAJOR.MINOR.PATCH".
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The README's Rust examples, compiled and run as doc-tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// The Rust examples of the guides in `docs/`, compiled and run as doc-tests.
#[cfg(doctest)]
pub mod guide_doctests {
    #[doc = include_str!("../docs/kernels.md")]
    pub struct Kernels;
    #[doc = include_str!("../docs/gathers.md")]
    pub struct Gathers;
    #[doc = include_str!("../docs/cache.md")]
    pub struct Cache;
    #[doc = include_str!("../docs/single-scattering.md")]
    pub struct SingleScattering;
    #[doc = include_str!("../docs/demo.md")]
    pub struct Demo;
    #[doc = include_str!("../docs/embree.md")]
    pub struct Embree;
    #[doc = include_str!("../docs/integrate.md")]
    pub struct Integrate;
    #[doc = include_str!("../docs/ARCHITECTURE.md")]
    pub struct Architecture;
}
