//! Records for the cache's lookup tests: on the plane z = 0 (normals tilted a little),
//! isotropic and anisotropic (one in three, axis ratio 2), with both gradients, positive values
//! (the third channel the record's index, so that records are told apart) and open fractions on
//! a grid of 1/16 (one in seven without one).

use glam::DVec3;
use raddiff::cache::{Extent, Record};

use super::splitmix;

/// `count` records in the square [0, 4]² with largest radii in [`radius.0`, `radius.0 +
/// radius.1`), drawn from `seed`.
pub fn plane_records(count: usize, seed: u64, radius: (f64, f64)) -> Vec<Record<[f32; 3]>> {
    let mut state = seed;
    let mut u = move || splitmix::uniform(&mut state);
    (0..count)
        .map(|i| {
            let position = DVec3::new(4.0 * u(), 4.0 * u(), 0.0);
            let normal = DVec3::new(0.05 * (u() - 0.5), 0.05 * (u() - 0.5), 1.0);
            let r = radius.0 + radius.1 * u();
            let extent = if i % 3 == 0 {
                Extent {
                    radii: [r, 0.5 * r, 0.0],
                    axes: [
                        DVec3::new(u() - 0.5, u() - 0.5, 0.0),
                        DVec3::ZERO,
                        DVec3::ZERO,
                    ],
                }
            } else {
                Extent::isotropic(r)
            };
            let value = [0.5 + u() as f32, 0.5 + u() as f32, 1.0 + i as f32];
            let mut record = Record::new(position, normal, value, extent);
            record.gradient = Some([[0.1, 0.0, 0.2], [0.0, -0.1, 0.0], [0.0; 3]]);
            record.rotation_gradient = Some([[0.0; 3], [0.05, 0.0, 0.0], [0.0; 3]]);
            record.open_fraction = (i % 7 != 3).then(|| (16.0 * u()).floor() / 16.0);
            record
        })
        .collect()
}
