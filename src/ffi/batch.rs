//! C wrappers for the batch kernels: solid angles and form factors of a whole triangle mesh seen
//! from one point, and of one triangle seen from many points.

// C entry points take raw pointers by design: each is NULL-checked and its validity for the
// stated length is the C caller's contract, documented on every function.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::ffi::c_void;

use glam::DVec3;

use super::common::*;
use crate::kernels::{self, TriangleMesh, VertexData};
use crate::{Deriv3, Error, Order};

/// `raddiff_triangle_mesh.vertex_format`: three `float` per vertex (Embree's `RTC_FORMAT_FLOAT3`).
pub const RADDIFF_VERTEX_FLOAT3: u32 = 0;
/// `raddiff_triangle_mesh.vertex_format`: three `double` per vertex.
pub const RADDIFF_VERTEX_DOUBLE3: u32 = 1;

/// A triangle set the caller already holds, read in place (nothing is copied or kept): the vertex
/// and index buffers a renderer shares with its ray tracer (Embree-style, with byte strides).
///
/// Vertex `i` is the three coordinates (`float` or `double`, per `vertex_format`) at byte offset
/// `i * vertex_stride` from `vertices`; triangle `t` has the three `uint32_t` vertex indices at
/// byte offset `t * index_stride` from `indices`, or, when `indices` is NULL, the vertices `3t`,
/// `3t + 1`, `3t + 2` (a triangle soup). A stride of 0 means packed (12 or 24 bytes per vertex,
/// 12 bytes per index triple); strides must be multiples of the element size, and both buffers
/// aligned to their element type. Every call validates the mesh (each index below `vertex_count`,
/// every vertex finite) and names the first bad element in `raddiff_last_error()`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct raddiff_triangle_mesh {
    /// The first vertex (`vertex_count` vertices; may be NULL when `vertex_count` is 0).
    pub vertices: *const c_void,
    /// `RADDIFF_VERTEX_FLOAT3` or `RADDIFF_VERTEX_DOUBLE3`.
    pub vertex_format: u32,
    /// Bytes from one vertex to the next (0: packed).
    pub vertex_stride: usize,
    /// The number of vertices.
    pub vertex_count: usize,
    /// `triangle_count` index triples, or NULL for a triangle soup.
    pub indices: *const u32,
    /// Bytes from one index triple to the next (0: packed, 12).
    pub index_stride: usize,
    /// The number of triangles.
    pub triangle_count: usize,
}

fn invalid(m: String) -> FfiError {
    Error::InvalidArgument(format!("triangle mesh: {m}")).into()
}

/// An element stride from a byte stride (0: `packed` elements).
fn stride(bytes: usize, elem: usize, packed: usize, what: &str) -> Result<usize, FfiError> {
    if bytes == 0 {
        return Ok(packed);
    }
    if bytes % elem != 0 || bytes < packed * elem {
        return Err(invalid(format!(
            "{what} stride {bytes} is not a multiple of {elem} bytes of at least {}",
            packed * elem
        )));
    }
    Ok(bytes / elem)
}

/// Elements spanned by `count` items `stride` elements apart, each 3 long.
fn span(count: usize, stride: usize, what: &str) -> Result<usize, FfiError> {
    if count == 0 {
        return Ok(0);
    }
    (count - 1)
        .checked_mul(stride)
        .and_then(|n| n.checked_add(3))
        .ok_or_else(|| invalid(format!("{count} {what} do not fit in memory")))
}

/// # Safety
/// `T` must be the element type the pointer is documented to point to; `ptr` NULL or valid for
/// `len` reads.
unsafe fn aligned_slice<'a, T>(
    ptr: *const T,
    len: usize,
    name: &'static str,
) -> Result<&'a [T], FfiError> {
    if len > 0 && !ptr.is_null() && ptr.align_offset(std::mem::align_of::<T>()) != 0 {
        return Err(invalid(format!(
            "{name} is not aligned to {} bytes",
            std::mem::align_of::<T>()
        )));
    }
    in_slice(ptr, len, name)
}

