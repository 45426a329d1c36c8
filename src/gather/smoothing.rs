//! Smoothing a gather's per-stratum values over their neighbours: quieter derivatives from the
//! same rays.
//!
//! A gather's gradients and Hessians are differences of neighbouring strata's radiance, so the
//! noise of one stratum's hit radiance (one shadow ray, one path) enters them amplified, while
//! the irradiance, a sum, averages it away. Replacing each stratum's value by `[1 2 1] / 4` of
//! it and its two neighbours before differentiating trades a little angular resolution for less
//! noise: on the real-scene benchmark (`docs/real-scenes.md`) two azimuthal passes and one polar
//! pass lowered every metric's error by 2-10% at 1,024 and 4,096 rays per gather. On noise-free
//! radiance it only blurs, so it is off unless asked for.
//!
//! Neighbours are the layout's grid neighbours, which are neighbours on the (hemi)sphere:
//! * cosine-polar and sphere: along φ (index `k`) the ring wraps around; along θ (index `j`)
//!   the first and last rings repeat themselves;
//! * concentric: along both square axes the edge cells repeat themselves (the Shirley-Chiu map
//!   is continuous, and opposite edges of the square are not neighbours).
//!
//! Every pass preserves the sum of each ring (azimuthal passes on polar layouts) or of each
//! line of the grid, so the strata's total, and with it the irradiance of a layout whose strata
//! carry equal measure, stays what it was up to rounding. One pass scales the `cos(pφ)`
//! component of a ring of `N` strata by `cos²(πp/N)`.

use crate::error::{Error, Result};

use super::input::{GatherInput, MediaRadiance};
use super::layout::{Layout, LayoutKind};

/// How many `[1 2 1] / 4` passes smooth a gather's strata before its derivatives are taken.
///
/// Each pass replaces every stratum's value by `[1 2 1] / 4` of it and its two grid neighbours
/// (on the cosine-polar and sphere layouts the rings wrap around and the edge rings repeat; on
/// the concentric layout the edge cells repeat) and keeps each ring's or grid line's sum. It
/// lowers the derivatives' noise under noisy hit radiance and only blurs noise-free radiance
/// (`docs/gathers.md`, "Smoothed strata"). The default, [`StrataSmoothing::OFF`], leaves the
/// strata as traced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct StrataSmoothing {
    /// Passes along φ (cosine-polar and sphere layouts, wrapping around each ring) or along the
    /// second square axis (concentric), 0..=[`StrataSmoothing::MAX_PASSES`].
    pub azimuthal_passes: u32,
    /// Passes along θ (cosine-polar and sphere) or along the first square axis (concentric),
    /// 0..=[`StrataSmoothing::MAX_PASSES`]; applied after the azimuthal passes.
    pub polar_passes: u32,
}

impl StrataSmoothing {
    /// No smoothing: the strata as traced.
    pub const OFF: StrataSmoothing = StrataSmoothing {
        azimuthal_passes: 0,
        polar_passes: 0,
    };

    /// Largest number of passes along either axis: 64 passes already spread a stratum's value
    /// with a standard deviation of about 6 strata (each pass adds a variance of 1/2); more
    /// only blur.
    ///
    /// cbindgen:ignore
    pub const MAX_PASSES: u32 = 64;

    /// `azimuthal_passes` along φ, then `polar_passes` along θ.
    pub const fn new(azimuthal_passes: u32, polar_passes: u32) -> StrataSmoothing {
        StrataSmoothing {
            azimuthal_passes,
            polar_passes,
        }
    }

    /// Whether any pass is asked for.
    pub fn is_on(&self) -> bool {
        self.azimuthal_passes > 0 || self.polar_passes > 0
    }

    /// `InvalidArgument` unless both counts are at most [`StrataSmoothing::MAX_PASSES`].
    pub fn validate(&self) -> Result<()> {
        for (what, passes) in [
            ("azimuthal", self.azimuthal_passes),
            ("polar", self.polar_passes),
        ] {
            if passes > Self::MAX_PASSES {
                return Err(Error::InvalidArgument(format!(
                    "{what} smoothing passes must be at most {}, got {passes}",
                    Self::MAX_PASSES
                )));
            }
        }
        Ok(())
    }

    /// Smooths `values` in place: `width` consecutive values per stratum (channels, or march
    /// steps × channels), strata in the layout's order `i = j·N + k`. Each value is filtered
    /// with the same value of its neighbours, as halves of halves, so the result lies between
    /// the smallest and the largest of the input's (finite input stays finite).
    ///
    /// `InvalidArgument` for a count above [`StrataSmoothing::MAX_PASSES`], `width == 0` or
    /// `values.len() != layout.len() · width`.
    pub fn apply(&self, layout: &Layout, values: &mut [f32], width: usize) -> Result<()> {
        if self.is_on() {
            let smoothed = self.smoothed(layout, values, width)?;
            values.copy_from_slice(&smoothed);
            Ok(())
        } else {
            self.check(layout, values.len(), width)
        }
    }

