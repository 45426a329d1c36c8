//! Criterion benches of the triangle solid angle, the flatland segment form factor and the
//! homogeneous and marched transmittance at each order, against the baselines a user would
//! otherwise write: (a) the textbook value formula (Van Oosterom-Strackee for the solid angle), (b)
//! central finite differences of that textbook value (gradient: 6 evaluations, 4 in 2D; Hessian:
//! 19, 9 in 2D) and (c) a num-dual second-order dual-number (Dual2Vec) Hessian of the same textbook
//! formula. Before timing, the errors of raddiff and of every baseline against 320-bit references
//! (astro-float, `tests/kernel_reference`) are printed side by side, and an interleaved timing
//! table gives every time as a ratio to the textbook value measured in the same rounds.
//!
//! `cargo bench --bench solid_angle_transmittance -- --warm-up-time 1 --measurement-time 3`

#![allow(clippy::needless_range_loop)] // index loops mirror the finite-difference stencils

use criterion::{criterion_group, criterion_main, Criterion};
use glam::{DVec2, DVec3};
use nalgebra::{SMatrix, SVector};
use num_dual::{Dual2SVec64, DualNum};
use raddiff::{kernels, Order};
use std::hint::black_box;

mod baselines;
#[path = "../tests/kernel_reference/mod.rs"]
mod reference;

use baselines::{dual_hessian3, fd_hessian3, textbook_solid_angle, textbook_solid_angle_f64, D3};

type D2 = Dual2SVec64<2>;

// ------------------------------------------------------------------------------------------------
// Finite-difference baselines (step relative to the configuration's scale).

fn fd_gradient3(f: &dyn Fn(DVec3) -> f64, x: DVec3, h: f64) -> DVec3 {
    let mut g = DVec3::ZERO;
    for i in 0..3 {
        let mut e = DVec3::ZERO;
        e[i] = h;
        g[i] = (f(x + e) - f(x - e)) / (2.0 * h);
    }
    g
}

fn fd_gradient2(f: &dyn Fn(DVec2) -> f64, x: DVec2, h: f64) -> DVec2 {
    let (ex, ey) = (DVec2::new(h, 0.0), DVec2::new(0.0, h));
    DVec2::new(
        (f(x + ex) - f(x - ex)) / (2.0 * h),
        (f(x + ey) - f(x - ey)) / (2.0 * h),
    )
}

fn fd_hessian2(f: &dyn Fn(DVec2) -> f64, x: DVec2, h: f64) -> [f64; 3] {
    let (ex, ey) = (DVec2::new(h, 0.0), DVec2::new(0.0, h));
    let f0 = f(x);
    [
        (f(x + ex) - 2.0 * f0 + f(x - ex)) / (h * h),
        (f(x + ex + ey) - f(x + ex - ey) - f(x - ex + ey) + f(x - ex - ey)) / (4.0 * h * h),
        (f(x + ey) - 2.0 * f0 + f(x - ey)) / (h * h),
    ]
}

// ------------------------------------------------------------------------------------------------
// Dual-number baselines: the same value formulas on num-dual's Dual2Vec.

fn textbook_sa(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    textbook_solid_angle_f64(p, a, b, c)
}

fn solid_angle_dual(x: &SVector<D3, 3>, a: DVec3, b: DVec3, c: DVec3) -> D3 {
    textbook_solid_angle([x[0], x[1], x[2]], a, b, c)
}

fn segment_dual(x: &SVector<D2, 2>, a: DVec2, b: DVec2) -> D2 {
    let (ax, ay) = (D2::from(a.x) - x[0], D2::from(a.y) - x[1]);
    let (bx, by) = (D2::from(b.x) - x[0], D2::from(b.y) - x[1]);
    let cross = ax * (b.y - a.y) - ay * (b.x - a.x);
    let cross = if cross.re < 0.0 { -cross } else { cross };
    cross.atan2(ax * bx + ay * by) * (0.5 / std::f64::consts::PI)
}

