//! A borrowed, validated view of a triangle set: vertex positions (f32 or f64, packed or strided)
//! with optional `u32` index triples, the layout renderers already keep for their ray tracer
//! (Embree's `RTC_FORMAT_FLOAT3` / `RTC_FORMAT_UINT3` buffers and their byte strides).

use glam::DVec3;

use crate::error::{Error, Result};

/// Vertex coordinates: `x, y, z` of each vertex, consecutive, in f32 or f64.
#[derive(Debug, Clone, Copy)]
pub enum VertexData<'a> {
    /// Single precision (widened exactly to f64 before any computation).
    F32(&'a [f32]),
    /// Double precision.
    F64(&'a [f64]),
}

impl VertexData<'_> {
    fn len(&self) -> usize {
        match self {
            VertexData::F32(d) => d.len(),
            VertexData::F64(d) => d.len(),
        }
    }

    #[inline(always)]
    fn point(&self, at: usize) -> DVec3 {
        match self {
            VertexData::F32(d) => DVec3::new(d[at] as f64, d[at + 1] as f64, d[at + 2] as f64),
            VertexData::F64(d) => DVec3::new(d[at], d[at + 1], d[at + 2]),
        }
    }
}

/// A set of triangles for the batch kernels: `triangle_count` triangles over `vertex_count`
/// vertices. Vertex `i` is at `vertices[i * vertex_stride ..][..3]`; triangle `t` has the vertex
/// indices `indices[t * index_stride ..][..3]`, or, without indices, the vertices `3t, 3t + 1,
/// 3t + 2` (a triangle soup). Strides count elements (f32, f64 or u32), not bytes.
///
/// Construction validates everything once (sizes, every index below `vertex_count`, every vertex
/// finite), so a mesh built once serves any number of batch calls without further checks. The
/// first offending element is named in the [`Error::InvalidArgument`] message.
#[derive(Debug, Clone, Copy)]
pub struct TriangleMesh<'a> {
    vertices: VertexData<'a>,
    vertex_stride: usize,
    indices: Option<&'a [u32]>,
    index_stride: usize,
    triangle_count: usize,
}

impl<'a> TriangleMesh<'a> {
    /// The general constructor (strides in elements, at least 3; see [`TriangleMesh`]).
    ///
    /// [`Error::InvalidArgument`]: a stride below 3, an array shorter than the counts need, no
    /// indices with `vertex_count < 3 · triangle_count`, an index `>= vertex_count`, a non-finite
    /// coordinate.
    pub fn new(
        vertices: VertexData<'a>,
        vertex_stride: usize,
        vertex_count: usize,
        indices: Option<&'a [u32]>,
        index_stride: usize,
        triangle_count: usize,
    ) -> Result<Self> {
        let invalid = |m: String| Err(Error::InvalidArgument(format!("triangle mesh: {m}")));
        if vertex_stride < 3 {
            return invalid(format!(
                "vertex stride {vertex_stride} is below 3 coordinates"
            ));
        }
        let needed = |count: usize, stride: usize| {
            count
                .checked_sub(1)
                .map_or(Some(0), |c| c.checked_mul(stride)?.checked_add(3))
        };
        match needed(vertex_count, vertex_stride) {
            Some(n) if n <= vertices.len() => {}
            _ => {
                return invalid(format!(
                    "{vertex_count} vertices with stride {vertex_stride} need more than the {} \
                     coordinates given",
                    vertices.len()
                ))
            }
        }
        match indices {
            Some(ix) => {
                if index_stride < 3 {
                    return invalid(format!("index stride {index_stride} is below 3 indices"));
                }
                match needed(triangle_count, index_stride) {
                    Some(n) if n <= ix.len() => {}
                    _ => {
                        return invalid(format!(
                            "{triangle_count} triangles with index stride {index_stride} need \
                             more than the {} indices given",
                            ix.len()
                        ))
                    }
                }
                for t in 0..triangle_count {
                    for k in 0..3 {
                        let i = ix[t * index_stride + k];
                        if i as usize >= vertex_count {
                            return invalid(format!(
                                "index {k} of triangle {t} is {i}, not below the vertex count \
                                 {vertex_count}"
                            ));
                        }
                    }
                }
            }
            None => {
                if triangle_count
                    .checked_mul(3)
                    .map_or(true, |n| n > vertex_count)
                {
                    return invalid(format!(
                        "without indices {triangle_count} triangles need 3 vertices each, but \
                         there are {vertex_count}"
                    ));
                }
            }
        }
        for v in 0..vertex_count {
            let p = vertices.point(v * vertex_stride);
            if !p.is_finite() {
                return invalid(format!("vertex {v} is not finite ({p})"));
            }
        }
        Ok(TriangleMesh {
            vertices,
            vertex_stride,
            indices,
            index_stride,
            triangle_count,
        })
    }

