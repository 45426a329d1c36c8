//! What a renderer traced for one irradiance record: the gather and the point it belongs to.

use glam::DVec3;

use crate::error::{Error, Result};
use crate::gather::{Frame, GatherInput, Layout};

/// One traced hemisphere gather at a shading point, as
/// [`GatherEvaluation::new`](super::GatherEvaluation::new) takes it. Index `i = j·N + k`
/// throughout.
#[derive(Debug, Clone, Copy)]
pub struct TracedGather<'a> {
    /// The layout the directions came from (a hemisphere layout).
    pub layout: Layout,
    /// The frame the directions were made in ([`Layout::directions`]); its position is the
    /// record's, and its normal the pole the occlusion-aware Hessian is taken about.
    pub frame: Frame,
    /// The record's surface normal: the record is stored with it and the Hessian radii are
    /// projected on its tangent plane. Unit within 1e-6; usually `frame.normal`. (A separate
    /// field so that a renderer that built its frame from a shading normal can keep that normal's
    /// exact bits in the record.)
    pub normal: DVec3,
    /// What the rays found: directions, hit distances (`f64::INFINITY` for a miss), radiance
    /// (`channels` per ray), and an optional homogeneous medium and marched media radiance.
    pub input: GatherInput<'a>,
    /// The unit surface normal at every hit (ignored for misses): needed by the
    /// occlusion-unaware and geometric Hessians only.
    pub hit_normals: Option<&'a [DVec3]>,
    /// The per-ray radiance of the metric's scalar, when the renderer has it more precisely than
    /// the channel-weighted sum of the `f32` channels (e.g. luminance computed before rounding);
    /// `None` computes it from `input.radiance` and the channel weights.
    pub scalar_radiance: Option<&'a [f32]>,
}

impl<'a> TracedGather<'a> {
    /// A traced gather on a surface outside any medium: `directions` from
    /// `layout.directions(&frame)`, `distance` and `radiance` (`channels` per ray) as traced; the
    /// record normal is `frame.normal`, no hit normals, the scalar from the channel weights.
    pub fn new(
        layout: Layout,
        frame: Frame,
        directions: &'a [DVec3],
        distance: &'a [f64],
        radiance: &'a [f32],
        channels: usize,
    ) -> Self {
        TracedGather {
            layout,
            frame,
            normal: frame.normal,
            input: GatherInput {
                directions,
                distance,
                radiance,
                channels,
                sigma_t: 0.0,
                media: None,
            },
            hit_normals: None,
            scalar_radiance: None,
        }
    }

    /// `InvalidArgument` unless the optional per-ray arrays hold one entry per direction (the
    /// scalar radiance finite) and the layout is a hemisphere's. The gather itself is validated
    /// where it is evaluated.
    pub(crate) fn check_extras(&self) -> Result<()> {
        if !self.layout.kind.is_hemisphere() {
            return Err(Error::InvalidArgument(
                "irradiance records need a hemisphere layout (cosine-polar or concentric)".into(),
            ));
        }
        let rays = self.layout.len();
        if let Some(normals) = self.hit_normals {
            if normals.len() != rays {
                return Err(Error::InvalidArgument(format!(
                    "{} hit normals for {rays} rays",
                    normals.len()
                )));
            }
        }
        if let Some(scalar) = self.scalar_radiance {
            if scalar.len() != rays {
                return Err(Error::InvalidArgument(format!(
                    "{} scalar radiance values for {rays} rays",
                    scalar.len()
                )));
            }
            if let Some(i) = scalar.iter().position(|v| !v.is_finite()) {
                return Err(Error::InvalidArgument(format!(
                    "scalar_radiance[{i}] is not finite ({})",
                    scalar[i]
                )));
            }
        }
        Ok(())
    }
}
