//! Criterion benches of the point-to-triangle and point-to-polygon form factors in their hard
//! regimes (issue 18: slivers, 1e-6 from the plane and 1e6 sizes away, each within 5x of the
//! generic case), at each order. Before the criterion groups two tables give ns per call and the
//! ratio to the generic case of the same vertex count at the same order, measured in the same
//! interleaved rounds (minimum over 40 rounds), so that every row sees the same machine load.
//! Accuracy in these configurations is checked by `tests/form_factor_accuracy.rs`,
//! `tests/form_factor_regimes.rs` and `tests/form_factor_near_plane.rs` against 320-bit references.
//!
//! `cargo bench --bench kernels_regimes -- --warm-up-time 1 --measurement-time 2` (table and
//! criterion); append a filter that matches nothing (`nomatch`) for the table alone.
//! For profilers, `RADDIFF_REGIMES_PROFILE="CASE ORDER CALLS"` runs one case only and exits (CASE
//! is a prefix of a case name, ORDER is `value`, `gradient` or `hessian`), e.g.
//! `RADDIFF_REGIMES_PROFILE="sliver,value,200000" valgrind --tool=callgrind <bench binary>`.
//! `RADDIFF_REGIMES_MIX="ORDER,CALLS"` instead runs `polygon_form_factor` over a fixed mix of
//! outside-near-plane configurations ([`polygon_mix`]), one call each, for the average cost of the
//! regime beyond the one configuration of the table (`RADDIFF_REGIMES_MIX="ORDER,CALLS,generic"`:
//! over its baseline of generic configurations; `...,triangles` for triangles through
//! `triangle_form_factor`). Two more tables time each mix against its baseline in the same rounds.

use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, Criterion};
use glam::DVec3;
use raddiff::{kernels, Order};

struct Case {
    name: &'static str,
    /// Three vertices: `triangle_form_factor`; more: `polygon_form_factor`.
    v: Vec<DVec3>,
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
    let mut all: Vec<Case> = list
        .into_iter()
        .map(|(name, tri, x)| facing(name, tri.to_vec(), x))
        .collect();
    // The apex-1e-6 sliver with the receiver tilted so that its tangent plane cuts off the
    // vertex at the origin (the sliver rule on the visible part, with the clip line's Hessian).
    all.push(Case {
        name: "sliver, apex 1e-6, clipped",
        v: sliver_6.to_vec(),
        x: DVec3::new(0.4, 0.1, 0.3),
        n: DVec3::new(1.0, 0.0, 0.3).normalize(),
    });
    all.extend(polygon_cases());
    all
}

/// The receiver faces the polygon, as in the kernels example.
fn facing(name: &'static str, v: Vec<DVec3>, x: DVec3) -> Case {
    let normal = DVec3::new(0.1, -0.2, 1.0).normalize();
    let n = if (v[0] - x).dot(normal) > 0.0 {
        normal
    } else {
        -normal
    };
    Case { name, v, x, n }
}

