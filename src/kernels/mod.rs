//! Closed-form derivative kernels: pure functions returning value, gradient and Hessian with respect
//! to an evaluation point `x`. Each takes an [`Order`](crate::Order) and does no work above it.

pub mod batch;
pub mod form_factor;
mod lambert;
mod lambert_clipped;
mod lambert_clipped_derivs;
mod lambert_clipped_polygon;
mod lambert_far;
mod lambert_polygon;
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

/// `std::array::from_fn(f)` as a loop filling an initialized array: in the near-plane routes'
/// large functions LLVM left `from_fn` out of line (`core::array::try_from_fn`, ~35 instructions
/// a call, callgrind).
#[inline(always)]
pub(crate) fn array_from<T: Copy + Default, const M: usize>(f: impl Fn(usize) -> T) -> [T; M] {
    let mut a = [T::default(); M];
    for (k, x) in a.iter_mut().enumerate() {
        *x = f(k);
    }
    a
}
