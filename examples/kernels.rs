//! The kernels at a glance: accuracy against 320-bit references and speed against finite differences.
//!
//! `cargo run --release --example kernels`
//!
//! For each kernel and configuration (generic, near the plane, near an edge, far away, sliver) it
//! prints the relative error (max-norm, normalized by the largest reference entry) of the value,
//! gradient and Hessian against an independent 320-bit evaluation (astro-float, central differences
//! with a step far below every length scale), then the time per call at each order and the speed-up of
//! the closed-form Hessian over a central finite-difference Hessian of the value kernel (19 value
//! evaluations). The timings here are a quick look; `cargo bench` has the criterion measurements.

#[path = "../tests/kernels_a_ref/mod.rs"]
mod reference_a;
#[path = "../tests/kernels_b_common/mod.rs"]
mod reference_b;

use std::hint::black_box;
use std::time::Instant;

use glam::{DMat3, DVec2, DVec3};
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

/// Nanoseconds per call of `f`, from the best of a few timed batches.
fn time_ns(mut f: impl FnMut()) -> f64 {
    let batch = 20_000;
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let start = Instant::now();
        for _ in 0..batch {
            f();
        }
        best = best.min(start.elapsed().as_secs_f64() * 1e9 / batch as f64);
    }
    best
}

/// Central finite-difference Hessian of a scalar function (19 evaluations), the baseline a user
/// would otherwise write; the step balances truncation and rounding for a unit-scale problem.
fn fd_hessian(x: DVec3, h: f64, f: &dyn Fn(DVec3) -> f64) -> DMat3 {
    let e = [DVec3::X * h, DVec3::Y * h, DVec3::Z * h];
    let f0 = f(x);
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        m[i][i] = (f(x + e[i]) - 2.0 * f0 + f(x - e[i])) / (h * h);
        for j in (i + 1)..3 {
            let v = (f(x + e[i] + e[j]) - f(x + e[i] - e[j]) - f(x - e[i] + e[j])
                + f(x - e[i] - e[j]))
                / (4.0 * h * h);
            m[i][j] = v;
            m[j][i] = v;
        }
    }
    DMat3::from_cols_array_2d(&m)
}

struct Row {
    kernel: &'static str,
    case: &'static str,
    err: [f64; 3],
    fd_err: f64,
    ns: [f64; 3],
    fd_ns: f64,
}

fn print_rows(rows: &[Row]) {
    println!(
        "| kernel | configuration | value err | gradient err | Hessian err | FD Hessian err | value ns | gradient ns | Hessian ns | Hessian/value | FD/closed-form |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        println!(
            "| {} | {} | {:.1e} | {:.1e} | {:.1e} | {:.1e} | {:.0} | {:.0} | {:.0} | {:.1}x | {:.1}x |",
            r.kernel,
            r.case,
            r.err[0],
            r.err[1],
            r.err[2],
            r.fd_err,
            r.ns[0],
            r.ns[1],
            r.ns[2],
            r.ns[2] / r.ns[0],
            r.fd_ns / r.ns[2]
        );
    }
}

fn measure3(
    kernel: &'static str,
    case: &'static str,
    x: DVec3,
    fd_step: f64,
    reference: (f64, DVec3, DMat3),
    f: &dyn Fn(DVec3, Order) -> raddiff::Result<Deriv3>,
) -> Row {
    let d = f(x, Order::Hessian).expect("kernel failed on a demo configuration");
    let value_only = |p: DVec3| f(p, Order::Value).map(|d| d.value).unwrap_or(0.0);
    let fd = fd_hessian(x, fd_step, &value_only);
    let ns = [Order::Value, Order::Gradient, Order::Hessian].map(|o| {
        time_ns(|| {
            black_box(f(black_box(x), o).ok());
        })
    });
    let fd_ns = time_ns(|| {
        black_box(fd_hessian(black_box(x), fd_step, &value_only));
    });
    Row {
        kernel,
        case,
        err: [
            rel(d.value, reference.0),
            rel_vec(d.gradient, reference.1),
            rel_mat(d.hessian, reference.2),
        ],
        fd_err: rel_mat(fd, reference.2),
        ns,
        fd_ns,
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
            &|p, o| kernels::triangle_solid_angle(p, t[0], t[1], t[2], o),
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
            &|p, o| kernels::triangle_form_factor(p, n, t[0], t[1], t[2], o),
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
            &|p, o| kernels::transmittance(p, y, sigma, o),
        ));
    }
    println!("## raddiff kernels: accuracy against 320-bit references, speed against finite differences\n");
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
        let v_ns = time_ns(|| {
            black_box(kernels::segment_form_factor_2d(black_box(x), a, b, Order::Value).ok());
        });
        let h_ns = time_ns(|| {
            black_box(kernels::segment_form_factor_2d(black_box(x), a, b, Order::Hessian).ok());
        });
        println!(
            "| {case} | {:.1e} | {:.1e} | {:.1e} | {v_ns:.0} | {h_ns:.0} |",
            reference_a::rel(d.value, r.value),
            reference_a::rel2(d.gradient, r.gradient),
            reference_a::rel22(d.hessian, r.hessian),
        );
    }
    println!(
        "\nErrors are max-norm relative to the largest reference entry. 'FD Hessian err' is what a \
         central finite-difference Hessian of the value kernel achieves with a step tuned per case."
    );
}
