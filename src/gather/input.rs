//! What a renderer hands back after tracing a layout's directions, and its validation.

use glam::DVec3;

use super::layout::{Frame, Layout};
use crate::error::{ensure_finite, Error, Result};

/// In-scattered (and emitted) radiance of a participating medium, marched along every direction.
///
/// Step `s` of direction `i` is the sample at `t_s = (s + 0.5)·step` and stands for the interval
/// `[s·step, (s+1)·step]`; the medium is marched over `[0, steps·step]`. Entries for steps at or
/// beyond a direction's hit distance are never read (they may hold anything finite).
#[derive(Debug, Clone, Copy)]
pub struct MediaRadiance<'a> {
    /// `σ_s·L_i (+ emission)` before attenuation, radiance per unit length; `M·N·steps·channels`
    /// values, index `(i·steps + s)·channels + c`.
    pub radiance: &'a [f32],
    /// Optional gradient of `radiance` with respect to the sample position (world axes), per L²;
    /// `M·N·steps·channels·3` values, index `((i·steps + s)·channels + c)·3 + axis`.
    pub gradient: Option<&'a [f32]>,
    /// Number of march steps per direction, ≥ 1.
    pub steps: usize,
    /// Step length (L), finite and > 0.
    pub step: f64,
}

/// What the rays of one gather found. Index `i = j·N + k` throughout.
#[derive(Debug, Clone, Copy)]
pub struct GatherInput<'a> {
    /// The traced world directions, as returned by [`Layout::directions`] (unit, each inside its
    /// stratum within [`GatherInput::DIRECTION_TOLERANCE`]).
    pub directions: &'a [DVec3],
    /// Hit distances (L), > 0; `f64::INFINITY` for a miss (distant environment).
    pub distance: &'a [f64],
    /// Radiance leaving each hit towards x (or the environment's, for a miss), before attenuation;
    /// `M·N·channels` values, index `i·channels + c`. Any finite value (signed data allowed).
    pub radiance: &'a [f32],
    /// Values per direction, ≥ 1.
    pub channels: usize,
    /// Homogeneous extinction coefficient (1/L) between x and the hits, finite and ≥ 0. With
    /// `sigma_t > 0` a miss is attenuated to zero (the medium is unbounded).
    pub sigma_t: f64,
    /// Optional marched media radiance (Jarosz et al. 2008, Sec. 5).
    pub media: Option<MediaRadiance<'a>>,
}

fn size_error(what: &str, got: usize, want: Option<usize>, formula: &str) -> Error {
    match want {
        Some(w) => Error::InvalidArgument(format!(
            "{what} holds {got} values, expected {formula} = {w}"
        )),
        None => Error::InvalidArgument(format!("{what}: {formula} overflows")),
    }
}

fn check_len(what: &str, got: usize, want: Option<usize>, formula: &str) -> Result<()> {
    if want == Some(got) {
        Ok(())
    } else {
        Err(size_error(what, got, want, formula))
    }
}

fn check_all_finite(values: &[f32], what: &str) -> Result<()> {
    if all_finite(values) {
        return Ok(());
    }
    let i = values.iter().position(|v| !v.is_finite()).unwrap_or(0);
    Err(Error::InvalidArgument(format!(
        "{what}[{i}] is not finite ({})",
        values[i]
    )))
}

/// Whether no value is Inf or NaN.
fn all_finite(values: &[f32]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2() {
        // SAFETY: the CPU has AVX2.
        return unsafe { all_finite_avx2(values) };
    }
    all_finite_any(values)
}

/// [`all_finite`] compiled for AVX2 (8 values per vector).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn all_finite_avx2(values: &[f32]) -> bool {
    all_finite_any(values)
}

#[inline(always)]
fn all_finite_any(values: &[f32]) -> bool {
    // Exponent bits all ones means Inf or NaN: then adding one to the exponent field carries into
    // the sign bit. Branch-free within blocks so the scan vectorizes.
    const EXP: u32 = 0x7f80_0000;
    const CARRY: u32 = 0x0080_0000;
    let mut acc = 0u32;
    for block in values.chunks(1024) {
        // An integer or-reduction: the compiler vectorizes and unrolls it freely.
        for v in block {
            acc |= (v.to_bits() & EXP) + CARRY;
        }
        if acc & 0x8000_0000 != 0 {
            return false;
        }
    }
    acc & 0x8000_0000 == 0
}

