//! Whether every direction of a gather lies in its own stratum: the contract the estimators rely
//! on (the Ward-Heckbert walls sit between grid neighbours, the occlusion mesh joins them), checked
//! for every layout before anything is evaluated.
//!
//! A direction `ω` of stratum `(j, k)` is taken to the layout's own coordinates in the frame and
//! compared with the stratum's bounds widened by
//! [`GatherInput::DIRECTION_TOLERANCE`](super::GatherInput::DIRECTION_TOLERANCE):
//!
//! * cosine-polar: `sin²θ = lx² + ly²` against `[j/M, (j+1)/M]`, and the azimuth against the walls
//!   `φ_k`, `φ_{k+1}` as two signs of 2D cross products with the walls' unit vectors;
//! * sphere: `cosθ = lz` against `[1 − 2(j+1)/M, 1 − 2j/M]`, azimuth as above;
//! * concentric: the inverse Shirley-Chiu map takes `(lx, ly)` back to the square `[−1, 1]²`
//!   (`r = |(lx, ly)|` is the square's "ring", the ratio of the smaller to the larger of `|lx|`,
//!   `|ly|` gives the position along it through an arctangent), compared with the cell
//!   `[2j/M − 1, 2(j+1)/M − 1] × [2k/N − 1, 2(k+1)/N − 1]`.
//!
//! Plus, for every layout: finite, unit within `2·tol` in `|ω|²`, and (hemisphere layouts) not
//! below the horizon by more than `tol`. No trigonometric call per direction: the walls' vectors
//! are tabulated per layout shape, and the concentric arctangent of a ratio in `[−1, 1]` is a fixed
//! polynomial ([`atan_unit`], within 1.8e-9 rad, so within 2.3e-9 in the square's coordinates,
//! far inside the 1e-6 tolerance). The scan is branch-free per row so that it vectorizes; the first
//! bad direction is then located by a scalar pass over the same expressions (the same verdicts).

use std::f64::consts::{FRAC_PI_4, TAU};

use glam::DVec3;

use super::layout::{Frame, Layout, LayoutKind, StratumBounds};
use super::walls::LayoutTables;
use crate::error::{Error, Result};

/// How far outside its stratum a direction may lie and still be accepted
/// ([`GatherInput::DIRECTION_TOLERANCE`](super::GatherInput::DIRECTION_TOLERANCE)).
pub(crate) const DIRECTION_TOLERANCE: f64 = 1e-6;
const TOL: f64 = DIRECTION_TOLERANCE;

/// The frame's tangent, bitangent and normal.
type Axes = (DVec3, DVec3, DVec3);

/// The direction check as the layout's method (here, beside the check, so that the layout needs
/// nothing of it).
impl Layout {
    /// `Ok` if every one of `directions` (index `j*N + k`, M·N of them) is finite, unit and inside
    /// its own stratum of this layout in `frame`, within
    /// [`GatherInput::DIRECTION_TOLERANCE`](super::GatherInput::DIRECTION_TOLERANCE): the check
    /// [`super::evaluate`] makes before it evaluates anything (a few flops per direction, no
    /// trigonometric call).
    ///
    /// `InvalidArgument` if the layout or frame is invalid, the count is not M·N, or a direction
    /// is not where it belongs; the message names the first such direction (its index, row j and
    /// column k), where it is and where its stratum is. Shifted, cyclically rotated or swapped
    /// rows or columns, a direction from the far side of the hemisphere, or directions from
    /// another layout or frame are all refused: a stratum's directions never leave it, whatever
    /// the seed.
    pub fn check_directions(&self, frame: &Frame, directions: &[DVec3]) -> Result<()> {
        self.validate()?;
        let frame = frame.orthonormalized()?;
        if directions.len() != self.len() {
            return Err(Error::InvalidArgument(format!(
                "{} directions given, the layout has m*n = {}",
                directions.len(),
                self.len()
            )));
        }
        check_directions(self, &frame, directions)
    }
}

