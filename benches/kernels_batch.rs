//! Criterion benches of the batch kernels against a loop over the single-element calls, in the
//! same run: one point against a 1024-triangle mesh light (summed and per triangle), and 1024
//! points against one triangle, at each order. Generic configurations: every triangle fully above
//! the receiver's tangent plane, about one to three sizes of the light away.
//!
//! Before the criterion groups, a table gives the mesh-light rows as the fastest of many interleaved
//! repetitions in one process (`RADDIFF_BATCH_REPS`, default 300): on a machine shared with other
//! jobs the minimum of short runs is far less sensitive to the load than criterion's means.
//!
//! `cargo bench --bench kernels_batch -- --warm-up-time 1 --measurement-time 3` (append a filter
//! that matches nothing, `nomatch`, for the table alone); `RADDIFF_SIMD=avx2` or `portable` caps
//! the instruction set.

use criterion::{criterion_group, criterion_main, Criterion};
use raddiff::glam::DVec3;
use raddiff::{kernels, Deriv3, Order};
use std::hint::black_box;
use std::time::Instant;

const COUNT: usize = 1024;

/// A deterministic generator (the benches' inputs must not change between runs).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A mesh light: small triangles scattered over the unit square 1..2 above the origin (the
/// receiver, normal +z), in f32 as a renderer stores them.
fn light(rng: &mut Lcg) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    let mut ix = Vec::new();
    for t in 0..COUNT as u32 {
        let (cx, cy, cz) = (rng.next() - 0.5, rng.next() - 0.5, 1.0 + rng.next());
        for _ in 0..3 {
            let d = [rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5];
            v.push([
                (cx + 0.1 * d[0]) as f32,
                (cy + 0.1 * d[1]) as f32,
                (cz + 0.1 * d[2]) as f32,
            ]);
        }
        ix.push([3 * t, 3 * t + 1, 3 * t + 2]);
    }
    (v, ix)
}

fn order_name(order: Order) -> &'static str {
    match order {
        Order::Value => "value",
        Order::Gradient => "gradient",
        Order::Hessian => "hessian",
    }
}

/// Microseconds of the fastest of `reps` runs of each of `runs`, interleaved.
fn fastest<const N: usize>(reps: usize, mut runs: [&mut dyn FnMut(); N]) -> [f64; N] {
    let mut best = [f64::INFINITY; N];
    for _ in 0..reps {
        for (b, run) in best.iter_mut().zip(runs.iter_mut()) {
            let t = Instant::now();
            run();
            *b = b.min(t.elapsed().as_secs_f64() * 1e6);
        }
    }
    best
}

/// Sum of a loop of single-element calls (what the batch replaces), for every order.
fn loop_sum(d: impl Iterator<Item = Deriv3>) -> f64 {
    d.map(|d| d.value + d.gradient.x + d.hessian.x_axis.x).sum()
}

/// The mesh-light rows as the fastest of interleaved repetitions (module documentation).
fn fastest_table(mesh: &kernels::TriangleMesh, x: DVec3, n: DVec3) {
    let reps: usize = std::env::var("RADDIFF_BATCH_REPS")
        .map_or(300, |s| s.parse().expect("RADDIFF_BATCH_REPS is a count"));
    let mut out = vec![Deriv3::default(); mesh.len()];
    println!("\nmesh light, {COUNT} triangles: fastest of {reps} interleaved runs, µs (ratio to the loop)");
    println!("| kernel | order | loop | sum | each |");
    println!("|---|---|---|---|---|");
    for order in [Order::Value, Order::Gradient, Order::Hessian] {
        let name = order_name(order);
        let [l, s, e] = fastest(
            reps,
            [
                &mut || {
                    black_box(loop_sum((0..mesh.len()).map(|t| {
                        let [p, q, r] = mesh.triangle(t);
                        kernels::triangle_solid_angle(black_box(x), p, q, r, order).unwrap()
                    })));
                },
                &mut || {
                    black_box(kernels::mesh_solid_angle(black_box(x), mesh, order).unwrap());
                },
                &mut || {
                    kernels::mesh_solid_angle_each(black_box(x), mesh, order, &mut out).unwrap();
                    black_box(&out);
                },
            ],
        );
        println!(
            "| solid angle | {name} | {l:.1} | {s:.1} ({:.2}x) | {e:.1} ({:.2}x) |",
            l / s,
            l / e
        );
        let [l, s, e] = fastest(
            reps,
            [
                &mut || {
                    black_box(loop_sum((0..mesh.len()).map(|t| {
                        let [p, q, r] = mesh.triangle(t);
                        kernels::triangle_form_factor(black_box(x), n, p, q, r, order).unwrap()
                    })));
                },
                &mut || {
                    black_box(kernels::mesh_form_factor(black_box(x), n, mesh, order).unwrap());
                },
                &mut || {
                    kernels::mesh_form_factor_each(black_box(x), n, mesh, order, &mut out).unwrap();
                    black_box(&out);
                },
            ],
        );
        println!(
            "| form factor | {name} | {l:.1} | {s:.1} ({:.2}x) | {e:.1} ({:.2}x) |",
            l / s,
            l / e
        );
    }
    println!();
}

