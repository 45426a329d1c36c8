//! The single-pass gather evaluation against the previous implementation, kept as
//! `tests/gather_support/evaluate_reference.rs`: random gathers over every layout (with misses,
//! grazing and slightly non-unit directions, 1-4 channels, with and without an absorbing medium and
//! marched media radiance with or without its gradient) and every combination of requested outputs must agree to
//! rounding (1e-13 of the scale of the summed terms), and bad input must fail with the same error.

use glam::{DQuat, DVec3};
use raddiff::gather::{
    evaluate, Frame, GatherInput, GatherValues, Layout, LayoutKind, MediaRadiance, Wanted,
};
use raddiff::Error;

#[path = "gather_support/evaluate_reference.rs"]
mod evaluate_reference;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

struct Gather {
    layout: Layout,
    frame: Frame,
    dirs: Vec<DVec3>,
    dist: Vec<f64>,
    rad: Vec<f32>,
    media: Vec<f32>,
    media_grad: Vec<f32>,
    channels: usize,
    steps: usize,
}

impl Gather {
    fn new(kind: LayoutKind, m: u32, n: u32, seed: u64, channels: usize, rng: &mut Rng) -> Gather {
        let layout = Layout::new(kind, m, n, seed).unwrap();
        let q = DQuat::from_euler(
            glam::EulerRot::XYZ,
            6.0 * rng.next(),
            6.0 * rng.next(),
            6.0 * rng.next(),
        );
        let frame = Frame::new(
            DVec3::new(rng.next(), -rng.next(), 3.0 * rng.next()),
            q * DVec3::Z,
            q * DVec3::X,
        )
        .unwrap();
        let mut dirs = layout.directions(&frame).unwrap();
        // Slightly off unit length (within the tolerance), and a few grazing rays exactly on the
        // horizon of the last ring (hemisphere layouts).
        for w in dirs.iter_mut() {
            *w *= 1.0 + 4e-7 * (rng.next() - 0.5);
        }
        if kind == LayoutKind::CosinePolar {
            for k in 0..n {
                if rng.next() < 0.3 {
                    let l = layout.grid_to_local(m as f64, k as f64 + rng.next());
                    dirs[layout.index(m - 1, k)] = frame.to_world(l);
                }
            }
        }
        let cells = layout.len();
        let steps = 1 + (rng.next() * 5.0) as usize;
        let dist = (0..cells)
            .map(|_| {
                let u = rng.next();
                if u < 0.25 {
                    f64::INFINITY
                } else if u < 0.3 {
                    1e-3 * u
                } else {
                    0.1 + 4.0 * u
                }
            })
            .collect();
        let rad = (0..cells * channels)
            .map(|_| (2.0 * rng.next() - 0.4) as f32)
            .collect();
        let media = (0..cells * steps * channels)
            .map(|_| (0.3 * rng.next()) as f32)
            .collect();
        let media_grad = (0..cells * steps * channels * 3)
            .map(|_| (rng.next() - 0.5) as f32 * 0.2)
            .collect();
        Gather {
            layout,
            frame,
            dirs,
            dist,
            rad,
            media,
            media_grad,
            channels,
            steps,
        }
    }

    fn input(&self, sigma_t: f64, media: bool, media_grad: bool) -> GatherInput<'_> {
        GatherInput {
            directions: &self.dirs,
            distance: &self.dist,
            radiance: &self.rad,
            channels: self.channels,
            sigma_t,
            media: media.then_some(MediaRadiance {
                radiance: &self.media,
                gradient: media_grad.then_some(&self.media_grad[..]),
                steps: self.steps,
                step: 0.37,
            }),
        }
    }

    /// Size of the summed terms: radiance (surface + marched media) per stratum times the
    /// stratum weight, and for the gradients times the largest inverse hit distance and the width
    /// of a stratum (wall vectors are about that long).
    fn scales(&self, media: bool) -> (f64, f64) {
        let mut sum = self.rad.iter().map(|l| l.abs() as f64).sum::<f64>();
        if media {
            sum += self.media.iter().map(|q| q.abs() as f64).sum::<f64>() * 0.37;
            sum += self.media_grad.iter().map(|q| q.abs() as f64).sum::<f64>() * 0.37 * 5.0;
        }
        let weight = 4.0 * std::f64::consts::PI / self.layout.len() as f64;
        let inv_r = self.dist.iter().map(|r| 1.0 / r).fold(1.0f64, f64::max);
        let e = sum * weight;
        (e, e * inv_r * weight.sqrt())
    }
}

fn wanted_combinations() -> Vec<Wanted> {
    (0..16)
        .map(|b| Wanted {
            irradiance: b & 1 != 0,
            gradient: b & 2 != 0,
            rotation_gradient: b & 4 != 0,
            distances: b & 8 != 0,
        })
        .collect()
}

