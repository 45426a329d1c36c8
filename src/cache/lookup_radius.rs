//! The lookup radius scale of [`CacheConfig::lookup_radius_scale`](super::CacheConfig::lookup_radius_scale)
//! (documented there, where users see it): its domain, and the coverage test that keeps misses
//! where they are at scale 1 while records are weighed over the scaled radii.

use glam::DVec3;

use super::interp::Kernel;
use super::weigh::{record_weight, UsedRecords};
use crate::error::{Error, Result};

/// Largest [`CacheConfig::lookup_radius_scale`](super::CacheConfig::lookup_radius_scale): a
/// lookup over 8 radii already weighs about 64 times the records of one over 1 (surfaces).
pub const LOOKUP_RADIUS_SCALE_MAX: f64 = 8.0;

/// `InvalidArgument` unless `scale` is a valid lookup radius scale: in
/// [1, [`LOOKUP_RADIUS_SCALE_MAX`]] (NaN and infinities refused).
pub(crate) fn check_scale(scale: f64) -> Result<()> {
    if (1.0..=LOOKUP_RADIUS_SCALE_MAX).contains(&scale) {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!(
            "the lookup radius scale must be in [1, {LOOKUP_RADIUS_SCALE_MAX}], got {scale}"
        )))
    }
}

/// Whether a query at `x` with unit normal `n`, whose records weighed with `kernel` are `used`,
/// is covered: some record covers it at its own radii (always, for an unscaled kernel and a
/// non-empty `used`). Every record that covers the query at its own radii is among `used`:
/// dividing by radii k ≥ 1 times larger never makes a normalized distance larger, and the leak
/// guard admits at least as much over larger radii.
pub(crate) fn covered(kernel: &Kernel, used: &UsedRecords<'_>, x: DVec3, n: DVec3) -> bool {
    if !kernel.is_scaled() {
        return true;
    }
    let own = kernel.at_own_radii();
    used.iter()
        .any(|u| record_weight(&own, u.head, x, n).0 > 0.0)
}
