//! C wrappers for hemisphere and sphere gathers (`raddiff_gather_*`).
// The C functions take raw pointers by contract (documented per argument) and NULL-check them;
// marking them `unsafe fn` would change nothing for C callers.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use glam::DVec3;

use super::common::*;
use crate::gather::hessian::occlusion_outputs;
use crate::gather::{
    self, Frame, GatherInput, Layout, LayoutKind, MediaRadiance, ValidGather, Wanted,
};
use crate::Error;

/// Ward-Heckbert cosine-weighted polar strata: `theta_j = asin(sqrt((j+u)/m))`, `phi_k = 2 pi (k+v)/n`.
pub const RADDIFF_LAYOUT_COSINE_POLAR: u32 = 0;
/// Cosine-weighted strata from the Shirley-Chiu concentric map of an m x n grid (its walls are the
/// images of the grid lines; their Ward-Heckbert terms are integrated numerically).
pub const RADDIFF_LAYOUT_CONCENTRIC: u32 = 1;
/// Whole sphere, m x n equal solid-angle strata (`cos theta_j = 1 - 2(j+u)/m`), for points in a medium.
pub const RADDIFF_LAYOUT_SPHERE: u32 = 2;
/// Largest m or n of a gather layout.
pub const RADDIFF_GATHER_MAX_STRATA_PER_AXIS: u32 = 65536;
/// Largest m*n of a gather layout.
pub const RADDIFF_GATHER_MAX_STRATA: u64 = 16777216;

/// The frame of a gather: `position`, unit `normal`, unit `tangent` perpendicular to it (each within
/// 1e-6); the bitangent is `normal x tangent`. Local direction (lx, ly, lz) is
/// `lx*tangent + ly*bitangent + lz*normal`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct raddiff_frame {
    /// The gather point.
    pub position: raddiff_vec3,
    /// Unit normal: the pole of the layout.
    pub normal: raddiff_vec3,
    /// Unit tangent, perpendicular to the normal: azimuth 0.
    pub tangent: raddiff_vec3,
}

/// An m x n stratified layout: `kind` is a `RADDIFF_LAYOUT_*` constant; 1 <= m, n <=
/// `RADDIFF_GATHER_MAX_STRATA_PER_AXIS`, m*n <= `RADDIFF_GATHER_MAX_STRATA`. Seed 0: stratum centres;
/// any other seed: deterministic jitter, identical on every platform.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct raddiff_gather_layout {
    /// `RADDIFF_LAYOUT_COSINE_POLAR`, `_CONCENTRIC` or `_SPHERE`.
    pub kind: u32,
    /// Strata along theta (or the first concentric grid axis).
    pub m: u32,
    /// Strata along phi (or the second concentric grid axis).
    pub n: u32,
    /// 0 for stratum centres, otherwise jitter seed.
    pub seed: u64,
}

/// What the rays found. Index `i = j*n + k`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct raddiff_gather_input {
    /// m*n world directions as returned by `raddiff_gather_directions`.
    pub directions: *const raddiff_vec3,
    /// m*n hit distances (> 0); `INFINITY` for a miss (distant environment).
    pub distance: *const f64,
    /// m*n*channels radiance leaving each hit towards x (environment radiance for a miss), before
    /// attenuation; index `i*channels + c`.
    pub radiance: *const f32,
    /// Values per direction (>= 1).
    pub channels: u32,
    /// Homogeneous extinction (1/L) between x and the hits, >= 0; 0 = no medium. With a medium a miss
    /// is attenuated to zero.
    pub sigma_t: f64,
    /// Nullable: m*n*steps*channels in-scattered radiance `sigma_s*L_i` (plus emission) at
    /// `t_s = (s + 0.5)*step` along each direction, before attenuation; index
    /// `(i*steps + s)*channels + c`. Sample s stands for `[s*step, (s+1)*step]`; samples beyond a
    /// direction's hit are not read.
    pub media_radiance: *const f32,
    /// Nullable: m*n*steps*3*channels world-space gradient of `media_radiance`; index
    /// `((i*steps + s)*channels + c)*3 + axis`.
    pub media_radiance_gradient: *const f32,
    /// Media march steps per direction (>= 1 when `media_radiance` is given).
    pub steps: u32,
    /// Media march step length (> 0 when `media_radiance` is given).
    pub step: f64,
}

