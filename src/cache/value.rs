//! The values a cache stores: one or more `f32` channels per record.

/// A value stored in a [`Cache`](super::Cache): a fixed or run-time number of `f32` channels
/// (irradiance, RGB, spherical-harmonic coefficients, ...).
///
/// Implemented for `f32` (one channel), `[f32; N]` (N channels fixed at compile time) and `Vec<f32>`
/// (channel count chosen when the cache is created, as the C ABI does).
pub trait CacheValue: Clone + Send + Sync + 'static {
    /// The channel count fixed by the type, or `None` when the cache's configuration chooses it.
    const FIXED_CHANNELS: Option<usize>;

    /// The channels of this value.
    fn as_channels(&self) -> &[f32];

    /// Builds a value from exactly the cache's channel count of channels.
    fn from_channels(channels: &[f32]) -> Self;
}

impl CacheValue for f32 {
    const FIXED_CHANNELS: Option<usize> = Some(1);

    fn as_channels(&self) -> &[f32] {
        std::slice::from_ref(self)
    }

    fn from_channels(channels: &[f32]) -> Self {
        channels.first().copied().unwrap_or(0.0)
    }
}

impl<const N: usize> CacheValue for [f32; N] {
    const FIXED_CHANNELS: Option<usize> = Some(N);

    fn as_channels(&self) -> &[f32] {
        self
    }

    fn from_channels(channels: &[f32]) -> Self {
        let mut out = [0.0; N];
        for (o, c) in out.iter_mut().zip(channels) {
            *o = *c;
        }
        out
    }
}

impl CacheValue for Vec<f32> {
    const FIXED_CHANNELS: Option<usize> = None;

    fn as_channels(&self) -> &[f32] {
        self
    }

    fn from_channels(channels: &[f32]) -> Self {
        channels.to_vec()
    }
}
