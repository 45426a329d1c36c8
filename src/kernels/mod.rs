//! Closed-form derivative kernels: pure functions returning value, gradient and Hessian with respect
//! to an evaluation point `x`. Each takes an [`Order`](crate::Order) and does no work above it.
//!
//! | module | computes | ladder |
//! |---|---|---|
//! | [`solid_angle`] | the solid angle a triangle subtends | certified f64 → exact `A` → robust |
//! | [`form_factor`] | point-to-edge, -triangle and -polygon form factors, clipped | its module |
//! | [`segment`] | the flatland form factor of a segment | one closed form |
//! | [`transmittance`](mod@transmittance), [`marched`] | transmittance, homogeneous and from samples | one closed form |
//! | [`batch`] | the above over meshes and point sets, in SIMD lanes | lanes → single kernel |
//! | [`polygon`] | Arvo's irradiance Jacobian (a cross-check of the gradient) | one closed form |
//!
//! Each kernel's module documentation starts with its ladder: which path answers which
//! configuration, and each path's error. Every path meets the accuracy contract: 1e-12 / 1e-12 /
//! 1e-10 relative to the largest entry (value / gradient / Hessian) in generic configurations,
//! 1e-10 / 1e-9 / 1e-8 in the hard regimes (near a plane, an edge or a vertex, slivers, far away,
//! extreme scales); docs/kernels.md has the measured errors and costs.
//!
//! `numeric` holds the arithmetic they share (double-double, SIMD lanes that round as scalar
//! code, a branch-free `atan2`, exact power-of-two scaling) and imports no kernel; the kernels
//! import nothing above this module.

pub mod batch;
pub mod form_factor;
pub mod marched;
pub(crate) mod numeric;
pub mod polygon;
pub mod segment;
pub mod solid_angle;
pub mod transmittance;

pub use batch::*;
pub use form_factor::*;
pub use marched::*;
pub use polygon::*;
pub use segment::*;
pub use solid_angle::*;
pub use transmittance::*;
