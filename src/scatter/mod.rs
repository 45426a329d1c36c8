//! Single scattering through refractive triangle meshes with interpolated normals (Holzschuch 2013,
//! INRIA RR-8312, extending Walter et al. 2009).
//!
//! Light from a point source refracts into a homogeneous medium through a triangle mesh with
//! interpolated shading normals, scatters once, and reaches an eye segment inside the mesh.
//! [`single_scatter`] integrates the single-scattered radiance along the segment by the per-triangle
//! interval method: for each triangle that survives the pruning tests ([`prune`]), the solution curve
//! of the refraction constraint ([`constraint`]) is intersected with the triangle's edges by Newton
//! solves ([`newton`]) to find the part of the segment the triangle lights ([`interval`]), which is
//! then integrated by Gauss-Legendre quadrature of the path contributions ([`contribution`]).
//! [`single_scatter_brute_force`] is the sample-point reference of Walter et al. without pruning.
//!
//! Units: positions in L, σ_t and σ_s in 1/L, intensity in power/sr; the result is radiance
//! (power / (L² sr)) arriving at the entry point inside the medium, before the refraction out.
//!
//! ```
//! use glam::DVec3;
//! use raddiff::scatter::{self, Medium, ScatterOptions};
//!
//! let mesh = scatter::scene::bumpy_sphere(6, 0.05, 6.0).build()?;
//! let medium = Medium { eta: 1.5, sigma_t: 0.5, sigma_s: 0.4, g: 0.0 };
//! let light = DVec3::new(0.0, 0.0, 5.0);
//! // An eye segment through the sphere, below the light.
//! let (entry, exit) = (DVec3::new(-0.9, 0.0, -0.3), DVec3::new(0.9, 0.0, -0.3));
//! let r = scatter::single_scatter(&mesh, &medium, entry, exit, light, 1.0, &ScatterOptions::default())?;
//! assert!(r.radiance > 0.0);
//! # Ok::<(), raddiff::Error>(())
//! ```

// `!(x > 0.0)` is used on purpose throughout: it is true for NaN, so undefined values take the
// rejecting branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bvh;
pub mod constraint;
pub mod contribution;
mod fold;
pub mod integrate;
pub mod interval;
pub mod mesh;
pub mod newton;
mod options;
pub mod prune;
pub mod quadrature;
pub mod scene;
pub mod stats;

pub use contribution::{DistanceFactor, Medium};
pub use integrate::{
    single_scatter, single_scatter_brute_force, straight_line_single_scatter, BruteForceOptions,
    ScatterOptions, ScatterResult,
};
pub use mesh::RefractiveMesh;
pub use newton::NewtonSettings;
pub use stats::ScatterStats;
