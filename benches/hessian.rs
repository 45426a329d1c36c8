//! Occlusion-aware Hessian of a hemisphere gather: triangulation, gradient, Hessian (shared edges
//! vs per triangle, and against the peer formulation: Radiance-style scalar per-edge closed forms,
//! `tests/hessian_common/peer.rs`) and radii, for 1024, 4096 and 16384 rays of the thesis
//! evaluation scene.
//! Run: `cargo bench --bench hessian -- --warm-up-time 1 --measurement-time 3`.

#[path = "../tests/hessian_common/mod.rs"]
mod hessian_common;

use std::hint::black_box;

use criterion::{criterion_group, BenchmarkId, Criterion, Throughput};
use glam::{DMat3, DVec3};
use hessian_common::peer::per_edge_closed_forms;
use hessian_common::{noisy_radiance, scene, SceneGather};
use raddiff::gather::hessian::occlusion_outputs;
use raddiff::gather::hessian::{
    mesh_geometry, occlusion_derivatives, occlusion_derivatives_per_triangle,
    occlusion_derivatives_reference, HemisphereGather, LayoutKind, Topology,
};
use raddiff::gather::radii::{surface_radii, ErrorMode};
use raddiff::gather::{Frame, GatherInput, Layout, MediaRadiance, ValidGather, Wanted};
use raddiff::Order;