impl raddiff_triangle_mesh {
    /// The validated Rust view of the caller's buffers.
    ///
    /// # Safety
    /// The buffers must be valid for the sizes the struct states.
    unsafe fn view(&self) -> Result<TriangleMesh<'_>, FfiError> {
        let (vertices, vstride) = match self.vertex_format {
            RADDIFF_VERTEX_FLOAT3 => {
                let s = stride(self.vertex_stride, 4, 3, "vertex")?;
                let len = span(self.vertex_count, s, "vertices")?;
                let p = self.vertices.cast::<f32>();
                (VertexData::F32(aligned_slice(p, len, "mesh vertices")?), s)
            }
            RADDIFF_VERTEX_DOUBLE3 => {
                let s = stride(self.vertex_stride, 8, 3, "vertex")?;
                let len = span(self.vertex_count, s, "vertices")?;
                let p = self.vertices.cast::<f64>();
                (VertexData::F64(aligned_slice(p, len, "mesh vertices")?), s)
            }
            f => {
                return Err(invalid(format!(
                "vertex_format {f} is not RADDIFF_VERTEX_FLOAT3 (0) or RADDIFF_VERTEX_DOUBLE3 (1)"
            )))
            }
        };
        let (indices, istride) = if self.indices.is_null() {
            (None, 3)
        } else {
            let s = stride(self.index_stride, 4, 3, "index")?;
            let len = span(self.triangle_count, s, "triangles")?;
            (Some(aligned_slice(self.indices, len, "mesh indices")?), s)
        };
        Ok(TriangleMesh::new(
            vertices,
            vstride,
            self.vertex_count,
            indices,
            istride,
            self.triangle_count,
        )?)
    }
}

/// The caller's per-element output arrays, checked before anything is computed and written only
/// once every element succeeded.
struct Outputs {
    values: *mut f64,
    gradients: *mut f64,
    hessians: *mut f64,
    count: usize,
    order: Order,
}

impl Outputs {
    fn new(
        values: *mut f64,
        gradients: *mut f64,
        hessians: *mut f64,
        count: usize,
        order: Order,
    ) -> Result<Outputs, FfiError> {
        if count > 0 {
            if values.is_null() {
                return Err(FfiError::Null("values"));
            }
            if order.gradient() && gradients.is_null() {
                return Err(FfiError::Null("gradients (order includes the gradient)"));
            }
            if order.hessian() && hessians.is_null() {
                return Err(FfiError::Null("hessians (order includes the Hessian)"));
            }
        }
        Ok(Outputs {
            values,
            gradients,
            hessians,
            count,
            order,
        })
    }

    /// # Safety
    /// The arrays must be valid for `count`, `3 count` and `9 count` writes (those `order` needs).
    unsafe fn write(&self, results: &[Deriv3]) {
        debug_assert_eq!(results.len(), self.count);
        if self.count == 0 {
            return;
        }
        let values = std::slice::from_raw_parts_mut(self.values, self.count);
        for (v, d) in values.iter_mut().zip(results) {
            *v = d.value;
        }
        if self.order.gradient() {
            let g = std::slice::from_raw_parts_mut(self.gradients, 3 * self.count);
            for (g, d) in g.chunks_exact_mut(3).zip(results) {
                g.copy_from_slice(&d.gradient.to_array());
            }
        }
        if self.order.hessian() {
            let h = std::slice::from_raw_parts_mut(self.hessians, 9 * self.count);
            for (h, d) in h.chunks_exact_mut(9).zip(results) {
                h.copy_from_slice(&mat3_to_row_major(d.hessian));
            }
        }
    }
}

