//! The near/far decomposition of irradiance at a reach (Arikan et al. 2005, "Fast and detailed
//! approximate global illumination by irradiance decomposition").
//!
//! Irradiance at a surface point x splits at a distance ρ, the reach, into the light from
//! surfaces closer than ρ (the near field) and the light from beyond it:
//!
//! ```text
//! E(x) = E_near(x) + V(x)·F(x)
//! ```
//!
//! where `V` is the open fraction (the share of the layout's measure whose rays reach at least ρ:
//! cosine-weighted for hemisphere layouts, solid angle for the sphere) and `F` the far field (the
//! irradiance those directions would give if every direction saw like them). Near a junction
//! `E_near` and `V` change within a pixel, which no cached record made a few pixels away can follow;
//! `F` changes on the scale of ρ. So a renderer estimates `E_near` and `V` at every pixel with a
//! few short rays ([`near_field`]), caches `F` ([`far_field_gather`], or [`far_field_radiance`] to
//! keep the near hits' distances, then the usual [`evaluate`](super::evaluate) and record), and
//! shows `E_near + V·F` ([`NearField::irradiance_with`]). With ρ a few pixel footprints the short
//! rays are cheap: on the real-scene benchmark at 512 px, 1,024 rays of 8 footprints per pixel
//! cost about 40 CPU s, the cache's 8,192 gathers about 65 (`docs/real-scenes.md`).
//!
//! Every stratum of every layout carries the same weight in its measure, so both splits are sums
//! over directions. The identity `E = E_near + V·F` holds exactly for one gather split with itself
//! (no medium).

use super::input::validate_hits;
use super::layout::Layout;
use crate::error::{ensure_finite, Error, Result};

/// What short rays from a pixel's point found within the reach.
#[derive(Debug, Clone, PartialEq)]
pub struct NearField {
    /// Irradiance from hits closer than the reach, per channel: `π/(MN)` times the sum of their
    /// radiance (`4π/(MN)` for the sphere layout, fluence).
    pub irradiance: Vec<f64>,
    /// Share of the layout's measure whose rays reach at least the reach, in `[0, 1]`.
    pub open_fraction: f64,
}

impl NearField {
    /// The irradiance `E_near + V·F` with the far field `far_field` (one value per channel, as
    /// interpolated from records of [`far_field_gather`]'s or [`far_field_radiance`]'s gathers at
    /// the same reach).
    ///
    /// `InvalidArgument` if `far_field` has the wrong length or a non-finite value; `Degenerate`
    /// if the sum overflows.
    pub fn irradiance_with(&self, far_field: &[f64]) -> Result<Vec<f64>> {
        if far_field.len() != self.irradiance.len() {
            return Err(Error::InvalidArgument(format!(
                "far_field holds {} values, the near field {} channels",
                far_field.len(),
                self.irradiance.len()
            )));
        }
        let mut out = Vec::with_capacity(far_field.len());
        for (near, &far) in self.irradiance.iter().zip(far_field) {
            ensure_finite(far, "far_field")?;
            let e = near + self.open_fraction * far;
            if !e.is_finite() {
                return Err(Error::Degenerate(format!(
                    "near field {near} plus {} x far field {far} overflows",
                    self.open_fraction
                )));
            }
            out.push(e);
        }
        Ok(out)
    }
}

/// Checks the reach: finite and > 0.
fn validate_reach(reach: f64) -> Result<()> {
    ensure_finite(reach, "reach")?;
    if reach > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!(
            "reach must be > 0 (got {reach})"
        )))
    }
}

/// A gather's radiance summed per channel over its near hits and over its open directions, and
/// how many directions are open, after validating every input.
struct Split {
    near: Vec<f64>,
    far: Vec<f64>,
    open: usize,
}

impl Split {
    fn new(
        layout: &Layout,
        distance: &[f64],
        radiance: &[f32],
        channels: usize,
        reach: f64,
    ) -> Result<Split> {
        layout.validate()?;
        validate_reach(reach)?;
        validate_hits(layout, distance, radiance, channels)?;
        let mut split = Split {
            near: vec![0.0; channels],
            far: vec![0.0; channels],
            open: 0,
        };
        for (&d, l) in distance.iter().zip(radiance.chunks_exact(channels)) {
            let sums = if reaches(d, reach) {
                split.open += 1;
                &mut split.far
            } else {
                &mut split.near
            };
            for (s, &v) in sums.iter_mut().zip(l) {
                *s += f64::from(v);
            }
        }
        Ok(split)
    }
}

