//! Arithmetic the kernels are built from, knowing nothing of any kernel: double-double numbers
//! ([`dd`]), SIMD lanes that round as scalar code ([`lanes`]), the compile-time fused multiply-add
//! ([`fma`]), a branch-free `atan2` for vectorized loops ([`atan2`]) and exact power-of-two
//! scaling ([`pow2`]). Nothing here imports from the rest of the crate.

pub(crate) mod array;
pub(crate) mod atan2;
pub(crate) mod dd;
pub(crate) mod fma;
pub(crate) mod lanes;
pub(crate) mod pow2;
