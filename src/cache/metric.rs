//! Error metrics: turning a gather's result into a record's radii.
//!
//! * [`harmonic_mean_distance`] and [`split_sphere`]: Ward's split sphere (thesis eq. 3.7-3.12).
//!   A record is valid while Ward's weight 1/(‖Δx‖/R + √(1 − n·nᵢ)) exceeds 1/a (eq. 3.11), i.e. up
//!   to the distance a·R for equal normals.
//! * [`split_sphere_bounded`]: the same radius, bounded by the actual gradient (Ward-Heckbert
//!   1992, Křivánek et al.): the split sphere predicts a gradient of about E/R; when the measured
//!   |∇E| is larger, R is replaced by E/|∇E| (thesis 3.5.2).
//! * [`gradient_metric`]: Jarosz et al. 2008 for media, R = ε ΣLⱼ / Σ‖∇Lⱼ‖ (Marco et al. eq. 5).
//! * [`hessian_surface`] and [`hessian_volume`]: the ellipse in the tangent plane / the ellipsoid
//!   over which the second-order error of first-order extrapolation stays within a tolerance
//!   (thesis ch. 4 and eq. 6.7-6.9, Marco eq. 20-22), computed by [`crate::gather::radii`] (see
//!   its module docs for the exact bound) and returned as an [`Extent`].
//! * [`RadiusLimits`]: minimum and maximum radius clamps; neighbour clamping (thesis 3.5.4) is
//!   [`Cache::clamp_to_neighbours`](super::Cache::clamp_to_neighbours).

use glam::{DMat3, DVec3};

pub use crate::gather::radii::ErrorMode;

use super::record::Extent;
use crate::error::{ensure_finite, ensure_finite3, Error, Result};

fn positive(v: f64, what: &str) -> Result<()> {
    ensure_finite(v, what)?;
    if v > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!(
            "{what} must be > 0 (got {v})"
        )))
    }
}

/// Harmonic mean of the hit distances of a gather, R = count / Σ 1/rⱼ (thesis eq. 3.9), in L.
///
/// Misses are `f64::INFINITY` and contribute 1/r = 0 (they still count in the numerator).
/// Distances must be > 0 (NaN and negative values are rejected). If every ray missed, R is
/// infinite and [`Error::Degenerate`] is returned: nothing bounds the record, use a maximum radius.
pub fn harmonic_mean_distance(distances: &[f64]) -> Result<f64> {
    if distances.is_empty() {
        return Err(Error::InvalidArgument("no distances".into()));
    }
    let mut inv = 0.0;
    for &d in distances {
        if d.is_nan() || d <= 0.0 {
            return Err(Error::InvalidArgument(format!(
                "hit distances must be > 0 (got {d})"
            )));
        }
        inv += 1.0 / d;
    }
    let r = distances.len() as f64 / inv;
    if r.is_finite() {
        Ok(r)
    } else {
        Err(Error::Degenerate(
            "every ray missed: the harmonic mean distance is infinite".into(),
        ))
    }
}

/// Ward's split-sphere radius a·R (L): `a` the accuracy (typically 0.1-0.3), `R` the harmonic mean
/// distance. Both must be finite and > 0.
pub fn split_sphere(a: f64, harmonic_mean_distance: f64) -> Result<f64> {
    positive(a, "a")?;
    positive(harmonic_mean_distance, "harmonic mean distance")?;
    Ok(a * harmonic_mean_distance)
}

/// The split-sphere radius bounded by the measured gradient: a·min(R, E/‖∇E‖) (L).
///
/// `value` E and `gradient` ∇E (per L) are a scalar summary of the record (e.g. luminance, or the
/// channel with the largest ‖∇E‖/E). When E ≤ 0 or ∇E = 0 the gradient gives no bound and the
/// result is the plain split-sphere radius.
pub fn split_sphere_bounded(
    a: f64,
    harmonic_mean_distance: f64,
    value: f64,
    gradient: DVec3,
) -> Result<f64> {
    let r = split_sphere(a, harmonic_mean_distance)?;
    ensure_finite(value, "value")?;
    ensure_finite3(gradient, "gradient")?;
    let g = gradient.length();
    if value > 0.0 && g > 0.0 {
        Ok(r.min(a * value / g))
    } else {
        Ok(r)
    }
}

