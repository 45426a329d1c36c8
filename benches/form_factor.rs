//! Criterion benches of the point-to-triangle / point-to-polygon form factors and of the per-edge
//! term at each order, against the baselines a user would otherwise write: (a) the textbook value
//! formula (Lambert's per-edge sum, with the clipping of the value formula below where the case is
//! clipped), (b) central finite differences of that textbook value (19 value calls for value +
//! gradient + Hessian) and (c) a num-dual hyper-dual Hessian of the same formula (6 hyper-dual
//! evaluations, one per Hessian entry). Before timing, a table gives time (ratio to the textbook
//! value, same interleaved rounds) and error against 320-bit references (`tests/form_factor_support`)
//! side by side.
//!
//! `cargo bench --bench form_factor -- --warm-up-time 1 --measurement-time 3`; append a filter that
//! matches nothing (`nomatch`) for the table alone.
//! For profilers, `RADDIFF_FORM_FACTOR_PROFILE="CASE,ORDER,CALLS"` runs one case only and exits (CASE
//! is a case name of the table, ORDER is `value`, `gradient` or `hessian`), e.g.
//! `RADDIFF_FORM_FACTOR_PROFILE="quad,hessian,20000" valgrind --tool=callgrind <bench binary>`.

use std::hint::black_box;

use criterion::{criterion_group, Criterion};
use glam::{DMat3, DVec3};
use num_dual::{DualNum, HyperDual64};
use raddiff::{kernels, Deriv3, Order};

#[path = "../tests/form_factor_support/mod.rs"]
mod reference;

/// Lambert's per-edge term as a user writes it: `β n·(r_a×r_b)/‖r_a×r_b‖ / 2π`,
/// `β = acos(r̂_a·r̂_b)`.
fn textbook_edge(x: DVec3, n: DVec3, a: DVec3, b: DVec3) -> f64 {
    let (ra, rb) = (a - x, b - x);
    let w = ra.cross(rb);
    let beta = (ra.normalize().dot(rb.normalize())).clamp(-1.0, 1.0).acos();
    beta * n.dot(w) / w.length() * (0.5 * std::f64::consts::FRAC_1_PI)
}

/// Lambert's per-edge sum for a polygon above the tangent plane (no clipping), as a user writes it.
fn textbook_polygon(x: DVec3, n: DVec3, t: &[DVec3]) -> f64 {
    let mut sum = 0.0;
    for i in 0..t.len() {
        sum += textbook_edge(x, n, t[i], t[(i + 1) % t.len()]);
    }
    sum.abs()
}

/// The textbook value of a case: the plain edge sum when nothing is clipped, otherwise the clipped
/// value formula below (in f64).
fn textbook_value(x: DVec3, n: DVec3, verts: &[DVec3]) -> f64 {
    if verts.iter().all(|v| n.dot(*v - x) > 0.0) {
        textbook_polygon(x, n, verts)
    } else {
        value_formula([x.x, x.y, x.z], n, verts)
    }
}

