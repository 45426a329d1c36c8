//! Times the point-to-triangle form factor in its hard regimes against its generic case, in the
//! same interleaved rounds, without the 320-bit references of the `kernels` example (their
//! accuracy is checked by `tests/kernels_b_accuracy.rs` and `tests/kernels_b_regimes.rs`).
//!
//! `cargo run --release --example form_factor_regimes` prints a table: ns per call (minimum over
//! 40 interleaved rounds) and the ratio to the generic case at the same order.
//! `cargo run --release --example form_factor_regimes -- CASE ORDER CALLS` runs one case only
//! (for profilers: `valgrind --tool=callgrind`); ORDER is `value`, `gradient` or `hessian`.

use std::hint::black_box;
use std::time::Instant;

use glam::DVec3;
use raddiff::{kernels, Order};

struct Case {
    name: &'static str,
    tri: [DVec3; 3],
    x: DVec3,
    n: DVec3,
}

/// The configurations of `examples/kernels.rs` (same triangles, points and normals).
fn cases() -> Vec<Case> {
    let tri = [
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(1.0, 0.0, 1.2),
        DVec3::new(0.2, 0.9, 0.8),
    ];
    let sliver = [
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(0.5, 1e-4, 1.0),
    ];
    let sliver_6 = [sliver[0], sliver[1], DVec3::new(0.5, 1e-6, 1.0)];
    let normal = DVec3::new(0.1, -0.2, 1.0).normalize();
    let plane_n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
    let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
    let far_dir = DVec3::new(-0.3, -0.2, -1.0).normalize();
    // In the triangle's plane, beyond edge (0, 1): the tangent plane clips the triangle.
    let outside = (tri[0] + tri[1]) * 0.5 + (tri[0] + tri[1] - tri[2] * 2.0) * 0.1;
    let list = [
        ("generic", tri, DVec3::new(0.3, 0.2, 0.1)),
        ("1e-6 above the plane", tri, centroid - plane_n * 1e-6),
        (
            "1e-5 from an edge",
            tri,
            (tri[0] + tri[1]) * 0.5 - plane_n * 1e-5,
        ),
        ("1e2 sizes away", tri, centroid + far_dir * 1e2),
        ("1e4 sizes away", tri, centroid + far_dir * 1e4),
        ("1e6 sizes away", tri, centroid + far_dir * 1e6),
        ("sliver", sliver, DVec3::new(0.4, 0.1, 0.3)),
        ("sliver, apex 1e-6", sliver_6, DVec3::new(0.4, 0.1, 0.3)),
        (
            "1e-6 from the plane, outside",
            tri,
            outside - plane_n * 1e-6,
        ),
    ];
    list.into_iter()
        .map(|(name, tri, x)| {
            // The receiver faces the triangle, as in the kernels example.
            let n = if (tri[0] - x).dot(normal) > 0.0 {
                normal
            } else {
                -normal
            };
            Case { name, tri, x, n }
        })
        .collect()
}

fn call(c: &Case, order: Order) {
    let t = c.tri;
    black_box(kernels::triangle_form_factor(black_box(c.x), c.n, t[0], t[1], t[2], order).ok());
}

fn main() {
    let orders = [Order::Value, Order::Gradient, Order::Hessian];
    let args: Vec<String> = std::env::args().collect();
    if args.len() == 4 {
        let case = cases()
            .into_iter()
            .find(|c| c.name.starts_with(args[1].as_str()))
            .expect("unknown case");
        let order = match args[2].as_str() {
            "value" => Order::Value,
            "gradient" => Order::Gradient,
            _ => Order::Hessian,
        };
        let calls: usize = args[3].parse().expect("CALLS");
        for _ in 0..calls {
            call(&case, order);
        }
        return;
    }
    let cases = cases();
    let (rounds, max_calls) = (40, 1000);
    // Calls per round: up to 1000, fewer for the slow cases (about 2 ms a round).
    let calls: Vec<[usize; 3]> = cases
        .iter()
        .map(|c| {
            orders.map(|order| {
                let start = Instant::now();
                call(c, order);
                let ns = start.elapsed().as_secs_f64() * 1e9;
                ((2e6 / ns) as usize).clamp(1, max_calls)
            })
        })
        .collect();
    let mut best = vec![[f64::INFINITY; 3]; cases.len()];
    for _ in 0..rounds {
        for (k, c) in cases.iter().enumerate() {
            for (o, order) in orders.iter().enumerate() {
                let calls = calls[k][o];
                let start = Instant::now();
                for _ in 0..calls {
                    call(c, *order);
                }
                let ns = start.elapsed().as_secs_f64() * 1e9 / calls as f64;
                best[k][o] = best[k][o].min(ns);
            }
        }
    }
    println!("| case | value ns | gradient ns | Hessian ns |");
    println!("|---|---|---|---|");
    for (k, c) in cases.iter().enumerate() {
        let cell = |o: usize| format!("{:.0} ({:.2}x)", best[k][o], best[k][o] / best[0][o]);
        println!("| {} | {} | {} | {} |", c.name, cell(0), cell(1), cell(2));
    }
    println!("\nns per call, minimum over {rounds} interleaved rounds of up to {max_calls} calls (about 2 ms a round for the slow cases); ratios to the generic case at the same order.");
}
