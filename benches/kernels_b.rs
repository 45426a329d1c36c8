//! Criterion benches of the point-to-triangle / point-to-polygon form factors at each order, against
//! (a) central finite differences of the value kernel (19 value calls for value + gradient + Hessian)
//! and (b) a num-dual hyper-dual Hessian of the value formula (6 hyper-dual evaluations, one per
//! Hessian entry), with the Hessian errors of both baselines printed next to the timings.
//!
//! `cargo bench --bench kernels_b -- --warm-up-time 1 --measurement-time 3`

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use glam::{DMat3, DVec3};
use num_dual::{DualNum, HyperDual64};
use raddiff::{kernels, Deriv3, Order};

/// The clipped form factor's value formula, generic over dual numbers (for the AD baseline).
fn value_formula<D: DualNum<Primitive = f64> + Copy>(x: [D; 3], n: DVec3, verts: &[DVec3]) -> D {
    let sub = |v: DVec3| {
        [
            D::from(v.x) - x[0],
            D::from(v.y) - x[1],
            D::from(v.z) - x[2],
        ]
    };
    let r: Vec<[D; 3]> = verts.iter().map(|v| sub(*v)).collect();
    let dot = |a: &[D; 3], b: &[D; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let ndot = |a: &[D; 3]| a[0] * n.x + a[1] * n.y + a[2] * n.z;
    let cross = |a: &[D; 3], b: &[D; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    // clip by n·r ≥ 0
    let d: Vec<D> = r.iter().map(ndot).collect();
    let mut poly: Vec<[D; 3]> = Vec::new();
    for i in 0..r.len() {
        let j = (i + 1) % r.len();
        if d[i].re() >= 0.0 {
            poly.push(r[i]);
        }
        if (d[i].re() > 0.0 && d[j].re() < 0.0) || (d[i].re() < 0.0 && d[j].re() > 0.0) {
            let t = d[i] / (d[i] - d[j]);
            poly.push([0, 1, 2].map(|k| r[i][k] + (r[j][k] - r[i][k]) * t));
        }
    }
    let mut sum = D::from(0.0);
    for i in 0..poly.len() {
        let (a, b) = (&poly[i], &poly[(i + 1) % poly.len()]);
        let w = cross(a, b);
        let wl = dot(&w, &w).sqrt();
        let beta = wl.atan2(dot(a, b));
        sum += beta * ndot(&w) / wl;
    }
    let normal = (verts[1] - verts[0]).cross(verts[2] - verts[0]);
    let xr = DVec3::new(x[0].re(), x[1].re(), x[2].re());
    let sign = if normal.dot(verts[0] - xr) > 0.0 {
        1.0
    } else {
        -1.0
    };
    sum * (sign * 0.5 * std::f64::consts::FRAC_1_PI)
}

/// Value, gradient and Hessian from 6 hyper-dual evaluations (one per independent Hessian entry).
fn hyperdual_hessian(x: DVec3, n: DVec3, verts: &[DVec3]) -> Deriv3 {
    let mut out = Deriv3::constant(0.0);
    for i in 0..3 {
        for j in i..3 {
            let xs = [0, 1, 2].map(|k| {
                let mut v = HyperDual64::from_re(x[k]);
                if k == i {
                    v.eps1 = 1.0;
                }
                if k == j {
                    v.eps2 = 1.0;
                }
                v
            });
            let f = value_formula(xs, n, verts);
            out.value = f.re;
            out.gradient[i] = f.eps1;
            out.hessian.col_mut(i)[j] = f.eps1eps2;
            out.hessian.col_mut(j)[i] = f.eps1eps2;
        }
    }
    out
}

/// Value, gradient and Hessian from 19 calls of the value kernel (central differences).
fn finite_difference_hessian(f: &dyn Fn(DVec3) -> f64, x: DVec3, h: f64) -> Deriv3 {
    let f0 = f(x);
    let e = [DVec3::X * h, DVec3::Y * h, DVec3::Z * h];
    let mut out = Deriv3::constant(f0);
    for i in 0..3 {
        let (fp, fm) = (f(x + e[i]), f(x - e[i]));
        out.gradient[i] = (fp - fm) / (2.0 * h);
        out.hessian.col_mut(i)[i] = (fp - 2.0 * f0 + fm) / (h * h);
        for j in 0..i {
            let v = (f(x + e[i] + e[j]) - f(x + e[i] - e[j]) - f(x - e[i] + e[j])
                + f(x - e[i] - e[j]))
                / (4.0 * h * h);
            out.hessian.col_mut(i)[j] = v;
            out.hessian.col_mut(j)[i] = v;
        }
    }
    out
}

fn rel_hessian_error(got: DMat3, want: DMat3) -> f64 {
    let (g, w) = (got.to_cols_array(), want.to_cols_array());
    let scale = w.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    g.iter()
        .zip(w.iter())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
        / scale
}

struct Case {
    name: &'static str,
    x: DVec3,
    n: DVec3,
    verts: Vec<DVec3>,
}

fn cases() -> Vec<Case> {
    let n = DVec3::new(0.2, -0.1, 1.0).normalize();
    let pentagon: Vec<DVec3> = (0..5)
        .map(|i| {
            let phi = std::f64::consts::TAU * i as f64 / 5.0;
            DVec3::new(phi.cos(), phi.sin(), 0.2 + 0.3 * phi.sin())
        })
        .collect();
    vec![
        Case {
            name: "triangle",
            x: DVec3::new(0.1, -0.2, 0.05),
            n,
            verts: vec![
                DVec3::new(-0.4, -0.3, 1.0),
                DVec3::new(0.7, -0.1, 1.2),
                DVec3::new(0.0, 0.8, 0.9),
            ],
        },
        Case {
            name: "triangle_clipped",
            x: DVec3::new(0.1, -0.2, 0.05),
            n,
            verts: vec![
                DVec3::new(-0.4, -0.3, 1.0),
                DVec3::new(0.7, -0.1, 1.2),
                DVec3::new(0.0, 0.8, -0.6),
            ],
        },
        Case {
            name: "triangle_far",
            x: DVec3::new(0.1, -0.2, -40.0),
            n,
            verts: vec![
                DVec3::new(-0.4, -0.3, 1.0),
                DVec3::new(0.7, -0.1, 1.2),
                DVec3::new(0.0, 0.8, 0.9),
            ],
        },
        Case {
            name: "pentagon_clipped",
            x: DVec3::new(0.1, -0.2, 0.05),
            n: DVec3::new(1.0, 1.0, 1.0).normalize(),
            verts: pentagon,
        },
    ]
}

fn bench(c: &mut Criterion) {
    println!("\nHessian error against the analytic kernel (max entry error / max entry):");
    for case in cases() {
        let analytic =
            kernels::polygon_form_factor(case.x, case.n, &case.verts, Order::Hessian).unwrap();
        let value = |x: DVec3| {
            kernels::polygon_form_factor(x, case.n, &case.verts, Order::Value)
                .unwrap()
                .value
        };
        let fd = finite_difference_hessian(&value, case.x, 1e-4);
        let ad = hyperdual_hessian(case.x, case.n, &case.verts);
        println!(
            "  {:<18} finite differences {:.1e}   hyper-dual {:.1e}   (gradient: fd {:.1e}, hyper-dual {:.1e})",
            case.name,
            rel_hessian_error(fd.hessian, analytic.hessian),
            rel_hessian_error(ad.hessian, analytic.hessian),
            (fd.gradient - analytic.gradient).abs().max_element()
                / analytic.gradient.abs().max_element(),
            (ad.gradient - analytic.gradient).abs().max_element()
                / analytic.gradient.abs().max_element(),
        );
    }
    for case in cases() {
        let mut g = c.benchmark_group(format!("form_factor/{}", case.name));
        let (x, n, v) = (case.x, case.n, case.verts.clone());
        for (label, order) in [
            ("value", Order::Value),
            ("gradient", Order::Gradient),
            ("hessian", Order::Hessian),
        ] {
            g.bench_function(label, |b| {
                b.iter(|| {
                    kernels::polygon_form_factor(black_box(x), black_box(n), black_box(&v), order)
                        .unwrap()
                })
            });
        }
        g.bench_function("finite_differences", |b| {
            let value = |x: DVec3| {
                kernels::polygon_form_factor(x, n, &v, Order::Value)
                    .unwrap()
                    .value
            };
            b.iter(|| finite_difference_hessian(&value, black_box(x), 1e-4))
        });
        g.bench_function("hyperdual", |b| {
            b.iter(|| hyperdual_hessian(black_box(x), n, &v))
        });
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
