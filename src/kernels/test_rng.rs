//! A deterministic uniform generator for the kernels' unit tests (PCG's 64-bit LCG step, the top
//! 53 bits as a double in [0, 1)), so that their random configurations are reproducible.

/// The next number in [0, 1) from `state`, which it advances.
pub(crate) fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}