/// Points given as `raddiff_vec3`, read in place as `DVec3` (same layout, asserted in
/// `ffi::kernels`).
///
/// # Safety
/// `points` NULL or valid for `count` reads.
unsafe fn read_points<'a>(
    points: *const raddiff_vec3,
    count: usize,
    name: &'static str,
) -> Result<&'a [DVec3], FfiError> {
    in_slice(points.cast::<DVec3>(), count, name)
}

/// Sum over the triangles of `mesh` of the unsigned solid angle (steradians) each subtends at `x`,
/// with gradient and Hessian with respect to `x` (see `raddiff_triangle_solid_angle` for the
/// limits per triangle, and the Rust `kernels::mesh_solid_angle`). Overlapping triangles count
/// once each. `RADDIFF_ERROR_DEGENERATE` (message naming the triangle) when `x` is on an edge or
/// at a vertex of a triangle.
///
/// # Safety
/// `mesh` must be NULL or point to a `raddiff_triangle_mesh` whose buffers are valid for the sizes
/// it states; `out` NULL or valid for one write.
#[no_mangle]
pub unsafe extern "C" fn raddiff_mesh_solid_angle(
    x: raddiff_vec3,
    mesh: *const raddiff_triangle_mesh,
    order: u32,
    out: *mut raddiff_deriv3,
) -> raddiff_status {
    guard(|| {
        let mesh = unsafe { in_ref(mesh, "mesh")?.view()? };
        let out = unsafe { out_ref(out, "out")? };
        let order = order_from_c(order)?;
        *out = kernels::mesh_solid_angle(x.into(), &mesh, order)?.into();
        Ok(())
    })
}

/// The unsigned solid angle of each triangle of `mesh` seen from `x` (as
/// `raddiff_mesh_solid_angle`, not summed): `values[t]`, `gradients[3t..3t+3]` and
/// `hessians[9t..9t+9]` (row-major). `values` must hold `triangle_count` doubles; `gradients`
/// (3 per triangle) is required from `RADDIFF_ORDER_GRADIENT` on and `hessians` (9 per triangle)
/// for `RADDIFF_ORDER_HESSIAN`, otherwise ignored (may be NULL). Nothing is written on error.
///
/// # Safety
/// As `raddiff_mesh_solid_angle`; the output arrays NULL or valid for the writes stated.
#[no_mangle]
pub unsafe extern "C" fn raddiff_mesh_solid_angle_each(
    x: raddiff_vec3,
    mesh: *const raddiff_triangle_mesh,
    order: u32,
    values: *mut f64,
    gradients: *mut f64,
    hessians: *mut f64,
) -> raddiff_status {
    guard(|| {
        let mesh = unsafe { in_ref(mesh, "mesh")?.view()? };
        let order = order_from_c(order)?;
        let outs = Outputs::new(values, gradients, hessians, mesh.len(), order)?;
        let mut results = vec![Deriv3::default(); mesh.len()];
        kernels::mesh_solid_angle_each(x.into(), &mesh, order, &mut results)?;
        unsafe { outs.write(&results) };
        Ok(())
    })
}

/// Sum over the triangles of `mesh` of the form factor from a differential area at `x` with unit
/// normal `n` to each triangle (see `raddiff_triangle_form_factor`: two-sided, clipped to the
/// half-space above the tangent plane; the Rust `kernels::mesh_form_factor`). No occlusion between
/// the triangles is accounted for. Triangles of (numerically) zero area contribute 0.
/// `RADDIFF_ERROR_DEGENERATE` (naming the triangle) for derivatives with `x` in a triangle's plane.
///
/// # Safety
/// As `raddiff_mesh_solid_angle`.
#[no_mangle]
pub unsafe extern "C" fn raddiff_mesh_form_factor(
    x: raddiff_vec3,
    n: raddiff_vec3,
    mesh: *const raddiff_triangle_mesh,
    order: u32,
    out: *mut raddiff_deriv3,
) -> raddiff_status {
    guard(|| {
        let mesh = unsafe { in_ref(mesh, "mesh")?.view()? };
        let out = unsafe { out_ref(out, "out")? };
        let order = order_from_c(order)?;
        *out = kernels::mesh_form_factor(x.into(), n.into(), &mesh, order)?.into();
        Ok(())
    })
}

