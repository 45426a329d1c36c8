//! A traced gather evaluated once: what every metric and threshold builds its record from.

use std::borrow::Cow;

use glam::{DMat3, DVec3};

use super::metric::{HessianKind, Metric};
use super::traced::TracedGather;
use crate::error::{Error, Result};
use crate::gather::hessian::outputs::cached_topology;
use crate::gather::hessian::unaware::{geometric_hessian, unaware_derivatives};
use crate::gather::hessian::{occlusion_derivatives, HemisphereGather};
use crate::gather::{StrataSmoothing, ValidGather, Wanted};
use crate::Order;

/// Which Hessians a [`GatherEvaluation`] computes (each costs from several times the gradient to
/// tens of times it; see `docs/gathers.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Hessians {
    /// The occlusion-aware Hessian ([`HessianKind::OcclusionAware`]).
    pub occlusion_aware: bool,
    /// The occlusion-unaware (radiometric) Hessian ([`HessianKind::Unaware`]).
    pub unaware: bool,
    /// The geometric Hessian ([`HessianKind::Geometric`]).
    pub geometric: bool,
}

impl Hessians {
    /// None: irradiance, gradients and distances only.
    pub const NONE: Hessians = Hessians {
        occlusion_aware: false,
        unaware: false,
        geometric: false,
    };

    /// The Hessians that `metrics` need, and no other.
    pub fn for_metrics(metrics: &[Metric]) -> Hessians {
        let mut wanted = Hessians::NONE;
        for kind in metrics.iter().filter_map(|m| m.hessian()) {
            *wanted.flag(kind) = true;
        }
        wanted
    }

    /// Whether `kind` is selected.
    pub fn contains(&self, kind: HessianKind) -> bool {
        match kind {
            HessianKind::OcclusionAware => self.occlusion_aware,
            HessianKind::Unaware => self.unaware,
            HessianKind::Geometric => self.geometric,
        }
    }

    fn flag(&mut self, kind: HessianKind) -> &mut bool {
        match kind {
            HessianKind::OcclusionAware => &mut self.occlusion_aware,
            HessianKind::Unaware => &mut self.unaware,
            HessianKind::Geometric => &mut self.geometric,
        }
    }
}

/// A traced gather evaluated once: per-channel irradiance and Ward-Heckbert gradients (what the
/// record stores), the scalar the metrics measure (the channel-weighted sum, e.g. luminance) with
/// its gradient, the harmonic-mean hit distance, and the Hessians of the scalar that were asked
/// for. [`IrradianceSettings::record`](super::IrradianceSettings::record) builds the record of
/// any metric and threshold from it, so that one gather can serve all of them.
#[derive(Debug, Clone, PartialEq)]
pub struct GatherEvaluation {
    /// The record's position (the frame's), L.
    pub position: DVec3,
    /// The record's normal ([`TracedGather::normal`]).
    pub normal: DVec3,
    /// Irradiance per channel (radiance units × sr).
    pub irradiance: Vec<f64>,
    /// Ward-Heckbert translational gradient per channel (world axes, per L), with the media terms
    /// of Jarosz et al. 2008 when the gather has a medium.
    pub gradient: Vec<DVec3>,
    /// Rotational gradient per channel (per radian).
    pub rotation_gradient: Vec<DVec3>,
    /// The metrics' scalar: `Σ w_c E_c` with the channel weights.
    pub scalar: f64,
    /// Its gradient, `Σ w_c ∇E_c`.
    pub scalar_gradient: DVec3,
    /// Harmonic mean of the hit distances (L); `f64::INFINITY` when every ray missed.
    pub harmonic_mean_distance: f64,
    /// The occlusion-aware Hessian of the scalar (per L²), with the thesis' robustness term
    /// ([`OcclusionDerivatives::robust_hessian`](crate::gather::hessian::OcclusionDerivatives::robust_hessian)),
    /// if asked for. In a medium it attenuates the surface radiance to each triangle's farthest
    /// vertex and leaves the marched in-scattered radiance out (it is smooth where the Hessian
    /// matters: the radii follow the surfaces' occlusion).
    pub occlusion_hessian: Option<DMat3>,
    /// The occlusion-unaware (radiometric) Hessian of the scalar, if asked for.
    pub unaware_hessian: Option<DMat3>,
    /// The geometric Hessian (thesis eq. 4.23) with the gather's largest scalar radiance, if
    /// asked for.
    pub geometric_hessian: Option<DMat3>,
    /// The channel weights the scalar was formed with.
    pub(super) weights: Vec<f64>,
    /// The smoothing the derivatives were taken with.
    pub(super) smoothing: StrataSmoothing,
}

