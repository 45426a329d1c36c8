//! The one generator the integration tests draw their random cases from (SplitMix64), so that a
//! failure reproduces from its seed on every run and platform. Each test's `Rng` keeps its own
//! helpers (ranges, vectors) on top of these two steps.

/// Advances `state` and returns the next 64 random bits.
pub fn next_u64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The next number in `[0, 1)` from `state`, which it advances (the top 53 bits of [`next_u64`]).
#[allow(dead_code)]
pub fn uniform(state: &mut u64) -> f64 {
    (next_u64(state) >> 11) as f64 / (1u64 << 53) as f64
}
