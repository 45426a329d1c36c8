//! What the surface and the media caches place their records by: the coarse-to-fine pixel
//! levels and the radius clamps.

use raddiff::cache::irradiance::RadiusBounds;
use raddiff::cache::Extent;

/// Record radii are clamped to [MIN, MAX] × the scene size (Křivánek et al.'s clamps, in scene
/// units).
pub const RADIUS_MIN: f64 = 0.004;
pub const RADIUS_MAX: f64 = 0.25;

/// The pixels of level `step` (16, 8, ..., 1) of a `w` × `h` image, in scanline order: every
/// `step`-th pixel of every `step`-th row, less those an earlier (coarser) level already visited.
pub fn level_pixels(w: usize, h: usize, step: usize) -> Vec<usize> {
    (0..h)
        .step_by(step)
        .flat_map(|y| (0..w).step_by(step).map(move |x| y * w + x))
        .filter(|&i| step == 16 || (i % w) % (2 * step) != 0 || (i / w) % (2 * step) != 0)
        .collect()
}

/// `extent` (or, when the metric gave none, the largest isotropic one) with every radius clamped
/// to [`RADIUS_MIN`, `RADIUS_MAX`] × `size` (a non-finite radius becomes the largest).
pub fn clamped_extent(extent: Option<Extent>, size: f64) -> Extent {
    clamped_extent_to(extent, RADIUS_MIN * size, RADIUS_MAX * size)
}

/// `extent` (or, when the metric gave none, the largest isotropic one) with every radius clamped
/// to [`min`, `max`] (a non-finite radius becomes `max`), as the library clamps records.
pub fn clamped_extent_to(extent: Option<Extent>, min: f64, max: f64) -> Extent {
    let extent = extent.unwrap_or_else(|| Extent::isotropic(max));
    RadiusBounds::apply(&extent, (min, max))
}