/// Caller-owned outputs; a NULL array means "not wanted" and its work is skipped. Per-channel
/// vectors are stored channel by channel: `gradient[3*c + axis]`, `hessian[9*c + 3*row + col]`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct raddiff_gather_output {
    /// channels: irradiance (hemisphere layouts) or scalar fluence (sphere). With L the largest
    /// |radiance| and no medium, at most pi L (4 pi L for the sphere).
    pub irradiance: *mut f64,
    /// 3*channels: Ward-Heckbert translational gradient (world axes, all three components), with the
    /// participating-media terms of Jarosz et al. 2008 when a medium is given. Without a medium its
    /// length is at most 2 pi (2m + n) L / min_distance.
    pub gradient: *mut f64,
    /// 3*channels: rotational gradient (world axes); zero for the sphere layout. Its length is at
    /// most (pi^2/2) L.
    pub rotation_gradient: *mut f64,
    /// 3*channels: occlusion-aware gradient of the triangulated environment (thesis ch. 6; Marco et
    /// al. 2018 sec. 4 for the sphere layout and for marched media radiance). Observed on random
    /// valid gathers: length at most 4 (m + n) L / min_distance (docs/robustness.md).
    pub occlusion_gradient: *mut f64,
    /// 9*channels: occlusion-aware 3x3 translation Hessian, row-major; for hemisphere layouts with
    /// the thesis' robustness terms (1% of the irradiance on every triangle, geometric Hessian for an
    /// all-black channel; their tangent projection is zero, so they change no radius). For robust
    /// radii pass it to raddiff_surface_radii_floored with `harmonic_mean_distance`. Observed on
    /// random valid gathers: Frobenius norm at most 16 (m + n) L / min_distance^2.
    pub hessian: *mut f64,
    /// Harmonic mean of the hit distances, m*n / sum(1/r); INFINITY if every ray missed.
    pub harmonic_mean_distance: f64,
    /// Smallest hit distance; INFINITY if every ray missed.
    pub min_distance: f64,
}

const _: () = assert!(
    RADDIFF_GATHER_MAX_STRATA_PER_AXIS == Layout::MAX_STRATA_PER_AXIS
        && RADDIFF_GATHER_MAX_STRATA == Layout::MAX_STRATA
);

// The directions array is read in place as glam vectors: both are three packed doubles.
const _: () = assert!(
    std::mem::size_of::<raddiff_vec3>() == std::mem::size_of::<DVec3>()
        && std::mem::align_of::<raddiff_vec3>() == std::mem::align_of::<DVec3>()
);

impl TryFrom<&raddiff_gather_layout> for Layout {
    type Error = Error;
    fn try_from(l: &raddiff_gather_layout) -> Result<Layout, Error> {
        Layout::new(LayoutKind::try_from(l.kind)?, l.m, l.n, l.seed)
    }
}

impl From<&raddiff_frame> for Frame {
    fn from(f: &raddiff_frame) -> Frame {
        Frame {
            position: f.position.into(),
            normal: f.normal.into(),
            tangent: f.tangent.into(),
        }
    }
}

/// Writes the m*n world directions of `layout` at `frame` (index `j*n + k`) to `directions`.
#[no_mangle]
pub extern "C" fn raddiff_gather_directions(
    layout: *const raddiff_gather_layout,
    frame: *const raddiff_frame,
    directions: *mut raddiff_vec3,
) -> raddiff_status {
    guard(|| {
        let layout = Layout::try_from(unsafe { in_ref(layout, "layout")? })?;
        let frame = Frame::from(unsafe { in_ref(frame, "frame")? });
        if directions.is_null() {
            return Err(FfiError::Null("directions"));
        }
        let dirs = layout.directions(&frame)?;
        let out = unsafe { std::slice::from_raw_parts_mut(directions, dirs.len()) };
        for (o, d) in out.iter_mut().zip(dirs) {
            *o = d.into();
        }
        Ok(())
    })
}

/// Irradiance (or fluence) and its derivatives from a traced gather (see `gather::evaluate`).
/// Every output array that is non-NULL is written on success; nothing is written on failure.
/// Every direction must lie in its own stratum of `layout` in `frame` (within 1e-6 in the layout's
/// coordinates; any seed's jitter passes): shifted, cyclically shifted or swapped rows or columns,
/// or a direction from the far side, give `RADDIFF_ERROR_INVALID_ARGUMENT` with a message naming
/// the first bad index, its row j and column k, and where it lies (docs/robustness.md).
#[no_mangle]
pub extern "C" fn raddiff_gather_evaluate(
    layout: *const raddiff_gather_layout,
    frame: *const raddiff_frame,
    input: *const raddiff_gather_input,
    output: *mut raddiff_gather_output,
) -> raddiff_status {
    guard(|| {
        let layout = Layout::try_from(unsafe { in_ref(layout, "layout")? })?;
        let frame = Frame::from(unsafe { in_ref(frame, "frame")? });
        let input = unsafe { gather_input_from_c(&layout, in_ref(input, "input")?)? };
        let output = unsafe { out_ref(output, "output")? };
        let ch = input.channels;
        let wanted = Wanted {
            irradiance: !output.irradiance.is_null(),
            gradient: !output.gradient.is_null(),
            rotation_gradient: !output.rotation_gradient.is_null(),
            distances: true,
        };
        // Validate once; the evaluation and the occlusion-aware pass share it.
        let valid = gather::ValidGather::new(&layout, &frame, &input)?;
        let values = valid.evaluate(wanted)?;
        unsafe {
            let occlusion_gradient = (!output.occlusion_gradient.is_null())
                .then(|| std::slice::from_raw_parts_mut(output.occlusion_gradient, 3 * ch));
            let hessian = (!output.hessian.is_null())
                .then(|| std::slice::from_raw_parts_mut(output.hessian, 9 * ch));
            // Computes before writing: on failure nothing has been written.
            fill_from_gather(&valid, occlusion_gradient, hessian)?;
            write(output.irradiance, &values.irradiance);
            write_vec3(output.gradient, &values.gradient);
            write_vec3(output.rotation_gradient, &values.rotation_gradient);
        }
        output.harmonic_mean_distance = values.harmonic_mean_distance.unwrap_or(f64::INFINITY);
        output.min_distance = values.min_distance.unwrap_or(f64::INFINITY);
        Ok(())
    })
}

