//! What a renderer hands back after tracing a layout's directions, and its validation.

use glam::DVec3;

use super::layout::{Frame, Layout, LayoutKind};
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

impl GatherInput<'_> {
    /// How far a traced direction may be from unit length (`| |ω|² − 1 |`) and from its stratum
    /// (in sin²θ or cosθ across a ring wall, in the sine of the angle across an azimuth wall).
    ///
    /// cbindgen:ignore
    pub const DIRECTION_TOLERANCE: f64 = 1e-6;

    /// Checks sizes and values against `layout` and the (orthonormalized) `frame`.
    pub(crate) fn validate(&self, layout: &Layout, frame: &Frame) -> Result<()> {
        let cells = layout.len();
        if self.channels == 0 {
            return Err(Error::InvalidArgument("channels must be >= 1".into()));
        }
        check_len("directions", self.directions.len(), Some(cells), "m*n")?;
        check_len("distance", self.distance.len(), Some(cells), "m*n")?;
        check_len(
            "radiance",
            self.radiance.len(),
            cells.checked_mul(self.channels),
            "m*n*channels",
        )?;
        ensure_finite(self.sigma_t, "sigma_t")?;
        if self.sigma_t < 0.0 {
            return Err(Error::InvalidArgument(format!(
                "sigma_t must be >= 0 (got {})",
                self.sigma_t
            )));
        }
        // `d > 0` is false for NaN too; branch-free so the scan vectorizes.
        if !self.distance.iter().fold(true, |ok, &d| ok & (d > 0.0)) {
            let i = self
                .distance
                .iter()
                .position(|&d| d.is_nan() || d <= 0.0)
                .unwrap_or(0);
            let d = self.distance[i];
            return Err(Error::InvalidArgument(format!(
                "distance[{i}] = {d}: distances must be > 0, or INFINITY for a miss"
            )));
        }
        check_all_finite(self.radiance, "radiance")?;
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
        if directions_ok(layout, frame, self.directions) {
            Ok(())
        } else {
            locate_bad_direction(layout, frame, self.directions)
        }
    }
}

/// `(cos φ_k, sin φ_k)` of the azimuth walls `φ_k = 2πk/N`, k = 0..=N (the last one is the
/// first), as the direction check uses them; empty for the concentric layout and N = 1.
pub(crate) fn azimuth_bounds(layout: &Layout) -> Vec<(f64, f64)> {
    let n = layout.n as usize;
    if layout.kind == LayoutKind::Concentric || n < 2 {
        return Vec::new();
    }
    (0..=n)
        .map(|k| {
            let (s, c) = (std::f64::consts::TAU * (k % n) as f64 / n as f64).sin_cos();
            (c, s)
        })
        .collect()
}

/// The ring's range in sin²θ (polar) or cosθ (sphere), widened by the tolerance.
#[inline]
fn ring_range(layout: &Layout, j: usize, tol: f64) -> (f64, f64) {
    let m = layout.m as f64;
    match layout.kind {
        LayoutKind::CosinePolar => (j as f64 / m - tol, (j + 1) as f64 / m + tol),
        LayoutKind::Sphere => (
            1.0 - 2.0 * (j + 1) as f64 / m - tol,
            1.0 - 2.0 * j as f64 / m + tol,
        ),
        LayoutKind::Concentric => (f64::NEG_INFINITY, f64::INFINITY),
    }
}

/// Whether every direction passes [`locate_bad_direction`]'s tests (the same expressions), without
/// a branch per direction: rows are scanned with the per-layout azimuth table and the verdict
/// and-ed, so the common case costs a few flops per direction.
fn directions_ok(layout: &Layout, frame: &Frame, directions: &[DVec3]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2() {
        // SAFETY: the CPU has AVX2. (No FMA: the same verdicts as the SSE2 build.)
        return unsafe { directions_ok_avx2(layout, frame, directions) };
    }
    directions_ok_any(layout, frame, directions)
}

/// [`directions_ok`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn directions_ok_avx2(layout: &Layout, frame: &Frame, directions: &[DVec3]) -> bool {
    directions_ok_any(layout, frame, directions)
}

#[inline(always)]
fn directions_ok_any(layout: &Layout, frame: &Frame, directions: &[DVec3]) -> bool {
    let tables = super::walls::LayoutTables::cached(layout);
    let walls = &tables.azimuth_bounds[..];
    let n = layout.n as usize;
    let tol = GatherInput::DIRECTION_TOLERANCE;
    let axes = (frame.tangent, frame.bitangent(), frame.normal);
    let sphere = layout.kind == LayoutKind::Sphere;
    // A plain loop (not `Iterator::all`) so that everything inlines into the AVX2 build.
    for (j, row) in directions.chunks_exact(n).enumerate() {
        let (lo, hi) = ring_range(layout, j, tol);
        let ok = match (sphere, walls.is_empty()) {
            (false, true) => row_ok::<false, false>(row, walls, axes, lo, hi, tol),
            (false, false) => row_ok::<false, true>(row, walls, axes, lo, hi, tol),
            (true, true) => row_ok::<true, false>(row, walls, axes, lo, hi, tol),
            (true, false) => row_ok::<true, true>(row, walls, axes, lo, hi, tol),
        };
        if !ok {
            return false;
        }
    }
    true
}

