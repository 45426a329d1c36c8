//! Time per eye segment of single scattering on the back-lit bumpy sphere (9680 triangles) and a
//! 100k-triangle bumpy sphere: the interval method with all pruning tests, with each test alone
//! and with none, against the brute-force reference (Walter et al.; no pruning).
//!
//! `cargo bench --bench scatter -- --warm-up-time 1 --measurement-time 3`

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;
use raddiff::scatter::{
    scene, single_scatter, single_scatter_brute_force, BruteForceOptions, Medium, RefractiveMesh,
    ScatterOptions,
};

const LIGHT: DVec3 = DVec3::new(0.35, 0.6, -3.0);

fn medium() -> Medium {
    Medium {
        eta: 1.5,
        sigma_t: 0.5,
        sigma_s: 0.45,
        g: 0.0,
    }
}

/// Chords of eye rays from a camera at z = 4 through a grid over the sphere.
fn segments(mesh: &RefractiveMesh, n: usize) -> Vec<(DVec3, DVec3)> {
    let cam = DVec3::new(0.0, 0.0, 4.0);
    let mut out = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let t = DVec3::new(
                1.4 * ((i as f64 + 0.5) / n as f64 - 0.5),
                1.4 * ((j as f64 + 0.5) / n as f64 - 0.5),
                0.0,
            );
            let d = (t - cam).normalize();
            let (Some(a), Some(b)) = (
                mesh.closest_hit(cam, d, 0.0, 1e9),
                mesh.closest_hit(cam, d, 0.0, 1e9)
                    .and_then(|a| mesh.closest_hit(cam, d, a.t + 1e-9, 1e9)),
            ) else {
                continue;
            };
            out.push((cam + a.t * d, cam + b.t * d));
        }
    }
    out
}

fn variants() -> Vec<(&'static str, ScatterOptions)> {
    let all = ScatterOptions::default();
    let none = ScatterOptions {
        sidedness_test: false,
        spindle_test: false,
        normal_cone_test: false,
        ..all
    };
    vec![
        ("all pruning", all),
        (
            "sidedness only",
            ScatterOptions {
                sidedness_test: true,
                ..none
            },
        ),
        (
            "spindle only",
            ScatterOptions {
                spindle_test: true,
                ..none
            },
        ),
        (
            "normal cone only",
            ScatterOptions {
                normal_cone_test: true,
                ..none
            },
        ),
        ("no pruning", none),
    ]
}

fn bench_mesh(c: &mut Criterion, name: &str, frequency: usize, grid: usize, brute: Option<usize>) {
    let mesh = scene::bumpy_sphere(frequency, 0.05, 6.0).build().unwrap();
    let segs = segments(&mesh, grid);
    let m = medium();
    let mut g = c.benchmark_group(format!("scatter/{name}"));
    g.sample_size(10);
    for (label, opts) in variants() {
        g.bench_function(
            format!("interval, {label} ({} segments)", segs.len()),
            |b| {
                b.iter(|| {
                    let mut sum = 0.0;
                    for &(e, x) in &segs {
                        sum += single_scatter(&mesh, &m, e, x, LIGHT, 1.0, &opts)
                            .unwrap()
                            .radiance;
                    }
                    black_box(sum)
                })
            },
        );
    }
    if let Some(samples) = brute {
        let (e, x) = segs[segs.len() / 2];
        g.bench_function(format!("brute force, {samples} samples (1 segment)"), |b| {
            b.iter(|| {
                let opts = BruteForceOptions {
                    samples,
                    ..Default::default()
                };
                black_box(single_scatter_brute_force(&mesh, &m, e, x, LIGHT, 1.0, &opts).unwrap())
            })
        });
    }
    g.finish();
}

fn benches(c: &mut Criterion) {
    bench_mesh(c, "bumpy sphere 9680", 22, 4, Some(32));
    bench_mesh(c, "bumpy sphere 100820", 71, 2, None);
}

criterion_group!(scatter_benches, benches);
criterion_main!(scatter_benches);
