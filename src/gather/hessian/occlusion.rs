//! Occlusion-aware irradiance gradients and Hessians from a hemisphere gather (Schwarzhaupt et al.,
//! thesis ch. 6), and the occlusion-unaware radiometric and geometric Hessians they improve on
//! (thesis ch. 4, Jarosz et al. 2012; in [`super::unaware`]).
//!
//! # Method
//!
//! The hit points of the gather's rays are triangulated with the layout's grid connectivity
//! ([`Topology`]; horizon ring and, for the polar layout, a pole vertex close the hemisphere).
//! The mesh is a snapshot of the scene seen from x: where a near occluder meets a far wall, long
//! "occlusion triangles" join them. Each triangle Δ carries the radiance `L_Δ` of its **farthest**
//! vertex (what a translation of x disoccludes) and irradiance is `E(x) ≈ Σ_Δ L_Δ F_Δ(x)` with the
//! point-to-triangle form factors of the mesh held fixed (eq. 6.1; reported times π, in the
//! gather's irradiance units); the gradient and Hessian are the sums of the form-factor gradients and
//! Hessians weighted by `L_Δ` (eq. 6.2-6.3).
//!
//! A triangle's form factor is the sum of its three edge terms (the closed-form edge integral
//! behind `kernels::edge_form_factor`, called directly on validated, power-of-two rescaled
//! positions), and an interior edge appears in its two triangles with opposite orientations, so
//!
//! ```text
//!   Σ_Δ L_Δ F_Δ = Σ_edges (L_left − L_right) f_edge      (L_right = 0 on the horizon)
//! ```
//!
//! Every edge term is computed once (about 3 per sample instead of 6), and edges whose two
//! triangles carry the same radiance cost nothing. With unit radiance everywhere only the horizon
//! edges remain: that is the mesh's total form factor and its derivatives
//! ([`Geometric`](super::gather_mesh::Geometric)), which is exactly 1 for any mesh whose horizon ring lies in the tangent plane (within 1e-13 in the tests).
//! The edge terms are signed, so quads folded over by jitter cancel correctly.
//!
//! # Misses
//!
//! A ray that hits nothing sees a distant environment. Its vertex is placed along its direction
//! at [`FAR_DISTANCE_FACTOR`](super::gather_mesh::FAR_DISTANCE_FACTOR) times the largest
//! finite hit distance (times 1 L if nothing was hit). All positions are relative to x (x is the origin of every kernel call), so nothing is lost to
//! large world coordinates, and every edge is measured from its nearer end, so near-to-far
//! occlusion edges keep full precision (from the far end the edge's foot point would lose about
//! log10(far/near) digits). Edges between two environment vertices with equal radiance cost
//! nothing and cannot cancel; the far geometry's own derivatives fall like `1/FAR_DISTANCE_FACTOR`.
//!
//! # Participating media
//!
//! With `sigma_t > 0` every triangle's radiance is attenuated by the transmittance to its farthest
//! vertex, `L_Δ T(x, y_Δ)`, and the product rule applies per triangle (Marco et al. eq. 17-18 with a
//! constant phase function): `∇(L T F) = L (T ∇F + F ∇T)`,
//! `H(L T F) = L (T HF + ∇T ∇Fᵀ + ∇F ∇Tᵀ + F HT)`. The `T ∇F` and `T HF` parts are edge sums like
//! the surface path's (weights `L_left T_left − L_right T_right`, same batched edge kernel); only
//! `F` and `∇F` of each triangle are summed from its three edges for the other terms. Misses are
//! attenuated to zero (the medium is unbounded).
//!
//! # Robustness (thesis sec. 6.3)
//!
//! The thesis makes radii robust by adding 1% of the irradiance to every triangle radiance
//! ([`OcclusionDerivatives::robust_hessian`], `H + 0.01 E H_geometric`, and the geometric Hessian
//! alone for a channel in which every ray returned black). The mesh is closed, and the irradiance
//! from a closed environment of uniform radiance is the same everywhere inside it, so
//! `H_geometric`'s tangent projection is zero (to rounding): the term changes no radius, and a
//! black gather keeps the largest one. The robustness term that works is the curvature floor of
//! [`crate::gather::radii::surface_radii_floored`].

use super::gather_mesh::{HemisphereGather, MeshGeometry, OcclusionDerivatives};
use super::mesh::Topology;
use super::workspace::OcclusionWorkspace;
use crate::error::Result;
use crate::Order;

/// Occlusion-aware irradiance, gradient and (for [`Order::Hessian`]) Hessian of one gather
/// (thesis eq. 6.1-6.3; module docs), each edge term computed once.
///
/// `order` must be at least [`Order::Gradient`]. Errors: `InvalidArgument` for inconsistent sizes,
/// non-finite values, non-positive distances or non-unit directions/normal; `Degenerate` if a kernel
/// cannot evaluate an edge (x on a mesh edge, which valid gathers cannot produce).
///
/// Scratch memory comes from a per-thread [`OcclusionWorkspace`] (kept for gathers of up to
/// [`KEPT_WORKSPACE_VERTICES`] mesh vertices); [`occlusion_derivatives_with`] takes the caller's.
pub fn occlusion_derivatives(
    topo: &Topology,
    g: &HemisphereGather,
    order: Order,
) -> Result<OcclusionDerivatives> {
    with_thread_workspace(|ws| occlusion_derivatives_with(ws, topo, g, order))
}

/// [`occlusion_derivatives`] with the caller's scratch memory (the same results).
pub fn occlusion_derivatives_with(
    workspace: &mut OcclusionWorkspace,
    topo: &Topology,
    g: &HemisphereGather,
    order: Order,
) -> Result<OcclusionDerivatives> {
    let (scale, far_distance) = workspace.place_gather(topo, g)?;
    workspace.derivatives(topo, g, order, scale, far_distance)
}

/// [`occlusion_derivatives`] on an already placed mesh.
pub fn occlusion_derivatives_on(
    topo: &Topology,
    mesh: &MeshGeometry,
    g: &HemisphereGather,
    order: Order,
) -> Result<OcclusionDerivatives> {
    with_thread_workspace(|ws| {
        let scale = ws.place_mesh(mesh);
        ws.derivatives(topo, g, order, scale, mesh.far_distance)
    })
}

/// The per-thread workspace keeps at most this many mesh vertices' worth of memory (100 to 250 bytes
/// each) between calls; larger gathers release theirs.
pub const KEPT_WORKSPACE_VERTICES: usize = 1 << 16;

thread_local! {
    static WORKSPACE: std::cell::Cell<OcclusionWorkspace> =
        std::cell::Cell::new(OcclusionWorkspace::new());
}

/// Runs `f` on this thread's workspace, taken out of its slot for the call (so a nested call, or
/// one during thread teardown, simply starts an empty one).
fn with_thread_workspace<R>(f: impl FnOnce(&mut OcclusionWorkspace) -> R) -> R {
    let mut ws = WORKSPACE.try_with(|w| w.take()).unwrap_or_default();
    let r = f(&mut ws);
    if ws.vertex_capacity() <= KEPT_WORKSPACE_VERTICES {
        // Fails only while the thread is being torn down: the memory is then simply freed.
        let _ = WORKSPACE.try_with(|w| w.set(ws));
    }
    r
}