/// Checks what a layout's rays found: `channels >= 1`, `distance` of `m·n` values, each > 0 or
/// `INFINITY`, `radiance` of `m·n·channels` finite values. `InvalidArgument` naming the first
/// problem.
pub(crate) fn validate_hits(
    layout: &Layout,
    distance: &[f64],
    radiance: &[f32],
    channels: usize,
) -> Result<()> {
    let cells = layout.len();
    if channels == 0 {
        return Err(Error::InvalidArgument("channels must be >= 1".into()));
    }
    check_len("distance", distance.len(), Some(cells), "m*n")?;
    check_len(
        "radiance",
        radiance.len(),
        cells.checked_mul(channels),
        "m*n*channels",
    )?;
    // `d > 0` is false for NaN too; branch-free so the scan vectorizes.
    if !distance.iter().fold(true, |ok, &d| ok & (d > 0.0)) {
        let i = distance
            .iter()
            .position(|&d| d.is_nan() || d <= 0.0)
            .unwrap_or(0);
        let d = distance[i];
        return Err(Error::InvalidArgument(format!(
            "distance[{i}] = {d}: distances must be > 0, or INFINITY for a miss"
        )));
    }
    check_all_finite(radiance, "radiance")
}

impl GatherInput<'_> {
    /// How far a traced direction may be from unit length (`| |ω|² − 1 | ≤ 2·tol`) and from its
    /// stratum: in sin²θ (cosine-polar) or cosθ (sphere) across a ring wall, in the sine of the
    /// angle across an azimuth wall, and in the grid coordinates `(a, b) ∈ [−1, 1]²` of the
    /// concentric square across a concentric wall; a hemisphere direction may dip `tol` below the
    /// horizon (`ω·n ≥ −tol`). Jittered directions from [`Layout::directions`] lie inside their
    /// strata to rounding, any seed; directions rounded to `f32` and back stay within it too.
    /// See [`Layout::check_directions`].
    ///
    /// cbindgen:ignore
    pub const DIRECTION_TOLERANCE: f64 = super::strata::DIRECTION_TOLERANCE;

    /// Checks sizes and values against `layout` and the (orthonormalized) `frame`.
    pub(crate) fn validate(&self, layout: &Layout, frame: &Frame) -> Result<()> {
        let cells = layout.len();
        check_len("directions", self.directions.len(), Some(cells), "m*n")?;
        validate_hits(layout, self.distance, self.radiance, self.channels)?;
        ensure_finite(self.sigma_t, "sigma_t")?;
        if self.sigma_t < 0.0 {
            return Err(Error::InvalidArgument(format!(
                "sigma_t must be >= 0 (got {})",
                self.sigma_t
            )));
        }
        if let Some(media) = &self.media {
            if media.steps == 0 {
                return Err(Error::InvalidArgument("media steps must be >= 1".into()));
            }
            ensure_finite(media.step, "media step")?;
            if media.step <= 0.0 || !(media.step * media.steps as f64).is_finite() {
                return Err(Error::InvalidArgument(format!(
                    "media step must be > 0 with a finite march length (step = {}, steps = {})",
                    media.step, media.steps
                )));
            }
            let samples = cells
                .checked_mul(media.steps)
                .and_then(|v| v.checked_mul(self.channels));
            check_len(
                "media_radiance",
                media.radiance.len(),
                samples,
                "m*n*steps*channels",
            )?;
            check_all_finite(media.radiance, "media_radiance")?;
            if let Some(g) = media.gradient {
                check_len(
                    "media_radiance_gradient",
                    g.len(),
                    samples.and_then(|v| v.checked_mul(3)),
                    "m*n*steps*3*channels",
                )?;
                check_all_finite(g, "media_radiance_gradient")?;
            }
        }
        super::strata::check_directions(layout, frame, self.directions)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The AVX2 build of the finiteness scan gives the portable build's verdicts.
    #[test]
    fn avx2_scan_matches_the_portable_scan() {
        let mut values: Vec<f32> = (0..3000).map(|i| i as f32 * 0.37 - 100.0).collect();
        values.push(f32::MAX);
        values.push(f32::MIN_POSITIVE / 2.0);
        assert!(all_finite(&values) && all_finite_any(&values));
        for bad in [f32::INFINITY, f32::NEG_INFINITY, f32::NAN, -f32::NAN] {
            for at in [0, 1023, 1024, 2047, 3001] {
                let mut v = values.clone();
                v[at] = bad;
                assert!(!all_finite(&v) && !all_finite_any(&v), "{bad} at {at}");
            }
        }
    }
}
