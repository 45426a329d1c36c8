//! Criterion benches of the point-to-triangle form factor in its hard regimes (issue 18: slivers,
//! 1e-6 from the plane and 1e6 sizes away, each within 5x of the generic case), at each order.
//! Before the criterion groups a table gives ns per call and the ratio to the generic case at the
//! same order, measured in the same interleaved rounds (minimum over 40 rounds), so that every
//! row sees the same machine load. Accuracy in these configurations is checked by
//! `tests/kernels_b_accuracy.rs` and `tests/kernels_b_regimes.rs` against 320-bit references.
//!
//! `cargo bench --bench kernels_regimes -- --warm-up-time 1 --measurement-time 2` (table and
//! criterion); append a filter that matches nothing (`nomatch`) for the table alone.
//! For profilers, `RADDIFF_REGIMES_PROFILE="CASE ORDER CALLS"` runs one case only and exits (CASE
//! is a prefix of a case name, ORDER is `value`, `gradient` or `hessian`), e.g.
//! `RADDIFF_REGIMES_PROFILE="sliver,value,200000" valgrind --tool=callgrind <bench binary>`.

use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, Criterion};
use glam::DVec3;
use raddiff::{kernels, Order};

struct Case {
    name: &'static str,
    tri: [DVec3; 3],
    x: DVec3,
    n: DVec3,
}

/// The configurations of `examples/kernels.rs` (same triangles, points and normals) and a few more.
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
        ("sliver, apex 1e-4", sliver, DVec3::new(0.4, 0.1, 0.3)),
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

const ORDERS: [(&str, Order); 3] = [
    ("value", Order::Value),
    ("gradient", Order::Gradient),
    ("hessian", Order::Hessian),
];

fn call(c: &Case, order: Order) {
    let t = c.tri;
    black_box(kernels::triangle_form_factor(black_box(c.x), c.n, t[0], t[1], t[2], order).ok());
}

/// `RADDIFF_REGIMES_PROFILE="CASE,ORDER,CALLS"`: the calls of one case, nothing else.
fn profile(spec: &str) {
    // From the right: case names contain commas.
    let parts: Vec<&str> = spec.rsplitn(3, ',').map(str::trim).collect();
    let [calls, order, case] = parts[..] else {
        panic!("RADDIFF_REGIMES_PROFILE must be CASE,ORDER,CALLS");
    };
    let case = cases()
        .into_iter()
        .find(|c| c.name.starts_with(case))
        .expect("unknown case");
    let order = ORDERS
        .iter()
        .find(|(name, _)| *name == order)
        .expect("ORDER is value, gradient or hessian")
        .1;
    for _ in 0..calls.parse::<usize>().expect("CALLS") {
        call(&case, order);
    }
}

/// ns per call, minimum over interleaved rounds, for every case and order.
fn ratio_table(cases: &[Case]) {
    let (rounds, max_calls) = (40, 1000);
    // Calls per round: up to 1000, fewer for slow cases (about 2 ms a round). Timed after a first
    // call, which may initialize the quadrature rules (once per process, tens of µs): calibrating
    // on it would give that case few calls per round, each round paying for cold caches.
    let calls: Vec<[usize; 3]> = cases
        .iter()
        .map(|c| {
            ORDERS.map(|(_, order)| {
                call(c, order);
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
            for (o, (_, order)) in ORDERS.iter().enumerate() {
                let start = Instant::now();
                for _ in 0..calls[k][o] {
                    call(c, *order);
                }
                let ns = start.elapsed().as_secs_f64() * 1e9 / calls[k][o] as f64;
                best[k][o] = best[k][o].min(ns);
            }
        }
    }
    println!("\ntriangle form factor in hard regimes: ns per call (ratio to the generic case, same order)");
    println!("| case | value | gradient | Hessian |");
    println!("|---|---|---|---|");
    for (k, c) in cases.iter().enumerate() {
        let cell = |o: usize| format!("{:.0} ns ({:.2}x)", best[k][o], best[k][o] / best[0][o]);
        println!("| {} | {} | {} | {} |", c.name, cell(0), cell(1), cell(2));
    }
    println!("minimum over {rounds} interleaved rounds of up to {max_calls} calls\n");
}

fn bench(c: &mut Criterion) {
    let cases = cases();
    ratio_table(&cases);
    for case in &cases {
        let mut g = c.benchmark_group(format!("form_factor_regimes/{}", case.name));
        for (label, order) in ORDERS {
            g.bench_function(label, |b| b.iter(|| call(case, order)));
        }
        g.finish();
    }
}

fn main() {
    if let Ok(spec) = std::env::var("RADDIFF_REGIMES_PROFILE") {
        profile(&spec);
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}

criterion_group!(benches, bench);