/// The form factor to each triangle of `mesh` (as `raddiff_mesh_form_factor`, not summed), into
/// the output arrays as `raddiff_mesh_solid_angle_each` describes. Nothing is written on error.
///
/// # Safety
/// As `raddiff_mesh_solid_angle_each`.
#[no_mangle]
pub unsafe extern "C" fn raddiff_mesh_form_factor_each(
    x: raddiff_vec3,
    n: raddiff_vec3,
    mesh: *const raddiff_triangle_mesh,
    order: u32,
    values: *mut f64,
    gradients: *mut f64,
    hessians: *mut f64,
) -> raddiff_status {
    guard(|| {
        let mesh = unsafe { in_ref(mesh, "mesh")?.view()? };
        let order = order_from_c(order)?;
        let outs = Outputs::new(values, gradients, hessians, mesh.len(), order)?;
        let mut results = vec![Deriv3::default(); mesh.len()];
        kernels::mesh_form_factor_each(x.into(), n.into(), &mesh, order, &mut results)?;
        unsafe { outs.write(&results) };
        Ok(())
    })
}

/// The unsigned solid angle of the triangle `(a, b, c)` seen from each of the `count` `points`
/// (as `raddiff_triangle_solid_angle` per point), into `values[i]`, `gradients[3i..3i+3]` and
/// `hessians[9i..9i+9]` (required as for `raddiff_mesh_solid_angle_each`). Nothing is written on
/// error; the message names the first bad point.
///
/// # Safety
/// `points` NULL or valid for `count` reads; the output arrays NULL or valid for the writes stated.
#[no_mangle]
pub unsafe extern "C" fn raddiff_points_solid_angle(
    points: *const raddiff_vec3,
    count: usize,
    a: raddiff_vec3,
    b: raddiff_vec3,
    c: raddiff_vec3,
    order: u32,
    values: *mut f64,
    gradients: *mut f64,
    hessians: *mut f64,
) -> raddiff_status {
    guard(|| {
        let p = unsafe { read_points(points, count, "points")? };
        let order = order_from_c(order)?;
        let outs = Outputs::new(values, gradients, hessians, count, order)?;
        let mut results = vec![Deriv3::default(); count];
        kernels::points_solid_angle(p, a.into(), b.into(), c.into(), order, &mut results)?;
        unsafe { outs.write(&results) };
        Ok(())
    })
}

/// The form factor from a differential area at each of the `count` `points` with unit normal
/// `normals[i]` to the triangle `(a, b, c)` (as `raddiff_triangle_form_factor` per point), into
/// the output arrays as `raddiff_points_solid_angle` describes. A zero-area triangle gives 0.
/// Nothing is written on error; the message names the first bad point or normal.
///
/// # Safety
/// `points` and `normals` NULL or valid for `count` reads; the output arrays as above.
#[no_mangle]
pub unsafe extern "C" fn raddiff_points_form_factor(
    points: *const raddiff_vec3,
    normals: *const raddiff_vec3,
    count: usize,
    a: raddiff_vec3,
    b: raddiff_vec3,
    c: raddiff_vec3,
    order: u32,
    values: *mut f64,
    gradients: *mut f64,
    hessians: *mut f64,
) -> raddiff_status {
    guard(|| {
        let p = unsafe { read_points(points, count, "points")? };
        let nrm = unsafe { read_points(normals, count, "normals")? };
        let order = order_from_c(order)?;
        let outs = Outputs::new(values, gradients, hessians, count, order)?;
        let mut results = vec![Deriv3::default(); count];
        let (a, b, c) = (a.into(), b.into(), c.into());
        kernels::points_form_factor(p, nrm, a, b, c, order, &mut results)?;
        unsafe { outs.write(&results) };
        Ok(())
    })
}