fn mesh_benches(c: &mut Criterion) {
    let mut rng = Lcg(1);
    let (v, ix) = light(&mut rng);
    let mesh = kernels::TriangleMesh::indexed_f32(&v, &ix).unwrap();
    let x = DVec3::new(0.05, -0.03, 0.0);
    let n = DVec3::Z;
    fastest_table(&mesh, x, n);
    let mut out = vec![Deriv3::default(); COUNT];
    for order in [Order::Value, Order::Gradient, Order::Hessian] {
        let name = order_name(order);
        let mut g = c.benchmark_group(format!("mesh solid angle, {COUNT} triangles, {name}"));
        g.bench_function("loop of triangle_solid_angle", |b| {
            b.iter(|| {
                let mut sum = 0.0;
                for t in 0..mesh.len() {
                    let [p, q, r] = mesh.triangle(t);
                    let d = kernels::triangle_solid_angle(black_box(x), p, q, r, order).unwrap();
                    sum += d.value + d.gradient.x + d.hessian.x_axis.x;
                }
                sum
            })
        });
        g.bench_function("mesh_solid_angle (sum)", |b| {
            b.iter(|| kernels::mesh_solid_angle(black_box(x), &mesh, order).unwrap())
        });
        g.bench_function("mesh_solid_angle_each", |b| {
            b.iter(|| kernels::mesh_solid_angle_each(black_box(x), &mesh, order, &mut out).unwrap())
        });
        g.finish();

        let mut g = c.benchmark_group(format!("mesh form factor, {COUNT} triangles, {name}"));
        g.bench_function("loop of triangle_form_factor", |b| {
            b.iter(|| {
                let mut sum = 0.0;
                for t in 0..mesh.len() {
                    let [p, q, r] = mesh.triangle(t);
                    let d = kernels::triangle_form_factor(black_box(x), n, p, q, r, order).unwrap();
                    sum += d.value + d.gradient.x + d.hessian.x_axis.x;
                }
                sum
            })
        });
        g.bench_function("mesh_form_factor (sum)", |b| {
            b.iter(|| kernels::mesh_form_factor(black_box(x), n, &mesh, order).unwrap())
        });
        g.finish();
    }
}

fn points_benches(c: &mut Criterion) {
    let mut rng = Lcg(2);
    let tri = [
        DVec3::new(-0.3, -0.2, 1.0),
        DVec3::new(0.4, -0.1, 1.2),
        DVec3::new(0.0, 0.5, 1.1),
    ];
    let points: Vec<DVec3> = (0..COUNT)
        .map(|_| {
            DVec3::new(
                2.0 * rng.next() - 1.0,
                2.0 * rng.next() - 1.0,
                0.3 * rng.next(),
            )
        })
        .collect();
    let mut out = vec![Deriv3::default(); COUNT];
    for order in [Order::Value, Order::Hessian] {
        let name = order_name(order);
        let mut g = c.benchmark_group(format!("points solid angle, {COUNT} points, {name}"));
        g.bench_function("loop of triangle_solid_angle", |b| {
            b.iter(|| {
                for (p, o) in points.iter().zip(out.iter_mut()) {
                    *o =
                        kernels::triangle_solid_angle(black_box(*p), tri[0], tri[1], tri[2], order)
                            .unwrap();
                }
            })
        });
        g.bench_function("points_solid_angle", |b| {
            b.iter(|| {
                kernels::points_solid_angle(
                    black_box(&points),
                    tri[0],
                    tri[1],
                    tri[2],
                    order,
                    &mut out,
                )
                .unwrap()
            })
        });
        g.finish();
    }
}

criterion_group!(benches, mesh_benches, points_benches);
criterion_main!(benches);
