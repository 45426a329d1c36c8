//! Split invariance (issue 19): the radiance of a segment equals the sum over any split of it,
//! each piece carried back to the entry point by exp(−σ_t offset).
//!
//! Not met yet (issue 19, item "find every branch near folds"): the worst relative difference over
//! 12 chords split in 10 is 5.7e-4 on the smooth sphere, and random splits differ by up to ~3e-4.
//! Both tests are ignored until fold branches are found independently of where a segment ends:
//! `cargo test --test scatter_split -- --ignored` reproduces the figures.

mod scatter_common;

use glam::DVec3;
use proptest::prelude::*;
use raddiff::scatter::{scene, single_scatter, Medium, RefractiveMesh, ScatterOptions};
use scatter_common::{chord, eye_rays, medium, LIGHT};

fn radiance(mesh: &RefractiveMesh, m: &Medium, a: DVec3, b: DVec3) -> f64 {
    single_scatter(mesh, m, a, b, LIGHT, 1.0, &ScatterOptions::default())
        .unwrap()
        .radiance
}

/// Σ over the pieces [t_k, t_{k+1}] of the chord, each weighted by exp(−σ_t distance to entry).
fn split_sum(mesh: &RefractiveMesh, m: &Medium, a: DVec3, b: DVec3, cuts: &[f64]) -> f64 {
    let len = (b - a).length();
    let mut ts = vec![0.0];
    ts.extend_from_slice(cuts);
    ts.push(1.0);
    ts.windows(2)
        .map(|w| {
            let (p, q) = (a + w[0] * (b - a), a + w[1] * (b - a));
            (-m.sigma_t * w[0] * len).exp() * radiance(mesh, m, p, q)
        })
        .sum()
}

#[test]
#[ignore = "issue 19: fold branches depend on the segment's ends (5.7e-4)"]
fn ten_pieces_sum_to_the_whole_on_spheres() {
    let m = medium();
    let cuts: Vec<f64> = (1..10).map(|k| k as f64 / 10.0).collect();
    for amplitude in [0.0, 0.05] {
        let mesh = scene::bumpy_sphere(8, amplitude, 6.0).build().unwrap();
        let mut worst: f64 = 0.0;
        for (o, d) in eye_rays(12) {
            let Some((a, b)) = chord(&mesh, o, d) else {
                continue;
            };
            let whole = radiance(&mesh, &m, a, b);
            let sum = split_sum(&mesh, &m, a, b, &cuts);
            worst = worst.max((sum - whole).abs() / whole);
        }
        assert!(
            worst <= 1e-9,
            "amplitude {amplitude}: worst relative difference {worst:.3e}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
    #[test]
    #[ignore = "issue 19: fold branches depend on the segment's ends (~3e-4)"]
    fn random_splits_sum_to_the_whole(ray in 0usize..64, mut cuts in prop::collection::vec(0.001f64..0.999, 1..5)) {
        let mesh = scene::bumpy_sphere(6, 0.05, 6.0).build().unwrap();
        let m = medium();
        cuts.sort_by(f64::total_cmp);
        let (o, d) = eye_rays(64)[ray];
        if let Some((a, b)) = chord(&mesh, o, d) {
            let whole = radiance(&mesh, &m, a, b);
            let sum = split_sum(&mesh, &m, a, b, &cuts);
            prop_assert!((sum - whole).abs() <= 1e-9 * whole, "{sum} vs {whole}");
        }
    }
}
