//! The closed-form kernels through the C ABI (`raddiff_triangle_solid_angle`,
//! `raddiff_triangle_form_factor`), called from Rust, against the textbook formula in plain `f64`
//! with `atan2` from libm, on the configurations of the C bench (`benches/c/bench_kernels.c`, run
//! by `scripts/bench-c-abi.sh`): "spread", 256 generic configurations (well-shaped triangles seen
//! from 0.5 to 3 sizes away, off their plane by more than 5% of the distance, the receiver's tangent
//! plane clear of the triangle), and "fixed", the one generic configuration of
//! `benches/solid_angle_transmittance.rs` (solid angle) and `benches/form_factor.rs` (form factor).
//!
//! Before the criterion groups, a table gives ns per call, the minimum over interleaved rounds of
//! per-thread CPU time, and the ratio to the textbook value of the same kernel on the same set in
//! the same rounds. The C bench is the reference for the targets (the textbook compiled by
//! `cc -O2`, as a C user compiles it); this one shows the same calls from a Rust caller.
//!
//! `cargo bench --bench c_abi -- --warm-up-time 1 --measurement-time 2` (append `nomatch` for the
//! table alone). `RADDIFF_C_ABI_PROFILE="CASE,CALLS"` runs one case and exits (for callgrind:
//! `scripts/instructions-per-call.sh <bench binary> RADDIFF_C_ABI_PROFILE 'CASE,{calls}'`), CASE a
//! row name of the table.

use std::hint::black_box;

use criterion::{criterion_group, Criterion};
use raddiff::ffi::{
    raddiff_deriv3, raddiff_status, raddiff_triangle_form_factor, raddiff_triangle_solid_angle,
    raddiff_vec3, RADDIFF_ORDER_GRADIENT, RADDIFF_ORDER_HESSIAN, RADDIFF_ORDER_VALUE,
};

#[derive(Clone, Copy)]
struct Config {
    x: [f64; 3],
    n: [f64; 3],
    v: [[f64; 3]; 3],
}

#[derive(Clone, Copy, PartialEq)]
enum Kernel {
    SolidAngle,
    FormFactor,
}

struct Case {
    name: &'static str,
    kernel: Kernel,
    /// `None`: the textbook value; else raddiff at this order.
    order: Option<u32>,
    fixed: bool,
}

const CASES: [Case; 16] = {
    const fn case(name: &'static str, kernel: Kernel, order: Option<u32>, fixed: bool) -> Case {
        Case {
            name,
            kernel,
            order,
            fixed,
        }
    }
    use Kernel::*;
    [
        case("solid_angle_textbook_value", SolidAngle, None, false),
        case(
            "solid_angle_value",
            SolidAngle,
            Some(RADDIFF_ORDER_VALUE),
            false,
        ),
        case(
            "solid_angle_gradient",
            SolidAngle,
            Some(RADDIFF_ORDER_GRADIENT),
            false,
        ),
        case(
            "solid_angle_hessian",
            SolidAngle,
            Some(RADDIFF_ORDER_HESSIAN),
            false,
        ),
        case("form_factor_textbook_value", FormFactor, None, false),
        case(
            "form_factor_value",
            FormFactor,
            Some(RADDIFF_ORDER_VALUE),
            false,
        ),
        case(
            "form_factor_gradient",
            FormFactor,
            Some(RADDIFF_ORDER_GRADIENT),
            false,
        ),
        case(
            "form_factor_hessian",
            FormFactor,
            Some(RADDIFF_ORDER_HESSIAN),
            false,
        ),
        case("fixed_solid_angle_textbook_value", SolidAngle, None, true),
        case(
            "fixed_solid_angle_value",
            SolidAngle,
            Some(RADDIFF_ORDER_VALUE),
            true,
        ),
        case(
            "fixed_solid_angle_gradient",
            SolidAngle,
            Some(RADDIFF_ORDER_GRADIENT),
            true,
        ),
        case(
            "fixed_solid_angle_hessian",
            SolidAngle,
            Some(RADDIFF_ORDER_HESSIAN),
            true,
        ),
        case("fixed_form_factor_textbook_value", FormFactor, None, true),
        case(
            "fixed_form_factor_value",
            FormFactor,
            Some(RADDIFF_ORDER_VALUE),
            true,
        ),
        case(
            "fixed_form_factor_gradient",
            FormFactor,
            Some(RADDIFF_ORDER_GRADIENT),
            true,
        ),
        case(
            "fixed_form_factor_hessian",
            FormFactor,
            Some(RADDIFF_ORDER_HESSIAN),
            true,
        ),
    ]
};

