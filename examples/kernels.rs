//! The kernels at a glance: time and accuracy against the formulas a user would otherwise write.
//!
//! `cargo run --release --example kernels`
//!
//! For each kernel and configuration (generic, near the plane, near an edge, far away, sliver) it
//! times, in the same interleaved rounds, the textbook value formula (Van Oosterom-Strackee for the
//! solid angle, Lambert's per-edge sum for the form factor), raddiff at each order, a central
//! finite-difference Hessian of the textbook value (19 calls) and num-dual's second-order dual
//! numbers on the textbook formula, and prints each time with its ratio to the textbook value next
//! to the relative errors (max-norm, normalized by the largest reference entry) against an
//! independent 320-bit evaluation (astro-float, central differences with a step far below every
//! length scale). `cargo bench --bench solid_angle_transmittance` / `form_factor` has the criterion measurements.

#[path = "../benches/baselines/mod.rs"]
mod baselines;
#[path = "../tests/kernel_reference/mod.rs"]
mod reference_a;
#[path = "../tests/form_factor_support/mod.rs"]
mod reference_b;

use std::hint::black_box;
use std::time::Instant;

use baselines::{dual_hessian3, fd_hessian3, textbook_solid_angle, textbook_solid_angle_f64, D3};
use glam::{DMat3, DVec2, DVec3};
use num_dual::DualNum;
use raddiff::{kernels, Deriv3, Order};

/// Relative max-norm error of a matrix normalized by its largest reference entry.
fn rel_mat(got: DMat3, want: DMat3) -> f64 {
    reference_b::rel_mat(got, want, 1e-300)
}

fn rel_vec(got: DVec3, want: DVec3) -> f64 {
    reference_b::rel_vec(got, want, 1e-300)
}

fn rel(got: f64, want: f64) -> f64 {
    reference_b::rel_scalar(got, want, 1e-300)
}

/// Nanoseconds per call of each variant: every round times each variant in turn (so that on a
/// loaded machine all of them see the same load), and the minimum over the rounds is kept.
fn min_ns(variants: &mut [&mut dyn FnMut()]) -> Vec<f64> {
    let (rounds, calls) = (40, 2_000);
    let mut best = vec![f64::INFINITY; variants.len()];
    for _ in 0..rounds {
        for (k, f) in variants.iter_mut().enumerate() {
            let start = Instant::now();
            for _ in 0..calls {
                f();
            }
            best[k] = best[k].min(start.elapsed().as_secs_f64() * 1e9 / calls as f64);
        }
    }
    best
}

// ------------------------------------------------------------------------------------------------
// The textbook value formulas, written as a user would (generic over f64 and dual numbers).

fn sub3<D: DualNum<Primitive = f64> + Copy>(v: DVec3, x: &[D; 3]) -> [D; 3] {
    [
        D::from(v.x) - x[0],
        D::from(v.y) - x[1],
        D::from(v.z) - x[2],
    ]
}

