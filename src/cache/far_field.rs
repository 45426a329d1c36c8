//! The far-field marker of a cache: records that hold the far field of the near/far
//! decomposition, at which reach.

use crate::error::{ensure_finite, Error, Result};

/// The reach ρ at which a cache's records split off their near field (the near/far decomposition
/// of [`gather::near_far`](crate::gather::near_far), Arikan et al. 2005): with it on, every
/// record holds the far field F of its gather, and a query's irradiance is `E_near + V·F` with
/// the near field `E_near` and open fraction `V` of the query's own short rays
/// ([`Cache::irradiance_near_far`](crate::cache::Cache::irradiance_near_far)). A plain lookup in
/// such a cache returns F, not irradiance: the marker is cache state, saved with the cache, so
/// that a cache of far fields is never mistaken for one of irradiance.
///
/// The reach at a query whose pixel footprint is `f` (L per pixel) is `max(world, pixels·f)`: a
/// reach in pixels follows the image (the real-scene benchmark measured 8 footprints,
/// `docs/real-scenes.md`), a world reach suits renderers without a footprint. Both 0 (the
/// default, [`FarFieldReach::OFF`]): records hold irradiance.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FarFieldReach {
    /// Reach in the length unit L (finite, ≥ 0).
    pub world: f64,
    /// Reach in pixel footprints (finite, ≥ 0).
    pub pixels: f64,
}

impl FarFieldReach {
    /// No decomposition: records hold irradiance.
    pub const OFF: FarFieldReach = FarFieldReach {
        world: 0.0,
        pixels: 0.0,
    };

    /// A reach of `pixels` pixel footprints.
    pub fn pixels(pixels: f64) -> Self {
        FarFieldReach { world: 0.0, pixels }
    }

    /// A reach of `world` in L.
    pub fn world(world: f64) -> Self {
        FarFieldReach { world, pixels: 0.0 }
    }

    /// Whether records hold far fields (either reach > 0).
    pub fn is_on(&self) -> bool {
        self.world > 0.0 || self.pixels > 0.0
    }

    /// `InvalidArgument` unless both reaches are finite and ≥ 0.
    pub fn validate(&self) -> Result<()> {
        for (value, what) in [
            (self.world, "far-field reach in L"),
            (self.pixels, "far-field reach in pixels"),
        ] {
            ensure_finite(value, what)?;
            if value < 0.0 {
                return Err(Error::InvalidArgument(format!(
                    "the {what} must be >= 0, got {value}"
                )));
            }
        }
        Ok(())
    }

    /// The reach ρ (L) at a query whose pixel footprint is `footprint` (L per pixel; 0 when
    /// unknown): `max(world, pixels·footprint)`. `InvalidArgument` for an invalid reach, a
    /// footprint that is negative or not finite, and when ρ comes out 0 or not finite (a reach
    /// in pixels only, queried without a footprint).
    pub fn resolve(&self, footprint: f64) -> Result<f64> {
        self.validate()?;
        if !(footprint >= 0.0 && footprint.is_finite()) {
            return Err(Error::InvalidArgument(format!(
                "footprint must be finite and >= 0 (0: unknown), got {footprint}"
            )));
        }
        let reach = self.world.max(self.pixels * footprint);
        if reach > 0.0 && reach.is_finite() {
            Ok(reach)
        } else {
            Err(Error::InvalidArgument(format!(
                "no far-field reach at footprint {footprint} (world {}, pixels {}): a reach in \
                 pixels needs the query's footprint, or set a world reach",
                self.world, self.pixels
            )))
        }
    }
}