// ------------------------------------------------------------------------------------------------
// The textbook formulas, as a user writes them.

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Van Oosterom and Strackee: `2 atan2(|r0·(r1×r2)|, l0 l1 l2 + (r0·r1) l2 + (r0·r2) l1 + (r1·r2) l0)`.
#[inline(never)]
fn textbook_solid_angle(x: [f64; 3], v: [[f64; 3]; 3]) -> f64 {
    let (r0, r1, r2) = (sub(v[0], x), sub(v[1], x), sub(v[2], x));
    let (l0, l1, l2) = (norm(r0), norm(r1), norm(r2));
    let num = dot(r0, cross(r1, r2)).abs();
    let den = l0 * l1 * l2 + dot(r0, r1) * l2 + dot(r0, r2) * l1 + dot(r1, r2) * l0;
    2.0 * num.atan2(den)
}

/// Lambert: `|Σ_i β_i n·(r_i × r_{i+1}) / ‖r_i × r_{i+1}‖| / 2π`.
#[inline(never)]
fn textbook_form_factor(x: [f64; 3], n: [f64; 3], v: [[f64; 3]; 3]) -> f64 {
    let r = [sub(v[0], x), sub(v[1], x), sub(v[2], x)];
    let mut sum = 0.0;
    for i in 0..3 {
        let w = cross(r[i], r[(i + 1) % 3]);
        let s = norm(w);
        sum += s.atan2(dot(r[i], r[(i + 1) % 3])) * dot(n, w) / s;
    }
    sum.abs() / (2.0 * std::f64::consts::PI)
}

// ------------------------------------------------------------------------------------------------
// Configurations (the C bench's, from the same SplitMix64 stream).

struct SplitMix(u64);

impl SplitMix {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / 9_007_199_254_740_992.0
    }
    fn in_ball(&mut self, radius: f64) -> [f64; 3] {
        loop {
            let p = [
                2.0 * self.uniform() - 1.0,
                2.0 * self.uniform() - 1.0,
                2.0 * self.uniform() - 1.0,
            ];
            if dot(p, p) <= 1.0 {
                return p.map(|c| c * radius);
            }
        }
    }
}

fn spread() -> Vec<Config> {
    let mut rng = SplitMix(0x9e37_79b9_7f4a_7c15);
    let mut out = Vec::new();
    while out.len() < 256 {
        let v = [rng.in_ball(1.0), rng.in_ball(1.0), rng.in_ball(1.0)];
        let size = (0..3).fold(0.0f64, |m, i| m.max(norm(sub(v[(i + 1) % 3], v[i]))));
        let normal = cross(sub(v[1], v[0]), sub(v[2], v[0]));
        if norm(normal) < 0.2 * size * size {
            continue;
        }
        let x = rng.in_ball(3.0 * size);
        let near = (0..3).fold(f64::INFINITY, |m, i| m.min(norm(sub(v[i], x))));
        let far = (0..3).fold(0.0f64, |m, i| m.max(norm(sub(v[i], x))));
        let height = dot(sub(v[0], x), normal).abs() / norm(normal);
        if near < 0.5 * size || far > 3.0 * size || height < 0.05 * near {
            continue;
        }
        let centroid = [0, 1, 2].map(|k| (v[0][k] + v[1][k] + v[2][k]) / 3.0);
        let towards = sub(centroid, x);
        let wobble = rng.in_ball(0.3 * norm(towards));
        let n = [0, 1, 2].map(|k| towards[k] + wobble[k]);
        let n = n.map(|c| c / norm(n));
        if (0..3).all(|i| dot(n, sub(v[i], x)) >= 0.1 * norm(sub(v[i], x))) {
            out.push(Config { x, n, v });
        }
    }
    out
}

fn fixed(kernel: Kernel) -> Config {
    match kernel {
        Kernel::SolidAngle => Config {
            x: [0.4, 0.3, 0.8],
            n: [0.0, 0.0, 1.0],
            v: [[0.1, -0.2, 0.05], [1.1, 0.1, 0.2], [0.3, 0.9, -0.1]],
        },
        Kernel::FormFactor => {
            let n = [0.2, -0.1, 1.0];
            Config {
                x: [0.1, -0.2, 0.05],
                n: n.map(|c| c / norm(n)),
                v: [[-0.4, -0.3, 1.0], [0.7, -0.1, 1.2], [0.0, 0.8, 0.9]],
            }
        }
    }
}

fn c(v: [f64; 3]) -> raddiff_vec3 {
    raddiff_vec3 {
        x: v[0],
        y: v[1],
        z: v[2],
    }
}