/// The textbook flatland form factor `θ/2π`, `θ = atan2(|r_a×r_b|, r_a·r_b)`.
fn textbook_segment(x: DVec2, a: DVec2, b: DVec2) -> f64 {
    let (ra, rb) = (a - x, b - x);
    ra.perp_dot(rb).abs().atan2(ra.dot(rb)) * (0.5 / std::f64::consts::PI)
}

fn transmittance_dual(x: &SVector<D3, 3>, y: DVec3, sigma: f64) -> D3 {
    let d = [x[0] - y.x, x[1] - y.y, x[2] - y.z];
    let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    (-(dist * sigma)).exp()
}

fn dual_hessian2(f: impl Fn(&SVector<D2, 2>) -> D2, x: DVec2) -> (f64, DVec2, [f64; 3]) {
    let (v, g, h): (f64, SVector<f64, 2>, SMatrix<f64, 2, 2>) =
        num_dual::hessian(|v: SVector<D2, 2>| f(&v), &SVector::from([x.x, x.y]));
    (v, DVec2::new(g[0], g[1]), [h[(0, 0)], h[(0, 1)], h[(1, 1)]])
}

// ------------------------------------------------------------------------------------------------
// Accuracy of the baselines, printed once.

fn rel_vec(a: &[f64], b: &[f64]) -> f64 {
    let m = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |e, (p, q)| e.max((p - q).abs()))
        / m
}

fn report_accuracy() {
    println!("\nbaseline error vs closed form (max |error| / max |entry|):");
    println!(
        "{:<40} {:>10} {:>10} {:>10} {:>10}",
        "configuration", "FD grad", "FD hess", "dual grad", "dual hess"
    );
    let (a, b, c) = TRI;
    for (name, x) in [
        ("solid angle, generic", DVec3::new(0.4, 0.3, 0.8)),
        ("solid angle, 1e4 sizes away", DVec3::new(4e3, -6e3, 7e3)),
    ] {
        let exact = kernels::triangle_solid_angle(x, a, b, c, Order::Hessian).unwrap();
        let f = |p: DVec3| textbook_sa(p, a, b, c);
        let h = 1e-5 * x.length().max(1.0);
        let fg = fd_gradient3(&f, x, h);
        let fh = fd_hessian3(&f, x, 1e-4 * x.length().max(1.0));
        let dual = dual_hessian3(|v| solid_angle_dual(v, a, b, c), x);
        println!(
            "{name:<40} {:>10.1e} {:>10.1e} {:>10.1e} {:>10.1e}",
            rel_vec(&fg.to_array(), &exact.gradient.to_array()),
            rel_vec(&fh.to_cols_array(), &exact.hessian.to_cols_array()),
            rel_vec(&dual.gradient.to_array(), &exact.gradient.to_array()),
            rel_vec(
                &dual.hessian.to_cols_array(),
                &exact.hessian.to_cols_array()
            ),
        );
    }
    let (sa, sb) = (DVec2::new(-0.3, 1.0), DVec2::new(0.8, 1.2));
    for (name, x) in [
        ("segment FF, generic", DVec2::new(0.1, -0.2)),
        ("segment FF, 1e4 lengths away", DVec2::new(5e3, -8e3)),
    ] {
        let exact = kernels::segment_form_factor_2d(x, sa, sb, Order::Hessian).unwrap();
        let eh = [
            exact.hessian.x_axis.x,
            exact.hessian.y_axis.x,
            exact.hessian.y_axis.y,
        ];
        let f = |p: DVec2| {
            kernels::segment_form_factor_2d(p, sa, sb, Order::Value)
                .unwrap()
                .value
        };
        let fg = fd_gradient2(&f, x, 1e-5 * x.length().max(1.0));
        let fh = fd_hessian2(&f, x, 1e-4 * x.length().max(1.0));
        let (_, dg, dh) = dual_hessian2(|v| segment_dual(v, sa, sb), x);
        println!(
            "{name:<40} {:>10.1e} {:>10.1e} {:>10.1e} {:>10.1e}",
            rel_vec(&fg.to_array(), &exact.gradient.to_array()),
            rel_vec(&fh, &eh),
            rel_vec(&dg.to_array(), &exact.gradient.to_array()),
            rel_vec(&dh, &eh),
        );
    }
    let (x, y, sigma) = (DVec3::new(0.3, 0.2, 0.1), DVec3::new(1.5, -0.7, 2.0), 0.8);
    let exact = kernels::transmittance(x, y, sigma, Order::Hessian).unwrap();
    let f = |p: DVec3| {
        kernels::transmittance(p, y, sigma, Order::Value)
            .unwrap()
            .value
    };
    let dual = dual_hessian3(|v| transmittance_dual(v, y, sigma), x);
    println!(
        "{:<40} {:>10.1e} {:>10.1e} {:>10.1e} {:>10.1e}\n",
        "transmittance, generic",
        rel_vec(
            &fd_gradient3(&f, x, 1e-5).to_array(),
            &exact.gradient.to_array()
        ),
        rel_vec(
            &fd_hessian3(&f, x, 1e-4).to_cols_array(),
            &exact.hessian.to_cols_array()
        ),
        rel_vec(&dual.gradient.to_array(), &exact.gradient.to_array()),
        rel_vec(
            &dual.hessian.to_cols_array(),
            &exact.hessian.to_cols_array()
        ),
    );
}

