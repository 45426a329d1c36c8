//! The radius bounds of irradiance records: in world units, and in pixels through the query's
//! footprint.

use crate::cache::Extent;
use crate::error::{ensure_finite, Error, Result};

/// Bounds on every radius of a record: `[max(world_min, pixel_min·f), min(world_max,
/// pixel_max·f)]` with `f` the footprint, the world-space size of one pixel at the record (the
/// pixel terms count only when `f > 0`). Pixel bounds make the clamps follow the image, as
/// renderers do (the thesis: one pixel to 150 px of an 1800 px image; Radiance's `-ar`), instead
/// of hand-tuned absolute clamps per scene.
///
/// A radius the metric leaves unbounded (every ray missed, a zero gradient or Hessian) takes the
/// upper bound, which must therefore be finite for the record at hand. When the two bounds cross
/// (a pixel minimum above a world maximum) the upper one wins: it is the one that keeps a record
/// from reaching past what its gather saw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadiusBounds {
    /// Smallest radius in the length unit L (≥ 0).
    pub world_min: f64,
    /// Largest radius in L (≥ `world_min`; `f64::INFINITY`: no world bound).
    pub world_max: f64,
    /// Smallest radius in pixels (≥ 0).
    pub pixel_min: f64,
    /// Largest radius in pixels (≥ `pixel_min`; `f64::INFINITY`: no pixel bound).
    pub pixel_max: f64,
}

impl Default for RadiusBounds {
    /// One pixel to 150 pixels (the thesis' clamps at its 1800-pixel images; scale the 150 with
    /// your resolution), no world bounds.
    fn default() -> Self {
        RadiusBounds {
            world_min: 0.0,
            world_max: f64::INFINITY,
            pixel_min: 1.0,
            pixel_max: 150.0,
        }
    }
}

impl RadiusBounds {
    /// World bounds only: `[min, max]` in L.
    pub fn world(min: f64, max: f64) -> Self {
        RadiusBounds {
            world_min: min,
            world_max: max,
            pixel_min: 0.0,
            pixel_max: f64::INFINITY,
        }
    }

    /// `InvalidArgument` unless every bound is ≥ 0 (maxima may be infinite, minima not) and
    /// each minimum is at most its maximum.
    pub fn validate(&self) -> Result<()> {
        for (value, what) in [(self.world_min, "world_min"), (self.pixel_min, "pixel_min")] {
            ensure_finite(value, what)?;
        }
        let ordered = |min: f64, max: f64| min >= 0.0 && max >= min;
        if !ordered(self.world_min, self.world_max) || !ordered(self.pixel_min, self.pixel_max) {
            return Err(Error::InvalidArgument(format!(
                "radius bounds must satisfy 0 <= min <= max: world [{}, {}], pixels [{}, {}]",
                self.world_min, self.world_max, self.pixel_min, self.pixel_max
            )));
        }
        Ok(())
    }

    /// The bounds `[min, max]` (L) for a record whose pixel footprint is `footprint` (L per
    /// pixel at the record; 0 when unknown: world bounds only). `InvalidArgument` for a negative
    /// or non-finite footprint, and when no bound gives a finite maximum.
    pub fn resolve(&self, footprint: f64) -> Result<(f64, f64)> {
        check_footprint(footprint)?;
        let (mut min, mut max) = (self.world_min, self.world_max);
        if footprint > 0.0 {
            min = min.max(self.pixel_min * footprint);
            max = max.min(self.pixel_max * footprint);
        }
        if !max.is_finite() {
            return Err(Error::InvalidArgument(format!(
                "no finite maximum radius (world_max {}, pixel_max {} at footprint {footprint}): \
                 pass the pixel footprint or set world_max, so that a gather that saw nothing \
                 cannot make a record without bounds",
                self.world_max, self.pixel_max
            )));
        }
        Ok((min.min(max), max))
    }

    /// `extent` with every radius clamped to `[min, max]` (a non-finite radius becomes `max`).
    pub fn apply(extent: &Extent, (min, max): (f64, f64)) -> Extent {
        let clamp = |r: f64| {
            if r.is_finite() {
                r.clamp(min, max)
            } else {
                max
            }
        };
        Extent {
            radii: extent.radii.map(clamp),
            axes: extent.axes,
        }
    }
}

/// `InvalidArgument` unless `footprint` is finite and ≥ 0.
pub(crate) fn check_footprint(footprint: f64) -> Result<()> {
    if footprint >= 0.0 && footprint.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!(
            "footprint must be finite and >= 0 (0: unknown), got {footprint}"
        )))
    }
}
