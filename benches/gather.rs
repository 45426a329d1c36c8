//! Cost of a gather evaluation against the cost of generating its directions (the baseline), for
//! 16x32, 32x64 and 64x128 cosine-polar layouts, 3 channels: irradiance only, irradiance with
//! translational and rotational gradients, and both with an absorbing, scattering medium marched in
//! 16 steps per direction (with media radiance gradients); and the concentric layout's gradients.
//! Every evaluation is also timed with the previous implementation (`gather::evaluate_reference`,
//! cases named "reference ...") as the baseline. After the criterion groups, a summary table in ns
//! per sample with the speed-up over the previous implementation, timed in the same run as on-CPU
//! time of the thread (robust on a shared machine; criterion's figures are wall time).
//! `RADDIFF_BENCH_SUMMARY_ONLY=1` skips the criterion groups.
//!
//! `cargo bench --bench gather -- --warm-up-time 1 --measurement-time 3`

use std::cell::RefCell;
use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, Criterion, Throughput};
use glam::DVec3;
use raddiff::gather::{
    evaluate, evaluate_reference, Frame, GatherInput, Layout, LayoutKind, MediaRadiance, Wanted,
};

const CHANNELS: usize = 3;
const STEPS: usize = 16;
const SIZES: [(u32, u32); 4] = [(16, 32), (32, 64), (32, 128), (64, 128)];

struct Scene {
    layout: Layout,
    frame: Frame,
    dirs: Vec<DVec3>,
    dist: Vec<f64>,
    rad: Vec<f32>,
    media: Vec<f32>,
    media_grad: Vec<f32>,
}

impl Scene {
    fn new(m: u32, n: u32) -> Scene {
        Scene::new_kind(LayoutKind::CosinePolar, m, n)
    }

    fn new_kind(kind: LayoutKind, m: u32, n: u32) -> Scene {
        let layout = Layout::new(kind, m, n, 1).unwrap();
        let frame = Frame::new(DVec3::new(0.3, 0.2, 0.0), DVec3::Z, DVec3::X).unwrap();
        let dirs = layout.directions(&frame).unwrap();
        let cells = layout.len();
        // a room-like mix: blocks of hits at varying distances, 20% misses
        let dist = (0..cells)
            .map(|i| {
                if (i * 7919) % 10 < 2 {
                    f64::INFINITY
                } else {
                    0.5 + ((i / 5) % 13) as f64 * 0.2
                }
            })
            .collect();
        let rad = (0..cells * CHANNELS)
            .map(|i| ((i / 15) % 7) as f32 * 0.1)
            .collect();
        let media = (0..cells * STEPS * CHANNELS)
            .map(|i| 0.05 + (i % 5) as f32 * 0.01)
            .collect();
        let media_grad = (0..cells * STEPS * CHANNELS * 3)
            .map(|i| (i % 7) as f32 * 0.001)
            .collect();
        Scene {
            layout,
            frame,
            dirs,
            dist,
            rad,
            media,
            media_grad,
        }
    }

    fn input(&self, medium: bool) -> GatherInput<'_> {
        GatherInput {
            directions: &self.dirs,
            distance: &self.dist,
            radiance: &self.rad,
            channels: CHANNELS,
            sigma_t: if medium { 0.2 } else { 0.0 },
            media: medium.then_some(MediaRadiance {
                radiance: &self.media,
                gradient: Some(&self.media_grad),
                steps: STEPS,
                step: 0.2,
            }),
        }
    }
}

const GRADIENTS: Wanted = Wanted {
    irradiance: true,
    gradient: true,
    rotation_gradient: true,
    distances: true,
};

type Case<'a> = (&'static str, Box<dyn Fn() + 'a>);

fn cases(s: &Scene) -> Vec<Case<'_>> {
    let buf = RefCell::new(vec![DVec3::ZERO; s.layout.len()]);
    let mut v: Vec<Case<'_>> = vec![(
        "directions",
        Box::new(move || {
            s.layout
                .directions_into(&s.frame, black_box(&mut buf.borrow_mut()))
                .unwrap()
        }),
    )];
    for (name, medium, wanted) in EVALUATIONS {
        v.push((
            name,
            Box::new(move || {
                black_box(evaluate(&s.layout, &s.frame, &s.input(medium), wanted).unwrap());
            }),
        ));
    }
    let concentric = Scene::new_kind(LayoutKind::Concentric, s.layout.m, s.layout.n);
    let concentric_ref = Scene::new_kind(LayoutKind::Concentric, s.layout.m, s.layout.n);
    v.push((
        "concentric gradients",
        Box::new(move || {
            let s = &concentric;
            black_box(evaluate(&s.layout, &s.frame, &s.input(false), GRADIENTS).unwrap());
        }),
    ));
    // The previous implementation, as the baseline of the speed-up.
    for (name, medium, wanted) in REFERENCE_EVALUATIONS {
        v.push((
            name,
            Box::new(move || {
                let input = s.input(medium);
                black_box(
                    evaluate_reference::evaluate(&s.layout, &s.frame, &input, wanted).unwrap(),
                );
            }),
        ));
    }
    v.push((
        "reference concentric gradients",
        Box::new(move || {
            let s = &concentric_ref;
            let input = s.input(false);
            black_box(
                evaluate_reference::evaluate(&s.layout, &s.frame, &input, GRADIENTS).unwrap(),
            );
        }),
    ));
    v
}

