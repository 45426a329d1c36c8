//! Closed-form derivative kernels: pure functions returning value, gradient and Hessian with respect
//! to an evaluation point `x`. Each takes an [`Order`](crate::Order) and does no work above it.

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
