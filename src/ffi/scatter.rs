//! C wrappers for single scattering through refractive triangle meshes (`crate::scatter`).

use super::common::*;
use crate::scatter::{self, Medium, RefractiveMesh, ScatterOptions};
use crate::Error;

/// A refractive triangle mesh with per-vertex shading normals and its bounding-sphere hierarchy
/// (opaque). Create with `raddiff_refractive_mesh_new`, release with `raddiff_refractive_mesh_free`.
/// Immutable after creation: one mesh may be shared by any number of threads.
pub struct raddiff_refractive_mesh {
    inner: RefractiveMesh,
}

/// The homogeneous medium inside a refractive mesh.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct raddiff_medium {
    /// Relative index of refraction (inside over outside), > 1.
    pub eta: f64,
    /// Extinction coefficient (1/length), >= 0.
    pub sigma_t: f64,
    /// Scattering coefficient (1/length), in [0, sigma_t].
    pub sigma_s: f64,
    /// Henyey-Greenstein asymmetry in (-1, 1); 0 is isotropic.
    pub g: f64,
}

impl From<raddiff_medium> for Medium {
    fn from(m: raddiff_medium) -> Self {
        Medium {
            eta: m.eta,
            sigma_t: m.sigma_t,
            sigma_s: m.sigma_s,
            g: m.g,
        }
    }
}

fn times3(n: usize, what: &str) -> Result<usize, FfiError> {
    n.checked_mul(3)
        .ok_or_else(|| FfiError::Lib(Error::InvalidArgument(format!("{what} {n} is too large"))))
}

/// Builds a refractive mesh: `positions` and `normals` hold 3 floats per vertex (`vertex_count`
/// vertices), `indices` 3 vertex indices per triangle (`triangle_count` triangles). Triangles wind
/// counter-clockwise seen from outside; normals point outwards and need not be unit. The arrays are
/// copied. Returns NULL on failure (NULL array, no triangles, index out of range, non-finite or zero
/// normal, non-finite position, zero-area triangle, normal facing away from its triangle); see
/// `raddiff_last_error()`.
///
/// # Safety
/// Each array must be NULL or valid for reads of the stated number of elements.
#[no_mangle]
pub unsafe extern "C" fn raddiff_refractive_mesh_new(
    positions: *const f32,
    normals: *const f32,
    vertex_count: usize,
    indices: *const u32,
    triangle_count: usize,
) -> *mut raddiff_refractive_mesh {
    guard_ptr(|| {
        let nv = times3(vertex_count, "vertex_count")?;
        let nt = times3(triangle_count, "triangle_count")?;
        let positions = unsafe { in_slice(positions, nv, "positions")? };
        let normals = unsafe { in_slice(normals, nv, "normals")? };
        let indices = unsafe { in_slice(indices, nt, "indices")? };
        let inner = RefractiveMesh::from_flat(positions, normals, indices)?;
        Ok(Box::into_raw(Box::new(raddiff_refractive_mesh { inner })))
    })
}

/// Releases a mesh created by `raddiff_refractive_mesh_new`. NULL is ignored.
///
/// # Safety
/// `mesh` must be NULL or a pointer returned by `raddiff_refractive_mesh_new` not yet freed.
#[no_mangle]
pub unsafe extern "C" fn raddiff_refractive_mesh_free(mesh: *mut raddiff_refractive_mesh) {
    if !mesh.is_null() {
        drop(Box::from_raw(mesh));
    }
}

/// Single-scattered radiance arriving at `entry` along the refracted eye segment `entry -> exit`
/// inside the mesh, from a point light of intensity `intensity` (power per steradian) at `light`
/// outside the mesh: the integral over the segment of sigma_s * phase * intensity * Fresnel
/// transmittance * exp(-sigma_t (distance travelled inside)) / D over all refracted paths (see the
/// README, "Single scattering"). It is radiance inside the medium, before the refraction out towards
/// the camera (multiply by the exit Fresnel transmittance / eta^2 for the radiance outside).
///
/// Errors: NULL pointer; `RADDIFF_ERROR_INVALID_ARGUMENT` for eta <= 1, sigma_s outside
/// [0, sigma_t], |g| >= 1, non-finite input, negative intensity; for a closed mesh also entry/exit
/// outside its bounding sphere or a light inside it; `RADDIFF_ERROR_DEGENERATE` when the radiance
/// itself overflows a double (an intensity near `DBL_MAX` focused by refraction; the radiance is
/// linear in `intensity`, scaled once at the end, so any result that fits is returned). `*radiance` is written only on success;
/// `entry == exit` gives 0. Occlusion of the light paths by other parts of the mesh is not tested.
///
/// # Safety
/// `mesh` must be NULL or a live mesh from `raddiff_refractive_mesh_new`; `medium` NULL or valid
/// for reads; `radiance` NULL or valid for writes.
#[no_mangle]
pub unsafe extern "C" fn raddiff_single_scatter(
    mesh: *const raddiff_refractive_mesh,
    medium: *const raddiff_medium,
    entry: raddiff_vec3,
    exit: raddiff_vec3,
    light: raddiff_vec3,
    intensity: f64,
    radiance: *mut f64,
) -> raddiff_status {
    guard(|| {
        let mesh = unsafe { in_ref(mesh, "mesh")? };
        let medium = unsafe { in_ref(medium, "medium")? };
        let out = unsafe { out_ref(radiance, "radiance")? };
        let r = scatter::single_scatter(
            &mesh.inner,
            &(*medium).into(),
            entry.into(),
            exit.into(),
            light.into(),
            intensity,
            &ScatterOptions::default(),
        )?;
        *out = r.radiance;
        Ok(())
    })
}
