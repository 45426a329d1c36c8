//! C wrappers for the mid-level irradiance calls: a traced gather evaluated once
//! (`raddiff_gather_evaluation_*`), and the record of one metric and threshold from it
//! (`raddiff_irradiance_record`), so that a renderer can share one gather between metrics.

// These are C entry points: every pointer is NULL-checked and the caller's validity contract is
// the header's; marking them `unsafe fn` would change nothing for C callers.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use glam::DVec3;

use super::cache::raddiff_cache_record;
use super::common::*;
use super::gather::{
    gather_input_from_c, raddiff_frame, raddiff_gather_input, raddiff_gather_layout,
};
use super::irradiance::{raddiff_irradiance_settings, settings_from_c};
use crate::cache::irradiance::{GatherEvaluation, HessianKind, Hessians, TracedGather};
use crate::cache::{Extent, Record};
use crate::gather::{Frame, Layout};
use crate::Error;

/// Bit of `raddiff_gather_evaluation_new`'s `hessians`: the occlusion-aware Hessian (the
/// `RADDIFF_METRIC_HESSIAN_ISOTROPIC` / `_ANISOTROPIC` metrics).
pub const RADDIFF_HESSIAN_OCCLUSION_AWARE: u32 = 1;
/// Bit: the occlusion-unaware (radiometric) Hessian (`RADDIFF_METRIC_HESSIAN_UNAWARE`); needs
/// `hit_normals` and no medium.
pub const RADDIFF_HESSIAN_UNAWARE: u32 = 2;
/// Bit: the geometric Hessian (`RADDIFF_METRIC_HESSIAN_GEOMETRIC`); needs `hit_normals` and no
/// medium.
pub const RADDIFF_HESSIAN_GEOMETRIC: u32 = 4;

/// A traced gather evaluated once (Rust: `cache::irradiance::GatherEvaluation`): irradiance and
/// gradients per channel, the settings' scalar (e.g. luminance) with its gradient, the
/// harmonic-mean distance and the Hessians asked for. Immutable: any number of threads may read
/// it and build records from it at once.
pub struct raddiff_gather_evaluation {
    inner: GatherEvaluation,
    /// The record's values as the cache takes them: `channels` floats, then the translational
    /// and rotational gradients, channel-major (`3*channels` floats each).
    value: Vec<f32>,
    gradient: Vec<f32>,
    rotation_gradient: Vec<f32>,
}

/// The scalar results of an evaluation. Hessians are row-major, per L^2, and all zero when not
/// computed (see `hessians`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct raddiff_gather_summary {
    /// The metrics' scalar: the channel-weighted irradiance.
    pub scalar: f64,
    /// Its Ward-Heckbert gradient (world axes, per L).
    pub scalar_gradient: [f64; 3],
    /// Harmonic mean of the hit distances (L); INFINITY if every ray missed.
    pub harmonic_mean_distance: f64,
    /// `RADDIFF_HESSIAN_*` bits of the Hessians present below.
    pub hessians: u32,
    /// The occlusion-aware Hessian of the scalar, with the thesis' robustness term.
    pub occlusion_hessian: [f64; 9],
    /// The occlusion-unaware (radiometric) Hessian of the scalar.
    pub unaware_hessian: [f64; 9],
    /// The geometric Hessian (thesis eq. 4.23) with the gather's brightest scalar radiance.
    pub geometric_hessian: [f64; 9],
}

fn hessians_from_c(bits: u32) -> Result<Hessians, FfiError> {
    let known =
        RADDIFF_HESSIAN_OCCLUSION_AWARE | RADDIFF_HESSIAN_UNAWARE | RADDIFF_HESSIAN_GEOMETRIC;
    if bits & !known != 0 {
        return Err(Error::InvalidArgument(format!(
            "hessians {bits:#x} has bits other than RADDIFF_HESSIAN_OCCLUSION_AWARE, _UNAWARE and \
             _GEOMETRIC"
        ))
        .into());
    }
    Ok(Hessians {
        occlusion_aware: bits & RADDIFF_HESSIAN_OCCLUSION_AWARE != 0,
        unaware: bits & RADDIFF_HESSIAN_UNAWARE != 0,
        geometric: bits & RADDIFF_HESSIAN_GEOMETRIC != 0,
    })
}