impl GatherEvaluation {
    /// Evaluates `traced` with the channel `weights` (one per channel, ≥ 0, not all 0) and the
    /// Hessians in `hessians`, every quantity from the strata as traced.
    ///
    /// `InvalidArgument` for a gather [`gather::evaluate`](crate::gather::evaluate) refuses, bad
    /// weights or per-ray arrays, an unaware or geometric Hessian without hit normals or in a
    /// medium; `Degenerate` when a result overflows. A gather whose every ray missed is valid:
    /// its distance is infinite (the metrics then leave the radius unbounded).
    pub fn new(traced: &TracedGather, weights: &[f64], hessians: Hessians) -> Result<Self> {
        Self::with_smoothing(traced, weights, hessians, StrataSmoothing::OFF)
    }

    /// [`GatherEvaluation::new`] with the derivatives (gradients, rotational gradients, the
    /// scalar's gradient and every Hessian) taken from the strata smoothed by `smoothing`
    /// ([`StrataSmoothing`]; [`IrradianceSettings::derivative_smoothing`](super::IrradianceSettings::derivative_smoothing)),
    /// and the irradiance, the scalar and the distances from the strata as traced: quieter
    /// derivatives and radii for noisy hit radiance, the record's value unbiased. With
    /// [`StrataSmoothing::OFF`] this is `new`. Errors as `new`, and `InvalidArgument` for more
    /// passes than [`StrataSmoothing::MAX_PASSES`].
    pub fn with_smoothing(
        traced: &TracedGather,
        weights: &[f64],
        hessians: Hessians,
        smoothing: StrataSmoothing,
    ) -> Result<Self> {
        traced.check_extras()?;
        check_weights(weights, traced.input.channels)?;
        smoothing.validate()?;
        let valid = ValidGather::new(&traced.layout, &traced.frame, &traced.input)?;
        let values = if smoothing.is_on() {
            let mut values = valid.evaluate(Wanted {
                distances: true,
                ..Wanted::IRRADIANCE
            })?;
            let derivatives = valid.evaluate_smoothed(
                smoothing,
                Wanted {
                    irradiance: false,
                    gradient: true,
                    rotation_gradient: true,
                    distances: false,
                },
            )?;
            values.gradient = derivatives.gradient;
            values.rotation_gradient = derivatives.rotation_gradient;
            values
        } else {
            valid.evaluate(Wanted::ALL)?
        };
        let weighted = |v: &dyn Fn(usize) -> f64| -> f64 {
            let mut sum = weights[0] * v(0);
            for (c, w) in weights.iter().enumerate().skip(1) {
                sum += w * v(c);
            }
            sum
        };
        let scalar = weighted(&|c| values.irradiance[c]);
        let scalar_gradient = DVec3::new(
            weighted(&|c| values.gradient[c].x),
            weighted(&|c| values.gradient[c].y),
            weighted(&|c| values.gradient[c].z),
        );
        let mut evaluation = GatherEvaluation {
            position: traced.frame.position,
            normal: traced.normal,
            irradiance: values.irradiance,
            gradient: values.gradient,
            rotation_gradient: values.rotation_gradient,
            scalar,
            scalar_gradient,
            harmonic_mean_distance: values.harmonic_mean_distance.unwrap_or(f64::INFINITY),
            occlusion_hessian: None,
            unaware_hessian: None,
            geometric_hessian: None,
            weights: weights.to_vec(),
            smoothing,
        };
        for kind in [
            HessianKind::OcclusionAware,
            HessianKind::Unaware,
            HessianKind::Geometric,
        ] {
            if hessians.contains(kind) {
                evaluation.add_hessian(traced, kind)?;
            }
        }
        Ok(evaluation)
    }