/// Minimum per-call time of each variant over interleaved rounds (all see the same load).
fn min_ns(variants: &mut [&mut dyn FnMut()]) -> Vec<f64> {
    let (rounds, calls) = (40, 1000);
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

fn report_time_and_error() {
    let mut big = reference::Big::new();
    println!(
        "
form factors: time (ns, ratio to the textbook value) and error vs 320-bit reference"
    );
    println!(
        "{:<18} {:>15} {:>15} {:>15} {:>15} {:>15} {:>15}",
        "case",
        "textbook value",
        "raddiff value",
        "raddiff grad",
        "raddiff hess",
        "FD hess (tb)",
        "dual hess (tb)"
    );
    let mut all = cases();
    all.push(edge_case(&all[0]));
    for case in all {
        let (x, n, v) = (case.x, case.n, case.verts.clone());
        let is_edge = v.len() == 2;
        let raddiff = |p: DVec3, o: Order| {
            if is_edge {
                kernels::edge_form_factor(p, n, v[0], v[1], o)
            } else if v.len() == 3 {
                kernels::triangle_form_factor(p, n, v[0], v[1], v[2], o)
            } else {
                kernels::polygon_form_factor(p, n, &v, o)
            }
        };
        let textbook = |p: DVec3| {
            if is_edge {
                textbook_edge(p, n, v[0], v[1])
            } else {
                textbook_value(p, n, &v)
            }
        };
        let r = if is_edge {
            big.edge_reference(x, n, v[0], v[1])
        } else {
            big.polygon_reference(x, n, &v, true)
        };
        let d = raddiff(x, Order::Hessian).unwrap();
        let fd = finite_difference_hessian(&textbook, x, 1e-4);
        let err = [
            reference::rel_scalar(textbook(x), r.value, 1e-300),
            reference::rel_scalar(d.value, r.value, 1e-300),
            reference::rel_vec(d.gradient, r.gradient, 1e-300),
            reference::rel_mat(d.hessian, r.hessian, 1e-300),
            reference::rel_mat(fd.hessian, r.hessian, 1e-300),
            if is_edge {
                f64::NAN
            } else {
                reference::rel_mat(hyperdual_hessian(x, n, &v).hessian, r.hessian, 1e-300)
            },
        ];
        let t = min_ns(&mut [
            &mut || {
                black_box(textbook(black_box(x)));
            },
            &mut || {
                black_box(raddiff(black_box(x), Order::Value).ok());
            },
            &mut || {
                black_box(raddiff(black_box(x), Order::Gradient).ok());
            },
            &mut || {
                black_box(raddiff(black_box(x), Order::Hessian).ok());
            },
            &mut || {
                black_box(finite_difference_hessian(&textbook, black_box(x), 1e-4));
            },
            &mut || {
                if !is_edge {
                    black_box(hyperdual_hessian(black_box(x), n, &v));
                }
            },
        ]);
        let cells: Vec<String> = (0..6)
            .map(|k| format!("{:.0} ({:.2}x)", t[k], t[k] / t[0]))
            .collect();
        println!(
            "{:<18} {:>15} {:>15} {:>15} {:>15} {:>15} {:>15}",
            case.name, cells[0], cells[1], cells[2], cells[3], cells[4], cells[5]
        );
        let errs: Vec<String> = err.iter().map(|e| format!("err {e:.1e}")).collect();
        println!(
            "{:<18} {:>15} {:>15} {:>15} {:>15} {:>15} {:>15}",
            "", errs[0], errs[1], errs[2], errs[3], errs[4], errs[5]
        );
    }
    println!();
}

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

/// The per-edge term alone: the first edge of the generic triangle `tri`.
fn edge_case(tri: &Case) -> Case {
    Case {
        name: "edge term",
        x: tri.x,
        n: tri.n,
        verts: tri.verts[..2].to_vec(),
    }
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
            name: "quad",
            x: DVec3::new(0.1, -0.2, 0.05),
            n,
            verts: [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
                .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
                .to_vec(),
        },
        Case {
            name: "pentagon",
            x: DVec3::new(0.1, -0.2, 0.05),
            n,
            verts: pentagon.iter().map(|v| *v + DVec3::Z).collect(),
        },
        Case {
            name: "pentagon_clipped",
            x: DVec3::new(0.1, -0.2, 0.05),
            n: DVec3::new(1.0, 1.0, 1.0).normalize(),
            verts: pentagon,
        },
    ]
}

const ORDERS: [(&str, Order); 3] = [
    ("value", Order::Value),
    ("gradient", Order::Gradient),
    ("hessian", Order::Hessian),
];

/// One call of the kernel a case benchmarks (triangles through their own entry point, which has
/// the triangle fast paths; two vertices are the edge term).
fn call(case: &Case, order: Order) -> Deriv3 {
    let (x, n, v) = (black_box(case.x), black_box(case.n), black_box(&case.verts));
    if v.len() == 2 {
        kernels::edge_form_factor(x, n, v[0], v[1], order)
    } else if v.len() == 3 {
        kernels::triangle_form_factor(x, n, v[0], v[1], v[2], order)
    } else {
        kernels::polygon_form_factor(x, n, v, order)
    }
    .unwrap()
}

/// `RADDIFF_FORM_FACTOR_PROFILE="CASE,ORDER,CALLS"`: the calls of one case, nothing else.
fn profile(spec: &str) {
    let parts: Vec<&str> = spec.split(',').map(str::trim).collect();
    let [case, order, calls] = parts[..] else {
        panic!("RADDIFF_FORM_FACTOR_PROFILE must be CASE,ORDER,CALLS");
    };
    let mut all = cases();
    all.push(edge_case(&all[0]));
    let case = all
        .into_iter()
        .find(|c| c.name == case)
        .expect("unknown case");
    let order = ORDERS
        .iter()
        .find(|(name, _)| *name == order)
        .expect("ORDER is value, gradient or hessian")
        .1;
    for _ in 0..calls.parse::<usize>().expect("CALLS") {
        black_box(call(&case, order));
    }
}

fn bench(c: &mut Criterion) {
    report_time_and_error();
    println!("\nHessian error against the analytic kernel (max entry error / max entry):");
    for case in cases() {
        let analytic =
            kernels::polygon_form_factor(case.x, case.n, &case.verts, Order::Hessian).unwrap();
        let value = |x: DVec3| textbook_value(x, case.n, &case.verts);
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
        for (label, order) in ORDERS {
            g.bench_function(label, |b| b.iter(|| call(&case, order)));
        }
        g.bench_function("textbook_value", |b| {
            b.iter(|| textbook_value(black_box(x), n, &v))
        });
        g.bench_function("finite_differences", |b| {
            let value = |x: DVec3| textbook_value(x, n, &v);
            b.iter(|| finite_difference_hessian(&value, black_box(x), 1e-4))
        });
        g.bench_function("hyperdual", |b| {
            b.iter(|| hyperdual_hessian(black_box(x), n, &v))
        });
        g.finish();
    }
}

fn main() {
    if let Ok(spec) = std::env::var("RADDIFF_FORM_FACTOR_PROFILE") {
        profile(&spec);
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}

criterion_group!(benches, bench);