fn dot3<D: DualNum<Primitive = f64> + Copy>(a: &[D; 3], b: &[D; 3]) -> D {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross3<D: DualNum<Primitive = f64> + Copy>(a: &[D; 3], b: &[D; 3]) -> [D; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Lambert's per-edge sum (unclipped: the cases keep the triangle above the tangent plane, except
/// where said): `F = |Σ β_i n·(r_i×r_{i+1})/‖r_i×r_{i+1}‖| / 2π`, `β_i = acos(r̂_i·r̂_{i+1})`.
fn textbook_form_factor<D: DualNum<Primitive = f64> + Copy>(
    x: &[D; 3],
    n: DVec3,
    t: &[DVec3; 3],
) -> D {
    let r = t.map(|v| sub3(v, x));
    let unit = r.map(|v| {
        let l = dot3(&v, &v).sqrt();
        [v[0] / l, v[1] / l, v[2] / l]
    });
    let mut sum = D::from(0.0);
    for i in 0..3 {
        let (a, b) = (&r[i], &r[(i + 1) % 3]);
        let w = cross3(a, b);
        let wl = dot3(&w, &w).sqrt();
        let beta = dot3(&unit[i], &unit[(i + 1) % 3]).acos();
        sum += beta * (w[0] * n.x + w[1] * n.y + w[2] * n.z) / wl;
    }
    let sum = if sum.re() < 0.0 { -sum } else { sum };
    sum * (0.5 * std::f64::consts::FRAC_1_PI)
}

/// Lambert's per-edge term `β n·(r_a×r_b)/‖r_a×r_b‖ / 2π`, `β = acos(r̂_a·r̂_b)`.
fn textbook_edge<D: DualNum<Primitive = f64> + Copy>(
    x: &[D; 3],
    n: DVec3,
    a: DVec3,
    b: DVec3,
) -> D {
    let (ra, rb) = (sub3(a, x), sub3(b, x));
    let (la, lb) = (dot3(&ra, &ra).sqrt(), dot3(&rb, &rb).sqrt());
    let w = cross3(&ra, &rb);
    let beta = (dot3(&ra, &rb) / (la * lb)).acos();
    beta * (w[0] * n.x + w[1] * n.y + w[2] * n.z) / dot3(&w, &w).sqrt()
        * (0.5 * std::f64::consts::FRAC_1_PI)
}

fn textbook_transmittance<D: DualNum<Primitive = f64> + Copy>(
    x: &[D; 3],
    y: DVec3,
    sigma: f64,
) -> D {
    let d = sub3(y, x);
    (-(dot3(&d, &d).sqrt() * sigma)).exp()
}

fn point(p: DVec3) -> [f64; 3] {
    p.to_array()
}

struct Row {
    kernel: &'static str,
    case: &'static str,
    /// textbook value, raddiff value, gradient, Hessian, FD of the textbook value, num-dual.
    ns: [f64; 6],
    /// textbook value; raddiff value, gradient, Hessian; FD Hessian; num-dual Hessian.
    err: [f64; 6],
}

fn print_rows(rows: &[Row]) {
    println!(
        "| kernel | configuration | textbook value ns | raddiff value ns | raddiff gradient ns | raddiff Hessian ns | FD (textbook) Hessian ns | num-dual (textbook) Hessian ns | textbook value err | raddiff value / gradient / Hessian err | FD Hessian err | num-dual Hessian err |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let t = r.ns[0];
        let cell = |v: f64| format!("{v:.0} ({:.2}x)", v / t);
        println!(
            "| {} | {} | {:.0} | {} | {} | {} | {} | {} | {:.1e} | {:.1e} / {:.1e} / {:.1e} | {:.1e} | {:.1e} |",
            r.kernel,
            r.case,
            t,
            cell(r.ns[1]),
            cell(r.ns[2]),
            cell(r.ns[3]),
            cell(r.ns[4]),
            cell(r.ns[5]),
            r.err[0],
            r.err[1],
            r.err[2],
            r.err[3],
            r.err[4],
            r.err[5],
        );
    }
}

struct Kernel<'a> {
    raddiff: &'a dyn Fn(DVec3, Order) -> raddiff::Result<Deriv3>,
    textbook: &'a dyn Fn(&[f64; 3]) -> f64,
    dual: &'a dyn Fn(&[D3; 3]) -> D3,
}

fn measure3(
    kernel: &'static str,
    case: &'static str,
    x: DVec3,
    fd_step: f64,
    reference: (f64, DVec3, DMat3),
    k: Kernel,
) -> Row {
    let d = (k.raddiff)(x, Order::Hessian).expect("kernel failed on a demo configuration");
    let textbook = |p: DVec3| (k.textbook)(&point(p));
    let fd = fd_hessian3(&textbook, x, fd_step);
    let dual = dual_hessian3(|p| (k.dual)(&[p[0], p[1], p[2]]), x);
    let ns = min_ns(&mut [
        &mut || {
            black_box(textbook(black_box(x)));
        },
        &mut || {
            black_box((k.raddiff)(black_box(x), Order::Value).ok());
        },
        &mut || {
            black_box((k.raddiff)(black_box(x), Order::Gradient).ok());
        },
        &mut || {
            black_box((k.raddiff)(black_box(x), Order::Hessian).ok());
        },
        &mut || {
            black_box(fd_hessian3(&textbook, black_box(x), fd_step));
        },
        &mut || {
            black_box(dual_hessian3(
                |p| (k.dual)(&[p[0], p[1], p[2]]),
                black_box(x),
            ));
        },
    ]);
    Row {
        kernel,
        case,
        ns: [ns[0], ns[1], ns[2], ns[3], ns[4], ns[5]],
        err: [
            rel(textbook(x), reference.0),
            rel(d.value, reference.0),
            rel_vec(d.gradient, reference.1),
            rel_mat(d.hessian, reference.2),
            rel_mat(fd, reference.2),
            rel_mat(dual.hessian, reference.2),
        ],
    }
}

fn main() {
    let mut hp = reference_a::Hp::new();
    let mut big = reference_b::Big::new();
    let mut rows = Vec::new();

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
    let normal = DVec3::new(0.1, -0.2, 1.0).normalize();
    let plane_n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
    let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
    let edge_mid = 0.5 * (tri[0] + tri[1]);
    let far_dir = DVec3::new(-0.3, -0.2, -1.0).normalize();
    let cases: [(&str, [DVec3; 3], DVec3, f64); 6] = [
        ("generic", tri, DVec3::new(0.3, 0.2, 0.1), 1e-4),
        ("1e-6 above the plane", tri, centroid - plane_n * 1e-6, 1e-8),
        ("1e-5 from an edge", tri, edge_mid - plane_n * 1e-5, 1e-7),
        ("1e4 sizes away", tri, centroid + far_dir * 1e4, 1.0),
        ("1e6 sizes away", tri, centroid + far_dir * 1e6, 1e2),
        ("sliver", sliver, DVec3::new(0.4, 0.1, 0.3), 1e-4),
    ];

    // the 320-bit references take tens of seconds: say what is happening (on stderr, so that
    // stdout stays the markdown tables)
    eprintln!("triangle solid angle: 320-bit references and timings of 6 configurations ...");
    for (case, t, x, fd_step) in cases {
        let step = 1e-30 * (t[0] - x).length().max(1e-300);
        let r = reference_a::central3(&mut hp, x, step, &mut |hp, p| {
            let v = t.map(|v| reference_a::V3::from(hp, v));
            reference_a::solid_angle_hp(hp, p, &v, false)
        });
        rows.push(measure3(
            "triangle solid angle",
            case,
            x,
            fd_step,
            (r.value, r.gradient, r.hessian),
            Kernel {
                raddiff: &|p, o| kernels::triangle_solid_angle(p, t[0], t[1], t[2], o),
                textbook: &|p| textbook_solid_angle_f64(DVec3::from_array(*p), t[0], t[1], t[2]),
                dual: &|p| textbook_solid_angle(*p, t[0], t[1], t[2]),
            },
        ));
    }
    eprintln!("triangle form factor: 320-bit references and timings of 6 configurations ...");
    for (case, t, x, fd_step) in cases {
        // The receiver faces the triangle so nothing is clipped, except where the case says so.
        let n = if (t[0] - x).dot(normal) > 0.0 {
            normal
        } else {
            -normal
        };
        let r = big.polygon_reference(x, n, &t, true);
        rows.push(measure3(
            "triangle form factor",
            case,
            x,
            fd_step,
            (r.value, r.gradient, r.hessian),
            Kernel {
                raddiff: &|p, o| kernels::triangle_form_factor(p, n, t[0], t[1], t[2], o),
                textbook: &|p| textbook_form_factor(p, n, &t),
                dual: &|p| textbook_form_factor(p, n, &t),
            },
        ));
    }
    {
        // The per-edge term alone (one edge of the generic triangle), for callers summing edges.
        let (x, a, b) = (cases[0].2, tri[0], tri[1]);
        let r = big.edge_reference(x, normal, a, b);
        rows.push(measure3(
            "edge form factor term",
            "generic",
            x,
            1e-4,
            (r.value, r.gradient, r.hessian),
            Kernel {
                raddiff: &|p, o| kernels::edge_form_factor(p, normal, a, b, o),
                textbook: &|p| textbook_edge(p, normal, a, b),
                dual: &|p| textbook_edge(p, normal, a, b),
            },
        ));
    }
    eprintln!("transmittance, flatland segment form factor ...");
    {
        let (x, y, sigma) = (DVec3::new(0.3, -0.2, 0.1), DVec3::new(1.5, 2.0, -0.7), 0.8);
        let step = 1e-30;
        let r = reference_a::central3(&mut hp, x, step, &mut |hp, p| {
            let d = reference_a::V3::from(hp, y).sub(hp, p).norm(hp);
            let e = hp.mul(&hp.f(-sigma), &d);
            hp.exp(&e)
        });
        rows.push(measure3(
            "transmittance",
            "generic",
            x,
            1e-4,
            (r.value, r.gradient, r.hessian),
            Kernel {
                raddiff: &|p, o| kernels::transmittance(p, y, sigma, o),
                textbook: &|p| textbook_transmittance(p, y, sigma),
                dual: &|p| textbook_transmittance(p, y, sigma),
            },
        ));
    }
    println!(
        "## raddiff kernels against the textbook value formulas: time (ratio to the textbook value) and error against 320-bit references\n"
    );
    print_rows(&rows);

    println!("\n## flatland segment form factor\n");
    println!("| configuration | value err | gradient err | Hessian err | value ns | Hessian ns |");
    println!("|---|---|---|---|---|---|");
    let (a, b) = (DVec2::new(0.0, 1.0), DVec2::new(1.0, 1.3));
    for (case, x) in [
        ("generic", DVec2::new(0.2, 0.1)),
        ("1e-6 from the line", DVec2::new(0.5, 1.15 - 1e-6)),
        ("1e6 sizes away", DVec2::new(-3e5, -1e6)),
    ] {
        let step = 1e-30 * (a - x).length();
        let r = reference_a::central2(&mut hp, x, step, &mut |hp, px, py| {
            reference_a::segment_hp(hp, px, py, a, b)
        });
        let d = kernels::segment_form_factor_2d(x, a, b, Order::Hessian).unwrap();
        let t = min_ns(&mut [
            &mut || {
                black_box(kernels::segment_form_factor_2d(black_box(x), a, b, Order::Value).ok());
            },
            &mut || {
                black_box(kernels::segment_form_factor_2d(black_box(x), a, b, Order::Hessian).ok());
            },
        ]);
        let (v_ns, h_ns) = (t[0], t[1]);
        println!(
            "| {case} | {:.1e} | {:.1e} | {:.1e} | {v_ns:.0} | {h_ns:.0} |",
            reference_a::rel(d.value, r.value),
            reference_a::rel2(d.gradient, r.gradient),
            reference_a::rel22(d.hessian, r.hessian),
        );
    }
    println!(
        "\nErrors are max-norm relative to the largest reference entry. Times are the minimum over 40 \
         interleaved rounds; ratios are to the textbook value formula in the same run. 'FD (textbook)' \
         is a central finite-difference Hessian (19 calls) of the textbook value formula with a step \
         tuned per case, 'num-dual (textbook)' the same formula on second-order dual numbers."
    );
}
