//! The occlusion-aware outputs of a gather evaluation (`occlusion_gradient` and `hessian` of
//! `raddiff_gather_evaluate`), with the mesh topology cached per layout on each thread.

use std::cell::RefCell;
use std::rc::Rc;

use glam::{DMat3, DVec3};

use super::hessian::{occlusion_derivatives, HemisphereGather};
use super::hessian_media::{media_derivatives, MediaGather, MediaSteps};
use super::hessian_mesh::Topology;
use super::{GatherInput, Layout, LayoutKind, ValidGather};
use crate::error::{Error, Result};
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
/// * Hemisphere layouts (irradiance): [`occlusion_derivatives`]; the Hessian returned is
///   [`super::hessian::OcclusionDerivatives::robust_hessian`] (1% of the irradiance added to every
///   triangle; the geometric Hessian for a channel whose rays all returned black), the form record
///   radii need. Marched media radiance is not part of the hemisphere triangulation:
///   `InvalidArgument` if it is given.
/// * Sphere layout (fluence at a point in a medium): [`media_derivatives`] (the media radiance
///   gradient, if given, is not used: Marco et al. hold radiance constant per triangle).
///
/// `hessian` selects [`Order::Hessian`]; otherwise only gradients are computed (Hessians zero).
pub fn occlusion_outputs(gather: &ValidGather, hessian: bool) -> Result<(Vec<DVec3>, Vec<DMat3>)> {
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
        if input.media.is_some() {
            return Err(Error::InvalidArgument(
                "occlusion_gradient/hessian of a hemisphere gather do not include marched media \
                 radiance: use the sphere layout at points in a medium, or pass no media_radiance"
                    .into(),
            ));
        }
        let g = HemisphereGather {
            normal: frame.normal,
            directions: input.directions,
            distance: input.distance,
            radiance: input.radiance,
            channels: input.channels,
            sigma_t: input.sigma_t,
        };
        let d = occlusion_derivatives(&topo, &g, order)?;
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

/// Fills the caller's `occlusion_gradient` (`3·channels`, `[3c + axis]`) and `hessian`
/// (`9·channels`, row-major `[9c + 3·row + col]`) from a validated gather (see
/// [`occlusion_outputs`]); `None` outputs are skipped, and nothing is computed when both are.
/// `InvalidArgument` if a slice has the wrong length; nothing is written on failure.
pub fn fill_from_gather(
    gather: &ValidGather,
    occlusion_gradient: Option<&mut [f64]>,
    hessian: Option<&mut [f64]>,
) -> Result<()> {
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