/// The solid-angle benchmark triangle (about one size from the generic point).
const TRI: (DVec3, DVec3, DVec3) = (
    DVec3::new(0.1, -0.2, 0.05),
    DVec3::new(1.1, 0.1, 0.2),
    DVec3::new(0.3, 0.9, -0.1),
);

/// Solid-angle configurations: (name, triangle, x, finite-difference step).
fn solid_angle_cases() -> Vec<(&'static str, [DVec3; 3], DVec3, f64)> {
    let t = [TRI.0, TRI.1, TRI.2];
    let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
    let centroid = (t[0] + t[1] + t[2]) / 3.0;
    let outside = centroid + (t[1] - t[0]) * 1.5;
    let sliver = [
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(0.5, 1e-4, 1.0),
    ];
    vec![
        ("generic", t, DVec3::new(0.4, 0.3, 0.8), 1e-4),
        (
            "sliver (apex 1e-4)",
            sliver,
            DVec3::new(0.4, 0.1, 0.3),
            1e-4,
        ),
        ("1e-6 above the plane", t, outside + n * 1e-6, 1e-8),
        (
            "1e6 sizes away",
            t,
            centroid + DVec3::new(-0.3, -0.2, -1.0).normalize() * 1e6,
            1e2,
        ),
    ]
}

