//! The gather's derivatives beyond the Ward-Heckbert gradients: irradiance (or fluence) Hessians
//! from the rays of one gather, for record radii (`super::radii`) and second-order extrapolation.
//!
//! # Which Hessian answers what
//!
//! | Question | Module | Entry point |
//! | --- | --- | --- |
//! | occlusion-aware gradient and Hessian at a surface point (Schwarzhaupt et al., thesis ch. 6) | [`occlusion`] | [`occlusion_derivatives`] (and `_with` a workspace, `_on` a placed mesh) |
//! | the same at a point in a medium, sphere gather (Marco et al. 2018, sec. 4), and in flatland | [`media`] | [`media::media_derivatives`], [`media::flatland_derivatives`] |
//! | occlusion-unaware radiometric and geometric Hessians (thesis ch. 4, Jarosz et al. 2012) | [`unaware`] | [`unaware::unaware_derivatives`], [`unaware::geometric_hessian`] |
//! | whichever of the first two a validated gather's layout calls for, with the robustness term | [`outputs`] | [`outputs::occlusion_outputs`] |
//!
//! The occlusion-aware Hessians triangulate the gather's hit points with the layout's grid
//! connectivity ([`mesh::Topology`], built once per layout) and differentiate the form factors
//! (solid angles in a medium) of the mesh's triangles held fixed: near-to-far "occlusion
//! triangles" carry what a translation of x disoccludes. Their error is that of the mesh against
//! the scene (it converges with the strata, `docs/gathers.md`), plus rounding: every edge term is
//! the kernels' closed-form edge integral, evaluated from its nearer end. The unaware Hessians are
//! Monte-Carlo estimates that hold visibility fixed and need hit normals; they are kept to compare
//! against.
//!
//! # Layers inside the folder
//!
//! Lowest first, each importing only those before it: [`mesh`] (topology); `gather_mesh` (the
//! gather placed as a mesh relative to x, its checks, scaling, edge term and result assembly);
//! `edges` (the surface path's edge terms in vector batches); `workspace` (the evaluation on
//! reusable buffers); [`occlusion`] (the entry points and the per-thread workspace); [`media`],
//! [`unaware`]; [`outputs`] (the per-layout dispatch the gather evaluation and the C ABI call,
//! which writes the results in its C layout in `ffi`). Beside them, `reference` holds the
//! references the tests and benches compare the occlusion-aware path against, compiled only with
//! the `reference` feature.

pub(crate) mod edges;
mod gather_mesh;
pub mod media;
pub mod mesh;
pub mod occlusion;
pub mod outputs;
#[cfg(feature = "reference")]
mod reference;
pub mod unaware;
mod workspace;

pub use crate::gather::layout::LayoutKind;
pub use gather_mesh::{
    mesh_geometry, Geometric, HemisphereGather, MeshGeometry, OcclusionDerivatives,
    FAR_DISTANCE_FACTOR, ROBUST_FRACTION,
};
pub use mesh::{Edge, Topology};
pub use occlusion::{
    occlusion_derivatives, occlusion_derivatives_on, occlusion_derivatives_with,
    KEPT_WORKSPACE_VERTICES,
};
pub use outputs::{cached_topology, occlusion_outputs};
#[cfg(feature = "reference")]
pub use reference::{occlusion_derivatives_per_triangle, occlusion_derivatives_reference};
pub use workspace::OcclusionWorkspace;
