//! Stratified direction layouts for hemisphere and sphere gathers, and irradiance with its
//! derivatives from what the traced rays found.
//!
//! A renderer asks a [`Layout`] for directions ([`Layout::directions`]), traces them itself, and
//! hands the hit distances and radiance back as a [`GatherInput`]; [`evaluate`] returns irradiance
//! (or fluence), Ward-Heckbert translational and rotational gradients with the participating-media
//! terms of Jarosz et al. 2008, and the harmonic-mean and minimum distances.
//!
//! ```
//! use glam::DVec3;
//! use raddiff::gather::{evaluate, Frame, GatherInput, Layout, LayoutKind, Wanted};
//!
//! let layout = Layout::new(LayoutKind::CosinePolar, 8, 16, 0)?;
//! let frame = Frame::new(DVec3::ZERO, DVec3::Z, DVec3::X)?;
//! let directions = layout.directions(&frame)?;
//! // "Trace": a uniform sky of radiance 1, nothing hit.
//! let distance = vec![f64::INFINITY; layout.len()];
//! let radiance = vec![1.0f32; layout.len()];
//! let input = GatherInput {
//!     directions: &directions,
//!     distance: &distance,
//!     radiance: &radiance,
//!     channels: 1,
//!     sigma_t: 0.0,
//!     media: None,
//! };
//! let e = evaluate(&layout, &frame, &input, Wanted::ALL)?;
//! assert!((e.irradiance[0] - std::f64::consts::PI).abs() < 1e-12);
//! assert_eq!(e.gradient[0], DVec3::ZERO);
//! # Ok::<(), raddiff::Error>(())
//! ```

mod evaluate;
mod input;
pub mod layout;
pub mod near_far;
mod smoothing;
mod strata;
mod walls;

pub use evaluate::{evaluate, GatherValues, ValidGather, Wanted};
pub use input::{GatherInput, MediaRadiance};
pub use layout::{concentric_to_local, Frame, Layout, LayoutKind, StratumBounds};
pub use near_far::{far_field_gather, far_field_radiance, near_field, NearField};
pub use smoothing::StrataSmoothing;

// The gather's Hessians (occlusion-aware on surfaces and in media, occlusion-unaware), and the
// record radii they imply.
pub mod hessian;
pub mod radii;
