//! Closed-form derivative kernels: pure functions returning value, gradient and Hessian with respect
//! to an evaluation point `x`. Each takes an [`Order`](crate::Order) and does no work above it.

pub mod transmittance;

pub use transmittance::transmittance;