/// Time and error side by side for the solid angle: raddiff and the baselines a user would write
/// (the textbook value, central differences of it, num-dual on it), errors against 320-bit
/// references, times as the minimum over interleaved rounds with ratios to the textbook value.
fn report_solid_angle() {
    let mut hp = reference::Hp::new();
    println!("\ntriangle solid angle: time (ns, ratio to the textbook value) and error vs 320-bit reference");
    println!(
        "{:<22} {:>16} {:>16} {:>16} {:>16} {:>16} {:>16} {:>16}",
        "configuration",
        "textbook value",
        "raddiff value",
        "raddiff grad",
        "raddiff hess",
        "FD grad (tb)",
        "FD hess (tb)",
        "dual hess (tb)"
    );
    for (name, t, x, step) in solid_angle_cases() {
        let [a, b, c] = t;
        let r = reference::central3(&mut hp, x, 1e-30 * (a - x).length(), &mut |hp, p| {
            let v = t.map(|v| reference::V3::from(hp, v));
            reference::solid_angle_hp(hp, p, &v, false)
        });
        let f = |p: DVec3| textbook_sa(p, a, b, c);
        let d = kernels::triangle_solid_angle(x, a, b, c, Order::Hessian).unwrap();
        let dual = dual_hessian3(|v| solid_angle_dual(v, a, b, c), x);
        let err = [
            reference::rel(f(x), r.value),
            reference::rel(d.value, r.value),
            reference::rel3(d.gradient, r.gradient),
            reference::rel33(d.hessian, r.hessian),
            reference::rel3(fd_gradient3(&f, x, step * 0.1), r.gradient),
            reference::rel33(fd_hessian3(&f, x, step), r.hessian),
            reference::rel33(dual.hessian, r.hessian),
        ];
        let t = min_ns(
            60,
            2000,
            &mut [
                &mut || {
                    black_box(f(black_box(x)));
                },
                &mut || {
                    black_box(kernels::triangle_solid_angle(
                        black_box(x),
                        a,
                        b,
                        c,
                        Order::Value,
                    ))
                    .ok();
                },
                &mut || {
                    black_box(kernels::triangle_solid_angle(
                        black_box(x),
                        a,
                        b,
                        c,
                        Order::Gradient,
                    ))
                    .ok();
                },
                &mut || {
                    black_box(kernels::triangle_solid_angle(
                        black_box(x),
                        a,
                        b,
                        c,
                        Order::Hessian,
                    ))
                    .ok();
                },
                &mut || {
                    black_box(fd_gradient3(&f, black_box(x), step * 0.1));
                },
                &mut || {
                    black_box(fd_hessian3(&f, black_box(x), step));
                },
                &mut || {
                    black_box(dual_hessian3(
                        |v| solid_angle_dual(v, a, b, c),
                        black_box(x),
                    ));
                },
            ],
        );
        let cells: Vec<String> = (0..7)
            .map(|k| format!("{:.0} ({:.2}x)", t[k], t[k] / t[0]))
            .collect();
        println!(
            "{name:<22} {:>16} {:>16} {:>16} {:>16} {:>16} {:>16} {:>16}",
            cells[0], cells[1], cells[2], cells[3], cells[4], cells[5], cells[6]
        );
        let errs: Vec<String> = err.iter().map(|e| format!("err {e:.1e}")).collect();
        println!(
            "{:<22} {:>16} {:>16} {:>16} {:>16} {:>16} {:>16} {:>16}",
            "", errs[0], errs[1], errs[2], errs[3], errs[4], errs[5], errs[6]
        );
    }
    println!();
}

// ------------------------------------------------------------------------------------------------
// Interleaved timing: on a shared, loaded machine criterion's sequential groups see different load
// levels. Here every variant of a kernel is timed in each round, rounds alternate, and the minimum
// per-call time over the rounds is kept, so the ratios compare like with like.

fn min_ns(rounds: usize, calls: usize, variants: &mut [&mut dyn FnMut()]) -> Vec<f64> {
    let mut best = vec![f64::INFINITY; variants.len()];
    for _ in 0..rounds {
        for (k, f) in variants.iter_mut().enumerate() {
            let t = std::time::Instant::now();
            for _ in 0..calls {
                f();
            }
            best[k] = best[k].min(t.elapsed().as_nanos() as f64 / calls as f64);
        }
    }
    best
}