/// Largest deviation relative to the scales; panics on any structural difference.
fn compare(got: &GatherValues, want: &GatherValues, (se, sg): (f64, f64), what: &str) -> f64 {
    assert_eq!(got.irradiance.len(), want.irradiance.len(), "{what}");
    assert_eq!(got.gradient.len(), want.gradient.len(), "{what}");
    assert_eq!(
        got.rotation_gradient.len(),
        want.rotation_gradient.len(),
        "{what}"
    );
    let mut worst = 0.0f64;
    for (a, b) in got.irradiance.iter().zip(&want.irradiance) {
        worst = worst.max((a - b).abs() / se.max(b.abs()));
    }
    for (a, b) in got
        .gradient
        .iter()
        .zip(&want.gradient)
        .chain(got.rotation_gradient.iter().zip(&want.rotation_gradient))
    {
        worst = worst.max((*a - *b).length() / sg.max(b.length()));
    }
    match (got.harmonic_mean_distance, want.harmonic_mean_distance) {
        (Some(a), Some(b)) => {
            assert!(
                a == b || (a - b).abs() <= 1e-13 * b,
                "{what}: harmonic mean {a} {b}"
            );
        }
        (a, b) => assert_eq!(a, b, "{what}"),
    }
    assert_eq!(got.min_distance, want.min_distance, "{what}");
    worst
}

#[test]
fn single_pass_evaluation_matches_the_previous_implementation() {
    let mut rng = Rng(0x5eed_1234_abcd_0001);
    let mut worst = 0.0f64;
    let mut cases = 0;
    let sizes = [(1, 1), (1, 6), (5, 1), (3, 7), (8, 2), (16, 33), (32, 128)];
    for kind in [
        LayoutKind::CosinePolar,
        LayoutKind::Concentric,
        LayoutKind::Sphere,
    ] {
        for (m, n) in sizes {
            for seed in [0, 11] {
                let channels = 1 + (rng.next() * 4.0) as usize;
                let g = Gather::new(kind, m, n, seed, channels, &mut rng);
                for (sigma_t, media, media_grad) in [
                    (0.0, false, false),
                    (0.3, false, false),
                    (0.0, true, false),
                    (0.3, true, false),
                    (0.3, true, true),
                    (2.5, true, true),
                ] {
                    let input = g.input(sigma_t, media, media_grad);
                    let scales = g.scales(media);
                    for wanted in wanted_combinations() {
                        let what = format!(
                            "{kind:?} {m}x{n} seed {seed} ch {channels} sigma {sigma_t} media {media}/{media_grad} {wanted:?}"
                        );
                        let want =
                            evaluate_reference::evaluate(&g.layout, &g.frame, &input, wanted)
                                .unwrap_or_else(|e| panic!("{what}: reference fails: {e}"));
                        let got = evaluate(&g.layout, &g.frame, &input, wanted)
                            .unwrap_or_else(|e| panic!("{what}: {e}"));
                        let d = compare(&got, &want, scales, &what);
                        assert!(d <= 1e-13, "{what}: deviation {d:e}");
                        worst = worst.max(d);
                        cases += 1;
                    }
                }
            }
        }
    }
    println!("{cases} evaluations, largest deviation {worst:e} of the term scale");
}

fn message(r: Result<GatherValues, Error>) -> String {
    match r {
        Ok(_) => "ok".into(),
        Err(e) => format!("{e:?}"),
    }
}

/// Every kind of bad input, at random places, gets the same error (kind and message).
#[test]
fn bad_input_fails_like_the_previous_implementation() {
    let mut rng = Rng(0x0bad_0bad_0bad_0001);
    for kind in [
        LayoutKind::CosinePolar,
        LayoutKind::Concentric,
        LayoutKind::Sphere,
    ] {
        for (m, n) in [(1, 1), (3, 7), (16, 33)] {
            let base = Gather::new(kind, m, n, 3, 3, &mut rng);
            let cells = base.layout.len();
            for case in 0..14 {
                let mut g = Gather::new(kind, m, n, 3, 3, &mut rng);
                g.dirs.clone_from(&base.dirs);
                g.frame = base.frame;
                let i = (rng.next() * cells as f64) as usize;
                let mut sigma_t = 0.3;
                match case {
                    0 => g.dist[i] = 0.0,
                    1 => g.dist[i] = f64::NAN,
                    2 => g.dist[i] = -1.0,
                    3 => g.rad[i * 3 + 1] = f32::NAN,
                    4 => g.rad[i * 3 + 2] = f32::INFINITY,
                    5 => {
                        let k = (rng.next() * g.media.len() as f64) as usize;
                        g.media[k] = f32::NEG_INFINITY;
                    }
                    6 => {
                        let k = (rng.next() * g.media_grad.len() as f64) as usize;
                        g.media_grad[k] = f32::NAN;
                    }
                    7 => g.dirs[i] *= 1.0 + 1e-5,
                    8 => g.dirs[i] = -g.dirs[i],
                    9 => g.dirs[i] = DVec3::new(f64::NAN, 0.0, 1.0),
                    10 => g.dirs[i] = g.dirs[(i + 1) % cells],
                    11 => g.dirs[i] = g.dirs[(i + n as usize) % cells],
                    12 => sigma_t = -1.0,
                    _ => {
                        g.dist[i] = 0.0;
                        g.rad[((i + 1) % cells) * 3] = f32::NAN;
                        g.dirs[(i + 2) % cells] *= 2.0;
                    }
                }
                for (media, media_grad) in [(false, false), (true, true)] {
                    let input = g.input(sigma_t, media, media_grad);
                    for wanted in [Wanted::ALL, Wanted::IRRADIANCE] {
                        let want = message(evaluate_reference::evaluate(
                            &g.layout, &g.frame, &input, wanted,
                        ));
                        let got = message(evaluate(&g.layout, &g.frame, &input, wanted));
                        assert_eq!(got, want, "{kind:?} {m}x{n} case {case}");
                    }
                }
            }
        }
    }
}