#[inline(always)]
fn row_ok<const SPHERE: bool, const AZIMUTH: bool>(
    row: &[DVec3],
    walls: &[(f64, f64)],
    (t, b, nrm): (DVec3, DVec3, DVec3),
    lo: f64,
    hi: f64,
    tol: f64,
) -> bool {
    let check = |w: DVec3, a: &[(f64, f64)]| {
        let lx = w.dot(t);
        let ly = w.dot(b);
        let lz = w.dot(nrm);
        let ring = if SPHERE { lz } else { lx * lx + ly * ly };
        let unit = (w.length_squared() - 1.0).abs() <= 2.0 * tol;
        let above = SPHERE || lz >= -tol;
        let azimuth =
            !AZIMUTH || ((a[0].0 * ly - a[0].1 * lx >= -tol) & (lx * a[1].1 - ly * a[1].0 >= -tol));
        // NaN fails every comparison, so this covers non-finite input too.
        unit & above & (ring >= lo) & (ring <= hi) & azimuth
    };
    // `for` loops rather than `fold`, which would not inline into the AVX2 build.
    let mut ok = true;
    if AZIMUTH {
        for (&w, a) in row.iter().zip(walls.windows(2)) {
            ok &= check(w, a);
        }
    } else {
        for &w in row {
            ok &= check(w, &[]);
        }
    }
    ok
}

/// The first direction that is not unit, in the right half-space, and (polar and sphere layouts)
/// inside its stratum, as an `InvalidArgument` naming it (Ok if there is none).
fn locate_bad_direction(layout: &Layout, frame: &Frame, directions: &[DVec3]) -> Result<()> {
    let tol = GatherInput::DIRECTION_TOLERANCE;
    let (m, n) = (layout.m as usize, layout.n as usize);
    // Azimuth walls as unit 2D vectors (φ_k = 2πk/N), N+1 of them (the last one is the first).
    let walls: Vec<(f64, f64)> = if layout.kind == LayoutKind::Concentric || n < 2 {
        Vec::new()
    } else {
        (0..=n)
            .map(|k| {
                let (s, c) = (std::f64::consts::TAU * (k % n) as f64 / n as f64).sin_cos();
                (c, s)
            })
            .collect()
    };
    let b = frame.bitangent();
    for (j, row) in directions.chunks_exact(n).enumerate() {
        // The ring's range in sin²θ (polar) or cosθ (sphere), widened by the tolerance.
        let (lo, hi) = match layout.kind {
            LayoutKind::CosinePolar => (j as f64 / m as f64 - tol, (j + 1) as f64 / m as f64 + tol),
            LayoutKind::Sphere => (
                1.0 - 2.0 * (j + 1) as f64 / m as f64 - tol,
                1.0 - 2.0 * j as f64 / m as f64 + tol,
            ),
            LayoutKind::Concentric => (f64::NEG_INFINITY, f64::INFINITY),
        };
        for (k, &w) in row.iter().enumerate() {
            let lx = w.dot(frame.tangent);
            let ly = w.dot(b);
            let lz = w.dot(frame.normal);
            let ring = match layout.kind {
                LayoutKind::Sphere => lz,
                _ => lx * lx + ly * ly,
            };
            let unit = (w.length_squared() - 1.0).abs() <= 2.0 * tol;
            let above = lz >= -tol || layout.kind == LayoutKind::Sphere;
            let azimuth = walls.is_empty() || {
                let (a0, a1) = (walls[k], walls[k + 1]);
                a0.0 * ly - a0.1 * lx >= -tol && lx * a1.1 - ly * a1.0 >= -tol
            };
            // NaN fails every comparison, so one test covers non-finite input too.
            if unit && above && ring >= lo && ring <= hi && azimuth {
                continue;
            }
            let why = if !w.is_finite() {
                "is not finite"
            } else if !unit {
                "is not unit"
            } else if !above {
                "is below the horizon"
            } else if !(ring >= lo && ring <= hi) {
                "is outside its stratum's ring (wrong frame or index order?)"
            } else {
                "is outside its stratum's azimuth range (wrong frame or index order?)"
            };
            return Err(Error::InvalidArgument(format!(
                "directions[{}] = {w} {why} (j = {j}, k = {k})",
                j * n + k
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The AVX2 builds of the scans give the portable build's verdicts.
    #[test]
    fn avx2_scans_match_the_portable_scans() {
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
        let frame = Frame::new(DVec3::ZERO, DVec3::new(0.0, 0.6, 0.8), DVec3::X).unwrap();
        for kind in [
            LayoutKind::CosinePolar,
            LayoutKind::Sphere,
            LayoutKind::Concentric,
        ] {
            let layout = Layout::new(kind, 5, 9, 3).unwrap();
            let dirs = layout.directions(&frame).unwrap();
            assert!(directions_ok(&layout, &frame, &dirs));
            assert!(directions_ok_any(&layout, &frame, &dirs));
            for (i, scale) in [(0, 1.0 + 1e-5), (17, -1.0), (44, 1.0 + 1e-7)] {
                let mut d = dirs.clone();
                d[i] *= scale;
                let want = locate_bad_direction(&layout, &frame, &d).is_ok();
                assert_eq!(directions_ok(&layout, &frame, &d), want, "{kind:?} {i}");
                assert_eq!(directions_ok_any(&layout, &frame, &d), want, "{kind:?} {i}");
            }
        }
    }
}
