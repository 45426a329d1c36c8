//! End-to-end cost of one irradiance record in the demo's Cornell box, at 4096 rays per record
//! (32 x 128 cosine-polar strata): the ray casting of the gather (baseline) against raddiff's work
//! on what the rays found: irradiance with Ward-Heckbert gradients, and the occlusion-aware
//! Hessian. The ratios to the baseline are the overhead of raddiff's derivatives in a renderer.
//!
//! `cargo bench --bench end_to_end -- --warm-up-time 1 --measurement-time 3`
//!
//! The scene, BVH and gather code are the demo's (`examples/demo/`), included by path.

#![allow(dead_code)]

#[path = "../examples/demo/bvh.rs"]
mod bvh;
#[path = "../examples/demo/derivs.rs"]
mod derivs;
#[path = "../examples/demo/geometry.rs"]
mod geometry;
#[path = "../examples/demo/image.rs"]
mod image;
#[path = "../examples/demo/lightmap.rs"]
mod lightmap;
#[path = "../examples/demo/scene.rs"]
mod scene;
#[path = "../examples/demo/timing.rs"]
mod timing;

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;

use raddiff::cache::irradiance::{HessianKind, Hessians};

use crate::derivs::Gatherer;
use crate::geometry::Ray;
use crate::lightmap::LightMap;
use crate::scene::{Scene, SceneKind};

/// Record positions: primary hits of a coarse pixel grid (floor, walls, blocks, ceiling).
fn record_points(scene: &Scene) -> Vec<(DVec3, DVec3)> {
    let mut points = Vec::new();
    for y in (4..64).step_by(12) {
        for x in (4..64).step_by(12) {
            let ray: Ray = scene.camera.ray(x, y, 64, 64);
            if let Some(sp) = scene.intersect(&ray) {
                points.push((sp.position, sp.normal));
            }
        }
    }
    points
}

fn bench(c: &mut Criterion) {
    let scene = Scene::build(SceneKind::Cornell);
    let lightmap = LightMap::build(&scene, &indicatif::ProgressBar::hidden());
    let hessians = Hessians {
        occlusion_aware: true,
        ..Hessians::NONE
    };
    let gatherer = Gatherer::new(32, 128, hessians).expect("valid layout");
    let points = record_points(&scene);
    let traced: Vec<_> = points
        .iter()
        .enumerate()
        .map(|(i, &(p, n))| {
            gatherer
                .trace(&scene, &lightmap, p, n, 1 + i as u64)
                .expect("gather traces")
        })
        .collect();
    let mut group = c.benchmark_group(format!("record_4096_rays_x{}", points.len()));
    group.bench_function("ray_casting", |b| {
        b.iter(|| {
            for (i, &(p, n)) in points.iter().enumerate() {
                black_box(
                    gatherer
                        .trace(&scene, &lightmap, p, n, 1 + i as u64)
                        .unwrap(),
                );
            }
        })
    });
    group.bench_function("raddiff_irradiance_and_gradients", |b| {
        b.iter(|| {
            for t in &traced {
                black_box(gatherer.evaluate(t).unwrap());
            }
        })
    });
    let evaluated: Vec<_> = traced
        .iter()
        .map(|t| gatherer.evaluate(t).expect("gather evaluates"))
        .collect();
    group.bench_function("raddiff_occlusion_hessian", |b| {
        b.iter(|| {
            for (t, evaluation) in traced.iter().zip(&evaluated) {
                // the clone (a few short vectors) is noise against the Hessian
                let mut evaluation = evaluation.clone();
                gatherer
                    .add_hessian(t, &mut evaluation, HessianKind::OcclusionAware)
                    .unwrap();
                black_box(evaluation);
            }
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
