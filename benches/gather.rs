//! Cost of a gather evaluation against the cost of generating its directions, for 16x32, 32x64,
//! 32x128 (the demo's 4096 rays) and 64x128 cosine-polar layouts, 3 channels: irradiance only,
//! irradiance with translational and rotational gradients, both with an absorbing, scattering
//! medium marched in 16 steps per direction (with media radiance gradients), the gradients with
//! the marched radiance but without its gradient (the demo's room), and the concentric layout's
//! gradients. Every evaluation is also timed with the previous implementation
//! (`tests/gather_support/evaluate_reference.rs`, cases named "reference ...") as the baseline.
//! After the criterion groups, a summary table in ns per sample with the speed-up over the previous
//! implementation, timed in the same run as on-CPU time of the thread (robust on a shared machine;
//! criterion's figures are wall time).
//! A second summary times the stratum check alone (`Layout::check_directions`, the validation of
//! every direction against its stratum that `evaluate` runs first) against the evaluation with
//! Ward-Heckbert gradients, for each layout kind at every size (criterion group `gather_check`).
//! A third summary times the evaluation with gradients from strata smoothed by 2 azimuthal and 1
//! polar passes (`ValidGather::evaluate_smoothed`, what `IrradianceSettings::derivative_smoothing`
//! adds to a record's evaluation) against the same evaluation without smoothing.
//! `RADDIFF_BENCH_SUMMARY_ONLY=1` skips the criterion groups, `RADDIFF_BENCH_CHECK_ONLY=1` the
//! first summary;
//! `RADDIFF_BENCH_PROFILE=32x128:gradients:1000` runs one case only (for `perf`/callgrind).
//!
//! `cargo bench --bench gather -- --warm-up-time 1 --measurement-time 3`

use std::cell::RefCell;
use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, Criterion, Throughput};
use glam::DVec3;
use raddiff::gather::{
    evaluate, Frame, GatherInput, Layout, LayoutKind, MediaRadiance, StrataSmoothing, ValidGather,
    Wanted,
};

#[path = "../tests/gather_support/evaluate_reference.rs"]
mod evaluate_reference;

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

    /// With `medium`, the media radiance gradient only if `media_gradient`.
    fn input_with(&self, medium: bool, media_gradient: bool) -> GatherInput<'_> {
        GatherInput {
            directions: &self.dirs,
            distance: &self.dist,
            radiance: &self.rad,
            channels: CHANNELS,
            sigma_t: if medium { 0.2 } else { 0.0 },
            media: medium.then_some(MediaRadiance {
                radiance: &self.media,
                gradient: media_gradient.then_some(&self.media_grad[..]),
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

type Case<'a> = (String, Box<dyn Fn() + 'a>);

/// An evaluation to time: name, concentric layout (else cosine-polar), medium, media radiance
/// gradient, outputs.
type Evaluation = (&'static str, bool, bool, bool, Wanted);

const EVALUATIONS: [Evaluation; 6] = [
    ("irradiance", false, false, false, Wanted::IRRADIANCE),
    ("gradients", false, false, false, GRADIENTS),
    ("irradiance+media", false, true, true, Wanted::IRRADIANCE),
    ("gradients+media", false, true, true, GRADIENTS),
    // The demo's room: marched in-scattering without its gradient.
    (
        "gradients+media without its gradient",
        false,
        true,
        false,
        GRADIENTS,
    ),
    ("concentric gradients", true, false, false, GRADIENTS),
];

/// The direction generation, then every evaluation with this implementation and with the previous
/// one (`tests/gather_support/evaluate_reference.rs`, named "reference ..."), the baseline of the
/// speed-up.
fn cases(s: &Scene) -> Vec<Case<'_>> {
    let buf = RefCell::new(vec![DVec3::ZERO; s.layout.len()]);
    let mut v: Vec<Case<'_>> = vec![(
        "directions".into(),
        Box::new(move || {
            s.layout
                .directions_into(&s.frame, black_box(&mut buf.borrow_mut()))
                .unwrap()
        }),
    )];
    let concentric = std::rc::Rc::new(Scene::new_kind(
        LayoutKind::Concentric,
        s.layout.m,
        s.layout.n,
    ));
    for reference in [false, true] {
        for (name, conc, medium, media_gradient, wanted) in EVALUATIONS {
            let scene = conc.then(|| std::rc::Rc::clone(&concentric));
            let name = if reference {
                format!("reference {name}")
            } else {
                name.to_string()
            };
            v.push((
                name,
                Box::new(move || {
                    let s = scene.as_deref().unwrap_or(s);
                    let input = s.input_with(medium, media_gradient);
                    let values = if reference {
                        evaluate_reference::evaluate(&s.layout, &s.frame, &input, wanted)
                    } else {
                        evaluate(&s.layout, &s.frame, &input, wanted)
                    };
                    black_box(values.unwrap());
                }),
            ));
        }
    }
    v
}