/// The Ward-Heckbert baseline: irradiance and translational gradient.
const WH: Wanted = Wanted {
    irradiance: true,
    gradient: true,
    rotation_gradient: false,
    distances: false,
};

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
        let noisy = noisy_radiance(&sg.radiance);
        let mut gn = g;
        gn.radiance = &noisy;
        group.bench_with_input(
            BenchmarkId::new("hessian (shared edges, noisy radiance)", samples),
            &gn,
            |b, g| b.iter(|| occlusion_derivatives(&topo, black_box(g), Order::Hessian).unwrap()),
        );
        group.bench_with_input(
            BenchmarkId::new("peer per-edge closed forms (noisy radiance)", samples),
            &gn,
            |b, g| b.iter(|| peer(&topo, black_box(g))),
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

/// The peer formulation's Hessian of a gather, placement of the mesh included (as in
/// `occlusion_derivatives`).
fn peer(topo: &Topology, g: &HemisphereGather) -> DMat3 {
    let mesh = mesh_geometry(topo, g).unwrap();
    per_edge_closed_forms(topo, &mesh, g, 0).hessian
}

/// CPU time of one call of `f` (thread CPU clock: the machine is shared, wall time is not stable):
/// the smallest of 5 averages over runs of about `budget / 5` seconds each (interference from other
/// processes only ever adds time).
fn cpu_time_per_call(budget: f64, mut f: impl FnMut()) -> f64 {
    fn thread_cpu() -> f64 {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid timespec to write into.
        unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        ts.tv_sec as f64 + 1e-9 * ts.tv_nsec as f64
    }
    f();
    let round = budget / 5.0;
    let mut calls = 1usize;
    loop {
        let t0 = thread_cpu();
        for _ in 0..calls {
            f();
        }
        let t = thread_cpu() - t0;
        if t >= round {
            break;
        }
        calls = (calls * 2).max((calls as f64 * round / t.max(1e-6) * 1.2) as usize);
    }
    (0..5)
        .map(|_| {
            let t0 = thread_cpu();
            for _ in 0..calls {
                f();
            }
            (thread_cpu() - t0) / calls as f64
        })
        .fold(f64::INFINITY, f64::min)
}

/// `RADDIFF_HESSIAN_CPU=1 cargo bench --bench hessian`: prints the README's CPU-time tables (polar
/// layouts with N = 4M; surfaces, then media) instead of running criterion.
fn cpu_table() {
    let x = DVec3::new(-0.3, -0.2, 0.0);
    let budget = 0.5;
    println!("| rays | triangulation | gradient | Hessian (scene) | Hessian (noisy) | previous Hessian (noisy) | peer per-edge closed forms (scene, noisy) | Ward-Heckbert gradient | Hessian / WH (scene, noisy) |");
    for (m, n) in [(16usize, 64usize), (32, 128), (64, 256)] {
        let kind = LayoutKind::CosinePolar;
        let sg = SceneGather::new(kind, m, n, 0, x, &scene::rects(), 0.5);
        let g = sg.gather();
        let noisy = noisy_radiance(&sg.radiance);
        let mut gn = g;
        gn.radiance = &noisy;
        let topo = Topology::new(kind, m, n).unwrap();
        let us = 1e6;
        let tri = us
            * cpu_time_per_call(budget, || {
                black_box(mesh_geometry(&topo, black_box(&g)).unwrap());
            });
        let grad = us
            * cpu_time_per_call(budget, || {
                black_box(occlusion_derivatives(&topo, black_box(&g), Order::Gradient).unwrap());
            });
        let hs = us
            * cpu_time_per_call(budget, || {
                black_box(occlusion_derivatives(&topo, black_box(&g), Order::Hessian).unwrap());
            });
        let hn = us
            * cpu_time_per_call(budget, || {
                black_box(occlusion_derivatives(&topo, black_box(&gn), Order::Hessian).unwrap());
            });
        let old = us
            * cpu_time_per_call(budget, || {
                black_box(
                    occlusion_derivatives_reference(&topo, black_box(&gn), Order::Hessian).unwrap(),
                );
            });
        let peer_scene = us
            * cpu_time_per_call(budget, || {
                black_box(peer(&topo, black_box(&g)));
            });
        let peer_noisy = us
            * cpu_time_per_call(budget, || {
                black_box(peer(&topo, black_box(&gn)));
            });
        let layout = Layout::new(kind, m as u32, n as u32, 0).unwrap();
        let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
        let input = GatherInput {
            directions: &sg.directions,
            distance: &sg.distance,
            radiance: &noisy,
            channels: 1,
            sigma_t: 0.0,
            media: None,
        };
        let valid = ValidGather::new(&layout, &frame, &input).unwrap();
        let wh = us
            * cpu_time_per_call(budget, || {
                black_box(black_box(&valid).evaluate(WH).unwrap());
            });
        println!(
            "| {} | {tri:.1} µs | {grad:.1} µs | {hs:.1} µs | {hn:.1} µs | {old:.1} µs | {peer_scene:.1} µs, {peer_noisy:.1} µs | {wh:.1} µs | {:.1}x, {:.1}x |",
            m * n,
            hs / wh,
            hn / wh
        );
    }
    media_table(budget);
}

/// The Hessian of a surface point in a medium (`sigma_t > 0`, noisy radiance), through
/// `occlusion_derivatives` and through its reference (the general kernel per edge and the product
/// rule per triangle), and the C ABI's hemisphere gather with 16 media march steps (one ring of
/// triangles per step, `occlusion_outputs`).
fn media_table(budget: f64) {
    let x = DVec3::new(-0.3, -0.2, 0.0);
    println!();
    println!("| rays | Hessian in a medium | reference (previous) | with 16 media rings |");
    for (m, n) in [(16usize, 64usize), (32, 128), (64, 256)] {
        let kind = LayoutKind::CosinePolar;
        let sg = SceneGather::new(kind, m, n, 0, x, &scene::rects(), 0.5);
        let noisy = noisy_radiance(&sg.radiance);
        let mut g = sg.gather();
        g.radiance = &noisy;
        g.sigma_t = 0.5;
        let topo = Topology::new(kind, m, n).unwrap();
        let us = 1e6;
        let medium = us
            * cpu_time_per_call(budget, || {
                black_box(occlusion_derivatives(&topo, black_box(&g), Order::Hessian).unwrap());
            });
        let reference = us
            * cpu_time_per_call(budget, || {
                black_box(
                    occlusion_derivatives_reference(&topo, black_box(&g), Order::Hessian).unwrap(),
                );
            });
        let steps = 16;
        let media: Vec<f32> = (0..m * n * steps)
            .map(|i| 0.1 + 0.001 * ((i * 31 % 17) as f32))
            .collect();
        let layout = Layout::new(kind, m as u32, n as u32, 0).unwrap();
        let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
        let input = GatherInput {
            directions: &sg.directions,
            distance: &sg.distance,
            radiance: &noisy,
            channels: 1,
            sigma_t: 0.5,
            media: Some(MediaRadiance {
                radiance: &media,
                gradient: None,
                steps,
                step: 0.15,
            }),
        };
        let valid = ValidGather::new(&layout, &frame, &input).unwrap();
        let rings = us
            * cpu_time_per_call(budget, || {
                black_box(occlusion_outputs(black_box(&valid), true).unwrap());
            });
        println!(
            "| {} | {medium:.1} µs | {reference:.1} µs | {rings:.0} µs |",
            m * n
        );
    }
}

/// `RADDIFF_HESSIAN_PROFILE=noisy|scene|gradient|triangulation cargo bench --bench hessian`: runs
/// one operation on the 4096-ray polar gather for about 3 s (for `perf record`), and prints the
/// mean wall time per call.
fn profile_loop(what: &str) {
    let x = DVec3::new(-0.3, -0.2, 0.0);
    let (m, n) = (32, 128);
    let kind = LayoutKind::CosinePolar;
    let sg = SceneGather::new(kind, m, n, 0, x, &scene::rects(), 0.5);
    let noisy = noisy_radiance(&sg.radiance);
    let mut g = sg.gather();
    if what == "noisy" {
        g.radiance = &noisy;
    }
    let topo = Topology::new(kind, m, n).unwrap();
    let order = if what == "gradient" {
        Order::Gradient
    } else {
        Order::Hessian
    };
    let start = std::time::Instant::now();
    let mut calls = 0u32;
    while start.elapsed().as_secs_f64() < 3.0 {
        calls += 100;
        for _ in 0..100 {
            if what == "triangulation" {
                black_box(mesh_geometry(&topo, black_box(&g)).unwrap());
            } else {
                black_box(occlusion_derivatives(&topo, black_box(&g), order).unwrap());
            }
        }
    }
    let per_call = start.elapsed().as_secs_f64() / calls as f64;
    println!(
        "{what}: {:.1} µs per call (wall, {calls} calls)",
        per_call * 1e6
    );
}

criterion_group!(benches, bench);

fn main() {
    if let Some(what) = std::env::var_os("RADDIFF_HESSIAN_PROFILE") {
        profile_loop(what.to_str().unwrap_or(""));
        return;
    }
    if std::env::var_os("RADDIFF_HESSIAN_CPU").is_some() {
        cpu_table();
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