/// The C layout of [`raddiff_gather_evaluate`]'s occlusion-aware outputs: fills the caller's
/// `occlusion_gradient` (`3·channels`, `[3c + axis]`) and `hessian` (`9·channels`, row-major
/// `[9c + 3·row + col]`) from a validated gather (see [`occlusion_outputs`]); `None` outputs are
/// skipped, and nothing is computed when both are.
/// `InvalidArgument` if a slice has the wrong length; nothing is written on failure.
pub fn fill_from_gather(
    gather: &ValidGather,
    occlusion_gradient: Option<&mut [f64]>,
    hessian: Option<&mut [f64]>,
) -> crate::Result<()> {
    if occlusion_gradient.is_none() && hessian.is_none() {
        return Ok(());
    }
    let ch = gather.input().channels;
    if occlusion_gradient
        .as_ref()
        .is_some_and(|g| g.len() != 3 * ch)
        || hessian.as_ref().is_some_and(|h| h.len() != 9 * ch)
    {
        return Err(Error::InvalidArgument(
            "occlusion_gradient must hold 3*channels and hessian 9*channels values".into(),
        ));
    }
    let (gradients, hessians) = occlusion_outputs(gather, hessian.is_some())?;
    if let Some(out) = occlusion_gradient {
        for (o, g) in out.chunks_exact_mut(3).zip(&gradients) {
            o.copy_from_slice(&g.to_array());
        }
    }
    if let Some(out) = hessian {
        for (o, h) in out.chunks_exact_mut(9).zip(&hessians) {
            o.copy_from_slice(&h.transpose().to_cols_array());
        }
    }
    Ok(())
}

/// The Rust view of a C gather input for `layout` (array sizes from the layout and the channel
/// count; values are validated where the gather is evaluated).
///
/// # Safety
/// Every non-NULL array of `input` is valid for the reads its documentation gives it.
pub(crate) unsafe fn gather_input_from_c<'a>(
    layout: &Layout,
    input: &'a raddiff_gather_input,
) -> Result<GatherInput<'a>, FfiError> {
    let cells = layout.len();
    let ch = input.channels as usize;
    let directions: &[raddiff_vec3] = in_slice(input.directions, cells, "input->directions")?;
    // SAFETY: same size and alignment (asserted above), both plain triples of f64.
    let directions: &[DVec3] =
        std::slice::from_raw_parts(directions.as_ptr().cast(), directions.len());
    let distance = in_slice(input.distance, cells, "input->distance")?;
    let radiance = in_slice(input.radiance, cells * ch, "input->radiance")?;
    let media = if input.media_radiance.is_null() {
        if !input.media_radiance_gradient.is_null() {
            return Err(Error::InvalidArgument(
                "media_radiance_gradient is given without media_radiance".into(),
            )
            .into());
        }
        None
    } else {
        let steps = input.steps as usize;
        let samples = cells
            .checked_mul(steps)
            .and_then(|v| v.checked_mul(ch))
            .and_then(|v| v.checked_mul(3).map(|_| v))
            .ok_or_else(|| {
                Error::InvalidArgument("m*n*steps*3*channels overflows size_t".into())
            })?;
        let radiance = in_slice(input.media_radiance, samples, "input->media_radiance")?;
        let gradient = if input.media_radiance_gradient.is_null() {
            None
        } else {
            Some(in_slice(
                input.media_radiance_gradient,
                3 * samples,
                "input->media_radiance_gradient",
            )?)
        };
        Some(MediaRadiance {
            radiance,
            gradient,
            steps,
            step: input.step,
        })
    };
    Ok(GatherInput {
        directions,
        distance,
        radiance,
        channels: ch,
        sigma_t: input.sigma_t,
        media,
    })
}

/// # Safety
/// `dst` is NULL or valid for `src.len()` writes.
unsafe fn write(dst: *mut f64, src: &[f64]) {
    if !dst.is_null() {
        std::slice::from_raw_parts_mut(dst, src.len()).copy_from_slice(src);
    }
}

/// # Safety
/// `dst` is NULL or valid for `3 * src.len()` writes.
unsafe fn write_vec3(dst: *mut f64, src: &[DVec3]) {
    if !dst.is_null() {
        let out = std::slice::from_raw_parts_mut(dst, 3 * src.len());
        for (o, v) in out.chunks_exact_mut(3).zip(src) {
            o.copy_from_slice(&v.to_array());
        }
    }
}