fn report_interleaved_timing() {
    let rounds = 60;
    println!("interleaved timing, minimum over {rounds} rounds (ns per call; ratio to the value kernel; FD of the textbook value):");
    println!(
        "{:<24} {:>8} {:>8} {:>8} {:>10} {:>10} {:>10}",
        "kernel", "value", "gradient", "hessian", "FD grad", "FD hess", "dual hess"
    );
    let print = |name: &str, t: &[f64]| {
        let v = t[0];
        let cell = |x: f64| format!("{x:.0} ({:.1}x)", x / v);
        println!(
            "{name:<24} {:>8.0} {:>8} {:>8} {:>10} {:>10} {:>10}",
            v,
            cell(t[1]),
            cell(t[2]),
            cell(t[3]),
            cell(t[4]),
            cell(t[5])
        );
    };

    let (sa, sb, sx) = (
        DVec2::new(-0.3, 1.0),
        DVec2::new(0.8, 1.2),
        DVec2::new(0.1, -0.2),
    );
    let f2 = |p: DVec2| textbook_segment(p, sa, sb);
    let t = min_ns(
        rounds,
        2000,
        &mut [
            &mut || {
                black_box(kernels::segment_form_factor_2d(
                    black_box(sx),
                    sa,
                    sb,
                    Order::Value,
                ))
                .ok();
            },
            &mut || {
                black_box(kernels::segment_form_factor_2d(
                    black_box(sx),
                    sa,
                    sb,
                    Order::Gradient,
                ))
                .ok();
            },
            &mut || {
                black_box(kernels::segment_form_factor_2d(
                    black_box(sx),
                    sa,
                    sb,
                    Order::Hessian,
                ))
                .ok();
            },
            &mut || {
                black_box(fd_gradient2(&f2, black_box(sx), 1e-5));
            },
            &mut || {
                black_box(fd_hessian2(&f2, black_box(sx), 1e-4));
            },
            &mut || {
                black_box(dual_hessian2(|v| segment_dual(v, sa, sb), black_box(sx)));
            },
        ],
    );
    print("segment form factor 2D", &t);

    let (tx, ty, sigma) = (DVec3::new(0.3, 0.2, 0.1), DVec3::new(1.5, -0.7, 2.0), 0.8);
    let ft = |p: DVec3| (-sigma * (p - ty).length()).exp();
    let t = min_ns(
        rounds,
        2000,
        &mut [
            &mut || {
                black_box(kernels::transmittance(
                    black_box(tx),
                    ty,
                    sigma,
                    Order::Value,
                ))
                .ok();
            },
            &mut || {
                black_box(kernels::transmittance(
                    black_box(tx),
                    ty,
                    sigma,
                    Order::Gradient,
                ))
                .ok();
            },
            &mut || {
                black_box(kernels::transmittance(
                    black_box(tx),
                    ty,
                    sigma,
                    Order::Hessian,
                ))
                .ok();
            },
            &mut || {
                black_box(fd_gradient3(&ft, black_box(tx), 1e-5));
            },
            &mut || {
                black_box(fd_hessian3(&ft, black_box(tx), 1e-4));
            },
            &mut || {
                black_box(dual_hessian3(
                    |v| transmittance_dual(v, ty, sigma),
                    black_box(tx),
                ));
            },
        ],
    );
    print("transmittance", &t);

    let samples: Vec<f64> = (0..16).map(|i| 0.5 + 0.05 * i as f64).collect();
    let grads: Vec<DVec3> = (0..16)
        .map(|i| DVec3::new(0.01 * i as f64, 0.02, -0.01))
        .collect();
    let fm = |p: DVec3| {
        kernels::transmittance_marched(p, ty, &samples, None, Order::Value)
            .unwrap()
            .value
    };
    let t = min_ns(
        rounds,
        2000,
        &mut [
            &mut || {
                black_box(kernels::transmittance_marched(
                    black_box(tx),
                    ty,
                    &samples,
                    Some(&grads),
                    Order::Value,
                ))
                .ok();
            },
            &mut || {
                black_box(kernels::transmittance_marched(
                    black_box(tx),
                    ty,
                    &samples,
                    Some(&grads),
                    Order::Gradient,
                ))
                .ok();
            },
            &mut || {
                black_box(fd_gradient3(&fm, black_box(tx), 1e-5));
            },
        ],
    );
    println!(
        "{:<24} {:>8.0} {:>8} {:>8} {:>10}\n",
        "marched, 16 samples",
        t[0],
        format!("{:.0} ({:.1}x)", t[1], t[1] / t[0]),
        "-",
        format!("{:.0} ({:.1}x)", t[2], t[2] / t[0])
    );
}

// ------------------------------------------------------------------------------------------------

