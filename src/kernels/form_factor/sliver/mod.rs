//! Slivers (thin triangles and polygons): the anisotropic sliver rule, its clipped form, the
//! sliver's exact geometry and the fan of a thin polygon.

pub(crate) mod clipped;
pub(crate) mod direct;
pub(crate) mod fan;
pub(crate) mod geometry;
pub(crate) mod rule;