/// One call of `case` on `g`; the sum of what it returns.
#[inline(always)]
fn call(case: &Case, g: &Config) -> f64 {
    let Some(order) = case.order else {
        return match case.kernel {
            Kernel::SolidAngle => textbook_solid_angle(g.x, g.v),
            Kernel::FormFactor => textbook_form_factor(g.x, g.n, g.v),
        };
    };
    let mut d = raddiff_deriv3::default();
    let [a, b, cc] = g.v.map(c);
    // SAFETY: `d` is a valid output.
    let status = unsafe {
        match case.kernel {
            Kernel::SolidAngle => raddiff_triangle_solid_angle(c(g.x), a, b, cc, order, &mut d),
            Kernel::FormFactor => {
                raddiff_triangle_form_factor(c(g.x), c(g.n), a, b, cc, order, &mut d)
            }
        }
    };
    debug_assert_eq!(status, raddiff_status::RADDIFF_OK);
    d.value + d.gradient[0] + d.hessian[0]
}

/// `calls` calls of `case`, cycling over its configurations.
fn run(case: &Case, configs: &[Config], calls: usize) -> f64 {
    let one = [fixed(case.kernel)];
    let configs = if case.fixed { &one[..] } else { configs };
    let mut sum = 0.0;
    for i in 0..calls {
        sum += call(case, black_box(&configs[i % configs.len()]));
    }
    black_box(sum)
}

/// On-CPU time of this thread in ns (`CLOCK_THREAD_CPUTIME_ID`).
fn cpu_ns() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: a valid clock id and a valid out-pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 * 1e9 + ts.tv_nsec as f64
}

/// raddiff agrees with the textbook value on every configuration (both accurate there), so that
/// both sides compute the same thing.
fn check(configs: &[Config]) {
    let mut worst = [0.0f64; 2];
    for (k, kernel) in [Kernel::SolidAngle, Kernel::FormFactor]
        .into_iter()
        .enumerate()
    {
        for g in configs.iter().chain([fixed(kernel)].iter()) {
            let textbook = Case {
                name: "",
                kernel,
                order: None,
                fixed: false,
            };
            let value = Case {
                order: Some(RADDIFF_ORDER_VALUE),
                ..textbook
            };
            let (t, v) = (call(&textbook, g), call(&value, g));
            worst[k] = worst[k].max((v - t).abs() / t);
        }
    }
    println!(
        "{} generic configurations; largest relative difference to the textbook value: solid \
         angle {:.1e}, form factor {:.1e}",
        configs.len(),
        worst[0],
        worst[1]
    );
    assert!(worst[0] <= 1e-12 && worst[1] <= 1e-12);
}

fn ratio_table(configs: &[Config]) {
    check(configs);
    let rounds = 30;
    // About 2 ms of each case per round, after a warm-up.
    let calls: Vec<usize> = CASES
        .iter()
        .map(|case| {
            run(case, configs, configs.len());
            let mut n = configs.len();
            loop {
                let t0 = cpu_ns();
                run(case, configs, n);
                if cpu_ns() - t0 > 2e6 || n > 1 << 26 {
                    return n;
                }
                n *= 2;
            }
        })
        .collect();
    let mut best = [f64::INFINITY; CASES.len()];
    for r in 0..rounds {
        for k in 0..CASES.len() {
            let c = (k + r) % CASES.len();
            let t0 = cpu_ns();
            run(&CASES[c], configs, calls[c]);
            best[c] = best[c].min((cpu_ns() - t0) / calls[c] as f64);
        }
    }
    println!(
        "\nns per call, minimum over {rounds} interleaved rounds (per-thread CPU time); ratio to the \
         textbook value of the same kernel on the same set in the same rounds"
    );
    println!("| case | ns per call | ratio |\n|---|---|---|");
    for (k, case) in CASES.iter().enumerate() {
        let base = CASES
            .iter()
            .position(|b| b.order.is_none() && b.kernel == case.kernel && b.fixed == case.fixed)
            .unwrap();
        println!(
            "| {} | {:.1} | {:.2}x |",
            case.name,
            best[k],
            best[k] / best[base]
        );
    }
}

fn bench(c: &mut Criterion) {
    let configs = spread();
    let mut group = c.benchmark_group("c_abi");
    for case in &CASES {
        let one = [fixed(case.kernel)];
        let set = if case.fixed { &one[..] } else { &configs[..] };
        group.bench_function(case.name, |b| {
            let mut i = 0;
            b.iter(|| {
                i += 1;
                call(case, black_box(&set[i % set.len()]))
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);

fn main() {
    let configs = spread();
    if let Ok(spec) = std::env::var("RADDIFF_C_ABI_PROFILE") {
        let (name, calls) = spec
            .split_once(',')
            .expect("RADDIFF_C_ABI_PROFILE must be CASE,CALLS");
        let case = CASES
            .iter()
            .find(|c| c.name == name.trim())
            .expect("CASE is a row name of the table");
        run(case, &configs, calls.trim().parse().expect("CALLS"));
        return;
    }
    ratio_table(&configs);
    benches();
    Criterion::default().configure_from_args().final_summary();
}