fn bench(c: &mut Criterion) {
    report_solid_angle();
    report_accuracy();
    report_interleaved_timing();

    let (a, b, tc) = (
        DVec3::new(0.1, -0.2, 0.05),
        DVec3::new(1.1, 0.1, 0.2),
        DVec3::new(0.3, 0.9, -0.1),
    );
    let x = DVec3::new(0.4, 0.3, 0.8);
    let mut g = c.benchmark_group("solid_angle");
    for (name, order) in [
        ("value", Order::Value),
        ("gradient", Order::Gradient),
        ("hessian", Order::Hessian),
    ] {
        g.bench_function(name, |bch| {
            bch.iter(|| {
                kernels::triangle_solid_angle(
                    black_box(x),
                    black_box(a),
                    black_box(b),
                    black_box(tc),
                    order,
                )
            })
        });
    }
    let f = |p: DVec3| textbook_sa(p, a, b, tc);
    g.bench_function("textbook_value", |bch| bch.iter(|| f(black_box(x))));
    g.bench_function("fd_gradient", |bch| {
        bch.iter(|| fd_gradient3(&f, black_box(x), 1e-5))
    });
    g.bench_function("fd_hessian", |bch| {
        bch.iter(|| fd_hessian3(&f, black_box(x), 1e-4))
    });
    g.bench_function("dual_hessian", |bch| {
        bch.iter(|| dual_hessian3(|v| solid_angle_dual(v, a, b, tc), black_box(x)))
    });
    g.finish();

    let (sa, sb, sx) = (
        DVec2::new(-0.3, 1.0),
        DVec2::new(0.8, 1.2),
        DVec2::new(0.1, -0.2),
    );
    let mut g = c.benchmark_group("segment_form_factor_2d");
    for (name, order) in [
        ("value", Order::Value),
        ("gradient", Order::Gradient),
        ("hessian", Order::Hessian),
    ] {
        g.bench_function(name, |bch| {
            bch.iter(|| {
                kernels::segment_form_factor_2d(black_box(sx), black_box(sa), black_box(sb), order)
            })
        });
    }
    let f2 = |p: DVec2| {
        kernels::segment_form_factor_2d(p, sa, sb, Order::Value)
            .unwrap()
            .value
    };
    g.bench_function("fd_gradient", |bch| {
        bch.iter(|| fd_gradient2(&f2, black_box(sx), 1e-5))
    });
    g.bench_function("fd_hessian", |bch| {
        bch.iter(|| fd_hessian2(&f2, black_box(sx), 1e-4))
    });
    g.bench_function("dual_hessian", |bch| {
        bch.iter(|| dual_hessian2(|v| segment_dual(v, sa, sb), black_box(sx)))
    });
    g.finish();

    let (tx, ty, sigma) = (DVec3::new(0.3, 0.2, 0.1), DVec3::new(1.5, -0.7, 2.0), 0.8);
    let mut g = c.benchmark_group("transmittance");
    for (name, order) in [
        ("value", Order::Value),
        ("gradient", Order::Gradient),
        ("hessian", Order::Hessian),
    ] {
        g.bench_function(name, |bch| {
            bch.iter(|| {
                kernels::transmittance(black_box(tx), black_box(ty), black_box(sigma), order)
            })
        });
    }
    let ft = |p: DVec3| {
        kernels::transmittance(p, ty, sigma, Order::Value)
            .unwrap()
            .value
    };
    g.bench_function("fd_gradient", |bch| {
        bch.iter(|| fd_gradient3(&ft, black_box(tx), 1e-5))
    });
    g.bench_function("fd_hessian", |bch| {
        bch.iter(|| fd_hessian3(&ft, black_box(tx), 1e-4))
    });
    g.bench_function("dual_hessian", |bch| {
        bch.iter(|| dual_hessian3(|v| transmittance_dual(v, ty, sigma), black_box(tx)))
    });
    g.finish();

    let samples: Vec<f64> = (0..16).map(|i| 0.5 + 0.05 * i as f64).collect();
    let grads: Vec<DVec3> = (0..16)
        .map(|i| DVec3::new(0.01 * i as f64, 0.02, -0.01))
        .collect();
    let mut g = c.benchmark_group("transmittance_marched_16");
    for (name, order) in [("value", Order::Value), ("gradient", Order::Gradient)] {
        g.bench_function(name, |bch| {
            bch.iter(|| {
                kernels::transmittance_marched(
                    black_box(tx),
                    black_box(ty),
                    black_box(&samples),
                    Some(&grads),
                    order,
                )
            })
        });
    }
    let fm = |p: DVec3| {
        kernels::transmittance_marched(p, ty, &samples, None, Order::Value)
            .unwrap()
            .value
    };
    g.bench_function("fd_gradient", |bch| {
        bch.iter(|| fd_gradient3(&fm, black_box(tx), 1e-5))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