/// `Ok` if every direction lies in its stratum of `layout` in the orthonormal `frame`, else
/// `InvalidArgument` naming the first one that does not and why. `directions.len()` must be M·N.
pub(crate) fn check_directions(layout: &Layout, frame: &Frame, directions: &[DVec3]) -> Result<()> {
    debug_assert_eq!(directions.len(), layout.len());
    if directions_ok(layout, frame, directions) {
        Ok(())
    } else {
        locate_bad_direction(layout, frame, directions)
    }
}

/// Row `j`'s range, widened by the tolerance: in sin²θ (polar), cosθ (sphere) or the square's
/// first coordinate `a` (concentric).
#[inline]
fn row_range(layout: &Layout, j: usize) -> (f64, f64) {
    let m = layout.m as f64;
    let (j0, j1) = (j as f64, (j + 1) as f64);
    match layout.kind {
        LayoutKind::CosinePolar => (j0 / m - TOL, j1 / m + TOL),
        LayoutKind::Sphere => (1.0 - 2.0 * j1 / m - TOL, 1.0 - 2.0 * j0 / m + TOL),
        LayoutKind::Concentric => (2.0 * j0 / m - 1.0 - TOL, 2.0 * j1 / m - 1.0 + TOL),
    }
}

/// Coefficients `c_i` of `atan(t) ≈ t Σ c_i t^{2i}` on `[−1, 1]`: a least-squares fit of
/// `atan(√s)/√s` in `s = t²` at 80 Chebyshev nodes of `[0, 1]`, solved in exact rational
/// arithmetic; largest error 1.8e-9 rad (asserted in the tests against `f64::atan`).
const ATAN_COEFFICIENTS: [f64; 10] = [
    0.999_999_997_546_019_9,
    -0.333_332_822_955_120_46,
    0.199_982_306_403_788_3,
    -0.142_615_736_802_877_9,
    0.109_401_989_650_829_71,
    -0.083_720_639_477_774_96,
    0.057_463_557_843_167_91,
    -0.030_717_508_898_849_114,
    0.010_680_719_443_168_833,
    -0.001_743_701_143_171_608_3,
];

/// `atan(t)` for `t ∈ [−1, 1]` to within 1.8e-9 rad, without a library call (so the scan
/// vectorizes). Horner's scheme with separate multiplies and adds: the same bits with and without
/// FMA hardware.
#[inline(always)]
pub(crate) fn atan_unit(t: f64) -> f64 {
    let s = t * t;
    let mut p = ATAN_COEFFICIENTS[9];
    for &c in ATAN_COEFFICIENTS[..9].iter().rev() {
        p = p * s + c;
    }
    t * p
}

/// The point `(a, b)` of the square `[−1, 1]²` that the Shirley-Chiu map
/// ([`super::layout::concentric_to_local`]) takes to the disk point `(lx, ly)`, to within 2.3e-9
/// (the arctangent's error; exact on the square's diagonals and axes).
///
/// Where `|lx| ≥ |ly|` the map is `(a cos ψ, a sin ψ)` with `ψ = (π/4)(b/a)`, so `|a| = r` with the
/// sign of `lx` and `b = a ψ/(π/4)`, `ψ = atan(ly/lx)`; elsewhere the same with the axes exchanged.
#[inline(always)]
pub(crate) fn local_to_square(lx: f64, ly: f64) -> (f64, f64) {
    let r = (lx * lx + ly * ly).sqrt();
    let first = lx.abs() >= ly.abs();
    let (num, den) = if first { (ly, lx) } else { (lx, ly) };
    // Both zero only at the pole (the square's centre).
    let t = if den != 0.0 { num / den } else { 0.0 };
    let major = if den < 0.0 { -r } else { r };
    let minor = major * atan_unit(t) * (1.0 / FRAC_PI_4);
    if first {
        (major, minor)
    } else {
        (minor, major)
    }
}

