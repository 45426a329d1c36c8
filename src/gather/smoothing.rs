//! Smoothing a gather's per-stratum values over their neighbours: quieter derivatives from the
//! same rays.
//!
//! A gather's gradients and Hessians are differences of neighbouring strata's radiance, so the
//! noise of one stratum's hit radiance (one shadow ray, one path) enters them amplified, while
//! the irradiance, a sum, averages it away. Replacing each stratum's value by `[1 2 1] / 4` of
//! it and its two neighbours before differentiating trades a little angular resolution for less
//! noise: on the real-scene benchmark (`docs/real-scenes.md`) two azimuthal passes and one polar
//! pass lowered every metric's error by 5-10% at 1,024 and 4,096 rays per gather. On noise-free
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

/// How many `[1 2 1] / 4` passes smooth a gather's strata before its derivatives are taken
/// (see the [module](self) docs). The default, [`StrataSmoothing::OFF`], leaves them as traced.
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
    /// with the same value of its neighbours, in f64, so the result lies between the smallest
    /// and the largest of the input's (finite input stays finite).
    ///
    /// `InvalidArgument` for a count above [`StrataSmoothing::MAX_PASSES`], `width == 0` or
    /// `values.len() != layout.len() · width`.
    pub fn apply(&self, layout: &Layout, values: &mut [f32], width: usize) -> Result<()> {
        self.validate()?;
        if width == 0 || Some(values.len()) != layout.len().checked_mul(width) {
            return Err(Error::InvalidArgument(format!(
                "smoothing {} values of width {width} over {} strata",
                values.len(),
                layout.len()
            )));
        }
        if !self.is_on() {
            return Ok(());
        }
        let (m, n) = (layout.m as usize, layout.n as usize);
        let wraps = layout.kind != LayoutKind::Concentric;
        let mut before = vec![0.0f32; values.len()];
        for _ in 0..self.azimuthal_passes {
            before.copy_from_slice(values);
            for j in 0..m {
                for k in 0..n {
                    let (previous, next) = neighbours(k, n, wraps);
                    blend(
                        values,
                        &before,
                        width,
                        j * n + k,
                        [j * n + previous, j * n + next],
                    );
                }
            }
        }
        for _ in 0..self.polar_passes {
            before.copy_from_slice(values);
            for j in 0..m {
                let (previous, next) = neighbours(j, m, false);
                for k in 0..n {
                    blend(
                        values,
                        &before,
                        width,
                        j * n + k,
                        [previous * n + k, next * n + k],
                    );
                }
            }
        }
        Ok(())
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
        let smoothed = |values: &[f32], width: usize| -> Result<Vec<f32>> {
            let mut copy = values.to_vec();
            smoothing.apply(layout, &mut copy, width)?;
            Ok(copy)
        };
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

/// The indices before and after `i` in `0..len`: wrapping around, or the edge repeating itself.
fn neighbours(i: usize, len: usize, wraps: bool) -> (usize, usize) {
    if wraps {
        ((i + len - 1) % len, (i + 1) % len)
    } else {
        (i.saturating_sub(1), (i + 1).min(len - 1))
    }
}

/// `values[here] = (before[a] + 2 before[here] + before[b]) / 4`, value by value over `width`.
fn blend(values: &mut [f32], before: &[f32], width: usize, here: usize, [a, b]: [usize; 2]) {
    let block = |s: usize| &before[s * width..(s + 1) * width];
    let (left, centre, right) = (block(a), block(here), block(b));
    for (c, out) in values[here * width..(here + 1) * width]
        .iter_mut()
        .enumerate()
    {
        *out = (0.25 * left[c] as f64 + 0.5 * centre[c] as f64 + 0.25 * right[c] as f64) as f32;
    }
}

#[cfg(test)]
mod tests;
