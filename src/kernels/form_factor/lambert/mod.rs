//! Lambert's per-edge sum with a running error bound: unclipped, far away, for convex polygons,
//! and over the loop the tangent plane clips, with that loop's derivatives.

pub(crate) mod clipped;
pub(crate) mod clipped_derivs;
pub(crate) mod clipped_polygon;
pub(crate) mod far;
pub(crate) mod polygon;
pub(crate) mod sum;