/// The Jarosz et al. 2008 gradient metric R = ε Σⱼ Lⱼ / Σⱼ ‖∇Lⱼ‖ (Marco et al. eq. 5), in L.
///
/// `values` and `gradients` are the per-sample radiances and translational gradients of the
/// gather (equal lengths). `epsilon` > 0 is the tolerance. If every gradient is zero the metric is
/// unbounded: [`Error::Degenerate`] (use a maximum radius). Σ Lⱼ ≤ 0 is [`Error::Degenerate`] too.
pub fn gradient_metric(epsilon: f64, values: &[f64], gradients: &[DVec3]) -> Result<f64> {
    positive(epsilon, "epsilon")?;
    if values.len() != gradients.len() || values.is_empty() {
        return Err(Error::InvalidArgument(format!(
            "{} values and {} gradients: need equal, non-zero counts",
            values.len(),
            gradients.len()
        )));
    }
    let mut sum_l = 0.0;
    let mut sum_g = 0.0;
    for (&l, &g) in values.iter().zip(gradients) {
        ensure_finite(l, "sample value")?;
        ensure_finite3(g, "sample gradient")?;
        sum_l += l;
        sum_g += g.length();
    }
    let r = epsilon * sum_l / sum_g;
    if r.is_finite() && r > 0.0 {
        Ok(r)
    } else {
        Err(Error::Degenerate(format!(
            "gradient metric undefined (sum of values {sum_l}, sum of gradient norms {sum_g})"
        )))
    }
}

fn nonzero(extent: Extent) -> Result<Extent> {
    if extent.radii.iter().any(|&r| r <= 0.0) {
        return Err(Error::Degenerate(
            "zero tolerance with a non-zero Hessian gives a zero radius".into(),
        ));
    }
    Ok(extent)
}

/// Hessian metric for a surface record: [`crate::gather::radii::surface_radii`] as an
/// [`Extent`] (radii ascending along the tangent eigenvectors). `hessian` is the 3x3 translation
/// Hessian (value/L²), `normal` unit length, `error` the tolerance (relative: divided by |value|),
/// `max_anisotropy` ≥ 1 the largest axis ratio (the thesis uses 2). A vanishing Hessian gives the
/// radius [`crate::gather::radii::MAX_RADIUS`]: apply [`RadiusLimits`]. A zero tolerance is
/// [`Error::Degenerate`].
pub fn hessian_surface(
    hessian: DMat3,
    normal: DVec3,
    value: f64,
    error: f64,
    mode: ErrorMode,
    max_anisotropy: f64,
) -> Result<Extent> {
    let r =
        crate::gather::radii::surface_radii(hessian, normal, value, error, mode, max_anisotropy)?;
    nonzero(Extent {
        radii: [r.radii[0], r.radii[1], r.radii[0]],
        axes: [r.axes[0], r.axes[1], normal],
    })
}

/// Hessian metric for a media record: [`crate::gather::radii::volume_radii`] as an ellipsoid
/// [`Extent`]. Same conventions and limits as [`hessian_surface`].
pub fn hessian_volume(
    hessian: DMat3,
    value: f64,
    error: f64,
    mode: ErrorMode,
    max_anisotropy: f64,
) -> Result<Extent> {
    let r = crate::gather::radii::volume_radii(hessian, value, error, mode, max_anisotropy)?;
    nonzero(Extent {
        radii: r.radii,
        axes: r.axes,
    })
}

/// Minimum and maximum radius clamps (L), applied to every radius of an extent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadiusLimits {
    /// Smallest radius (e.g. the footprint of one pixel).
    pub min: f64,
    /// Largest radius.
    pub max: f64,
}

impl RadiusLimits {
    /// Limits `min ≤ r ≤ max`; `0 < min ≤ max`, both finite.
    pub fn new(min: f64, max: f64) -> Result<Self> {
        positive(min, "minimum radius")?;
        positive(max, "maximum radius")?;
        if min > max {
            return Err(Error::InvalidArgument(format!(
                "minimum radius {min} exceeds maximum radius {max}"
            )));
        }
        Ok(RadiusLimits { min, max })
    }

    /// Clamps one radius.
    pub fn clamp(&self, r: f64) -> f64 {
        r.clamp(self.min, self.max)
    }

    /// Clamps every radius of `extent` (which may change its anisotropy).
    pub fn apply(&self, extent: &Extent) -> Extent {
        Extent {
            radii: extent.radii.map(|r| self.clamp(r)),
            axes: extent.axes,
        }
    }
}

#[cfg(test)]
mod tests;