    /// [`StrataSmoothing::apply`] into a new vector, `values` unchanged (each pass reads one
    /// buffer and writes the other: no copy between passes). Errors as `apply`.
    pub fn smoothed(&self, layout: &Layout, values: &[f32], width: usize) -> Result<Vec<f32>> {
        self.check(layout, values.len(), width)?;
        let (m, n) = (layout.m as usize, layout.n as usize);
        let row = n * width;
        let wraps = layout.kind != LayoutKind::Concentric;
        let azimuthal = |from: &[f32], to: &mut [f32]| {
            for (out, ring) in to.chunks_exact_mut(row).zip(from.chunks_exact(row)) {
                smooth_line(out, ring, width, wraps);
            }
        };
        let polar = |from: &[f32], to: &mut [f32]| {
            let ring = |j: usize| &from[j * row..(j + 1) * row];
            for (j, out) in to.chunks_exact_mut(row).enumerate() {
                let (previous, next) = (ring(j.saturating_sub(1)), ring((j + 1).min(m - 1)));
                blend(out, previous, ring(j), next);
            }
        };
        let passes = (0..self.azimuthal_passes)
            .map(|_| true)
            .chain((0..self.polar_passes).map(|_| false));
        let (mut current, mut spare) = (None::<Vec<f32>>, Vec::new());
        for along_azimuth in passes {
            let mut out = std::mem::take(&mut spare);
            out.resize(values.len(), 0.0);
            let from = current.as_deref().unwrap_or(values);
            if along_azimuth {
                azimuthal(from, &mut out);
            } else {
                polar(from, &mut out);
            }
            spare = current.replace(out).unwrap_or_default();
        }
        Ok(current.unwrap_or_else(|| values.to_vec()))
    }

    /// `InvalidArgument` for a count out of range or values that are not `width` per stratum.
    fn check(&self, layout: &Layout, len: usize, width: usize) -> Result<()> {
        self.validate()?;
        if width == 0 || Some(len) != layout.len().checked_mul(width) {
            return Err(Error::InvalidArgument(format!(
                "smoothing {len} values of width {width} over {} strata",
                layout.len()
            )));
        }
        Ok(())
    }
}

/// One line of strata (`width` values each), filtered along itself: wrapping around, or with the
/// end strata repeating themselves.
fn smooth_line(out: &mut [f32], line: &[f32], width: usize, wraps: bool) {
    let len = line.len();
    if len == width {
        // a single stratum is its own neighbour either way
        out.copy_from_slice(line);
        return;
    }
    let last = len - width;
    blend(
        &mut out[width..last],
        &line[..last - width],
        &line[width..last],
        &line[2 * width..],
    );
    let (before_first, after_last) = if wraps {
        (&line[last..], &line[..width])
    } else {
        (&line[..width], &line[last..])
    };
    blend(
        &mut out[..width],
        before_first,
        &line[..width],
        &line[width..2 * width],
    );
    blend(
        &mut out[last..],
        &line[last - width..last],
        &line[last..],
        after_last,
    );
}

/// `out = (previous + 2 centre + next) / 4`, value by value, as halves of halves: no partial
/// sum exceeds the largest input's magnitude, so finite values stay finite.
fn blend(out: &mut [f32], previous: &[f32], centre: &[f32], next: &[f32]) {
    for (((o, &a), &b), &c) in out.iter_mut().zip(previous).zip(centre).zip(next) {
        *o = 0.5 * b + 0.5 * (0.5 * a + 0.5 * c);
    }
}

/// Smoothed copies of a gather's per-stratum radiance: the surface radiance, and the marched
/// media radiance and its gradient when the gather has them.
pub(super) struct SmoothedRadiance {
    radiance: Vec<f32>,
    media_radiance: Vec<f32>,
    media_gradient: Option<Vec<f32>>,
}

impl SmoothedRadiance {
    /// The radiance of `input`, traced with `layout`, smoothed by `smoothing` (errors as
    /// [`StrataSmoothing::apply`]).
    pub(super) fn of(
        layout: &Layout,
        input: &GatherInput,
        smoothing: StrataSmoothing,
    ) -> Result<Self> {
        let smoothed = |values: &[f32], width: usize| smoothing.smoothed(layout, values, width);
        let radiance = smoothed(input.radiance, input.channels)?;
        let (media_radiance, media_gradient) = match &input.media {
            Some(media) => {
                let width = media.steps * input.channels;
                let gradient = media.gradient.map(|g| smoothed(g, width * 3)).transpose()?;
                (smoothed(media.radiance, width)?, gradient)
            }
            None => (Vec::new(), None),
        };
        Ok(SmoothedRadiance {
            radiance,
            media_radiance,
            media_gradient,
        })
    }

    /// `input` with the smoothed radiance in place of its own.
    pub(super) fn input<'b>(&'b self, input: &GatherInput<'b>) -> GatherInput<'b> {
        GatherInput {
            radiance: &self.radiance,
            media: input.media.map(|media| MediaRadiance {
                radiance: &self.media_radiance,
                gradient: self.media_gradient.as_deref(),
                ..media
            }),
            ..*input
        }
    }
}

#[cfg(test)]
mod tests;