    /// Indexed triangles over f64 vertices.
    pub fn indexed(vertices: &'a [DVec3], indices: &'a [[u32; 3]]) -> Result<Self> {
        // SAFETY: DVec3 is #[repr(C)] { x, y, z: f64 } (glam guarantees it; asserted in ffi), so
        // the array is 3 · len contiguous f64.
        let flat =
            unsafe { std::slice::from_raw_parts(vertices.as_ptr().cast(), vertices.len() * 3) };
        let ix = indices.as_flattened();
        Self::new(
            VertexData::F64(flat),
            3,
            vertices.len(),
            Some(ix),
            3,
            indices.len(),
        )
    }

    /// Indexed triangles over f32 vertices (as most renderers store them).
    pub fn indexed_f32(vertices: &'a [[f32; 3]], indices: &'a [[u32; 3]]) -> Result<Self> {
        let flat = vertices.as_flattened();
        let ix = indices.as_flattened();
        Self::new(
            VertexData::F32(flat),
            3,
            vertices.len(),
            Some(ix),
            3,
            indices.len(),
        )
    }

    /// A triangle soup: `triangles[t]` are the vertices of triangle `t`.
    pub fn soup(triangles: &'a [[DVec3; 3]]) -> Result<Self> {
        // SAFETY: as in `indexed`, [[DVec3; 3]] is 9 · len contiguous f64.
        let flat =
            unsafe { std::slice::from_raw_parts(triangles.as_ptr().cast(), triangles.len() * 9) };
        Self::new(
            VertexData::F64(flat),
            3,
            triangles.len() * 3,
            None,
            3,
            triangles.len(),
        )
    }

    /// The number of triangles.
    pub fn len(&self) -> usize {
        self.triangle_count
    }

    /// True when there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.triangle_count == 0
    }

    /// The vertices of triangle `t` (in f64). Panics when `t >= len()`.
    #[inline(always)]
    pub fn triangle(&self, t: usize) -> [DVec3; 3] {
        assert!(
            t < self.triangle_count,
            "triangle {t} of {}",
            self.triangle_count
        );
        let at = |i: usize| self.vertices.point(i * self.vertex_stride);
        match self.indices {
            Some(ix) => {
                let base = t * self.index_stride;
                [
                    at(ix[base] as usize),
                    at(ix[base + 1] as usize),
                    at(ix[base + 2] as usize),
                ]
            }
            None => [at(3 * t), at(3 * t + 1), at(3 * t + 2)],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strided_f32_with_padding_reads_the_right_vertices() {
        // float4 vertices (Embree's padded layout), index stride 4 (uint4).
        let v: [f32; 12] = [0., 0., 0., 9., 1., 0., 0., 9., 0., 1., 0., 9.];
        let ix: [u32; 8] = [0, 1, 2, 7, 2, 1, 0, 7];
        let m = TriangleMesh::new(VertexData::F32(&v), 4, 3, Some(&ix), 4, 2).unwrap();
        assert_eq!(m.len(), 2);
        assert_eq!(m.triangle(1), [DVec3::Y, DVec3::X, DVec3::ZERO]);
    }

    #[test]
    fn validation_names_the_first_bad_element() {
        let v = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let err = TriangleMesh::indexed(&v, &[[0, 1, 2], [0, 3, 1]]).unwrap_err();
        assert!(
            err.to_string().contains("index 1 of triangle 1 is 3"),
            "{err}"
        );
        let bad = [DVec3::ZERO, DVec3::new(f64::NAN, 0., 0.), DVec3::Y];
        let err = TriangleMesh::indexed(&bad, &[[0, 1, 2]]).unwrap_err();
        assert!(err.to_string().contains("vertex 1 is not finite"), "{err}");
        let flat = [0.0f64; 8];
        let err = TriangleMesh::new(VertexData::F64(&flat), 3, 3, None, 3, 1).unwrap_err();
        assert!(err.to_string().contains("need more than the 8"), "{err}");
        let err = TriangleMesh::new(VertexData::F64(&[0.0; 9]), 3, 3, None, 3, 2).unwrap_err();
        assert!(err.to_string().contains("need 3 vertices each"), "{err}");
        let err = TriangleMesh::new(VertexData::F64(&[0.0; 9]), 2, 3, None, 3, 1).unwrap_err();
        assert!(err.to_string().contains("vertex stride 2"), "{err}");
    }
}
