//! Images of a cache: the shaded render, record positions and extents, and the error map.

use glam::DVec3;
use raddiff::cache::Record;

use crate::geometry::tangent_of;
use crate::image::{self, Rgb8};
use crate::render::GBuffer;
use crate::scene::Camera;

/// Pixel coordinates of a world point, if in front of the camera.
fn project(camera: &Camera, p: DVec3, width: usize, height: usize) -> Option<(f64, f64)> {
    let d = p - camera.position;
    let z = d.dot(camera.forward);
    if z <= 1e-9 {
        return None;
    }
    let aspect = width as f64 / height as f64;
    let px = d.dot(camera.right) / (z * camera.tan_half_fov * aspect);
    let py = d.dot(camera.up) / (z * camera.tan_half_fov);
    Some((
        (px + 1.0) * 0.5 * width as f64 - 0.5,
        (1.0 - py) * 0.5 * height as f64 - 0.5,
    ))
}

/// The render (dimmed) with every record's extent outlined and its position marked.
pub fn records_overlay(
    camera: &Camera,
    gbuffer: &GBuffer,
    render: &[DVec3],
    exposure: f64,
    records: &[Record<[f32; 3]>],
) -> Rgb8 {
    let (w, h) = (gbuffer.width, gbuffer.height);
    let dim: Vec<DVec3> = render.iter().map(|v| *v * 0.45).collect();
    let mut img = image::tonemap(w, h, &dim, exposure);
    for r in records {
        let n = r.normal.normalize();
        let (a0, a1) = if r.extent.axes[0].length_squared() > 0.0 {
            let a = (r.extent.axes[0] - n * n.dot(r.extent.axes[0])).normalize();
            (a, n.cross(a))
        } else {
            let t = tangent_of(n);
            (t, n.cross(t))
        };
        for s in 0..48 {
            let angle = std::f64::consts::TAU * s as f64 / 48.0;
            let p = r.position
                + a0 * (r.extent.radii[0] * angle.cos())
                + a1 * (r.extent.radii[1] * angle.sin());
            if let Some((x, y)) = project(camera, p, w, h) {
                if x >= 0.0 && y >= 0.0 {
                    img.set(x.round() as usize, y.round() as usize, [90, 170, 255]);
                }
            }
        }
    }
    for r in records {
        if let Some((x, y)) = project(camera, r.position, w, h) {
            if x >= 0.0 && y >= 0.0 {
                img.set(x.round() as usize, y.round() as usize, [255, 60, 40]);
            }
        }
    }
    img
}

/// |luminance error| per pixel divided by the mean reference luminance, 0 … `scale` on the ramp,
/// with a colour bar below.
pub fn error_map(
    gbuffer: &GBuffer,
    image_values: &[DVec3],
    reference: &[DVec3],
    scale: f64,
) -> Rgb8 {
    let mean =
        reference.iter().map(|v| image::luminance(*v)).sum::<f64>() / reference.len().max(1) as f64;
    let errors: Vec<f64> = image_values
        .iter()
        .zip(reference)
        .map(|(v, r)| (image::luminance(*v) - image::luminance(*r)).abs() / mean.max(1e-300))
        .collect();
    image::with_colour_bar(
        &image::heat_map(gbuffer.width, gbuffer.height, &errors, scale),
        scale,
        ERROR_CAPTION,
    )
}

/// What an error map's colour bar maps: the caption under its ramp.
pub const ERROR_CAPTION: &str = "|error| / mean";
