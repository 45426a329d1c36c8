//! Stratified direction layouts for hemisphere and sphere gathers, and irradiance with its
//! derivatives from what the traced rays found.

// Occlusion-aware Hessians from the triangulated gather, and the record radii they imply.
pub mod hessian;
pub mod hessian_media;
pub mod hessian_mesh;
pub mod hessian_unaware;
pub mod radii;
