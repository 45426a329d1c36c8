//! Quadrature of the form factor's smooth integrand: Gauss-Legendre rules, the far-field tensor
//! rule on a triangle, its sums four nodes at a time, and subdivision for nearby pieces.

pub(crate) mod lanes;
pub(crate) mod rules;
pub(crate) mod subdivide;
pub(crate) mod tensor;
