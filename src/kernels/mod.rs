//! Closed-form derivative kernels: pure functions returning value, gradient and Hessian with respect
//! to an evaluation point `x`. Each takes an [`Order`](crate::Order) and does no work above it.

pub mod batch;
mod dd;
pub mod form_factor;
mod lambert;
mod lambert_clipped;
mod lambert_clipped_derivs;
mod lambert_clipped_polygon;
mod lambert_far;
mod lambert_polygon;
mod lanes;
pub mod marched;
pub mod polygon;
pub mod segment;
pub mod solid_angle;
#[cfg(test)]
mod test_rng;
pub mod transmittance;

pub use batch::*;
pub use form_factor::*;
pub use marched::*;
pub use polygon::*;
pub use segment::*;
pub use solid_angle::*;
pub use transmittance::*;
