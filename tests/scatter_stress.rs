//! Robustness: random eye segments and lights over the bumpy sphere never give NaN, Inf, a negative
//! radiance or a panic. `RADDIFF_STRESS_CALLS` sets the number of calls (default 150; the issue's
//! 1e6 takes about 20 min in release on one core:
//! `RADDIFF_STRESS_CALLS=1000000 cargo test --release --test scatter_stress`).

mod scatter_common;

use glam::DVec3;
use raddiff::scatter::{scene, single_scatter, Medium, ScatterOptions};
use scatter_common::chord;

fn calls() -> usize {
    std::env::var("RADDIFF_STRESS_CALLS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(150)
}

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.next(), self.next(), self.next()) * 2.0 - DVec3::ONE;
            if let Some(u) = v.try_normalize() {
                if v.length() <= 1.0 {
                    return u;
                }
            }
        }
    }
}

#[test]
fn random_segments_and_lights_give_finite_radiance() {
    let mesh = scene::bumpy_sphere(10, 0.06, 7.0).build().unwrap();
    let mut rng = Rng(0x2545f4914f6cdd1d);
    let n = calls();
    let (mut nonzero, mut done) = (0, 0);
    while done < n {
        // Chords of random rays (most), or random points inside the bounding sphere.
        let (entry, exit) = if rng.next() < 0.8 {
            let origin = rng.unit() * 3.0;
            let target = rng.unit() * 0.8 * rng.next();
            match chord(&mesh, origin, target - origin) {
                Some(c) => c,
                None => continue,
            }
        } else {
            (rng.unit() * 0.9 * rng.next(), rng.unit() * 0.9 * rng.next())
        };
        // Lights from just outside the surface to far away.
        let light = rng.unit() * (1.08 + 20.0 * rng.next().powi(3));
        let medium = Medium {
            eta: 1.0 + 1e-6 + 2.0 * rng.next(),
            sigma_t: 5.0 * rng.next(),
            sigma_s: 0.0,
            g: 1.98 * rng.next() - 0.99,
        };
        let medium = Medium {
            sigma_s: medium.sigma_t * rng.next(),
            ..medium
        };
        let r = single_scatter(
            &mesh,
            &medium,
            entry,
            exit,
            light,
            1.0,
            &ScatterOptions::default(),
        );
        match r {
            Ok(r) => {
                assert!(
                    r.radiance.is_finite() && r.radiance >= 0.0,
                    "radiance {} for entry {entry}, exit {exit}, light {light}, {medium:?}",
                    r.radiance
                );
                if r.radiance > 0.0 {
                    nonzero += 1;
                }
            }
            // A light inside a bump's concavity can be inside the closed mesh: a clear error.
            Err(e) => assert!(e.to_string().contains("inside"), "{e}"),
        }
        done += 1;
    }
    assert!(
        nonzero * 4 > n,
        "only {nonzero} of {n} calls saw single scattering"
    );
}
