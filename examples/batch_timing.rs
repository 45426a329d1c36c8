//! Batch entry points against loops of single-element calls, timed as the minimum over many
//! interleaved repetitions in one process: on a machine shared with other jobs the minimum of short
//! runs is far less sensitive to the load than criterion's mean (`benches/kernels_batch.rs` has the
//! same inputs: 1024 f32 triangles ~0.1 in size 1-2 above the receiver at (0.05, -0.03, 0), normal
//! +z).
//!
//! `cargo run --profile bench --example batch_timing [REPS]` (default 300), with
//! `RADDIFF_SIMD=avx2` or `portable` to cap the instruction set. Prints, per order, the loop, the
//! summed batch (`mesh_solid_angle`, `mesh_form_factor`) and the per-element batch
//! (`mesh_solid_angle_each`) in µs with their ratios to the loop.

use raddiff::glam::DVec3;
use raddiff::{kernels, Deriv3, Order};
use std::hint::black_box;
use std::time::Instant;

/// The bench's generator (same seed, same light).
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

fn main() {
    let reps: usize = std::env::args()
        .nth(1)
        .map_or(300, |s| s.parse().expect("REPS is a count"));
    let mut rng = Lcg(1);
    let mut v = Vec::new();
    let mut ix = Vec::new();
    for t in 0..1024u32 {
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
    let mesh = kernels::TriangleMesh::indexed_f32(&v, &ix).expect("valid light");
    let (x, n) = (DVec3::new(0.05, -0.03, 0.0), DVec3::Z);
    let mut out = vec![Deriv3::default(); mesh.len()];
    for order in [Order::Value, Order::Gradient, Order::Hessian] {
        let [l, s, e] = fastest(
            reps,
            [
                &mut || {
                    let mut sum = 0.0;
                    for t in 0..mesh.len() {
                        let [p, q, r] = mesh.triangle(t);
                        let d = kernels::triangle_solid_angle(black_box(x), p, q, r, order)
                            .expect("generic");
                        sum += d.value + d.gradient.x + d.hessian.x_axis.x;
                    }
                    black_box(sum);
                },
                &mut || {
                    black_box(kernels::mesh_solid_angle(black_box(x), &mesh, order).expect("ok"));
                },
                &mut || {
                    kernels::mesh_solid_angle_each(black_box(x), &mesh, order, &mut out)
                        .expect("ok");
                    black_box(&out);
                },
            ],
        );
        println!(
            "solid angle {order:?}: loop {l:.1}, sum {s:.1} ({:.2}x), each {e:.1} ({:.2}x)",
            l / s,
            l / e
        );
        let [l, s] = fastest(
            reps,
            [
                &mut || {
                    let mut sum = 0.0;
                    for t in 0..mesh.len() {
                        let [p, q, r] = mesh.triangle(t);
                        let d = kernels::triangle_form_factor(black_box(x), n, p, q, r, order)
                            .expect("generic");
                        sum += d.value + d.gradient.x + d.hessian.x_axis.x;
                    }
                    black_box(sum);
                },
                &mut || {
                    black_box(
                        kernels::mesh_form_factor(black_box(x), n, &mesh, order).expect("ok"),
                    );
                },
            ],
        );
        println!(
            "form factor {order:?}: loop {l:.1}, sum {s:.1} ({:.2}x)",
            l / s
        );
    }
}
