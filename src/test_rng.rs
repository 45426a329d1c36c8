//! The one deterministic generator of the crate's unit tests, so that their random configurations
//! are the same on every run and platform: PCG's 64-bit linear congruential step, read as a double
//! in `[0, 1)` from its top 53 bits.

use glam::DVec3;

/// Advances `state` by one step and returns the new state, all 64 bits (for tests that draw
/// exponents or signs from the bits themselves).
pub(crate) fn step(state: &mut u64) -> u64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    *state
}

/// The next number in `[0, 1)` from `state`, which it advances.
pub(crate) fn lcg(state: &mut u64) -> f64 {
    (step(state) >> 11) as f64 / (1u64 << 53) as f64
}

/// [`lcg`] as a generator that owns its state.
pub(crate) struct Lcg(pub(crate) u64);

impl Lcg {
    /// The next number in `[0, 1)`.
    pub(crate) fn next(&mut self) -> f64 {
        lcg(&mut self.0)
    }

    /// A point in the cube of side `s` centred at the origin.
    pub(crate) fn point(&mut self, s: f64) -> DVec3 {
        DVec3::new(self.next() - 0.5, self.next() - 0.5, self.next() - 0.5) * s
    }
}