/// The per-direction test of the polar and sphere layouts: unit, above the horizon (hemisphere),
/// inside the row's range and (N ≥ 2) between the azimuth walls `a0`, `a1`.
#[inline(always)]
fn polar_ok<const SPHERE: bool, const AZIMUTH: bool>(
    w: DVec3,
    (t, b, nrm): Axes,
    (lo, hi): (f64, f64),
    a0: (f64, f64),
    a1: (f64, f64),
) -> bool {
    let lx = w.dot(t);
    let ly = w.dot(b);
    let lz = w.dot(nrm);
    let ring = if SPHERE { lz } else { lx * lx + ly * ly };
    let unit = (w.length_squared() - 1.0).abs() <= 2.0 * TOL;
    let above = SPHERE || lz >= -TOL;
    let azimuth = !AZIMUTH || ((a0.0 * ly - a0.1 * lx >= -TOL) & (lx * a1.1 - ly * a1.0 >= -TOL));
    // NaN fails every comparison, so this covers non-finite input too.
    unit & above & (ring >= lo) & (ring <= hi) & azimuth
}

/// The per-direction test of the concentric layout: unit, above the horizon, and its square point
/// inside the cell `[a_lo, a_hi] × [b0, b1]` (the row's range is already widened).
#[inline(always)]
fn concentric_ok(w: DVec3, (t, b, nrm): Axes, (a_lo, a_hi): (f64, f64), b0: f64, b1: f64) -> bool {
    let lx = w.dot(t);
    let ly = w.dot(b);
    let lz = w.dot(nrm);
    let (sa, sb) = local_to_square(lx, ly);
    let unit = (w.length_squared() - 1.0).abs() <= 2.0 * TOL;
    let above = lz >= -TOL;
    unit & above & (sa >= a_lo) & (sa <= a_hi) & (sb >= b0 - TOL) & (sb <= b1 + TOL)
}

/// Whether every direction passes [`locate_bad_direction`]'s tests (the same expressions), without
/// a branch per direction: rows are scanned with the per-layout tables and the verdict and-ed, so
/// the common case costs a few flops per direction.
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
    let tables = LayoutTables::cached(layout);
    let walls = &tables.azimuth_bounds[..];
    let columns = &tables.column_bounds[..];
    let n = layout.n as usize;
    let axes = (frame.tangent, frame.bitangent(), frame.normal);
    let none = (0.0, 0.0);
    // Plain loops (not `Iterator::all` or `fold`) so that everything inlines into the AVX2 build.
    for (j, row) in directions.chunks_exact(n).enumerate() {
        let range = row_range(layout, j);
        let mut ok = true;
        match (layout.kind, walls.is_empty()) {
            (LayoutKind::Concentric, _) => {
                for (&w, c) in row.iter().zip(columns.windows(2)) {
                    ok &= concentric_ok(w, axes, range, c[0], c[1]);
                }
            }
            (LayoutKind::CosinePolar, true) => {
                for &w in row {
                    ok &= polar_ok::<false, false>(w, axes, range, none, none);
                }
            }
            (LayoutKind::CosinePolar, false) => {
                for (&w, a) in row.iter().zip(walls.windows(2)) {
                    ok &= polar_ok::<false, true>(w, axes, range, a[0], a[1]);
                }
            }
            (LayoutKind::Sphere, true) => {
                for &w in row {
                    ok &= polar_ok::<true, false>(w, axes, range, none, none);
                }
            }
            (LayoutKind::Sphere, false) => {
                for (&w, a) in row.iter().zip(walls.windows(2)) {
                    ok &= polar_ok::<true, true>(w, axes, range, a[0], a[1]);
                }
            }
        }
        if !ok {
            return false;
        }
    }
    true
}

