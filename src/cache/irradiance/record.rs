//! A record from an evaluated gather: the metric's radii, their bounds, the stored values.

use glam::DVec3;

use super::bounds::RadiusBounds;
use super::evaluation::GatherEvaluation;
use super::metric::Metric;
use super::settings::IrradianceSettings;
use crate::cache::{metric, CacheValue, Extent, Record};
use crate::error::{Error, Result};
use crate::gather::radii::{surface_radii, surface_radii_floored, CurvatureFloor, ErrorMode};

/// The smallest scalar the gradient-based metrics divide by: a black gather's E/|∇E| is then 0
/// over 0 replaced by a finite ratio (and the Hessian metrics' relative tolerance stays > 0).
const SCALAR_FLOOR: f64 = 1e-12;

/// Radii are kept at least this fraction of the largest coordinate of the record's position, so
/// that the cache's index can place the record (it refuses radii below 2⁻⁴⁰ of the position).
const INDEX_RESOLUTION: f64 = 1.0 / (1u64 << 39) as f64;

impl IrradianceSettings {
    /// The metric's extent for `evaluation` at [`IrradianceSettings::accuracy`], before any
    /// bound: radii ascending along tangent axes for the Hessian metrics, isotropic otherwise.
    /// A radius the metric leaves unbounded is `f64::INFINITY` (the split-sphere family when
    /// every ray missed, the gradient metric at a zero gradient); a vanishing Hessian gives
    /// [`MAX_RADIUS`](crate::gather::radii::MAX_RADIUS) unless the curvature floor binds.
    ///
    /// `InvalidArgument` when the metric's Hessian is not in the evaluation.
    pub fn extent(&self, evaluation: &GatherEvaluation) -> Result<Extent> {
        let e = evaluation;
        let a = self.accuracy;
        let distance = e.harmonic_mean_distance;
        let value = e.scalar.max(SCALAR_FLOOR);
        let unbounded = Extent::isotropic(f64::INFINITY);
        let Some(kind) = self.metric.hessian() else {
            return Ok(match self.metric {
                _ if !distance.is_finite() && self.metric != Metric::Gradient => unbounded,
                Metric::SplitSphere => Extent::isotropic(metric::split_sphere(a, distance)?),
                Metric::BoundedSplitSphere => Extent::isotropic(metric::split_sphere_bounded(
                    a,
                    distance,
                    value,
                    e.scalar_gradient,
                )?),
                _ => {
                    let slope = e.scalar_gradient.length();
                    if slope > 0.0 {
                        Extent::isotropic(a * value / slope)
                    } else {
                        unbounded
                    }
                }
            });
        };
        let hessian = e.hessian(kind).ok_or_else(|| {
            Error::InvalidArgument(format!(
                "the evaluation holds no {kind:?} Hessian: evaluate the gather with it \
                 (IrradianceSettings::hessians)"
            ))
        })?;
        let anisotropy = if self.metric == Metric::HessianIsotropic {
            1.0
        } else {
            self.max_anisotropy
        };
        let r = if self.curvature_floor > 0.0 && distance.is_finite() {
            let floor = CurvatureFloor {
                distance,
                weight: self.curvature_floor,
            };
            let mode = ErrorMode::Relative;
            surface_radii_floored(hessian, e.normal, e.scalar, a, mode, anisotropy, floor)?
        } else {
            surface_radii(hessian, e.normal, value, a, ErrorMode::Relative, anisotropy)?
        };
        Ok(Extent {
            radii: [r.radii[0], r.radii[1], r.radii[0].min(r.radii[1])],
            axes: [r.axes[0], r.axes[1], DVec3::ZERO],
        })
    }

    /// The record of `evaluation` under these settings: the metric's extent
    /// ([`IrradianceSettings::extent`]) clamped by the radius bounds at the pixel `footprint`
    /// (the world-space size of one pixel at the record, L; 0 when unknown: world bounds only;
    /// [`RadiusBounds::resolve`]), the irradiance and both gradients rounded to `f32`. Radii
    /// are kept above 2⁻³⁹ of the position's largest coordinate (the cache index's resolution).
    ///
    /// `InvalidArgument` for invalid settings, a footprint that is negative or not finite, bounds
    /// without a finite maximum, a channel count that disagrees with the evaluation or with `V`,
    /// or a missing Hessian.
    pub fn record<V: CacheValue>(
        &self,
        evaluation: &GatherEvaluation,
        footprint: f64,
    ) -> Result<Record<V>> {
        self.validate()?;
        let channels = evaluation.irradiance.len();
        if channels != self.channels || V::FIXED_CHANNELS.is_some_and(|n| n != channels) {
            return Err(Error::InvalidArgument(format!(
                "the evaluation has {channels} channels, the settings {} (and the value type {:?})",
                self.channels,
                V::FIXED_CHANNELS
            )));
        }
        let bounds = self.radius_bounds.resolve(footprint)?;
        let extent = RadiusBounds::apply(&self.extent(evaluation)?, bounds);
        let floor = evaluation.position.abs().max_element() * INDEX_RESOLUTION;
        let extent = Extent {
            radii: extent.radii.map(|r| r.max(floor)),
            axes: extent.axes,
        };
        evaluation.record(extent)
    }
}

impl GatherEvaluation {
    /// The record of this gather with `extent` as given (no metric, no bounds): position and
    /// normal, the irradiance and both gradients rounded to `f32` (axis-major, as [`Record`]
    /// holds them). For renderers that choose radii their own way. `InvalidArgument` when `V`
    /// has another channel count.
    pub fn record<V: CacheValue>(&self, extent: Extent) -> Result<Record<V>> {
        let channels = self.irradiance.len();
        if V::FIXED_CHANNELS.is_some_and(|n| n != channels) {
            return Err(Error::InvalidArgument(format!(
                "the evaluation has {channels} channels, the value type {:?}",
                V::FIXED_CHANNELS
            )));
        }
        let narrow = |v: &mut dyn Iterator<Item = f64>| -> V {
            V::from_channels(&v.map(|x| x as f32).collect::<Vec<f32>>())
        };
        let axis_major = |g: &[DVec3]| -> [V; 3] {
            std::array::from_fn(|k| narrow(&mut g.iter().map(|v| v[k])))
        };
        let mut record = Record::new(
            self.position,
            self.normal,
            narrow(&mut self.irradiance.iter().copied()),
            extent,
        );
        record.gradient = Some(axis_major(&self.gradient));
        record.rotation_gradient = Some(axis_major(&self.rotation_gradient));
        Ok(record)
    }
}