/// The quad and pentagon of `benches/form_factor.rs` in the triangle's regimes, each first in its
/// generic configuration (the baseline of its rows), plus slivers (width 1e-6 of the length).
fn polygon_cases() -> Vec<Case> {
    let quad: Vec<DVec3> = [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
        .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
        .to_vec();
    let pentagon: Vec<DVec3> = (0..5)
        .map(|i| {
            let phi = std::f64::consts::TAU * i as f64 / 5.0;
            DVec3::new(phi.cos(), phi.sin(), 1.2 + 0.3 * phi.sin())
        })
        .collect();
    // A trapezoid 1 long and 1e-6 wide, and a pentagon on a flat arc as thin.
    let sliver_quad = vec![
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(0.7, 1e-6, 1.0),
        DVec3::new(0.2, 1e-6, 1.0),
    ];
    let sliver_pentagon = vec![
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(0.8, 0.8e-6, 1.0),
        DVec3::new(0.5, 1e-6, 1.0),
        DVec3::new(0.2, 0.8e-6, 1.0),
    ];
    let far_dir = DVec3::new(-0.3, -0.2, -1.0).normalize();
    // `edge`: the edge beyond which x lies outside, one that the tangent plane then cuts.
    let regimes = |v: &[DVec3], edge: usize, names: [&'static str; 4]| {
        let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        let centroid = v.iter().sum::<DVec3>() / v.len() as f64;
        // In the plane, beyond the edge by a fifth of the centroid's distance to its midpoint.
        let mid = (v[edge] + v[(edge + 1) % v.len()]) * 0.5;
        let outside = mid + (mid - centroid) * 0.2;
        [
            facing(names[0], v.to_vec(), DVec3::new(0.3, 0.2, 0.1)),
            facing(names[1], v.to_vec(), centroid + far_dir * 1e6),
            facing(names[2], v.to_vec(), centroid - plane_n * 1e-6),
            facing(names[3], v.to_vec(), outside - plane_n * 1e-6),
        ]
    };
    let mut list = Vec::new();
    list.extend(regimes(
        &quad,
        0,
        [
            "quad generic",
            "quad 1e6 sizes away",
            "quad 1e-6 above the plane",
            "quad 1e-6 from the plane, outside",
        ],
    ));
    list.push(facing(
        "quad sliver 1e-6",
        sliver_quad,
        DVec3::new(0.4, 0.1, 0.3),
    ));
    list.extend(regimes(
        &pentagon,
        1,
        [
            "pentagon generic",
            "pentagon 1e6 sizes away",
            "pentagon 1e-6 above the plane",
            "pentagon 1e-6 from the plane, outside",
        ],
    ));
    list.push(facing(
        "pentagon sliver 1e-6",
        sliver_pentagon,
        DVec3::new(0.4, 0.1, 0.3),
    ));
    list
}

const ORDERS: [(&str, Order); 3] = [
    ("value", Order::Value),
    ("gradient", Order::Gradient),
    ("hessian", Order::Hessian),
];

fn call(c: &Case, order: Order) {
    if let [a, b, t] = c.v[..] {
        black_box(kernels::triangle_form_factor(black_box(c.x), c.n, a, b, t, order).ok());
    } else {
        black_box(kernels::polygon_form_factor(black_box(c.x), c.n, &c.v, order).ok());
    }
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
    // Each row against the first case of its vertex count (the generic one).
    let baseline = |k: usize| {
        (0..cases.len())
            .find(|&j| cases[j].v.len() == cases[k].v.len())
            .unwrap()
    };
    for (title, triangles) in [("triangle", true), ("polygon", false)] {
        println!("\n{title} form factor in hard regimes: ns per call (ratio to the generic case, same order)");
        println!("| case | value | gradient | Hessian |");
        println!("|---|---|---|---|");
        for (k, c) in cases.iter().enumerate() {
            if (c.v.len() == 3) != triangles {
                continue;
            }
            let b = baseline(k);
            let cell = |o: usize| format!("{:.0} ns ({:.2}x)", best[k][o], best[k][o] / best[b][o]);
            println!("| {} | {} | {} | {} |", c.name, cell(0), cell(1), cell(2));
        }
    }
    println!("minimum over {rounds} interleaved rounds of up to {max_calls} calls\n");
}

/// ns per call over the outside mix and over the generic mix of the same shapes (minimum over
/// interleaved rounds of one pass over each), and their ratio: the regime's average cost against
/// the generic configurations of the same shapes, for quads and pentagons, then for triangles.
fn mix_table() {
    let (count, rounds) = (1000, 30);
    for (shapes, triangles) in [("quads and pentagons", false), ("triangles", true)] {
        let outside = polygon_mix(count, false, triangles);
        let generic = polygon_mix(count, true, triangles);
        let mut best = [[f64::INFINITY; 3]; 2];
        for _ in 0..rounds {
            for (m, mix) in [&outside, &generic].into_iter().enumerate() {
                for (o, (_, order)) in ORDERS.iter().enumerate() {
                    let start = Instant::now();
                    for case in mix {
                        call(case, *order);
                    }
                    let ns = start.elapsed().as_secs_f64() * 1e9 / count as f64;
                    best[m][o] = best[m][o].min(ns);
                }
            }
        }
        println!(
            "form factor of {count} {shapes}: ns per call (ratio to the generic mix, same order)"
        );
        println!("| mix | value | gradient | Hessian |");
        println!("|---|---|---|---|");
        for (m, name) in ["outside near the plane (1e-6)", "generic (same shapes)"]
            .into_iter()
            .enumerate()
        {
            let cell = |o: usize| format!("{:.0} ns ({:.2}x)", best[m][o], best[m][o] / best[1][o]);
            println!("| {name} | {} | {} | {} |", cell(0), cell(1), cell(2));
        }
        println!("minimum over {rounds} interleaved rounds of one pass over each mix\n");
    }
}

fn bench(c: &mut Criterion) {
    let cases = cases();
    ratio_table(&cases);
    mix_table();
    for case in &cases {
        let mut g = c.benchmark_group(format!("form_factor_regimes/{}", case.name));
        for (label, order) in ORDERS {
            g.bench_function(label, |b| b.iter(|| call(case, order)));
        }
        g.finish();
    }
}

/// `calls` clipped convex quads and pentagons of unit circumradius (vertices at jittered even
/// angles, in the plane z = 0; with `triangles`, triangles so jittered), x 1e-6 from their plane
/// (either side) at 1.05-3 radii from the centre, receiver normals uniform on the sphere, kept when
/// the tangent plane cuts the polygon: a deterministic stand-in for the "1e-6 from the plane,
/// outside" regime's spread of positions and tangent planes. With `generic`, its baseline: shapes
/// from the same generator, `x` instead over the interior (within 0.3 radii of the centre)
/// 0.5-1.5 radii from the plane on either side, kept when every vertex is above the tangent plane
/// (nothing clipped).
fn polygon_mix(calls: usize, generic: bool, triangles: bool) -> Vec<Case> {
    let mut state = 7u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut mix = Vec::with_capacity(calls);
    while mix.len() < calls {
        let m = if triangles {
            3
        } else {
            4 + (next() * 2.0) as usize
        };
        let v: Vec<DVec3> = (0..m)
            .map(|k| {
                let a = (k as f64 + 0.3 * next()) / m as f64 * std::f64::consts::TAU;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        let (angle, distance) = (next() * std::f64::consts::TAU, 1.05 + 2.0 * next());
        let h = if next() < 0.5 { 1e-6 } else { -1e-6 };
        let x = if generic {
            let side = if h > 0.0 { 1.0 } else { -1.0 };
            DVec3::new(
                0.3 * (distance - 1.05) / 2.0 * angle.cos(),
                0.3 * (distance - 1.05) / 2.0 * angle.sin(),
                side * (0.5 + next()),
            )
        } else {
            DVec3::new(distance * angle.cos(), distance * angle.sin(), h)
        };
        let n = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
        let above = v.iter().filter(|p| n.dot(**p - x) > 0.0).count();
        let keep = if generic {
            above == m
        } else {
            above > 0 && above < m
        };
        if keep {
            mix.push(Case {
                name: if generic {
                    "generic mix"
                } else {
                    "outside mix"
                },
                v,
                x,
                n,
            });
        }
    }
    mix
}

fn main() {
    if let Ok(spec) = std::env::var("RADDIFF_REGIMES_MIX") {
        let (order, calls) = spec
            .split_once(',')
            .expect("RADDIFF_REGIMES_MIX must be ORDER,CALLS");
        let order = ORDERS
            .iter()
            .find(|(name, _)| *name == order.trim())
            .expect("ORDER is value, gradient or hessian")
            .1;
        let mut fields = calls.split(',');
        let calls = fields.next().unwrap().trim().parse().expect("CALLS");
        let flags: Vec<&str> = fields.map(str::trim).collect();
        let mix = polygon_mix(
            calls,
            flags.contains(&"generic"),
            flags.contains(&"triangles"),
        );
        for case in mix {
            call(&case, order);
        }
        return;
    }
    if let Ok(spec) = std::env::var("RADDIFF_REGIMES_PROFILE") {
        profile(&spec);
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}

criterion_group!(benches, bench);
