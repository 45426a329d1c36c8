//! Numbers and 3-vectors per SIMD lane, each lane rounding exactly as scalar `f64` code does.
//!
//! [`Lane`] is a number per lane: `f64` (one lane), [`Pair`] (two lanes: one SSE2 register on
//! x86-64, a plain array elsewhere) or [`Wide`] (four lanes: one AVX register, only inside code
//! compiled with AVX2 and FMA). [`V3`] is a 3-vector per lane with glam's operation order, so
//! `V3<f64>` rounds as `DVec3` does. [`Lanes`] loads a group of four quadrature nodes into lanes
//! and adds the lanes back in one fixed tree, `(l0 + l1) + (l2 + l3)`.
//!
//! Who uses them: the derivative fast path of Lambert's sum takes two edges side by side
//! (`V3<Pair>`), the far-field tensor rule two consecutive nodes (`V3<Pair>`), the sliver rule's
//! sums four nodes at a time (`Wide` in the AVX2 build, two `Pair` halves in the portable one).
//!
//! Why lanes written by hand: without AVX a `DVec3` fills one and a half SSE2 registers, and
//! per-edge arithmetic (cross products, six Hessian entries) spends as many instructions on
//! shuffles as on arithmetic; two edges in the two lanes of a register need none. Left to itself,
//! LLVM paired the components of one edge instead of the two edges.
//!
//! Bits: every operation rounds each lane as the scalar code would (no fused multiply-add; the
//! same operations in the same order), and lane sums use one tree in every build, so results do
//! not depend on the lane type or the instruction set (`tests.rs` checks it bit for bit).

mod lane;
mod pair;
mod v3;
#[cfg(target_arch = "x86_64")]
mod wide;

pub(crate) use lane::{Lane, Lanes};
pub(crate) use pair::Pair;
pub(crate) use v3::V3;
#[cfg(target_arch = "x86_64")]
pub(crate) use wide::Wide;

#[cfg(test)]
mod tests;
