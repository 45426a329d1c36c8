//! Occlusion-aware Hessian of a hemisphere gather: triangulation, gradient, Hessian (shared edges
//! vs per triangle) and radii, for 1024, 4096 and 16384 rays of the thesis evaluation scene.
//! Run: `cargo bench --bench hessian -- --warm-up-time 1 --measurement-time 3`.

#[path = "../tests/hessian_common/mod.rs"]
mod hessian_common;

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::DVec3;
use hessian_common::{scene, SceneGather};
use raddiff::gather::hessian::{
    mesh_geometry, occlusion_derivatives, occlusion_derivatives_per_triangle, LayoutKind, Topology,
};
use raddiff::gather::hessian_fill::occlusion_outputs;
use raddiff::gather::radii::{surface_radii, ErrorMode};
use raddiff::gather::{Frame, GatherInput, Layout, ValidGather, Wanted};
use raddiff::Order;

fn bench(c: &mut Criterion) {
    let x = DVec3::new(-0.3, -0.2, 0.0);
    let mut group = c.benchmark_group("hessian");
    for side in [32usize, 64, 128] {
        let samples = side * side;
        let kind = LayoutKind::Concentric;
        // Grey environment: every triangle carries a radiance, as in a lit interior.
        let sg = SceneGather::new(kind, side, side, 0, x, &scene::rects(), 0.5);
        let g = sg.gather();
        let topo = Topology::new(kind, side, side).unwrap();
        group.throughput(Throughput::Elements(samples as u64));
        group.bench_with_input(
            BenchmarkId::new("topology (once per layout)", samples),
            &side,
            |b, &s| b.iter(|| Topology::new(kind, black_box(s), s).unwrap()),
        );
        group.bench_with_input(BenchmarkId::new("triangulation", samples), &g, |b, g| {
            b.iter(|| mesh_geometry(&topo, black_box(g)).unwrap())
        });
        group.bench_with_input(BenchmarkId::new("gradient", samples), &g, |b, g| {
            b.iter(|| occlusion_derivatives(&topo, black_box(g), Order::Gradient).unwrap())
        });
        group.bench_with_input(
            BenchmarkId::new("hessian (shared edges)", samples),
            &g,
            |b, g| b.iter(|| occlusion_derivatives(&topo, black_box(g), Order::Hessian).unwrap()),
        );
        group.bench_with_input(
            BenchmarkId::new("hessian (per triangle)", samples),
            &g,
            |b, g| {
                b.iter(|| {
                    occlusion_derivatives_per_triangle(&topo, black_box(g), Order::Hessian).unwrap()
                })
            },
        );
        // Worst case: every sample a different radiance, so no edge can be skipped.
        let noisy: Vec<f32> = sg
            .radiance
            .iter()
            .enumerate()
            .map(|(i, l)| l + 0.01 * ((i * 7919 % 101) as f32))
            .collect();
        let mut gn = g;
        gn.radiance = &noisy;
        group.bench_with_input(
            BenchmarkId::new("hessian (shared edges, noisy radiance)", samples),
            &gn,
            |b, g| b.iter(|| occlusion_derivatives(&topo, black_box(g), Order::Hessian).unwrap()),
        );
        let d = occlusion_derivatives(&topo, &g, Order::Hessian).unwrap();
        let h = d.robust_hessian(0);
        let e = d.irradiance[0];
        group.bench_with_input(BenchmarkId::new("radii", samples), &h, |b, h| {
            b.iter(|| {
                surface_radii(black_box(*h), DVec3::Z, e, 0.05, ErrorMode::Relative, 2.0).unwrap()
            })
        });
    }
    group.finish();

    // Polar layout: the occlusion-aware Hessian against the Ward-Heckbert gradient of the same gather.
    let mut group = c.benchmark_group("hessian vs ward-heckbert (polar)");
    for (m, n) in [(16u32, 64u32), (32, 128), (64, 256)] {
        let samples = (m * n) as usize;
        let layout = Layout::new(LayoutKind::CosinePolar, m, n, 0).unwrap();
        let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
        let sg = SceneGather::new(
            LayoutKind::CosinePolar,
            m as usize,
            n as usize,
            0,
            x,
            &scene::rects(),
            0.5,
        );
        let input = GatherInput {
            directions: &sg.directions,
            distance: &sg.distance,
            radiance: &sg.radiance,
            channels: 1,
            sigma_t: 0.0,
            media: None,
        };
        let valid = ValidGather::new(&layout, &frame, &input).unwrap();
        group.throughput(Throughput::Elements(samples as u64));
        let wh = Wanted {
            irradiance: true,
            gradient: true,
            rotation_gradient: false,
            distances: false,
        };
        group.bench_with_input(
            BenchmarkId::new("ward-heckbert gradient", samples),
            &valid,
            |b, v| b.iter(|| black_box(v).evaluate(wh).unwrap()),
        );
        group.bench_with_input(
            BenchmarkId::new("occlusion-aware hessian", samples),
            &valid,
            |b, v| b.iter(|| occlusion_outputs(black_box(v), true).unwrap()),
        );
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