/// Per layout kind: the stratum check alone, and the evaluation with gradients (which includes it).
fn check_cases(m: u32, n: u32) -> Vec<(String, Box<dyn Fn()>)> {
    let mut v: Vec<(String, Box<dyn Fn()>)> = Vec::new();
    for kind in [
        LayoutKind::CosinePolar,
        LayoutKind::Concentric,
        LayoutKind::Sphere,
    ] {
        let s = std::rc::Rc::new(Scene::new_kind(kind, m, n));
        let s2 = std::rc::Rc::clone(&s);
        v.push((
            format!("{kind:?} check"),
            Box::new(move || {
                s.layout
                    .check_directions(&s.frame, black_box(&s.dirs))
                    .unwrap()
            }),
        ));
        v.push((
            format!("{kind:?} gradients"),
            Box::new(move || {
                let input = s2.input_with(false, false);
                black_box(evaluate(&s2.layout, &s2.frame, &input, GRADIENTS).unwrap());
            }),
        ));
    }
    v
}

fn check_summary() {
    println!(
        "\nStratum check alone vs evaluate with Ward-Heckbert gradients ({CHANNELS} channels), CPU ns per sample:"
    );
    println!("| layout | cosine-polar check / gradients | concentric check / gradients | sphere check / gradients |");
    println!("|---|---|---|---|");
    for (m, n) in SIZES {
        let samples = (m * n) as f64;
        let t: Vec<f64> = check_cases(m, n)
            .iter()
            .map(|(_, f)| time(f.as_ref()) / samples)
            .collect();
        let cell = |i: usize| {
            format!(
                "{:.2} / {:.1} ({:.1}%)",
                t[2 * i],
                t[2 * i + 1],
                100.0 * t[2 * i] / t[2 * i + 1]
            )
        };
        println!("| {m}x{n} | {} | {} | {} |", cell(0), cell(1), cell(2));
    }
}

fn bench(c: &mut Criterion) {
    {
        let (m, n) = (32, 128);
        let mut group = c.benchmark_group(format!("gather_check_{m}x{n}"));
        group.throughput(Throughput::Elements((m * n) as u64));
        for (name, f) in check_cases(m, n) {
            group.bench_function(&name, |b| b.iter(&f));
        }
        group.finish();
    }
    for (m, n) in SIZES {
        let scene = Scene::new(m, n);
        let mut group = c.benchmark_group(format!("gather_{m}x{n}"));
        group.throughput(Throughput::Elements((m * n) as u64));
        for (name, f) in cases(&scene) {
            group.bench_function(&name, |b| b.iter(&f));
        }
        group.finish();
    }
}

/// On-CPU time of this thread in ns (`CLOCK_THREAD_CPUTIME_ID`): unlike wall time, it does not
/// count the time other processes hold the core, so the figures survive a busy machine. Wall time
/// where the clock is missing.
fn cpu_ns() -> Option<u64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: a valid clock id and a valid out-pointer.
    let ok = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0;
    ok.then(|| ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64)
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
        "| layout | directions | irradiance | + gradients | irradiance + media | gradients + media | gradients + media without its gradient | concentric, + gradients |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (m, n) in SIZES {
        let scene = Scene::new(m, n);
        let samples = (m * n) as f64;
        let t: Vec<(String, f64)> = cases(&scene)
            .iter()
            .map(|(name, f)| (name.clone(), time(f.as_ref()) / samples))
            .collect();
        let get = |name: &str| t.iter().find(|(n, _)| n == name).map(|(_, t)| *t).unwrap();
        let cell = |name: &str| {
            let (new, old) = (get(name), get(&format!("reference {name}")));
            format!("{new:.1} ({old:.1}, {:.1}x)", old / new)
        };
        let cells: Vec<String> = EVALUATIONS.iter().map(|e| cell(e.0)).collect();
        println!(
            "| {m}x{n} | {:.1} | {} |",
            get("directions"),
            cells.join(" | ")
        );
    }
}

/// The evaluation with gradients, as traced and from smoothed strata (2 azimuthal passes, 1
/// polar), both validating the gather as `evaluate` does.
fn smoothing_summary() {
    println!(
        "\nEvaluate with gradients ({CHANNELS} channels), CPU ns per sample: as traced / from strata smoothed 2,1 (ratio):"
    );
    println!("| layout | cosine-polar | concentric |");
    println!("|---|---|---|");
    for (m, n) in SIZES {
        let samples = (m * n) as f64;
        let mut cells = Vec::new();
        for kind in [LayoutKind::CosinePolar, LayoutKind::Concentric] {
            let s = Scene::new_kind(kind, m, n);
            let input = s.input_with(false, false);
            let run = |smoothing: StrataSmoothing| {
                let valid = ValidGather::new(&s.layout, &s.frame, &input).unwrap();
                black_box(valid.evaluate_smoothed(smoothing, GRADIENTS).unwrap());
            };
            let plain = time(&|| run(StrataSmoothing::OFF)) / samples;
            let smoothed = time(&|| run(StrataSmoothing::new(2, 1))) / samples;
            let copy = RefCell::new(s.rad.clone());
            let filter = time(&|| {
                StrataSmoothing::new(2, 1)
                    .apply(&s.layout, black_box(&mut copy.borrow_mut()), CHANNELS)
                    .unwrap()
            }) / samples;
            cells.push(format!(
                "{plain:.1} / {smoothed:.1} ({:.2}x; the filter alone {filter:.1})",
                smoothed / plain
            ));
        }
        println!("| {m}x{n} | {} |", cells.join(" | "));
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
        .find(|(name, _)| name == parts[1])
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
    if std::env::var_os("RADDIFF_BENCH_CHECK_ONLY").is_none() {
        summary();
    }
    check_summary();
    smoothing_summary();
}