    /// Computes the Hessian `kind` of the scalar from `traced` (the gather this evaluation came
    /// from, its strata smoothed as the evaluation's) and keeps it: for callers that time or
    /// choose the Hessians one at a time. Errors as [`GatherEvaluation::new`].
    pub fn add_hessian(&mut self, traced: &TracedGather, kind: HessianKind) -> Result<()> {
        traced.check_extras()?;
        let mut scalar = scalar_radiance(traced, &self.weights);
        if self.smoothing.is_on() {
            scalar = Cow::Owned(self.smoothing.smoothed(&traced.layout, &scalar, 1)?);
        }
        let gather = HemisphereGather {
            normal: traced.frame.normal,
            directions: traced.input.directions,
            distance: traced.input.distance,
            radiance: &scalar,
            channels: 1,
            sigma_t: traced.input.sigma_t,
        };
        let hessian = match kind {
            HessianKind::OcclusionAware => {
                let topology = cached_topology(&traced.layout)?;
                occlusion_derivatives(&topology, &gather, Order::Hessian)?.robust_hessian(0)
            }
            HessianKind::Unaware | HessianKind::Geometric => {
                let normals = unaware_input(traced)?;
                if kind == HessianKind::Unaware {
                    unaware_derivatives(&gather, normals, Order::Hessian)?.hessian[0]
                } else {
                    let brightest = scalar.iter().fold(0.0f32, |m, &l| m.max(l)) as f64;
                    geometric_hessian(&gather, normals, brightest)?
                }
            }
        };
        if !hessian.is_finite() {
            return Err(Error::Degenerate(format!(
                "the {kind:?} Hessian overflows (hit distances or radiance too extreme)"
            )));
        }
        *self.hessian_slot(kind) = Some(hessian);
        Ok(())
    }

    /// The Hessian `kind`, if it was computed.
    pub fn hessian(&self, kind: HessianKind) -> Option<DMat3> {
        match kind {
            HessianKind::OcclusionAware => self.occlusion_hessian,
            HessianKind::Unaware => self.unaware_hessian,
            HessianKind::Geometric => self.geometric_hessian,
        }
    }

    /// The channel weights the scalar was formed with.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// The smoothing of the strata the derivatives were taken with.
    pub fn smoothing(&self) -> StrataSmoothing {
        self.smoothing
    }

    fn hessian_slot(&mut self, kind: HessianKind) -> &mut Option<DMat3> {
        match kind {
            HessianKind::OcclusionAware => &mut self.occlusion_hessian,
            HessianKind::Unaware => &mut self.unaware_hessian,
            HessianKind::Geometric => &mut self.geometric_hessian,
        }
    }
}

/// The per-ray radiance of the scalar: the renderer's, or the weighted channels rounded to `f32`
/// (the precision of the channels themselves).
fn scalar_radiance<'a>(traced: &TracedGather<'a>, weights: &[f64]) -> Cow<'a, [f32]> {
    if let Some(scalar) = traced.scalar_radiance {
        return Cow::Borrowed(scalar);
    }
    let channels = traced.input.channels;
    if channels == 1 && weights[0] == 1.0 {
        return Cow::Borrowed(traced.input.radiance);
    }
    Cow::Owned(
        traced
            .input
            .radiance
            .chunks_exact(channels)
            .map(|ray| {
                let mut sum = weights[0] * ray[0] as f64;
                for (w, &l) in weights.iter().zip(ray).skip(1) {
                    sum += w * l as f64;
                }
                sum as f32
            })
            .collect(),
    )
}

/// The hit normals the occlusion-unaware Hessians need, or why they cannot be computed.
fn unaware_input<'a>(traced: &TracedGather<'a>) -> Result<&'a [glam::DVec3]> {
    if traced.input.sigma_t != 0.0 || traced.input.media.is_some() {
        return Err(Error::InvalidArgument(
            "the occlusion-unaware and geometric Hessians are not defined in a medium".into(),
        ));
    }
    traced.hit_normals.ok_or_else(|| {
        Error::InvalidArgument(
            "the occlusion-unaware and geometric Hessians need the hit normals".into(),
        )
    })
}

/// `InvalidArgument` unless there is one finite, non-negative weight per channel and one is
/// positive.
pub(crate) fn check_weights(weights: &[f64], channels: usize) -> Result<()> {
    if weights.len() != channels {
        return Err(Error::InvalidArgument(format!(
            "{} channel weights for {channels} channels",
            weights.len()
        )));
    }
    if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) || !weights.iter().any(|&w| w > 0.0) {
        return Err(Error::InvalidArgument(format!(
            "channel weights must be finite, >= 0 and not all 0 (got {weights:?})"
        )));
    }
    Ok(())
}