/// Whether a ray that found `distance` reaches at least `reach` (a miss, `INFINITY`, does).
#[inline]
fn reaches(distance: f64, reach: f64) -> bool {
    distance >= reach
}

/// The near field at a pixel's point: from the layout's directions traced no farther than `reach`
/// (a miss, `INFINITY`, or any distance ≥ `reach` counts as open), the irradiance of the hits
/// closer than `reach` and the open fraction. `distance` and `radiance` are as in
/// [`GatherInput`](super::GatherInput) (`m·n` and `m·n·channels` values, index `i·channels + c`);
/// the directions themselves are not needed.
///
/// Its noise is one pixel's, and shows in the image: the real-scene benchmark found 16 rays per
/// pixel doubling the error and used 32 × 32 (`docs/real-scenes.md`).
///
/// `InvalidArgument` for an invalid layout, `reach` not finite and > 0, wrong sizes, a distance
/// not > 0 (or NaN) or non-finite radiance.
pub fn near_field(
    layout: &Layout,
    distance: &[f64],
    radiance: &[f32],
    channels: usize,
    reach: f64,
) -> Result<NearField> {
    let split = Split::new(layout, distance, radiance, channels, reach)?;
    let weight = layout.kind.measure() / layout.len() as f64;
    Ok(NearField {
        irradiance: split.near.iter().map(|s| s * weight).collect(),
        open_fraction: split.open as f64 / layout.len() as f64,
    })
}

/// Turns a gather into its far-field gather, in place: the radiance of every direction whose hit
/// is closer than `reach` becomes the mean radiance of the directions that reach at least that
/// far (per channel; zero when none does). Returns the open fraction, in `[0, 1]`.
///
/// Evaluated as usual ([`evaluate`](super::evaluate), the Hessians, the radii), the result is the
/// far field `F` with its derivatives: the irradiance as if the near geometry showed the far
/// field's mean radiance. Near hits keep their distances, so occlusion-aware derivatives still see
/// the near geometry's edges, now with the far field's radiance on both sides of them. Without a
/// medium, the evaluated irradiance is `(E − E_near)/V` of the unmodified gather (up to the
/// mean's rounding to `f32`).
///
/// `InvalidArgument` for an invalid layout, `reach` not finite and > 0, wrong sizes, a distance
/// not > 0 (or NaN) or non-finite radiance; `radiance` is unchanged on failure.
pub fn far_field_radiance(
    layout: &Layout,
    distance: &[f64],
    radiance: &mut [f32],
    channels: usize,
    reach: f64,
) -> Result<f64> {
    let Split { far, open, .. } = Split::new(layout, distance, radiance, channels, reach)?;
    // A mean of finite f32 values is a finite f32.
    let mean: Vec<f32> = far
        .iter()
        .map(|&s| {
            if open > 0 {
                (s / open as f64) as f32
            } else {
                0.0
            }
        })
        .collect();
    for (&d, l) in distance.iter().zip(radiance.chunks_exact_mut(channels)) {
        if !reaches(d, reach) {
            l.copy_from_slice(&mean);
        }
    }
    Ok(open as f64 / layout.len() as f64)
}

/// Turns a gather into its far-field gather, in place, radiance and distances: as
/// [`far_field_radiance`], and every hit closer than `reach` moves to the reach (its distance
/// becomes `reach`), as if a surface at the reach showed the far field's mean radiance. The far
/// field's derivatives and radii then see only the far geometry: the near geometry is the pixel's
/// near field's business, and a record's radius no longer shrinks beside a junction whose light
/// the near field already carries. Returns the open fraction, in `[0, 1]`.
///
/// Hit normals, where a metric uses them (the geometric Hessian), should face the gather point
/// for the moved hits (`−ω`). Errors as [`far_field_radiance`]; nothing is changed on failure.
pub fn far_field_gather(
    layout: &Layout,
    distance: &mut [f64],
    radiance: &mut [f32],
    channels: usize,
    reach: f64,
) -> Result<f64> {
    let open = far_field_radiance(layout, distance, radiance, channels, reach)?;
    for d in distance.iter_mut() {
        if !reaches(*d, reach) {
            *d = reach;
        }
    }
    Ok(open)
}