const EVALUATIONS: [(&str, bool, Wanted); 4] = [
    ("irradiance", false, Wanted::IRRADIANCE),
    ("gradients", false, GRADIENTS),
    ("irradiance+media", true, Wanted::IRRADIANCE),
    ("gradients+media", true, GRADIENTS),
];

const REFERENCE_EVALUATIONS: [(&str, bool, Wanted); 4] = [
    ("reference irradiance", false, Wanted::IRRADIANCE),
    ("reference gradients", false, GRADIENTS),
    ("reference irradiance+media", true, Wanted::IRRADIANCE),
    ("reference gradients+media", true, GRADIENTS),
];

fn bench(c: &mut Criterion) {
    for (m, n) in SIZES {
        let scene = Scene::new(m, n);
        let mut group = c.benchmark_group(format!("gather_{m}x{n}"));
        group.throughput(Throughput::Elements((m * n) as u64));
        for (name, f) in cases(&scene) {
            group.bench_function(name, |b| b.iter(&f));
        }
        group.finish();
    }
}

/// On-CPU time of this thread in ns (Linux `schedstat`): unlike wall time, it does not count the
/// time other processes hold the core, so the figures survive a busy machine. Wall time elsewhere.
fn cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

fn now_ns(start: Instant) -> f64 {
    match cpu_ns() {
        Some(ns) => ns as f64,
        None => start.elapsed().as_nanos() as f64,
    }
}

/// Median over 7 batches of the (CPU) time per call, in ns.
fn time(f: &dyn Fn()) -> f64 {
    let start = Instant::now();
    let mut reps = 1;
    loop {
        let t = now_ns(start);
        for _ in 0..reps {
            f();
        }
        if now_ns(start) - t > 3e7 {
            break;
        }
        reps *= 2;
    }
    let mut v: Vec<f64> = (0..7)
        .map(|_| {
            let t = now_ns(start);
            for _ in 0..reps {
                f();
            }
            (now_ns(start) - t) / reps as f64
        })
        .collect();
    v.sort_by(f64::total_cmp);
    v[3]
}

fn summary() {
    println!(
        "\nCPU ns per sample, {CHANNELS} channels, {STEPS} media steps: this implementation (the previous one, speed-up):"
    );
    println!(
        "| layout | directions | irradiance | + gradients | irradiance + media | gradients + media | gradient cost | concentric + gradients |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (m, n) in SIZES {
        let scene = Scene::new(m, n);
        let samples = (m * n) as f64;
        let t: Vec<f64> = cases(&scene)
            .iter()
            .map(|(_, f)| time(f.as_ref()) / samples)
            .collect();
        // t: directions, 4 evaluations, concentric, 4 references, reference concentric
        let cell = |i: usize| format!("{:.1} ({:.1}, {:.2}x)", t[i], t[i + 5], t[i + 5] / t[i]);
        println!(
            "| {m}x{n} | {:.1} | {} | {} | {} | {} | +{:.1} ns (+{:.1}) | {} |",
            t[0],
            cell(1),
            cell(2),
            cell(3),
            cell(4),
            t[2] - t[1],
            t[7] - t[6],
            cell(5)
        );
    }
}

criterion_group!(benches, bench);

/// `RADDIFF_BENCH_PROFILE=<m>x<n>:<case>:<calls>`: runs one case that many times and nothing else,
/// for `perf` / `valgrind --tool=callgrind` (e.g. `32x64:gradients:1000`).
fn profile(spec: &str) {
    let parts: Vec<&str> = spec.split(':').collect();
    let (m, n) = parts[0].split_once('x').expect("<m>x<n>");
    let scene = Scene::new(m.parse().unwrap(), n.parse().unwrap());
    let calls: usize = parts.get(2).map_or(1000, |c| c.parse().unwrap());
    let cases = cases(&scene);
    let (_, f) = cases
        .iter()
        .find(|(name, _)| *name == parts[1])
        .expect("case name as in the summary");
    for _ in 0..calls {
        f();
    }
}

fn main() {
    if let Ok(spec) = std::env::var("RADDIFF_BENCH_PROFILE") {
        profile(&spec);
        return;
    }
    if std::env::var_os("RADDIFF_BENCH_SUMMARY_ONLY").is_none() {
        benches();
    }
    Criterion::default().configure_from_args().final_summary();
    summary();
}