/// The per-direction verdict of [`directions_ok_any`] for direction `(j, k)`.
fn direction_ok(
    layout: &Layout,
    tables: &LayoutTables,
    axes: Axes,
    w: DVec3,
    j: usize,
    k: usize,
) -> bool {
    let range = row_range(layout, j);
    let walls = &tables.azimuth_bounds;
    let wall = |i: usize| walls.get(i).copied().unwrap_or((0.0, 0.0));
    match (layout.kind, walls.is_empty()) {
        (LayoutKind::Concentric, _) => concentric_ok(
            w,
            axes,
            range,
            tables.column_bounds[k],
            tables.column_bounds[k + 1],
        ),
        (LayoutKind::CosinePolar, true) => {
            polar_ok::<false, false>(w, axes, range, wall(k), wall(k))
        }
        (LayoutKind::CosinePolar, false) => {
            polar_ok::<false, true>(w, axes, range, wall(k), wall(k + 1))
        }
        (LayoutKind::Sphere, true) => polar_ok::<true, false>(w, axes, range, wall(k), wall(k)),
        (LayoutKind::Sphere, false) => polar_ok::<true, true>(w, axes, range, wall(k), wall(k + 1)),
    }
}

/// The first direction that fails [`direction_ok`], as an `InvalidArgument` naming its index, its
/// stratum and what is wrong (Ok if there is none).
fn locate_bad_direction(layout: &Layout, frame: &Frame, directions: &[DVec3]) -> Result<()> {
    let tables = LayoutTables::cached(layout);
    let axes = (frame.tangent, frame.bitangent(), frame.normal);
    let n = layout.n as usize;
    for (i, &w) in directions.iter().enumerate() {
        let (j, k) = (i / n, i % n);
        if !direction_ok(layout, &tables, axes, w, j, k) {
            return Err(describe(layout, frame, w, i));
        }
    }
    Ok(())
}

/// What is wrong with direction `i` (which failed [`direction_ok`]).
fn describe(layout: &Layout, frame: &Frame, w: DVec3, i: usize) -> Error {
    let n = layout.n as usize;
    let (j, k) = (i / n, i % n);
    let l = frame.to_local(w);
    let why = if !w.is_finite() {
        format!("is not finite ({w})")
    } else if (w.length_squared() - 1.0).abs() > 2.0 * TOL {
        format!("is not unit (|w|^2 = {})", w.length_squared())
    } else if layout.kind.is_hemisphere() && l.z < -TOL {
        format!(
            "points below the horizon (w.n = {:.6}: a direction from the far side of the \
             hemisphere, or the wrong normal?)",
            l.z
        )
    } else {
        let where_ = match layout.stratum_bounds(j as u32, k as u32) {
            StratumBounds::Polar { theta, phi } => {
                let (lo, hi) = row_range(layout, j);
                let ring = if layout.kind == LayoutKind::Sphere {
                    l.z
                } else {
                    l.x * l.x + l.y * l.y
                };
                let which = if ring >= lo && ring <= hi {
                    "azimuth range"
                } else {
                    "ring"
                };
                format!(
                "outside the {which}: it is at theta = {:.4} deg, phi = {:.4} deg; the stratum \
                 spans theta in [{:.4}, {:.4}] deg, phi in [{:.4}, {:.4}] deg",
                l.z.clamp(-1.0, 1.0).acos().to_degrees(),
                l.y.atan2(l.x).rem_euclid(TAU).to_degrees(),
                theta.0.to_degrees(),
                theta.1.to_degrees(),
                phi.0.to_degrees(),
                phi.1.to_degrees()
            )
            }
            StratumBounds::Square { min, max } => {
                let (a, b) = local_to_square(l.x, l.y);
                format!(
                    "it maps to ({a:.6}, {b:.6}) on the concentric square; the stratum is \
                     [{:.6}, {:.6}] x [{:.6}, {:.6}]",
                    min.x, max.x, min.y, max.y
                )
            }
        };
        format!(
            "lies outside its stratum: {where_} (wrong frame, shifted or swapped rows or \
             columns, or directions of another layout?)"
        )
    };
    Error::InvalidArgument(format!(
        "directions[{i}] (row j = {j}, column k = {k} of the {m}x{n} {kind:?} layout) {why}",
        m = layout.m,
        kind = layout.kind
    ))
}

#[cfg(test)]
mod tests;