/// Evaluates a traced gather once, for records of any metric and threshold. `settings` gives the
/// channel count and weights (of the scalar the metrics measure) and the smoothing of the strata
/// the derivatives are taken from (`derivative_smoothing_azimuthal`, `_polar`); `layout`,
/// `frame` and `input` are what `raddiff_gather_evaluate` takes (a hemisphere layout; the
/// frame's position and normal are the record's); `hit_normals` (nullable) the unit surface
/// normal at every hit, needed by the unaware and geometric Hessians; `hessians` the `RADDIFF_HESSIAN_*` bits to compute (each
/// costs several times the gradient; ask only for those your metrics need). In a medium the
/// occlusion-aware Hessian attenuates the surface radiance and leaves the marched in-scattered
/// radiance out. Returns NULL (with `raddiff_last_error`) for NULL or invalid arguments, a
/// gather `raddiff_gather_evaluate` refuses, or an overflow; `input->channels` must equal
/// `settings->channels`. Free it with `raddiff_gather_evaluation_free`.
#[no_mangle]
pub extern "C" fn raddiff_gather_evaluation_new(
    settings: *const raddiff_irradiance_settings,
    layout: *const raddiff_gather_layout,
    frame: *const raddiff_frame,
    input: *const raddiff_gather_input,
    hit_normals: *const raddiff_vec3,
    hessians: u32,
) -> *mut raddiff_gather_evaluation {
    guard_ptr(|| {
        let settings = unsafe { settings_from_c(in_ref(settings, "settings")?)? };
        let layout = Layout::try_from(unsafe { in_ref(layout, "layout")? })?;
        let frame = Frame::from(unsafe { in_ref(frame, "frame")? });
        let input = unsafe { gather_input_from_c(&layout, in_ref(input, "input")?)? };
        if input.channels != settings.channels {
            return Err(Error::InvalidArgument(format!(
                "input->channels ({}) differs from settings->channels ({})",
                input.channels, settings.channels
            ))
            .into());
        }
        let hit_normals = (!hit_normals.is_null())
            .then(|| unsafe { in_slice(hit_normals, layout.len(), "hit_normals") })
            .transpose()?
            // SAFETY: raddiff_vec3 and DVec3 have the same layout (asserted in gather.rs).
            .map(|n| unsafe { std::slice::from_raw_parts(n.as_ptr().cast::<DVec3>(), n.len()) });
        let traced = TracedGather {
            layout,
            frame,
            normal: frame.normal,
            input,
            hit_normals,
            scalar_radiance: None,
        };
        let inner = GatherEvaluation::with_smoothing(
            &traced,
            &settings.weights(),
            hessians_from_c(hessians)?,
            settings.derivative_smoothing,
        )?;
        let stored: Record<Vec<f32>> = inner.record(Extent::isotropic(1.0))?;
        let gradient = stored.gradient.as_ref().map(crate::cache::channel_major);
        let rotation = stored
            .rotation_gradient
            .as_ref()
            .map(crate::cache::channel_major);
        Ok(Box::into_raw(Box::new(raddiff_gather_evaluation {
            value: stored.value,
            gradient: gradient.map_or_else(Vec::new, |g| g.to_vec()),
            rotation_gradient: rotation.map_or_else(Vec::new, |g| g.to_vec()),
            inner,
        })))
    })
}

/// Frees an evaluation (NULL is ignored). Records built from it must not be used afterwards.
#[no_mangle]
pub extern "C" fn raddiff_gather_evaluation_free(evaluation: *mut raddiff_gather_evaluation) {
    if !evaluation.is_null() {
        // SAFETY: from `raddiff_gather_evaluation_new`, freed once.
        drop(unsafe { Box::from_raw(evaluation) });
    }
}

/// Writes the evaluation's scalar results (scalar, gradient, distance, Hessians) to `*summary`.
#[no_mangle]
pub extern "C" fn raddiff_gather_evaluation_summary(
    evaluation: *const raddiff_gather_evaluation,
    summary: *mut raddiff_gather_summary,
) -> raddiff_status {
    guard(|| {
        let e = &unsafe { in_ref(evaluation, "evaluation")? }.inner;
        let summary = unsafe { out_ref(summary, "summary")? };
        let mut s = raddiff_gather_summary {
            scalar: e.scalar,
            scalar_gradient: e.scalar_gradient.to_array(),
            harmonic_mean_distance: e.harmonic_mean_distance,
            ..Default::default()
        };
        let slots = [
            (HessianKind::OcclusionAware, RADDIFF_HESSIAN_OCCLUSION_AWARE),
            (HessianKind::Unaware, RADDIFF_HESSIAN_UNAWARE),
            (HessianKind::Geometric, RADDIFF_HESSIAN_GEOMETRIC),
        ];
        for (kind, bit) in slots {
            if let Some(h) = e.hessian(kind) {
                s.hessians |= bit;
                let out = match kind {
                    HessianKind::OcclusionAware => &mut s.occlusion_hessian,
                    HessianKind::Unaware => &mut s.unaware_hessian,
                    HessianKind::Geometric => &mut s.geometric_hessian,
                };
                *out = mat3_to_row_major(h);
            }
        }
        *summary = s;
        Ok(())
    })
}

/// Builds the record of `evaluation` under `settings` (metric, accuracy, radius bounds at the
/// pixel `footprint`, anisotropy, curvature floor; the settings' channels must be the
/// evaluation's) into `*record`, ready for `raddiff_cache_insert`: position and normal from the
/// gather's frame, radii and axes from the metric, and `value`, `gradient` and
/// `rotation_gradient` pointing into `evaluation` (valid until it is freed). This is the record
/// `raddiff_cache_irradiance` inserts. `RADDIFF_ERROR_INVALID_ARGUMENT` for invalid settings, a
/// negative or non-finite footprint, bounds without a finite maximum, or a metric whose Hessian
/// the evaluation lacks.
#[no_mangle]
pub extern "C" fn raddiff_irradiance_record(
    settings: *const raddiff_irradiance_settings,
    evaluation: *const raddiff_gather_evaluation,
    footprint: f64,
    record: *mut raddiff_cache_record,
) -> raddiff_status {
    guard(|| {
        let settings = unsafe { settings_from_c(in_ref(settings, "settings")?)? };
        let evaluation = unsafe { in_ref(evaluation, "evaluation")? };
        let record = unsafe { out_ref(record, "record")? };
        let built: Record<Vec<f32>> = settings.record(&evaluation.inner, footprint)?;
        *record = raddiff_cache_record {
            position: built.position.into(),
            normal: built.normal.into(),
            value: evaluation.value.as_ptr(),
            gradient: evaluation.gradient.as_ptr(),
            rotation_gradient: evaluation.rotation_gradient.as_ptr(),
            radii: built.extent.radii,
            axes: built.extent.axes.map(raddiff_vec3::from),
            open_fraction: std::ptr::null(),
        };
        Ok(())
    })
}
