//! The occlusion-aware outputs of a gather evaluation (`occlusion_gradient` and `hessian` of
//! `raddiff_gather_evaluate`, which writes them in its C layout), with the mesh topology cached per
//! layout on each thread: the occlusion-aware Hessian of a hemisphere gather (with its marched
//! media rings) or of a sphere gather in a medium, whichever the layout is.

use std::cell::RefCell;
use std::rc::Rc;

use glam::{DMat3, DVec3};

use super::gather_mesh::{HemisphereGather, OcclusionDerivatives};
use super::media::{media_derivatives, MediaGather, MediaSteps};
use super::mesh::Topology;
use super::occlusion::occlusion_derivatives;
use crate::error::{Error, Result};
use crate::gather::evaluate::ValidGather;
use crate::gather::input::{GatherInput, MediaRadiance};
use crate::gather::layout::{Layout, LayoutKind};
use crate::Order;

/// How many layouts' topologies each thread keeps.
const CACHED_TOPOLOGIES: usize = 4;

/// A cached topology and the layout shape it belongs to.
type CachedTopology = (LayoutKind, u32, u32, Rc<Topology>);

thread_local! {
    static TOPOLOGIES: RefCell<Vec<CachedTopology>> = const { RefCell::new(Vec::new()) };
}

/// The mesh topology of `layout`, built once per thread and layout shape (the last few are kept).
pub fn cached_topology(layout: &Layout) -> Result<Rc<Topology>> {
    TOPOLOGIES.with(|cache| {
        let mut cache = cache.borrow_mut();
        if let Some(pos) = cache
            .iter()
            .position(|(k, m, n, _)| *k == layout.kind && *m == layout.m && *n == layout.n)
        {
            let entry = cache.remove(pos);
            let topo = entry.3.clone();
            cache.push(entry);
            return Ok(topo);
        }
        let topo = Rc::new(Topology::new(
            layout.kind,
            layout.m as usize,
            layout.n as usize,
        )?);
        if cache.len() >= CACHED_TOPOLOGIES {
            cache.remove(0);
        }
        cache.push((layout.kind, layout.m, layout.n, topo.clone()));
        Ok(topo)
    })
}

/// Occlusion-aware gradient and Hessian of one validated gather, per channel.
///
/// * Hemisphere layouts (irradiance): [`occlusion_derivatives`], plus one hemisphere ring per
///   march step when media radiance is given (its gradient, if any, is not used); the Hessian
///   returned is [`OcclusionDerivatives::robust_hessian`] (1% of the irradiance added to every
///   triangle; the geometric Hessian for a channel whose rays all returned black), the form record
///   radii need.
/// * Sphere layout (fluence at a point in a medium): [`media_derivatives`] (the media radiance
///   gradient, if given, is not used: Marco et al. hold radiance constant per triangle).
///
/// `hessian` selects [`Order::Hessian`]; otherwise only gradients are computed (Hessians zero).
///
/// `Degenerate` when a result overflows `f64` (radiance near `f32::MAX` at hit distances near the
/// smallest doubles), as [`ValidGather::evaluate`] does, rather than an infinity or a NaN.
pub fn occlusion_outputs(gather: &ValidGather, hessian: bool) -> Result<(Vec<DVec3>, Vec<DMat3>)> {
    let (gradients, hessians) = occlusion_outputs_unchecked(gather, hessian)?;
    // Found by fuzzing (fuzz/regressions/gather_evaluate/): finite input, infinite output.
    if !(gradients.iter().all(|g| g.is_finite()) && hessians.iter().all(|h| h.is_finite())) {
        return Err(Error::Degenerate(
            "occlusion-aware gradient or Hessian overflows (hit distances or radiance too extreme)"
                .into(),
        ));
    }
    Ok((gradients, hessians))
}

fn occlusion_outputs_unchecked(
    gather: &ValidGather,
    hessian: bool,
) -> Result<(Vec<DVec3>, Vec<DMat3>)> {
    let layout = gather.layout();
    let frame = gather.frame();
    let input: &GatherInput = gather.input();
    let topo = cached_topology(layout)?;
    let order = if hessian {
        Order::Hessian
    } else {
        Order::Gradient
    };
    if layout.kind.is_hemisphere() {
        let g = HemisphereGather {
            normal: frame.normal,
            directions: input.directions,
            distance: input.distance,
            radiance: input.radiance,
            channels: input.channels,
            sigma_t: input.sigma_t,
        };
        let mut d = occlusion_derivatives(&topo, &g, order)?;
        if let Some(media) = &input.media {
            add_media_rings(&topo, &g, media, order, &mut d)?;
        }
        let hessians = (0..input.channels)
            .map(|c| {
                if hessian {
                    d.robust_hessian(c)
                } else {
                    DMat3::ZERO
                }
            })
            .collect();
        Ok((d.gradient, hessians))
    } else {
        let g = MediaGather {
            directions: input.directions,
            distance: input.distance,
            radiance: input.radiance,
            channels: input.channels,
            sigma_t: input.sigma_t,
            media: input.media.map(|m| MediaSteps {
                radiance: m.radiance,
                steps: m.steps,
                step: m.step,
            }),
        };
        let d = media_derivatives(&topo, &g, order)?;
        Ok((
            d.channels.iter().map(|c| c.gradient).collect(),
            d.channels.iter().map(|c| c.hessian).collect(),
        ))
    }
}

/// Adds the marched media of a hemisphere gather: one hemisphere mesh per step `s` with vertices at
/// `min(t_s, d_i)` carrying the in-scattered radiance, or zero where a surface occludes the ring
/// (Marco et al. Fig. 2e with the surface form factor instead of the solid angle), weighted by the
/// step (`1/pdf`) and attenuated to each triangle's farthest vertex.
fn add_media_rings(
    topo: &Topology,
    g: &HemisphereGather,
    media: &MediaRadiance,
    order: Order,
    total: &mut OcclusionDerivatives,
) -> Result<()> {
    let count = g.directions.len();
    let ch = g.channels;
    let mut distance = vec![0.0f64; count];
    let mut radiance = vec![0.0f32; count * ch];
    for s in 0..media.steps {
        let t = (s as f64 + 0.5) * media.step;
        if !g.distance.iter().any(|&d| t < d) {
            break;
        }
        for i in 0..count {
            let visible = t < g.distance[i];
            distance[i] = if visible { t } else { g.distance[i] };
            for c in 0..ch {
                radiance[i * ch + c] = if visible {
                    media.radiance[(i * media.steps + s) * ch + c]
                } else {
                    0.0
                };
            }
        }
        let ring = HemisphereGather {
            distance: &distance,
            radiance: &radiance,
            ..*g
        };
        let d = occlusion_derivatives(topo, &ring, order)?;
        let w = media.step;
        for c in 0..ch {
            total.irradiance[c] += w * d.irradiance[c];
            total.gradient[c] += d.gradient[c] * w;
            total.hessian[c] += d.hessian[c] * w;
            total.all_black[c] &= d.all_black[c];
        }
    }
    Ok(())
}
