//! Stress test of the C functions of `src/ffi/kernels.rs` (solid angle, segment, transmittance),
//! called through the C ABI (`extern "C"`) from Rust: random and adversarial inputs (exact singular configurations, coincident and collinear points,
//! huge, tiny and subnormal coordinates, non-finite values, bad orders and sizes).
//!
//! Every call must return `RADDIFF_OK` with finite outputs in the documented range, or a
//! documented error (`RADDIFF_ERROR_DEGENERATE` for singular configurations,
//! `RADDIFF_ERROR_INVALID_ARGUMENT` only for non-finite input or bad order/size), never a panic, and
//! must leave the output untouched on failure.
//!
//! Default: ~1e5 calls (a few seconds). `RADDIFF_STRESS_CALLS=N` sets the number of calls, e.g.
//! `RADDIFF_STRESS_CALLS=5000000 cargo test --release --test c_abi_kernels_stress -- --nocapture`.

use raddiff::ffi::*;
use std::f64::consts::PI;

#[path = "common/splitmix.rs"]
mod splitmix;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        splitmix::next_u64(&mut self.0)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    /// A coordinate from a mixture of distributions, mostly finite.
    fn coord(&mut self, finite_only: bool) -> f64 {
        let sign = if self.next() & 1 == 0 { 1.0 } else { -1.0 };
        match self.below(if finite_only { 10 } else { 11 }) {
            0..=2 => sign * self.unit() * 2.0,
            3 => sign * 10f64.powf(self.unit() * 600.0 - 300.0),
            4 => sign * 10f64.powf(self.unit() * 12.0 - 6.0),
            5 => (self.below(5) as f64 - 2.0) * 0.5,
            6 => {
                sign * [
                    f64::MAX,
                    f64::MIN_POSITIVE,
                    5e-324,
                    1e308,
                    1e-308,
                    1e154,
                    1e-154,
                ][self.below(7) as usize]
            }
            7 => sign * 1e6 + self.unit(),
            8 => sign * 1e-6 * self.unit(),
            9 => 0.0,
            _ => [f64::NAN, f64::INFINITY, f64::NEG_INFINITY][self.below(3) as usize],
        }
    }
    fn v3(&mut self, finite_only: bool) -> raddiff_vec3 {
        raddiff_vec3 {
            x: self.coord(finite_only),
            y: self.coord(finite_only),
            z: self.coord(finite_only),
        }
    }
    fn v2(&mut self, finite_only: bool) -> raddiff_vec2 {
        raddiff_vec2 {
            x: self.coord(finite_only),
            y: self.coord(finite_only),
        }
    }
}

fn finite3(v: &raddiff_vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

fn finite2(v: &raddiff_vec2) -> bool {
    v.x.is_finite() && v.y.is_finite()
}

fn lerp3(a: raddiff_vec3, b: raddiff_vec3, t: f64) -> raddiff_vec3 {
    raddiff_vec3 {
        x: a.x + (b.x - a.x) * t,
        y: a.y + (b.y - a.y) * t,
        z: a.z + (b.z - a.z) * t,
    }
}

const SENTINEL: f64 = 12345.0;

fn d3_sentinel() -> raddiff_deriv3 {
    raddiff_deriv3 {
        value: SENTINEL,
        gradient: [SENTINEL; 3],
        hessian: [SENTINEL; 9],
    }
}

fn d2_sentinel() -> raddiff_deriv2 {
    raddiff_deriv2 {
        value: SENTINEL,
        gradient: [SENTINEL; 2],
        hessian: [SENTINEL; 4],
    }
}

#[derive(Default, Debug)]
struct Tally {
    ok: usize,
    degenerate: usize,
    invalid: usize,
}

impl Tally {
    fn record(&mut self, status: raddiff_status, finite: bool, untouched: bool, what: &str) {
        use raddiff_status::*;
        match status {
            RADDIFF_OK => self.ok += 1,
            RADDIFF_ERROR_DEGENERATE => {
                assert!(untouched, "{what}: output written on failure");
                self.degenerate += 1;
            }
            RADDIFF_ERROR_INVALID_ARGUMENT => {
                assert!(
                    !finite,
                    "{what}: finite input rejected as invalid: {}",
                    last_error()
                );
                assert!(untouched, "{what}: output written on failure");
                self.invalid += 1;
            }
            other => panic!("{what}: unexpected status {other:?}: {}", last_error()),
        }
        if !finite {
            assert_ne!(status, RADDIFF_OK, "{what}: non-finite input accepted");
        }
    }
}

fn last_error() -> String {
    unsafe { std::ffi::CStr::from_ptr(raddiff_last_error()) }
        .to_string_lossy()
        .into_owned()
}

fn check_d3(d: &raddiff_deriv3, lo: f64, hi: f64, what: &str) {
    assert!(
        d.value.is_finite()
            && d.gradient.iter().all(|v| v.is_finite())
            && d.hessian.iter().all(|v| v.is_finite()),
        "{what}: non-finite output {d:?}"
    );
    assert!(
        (lo..=hi).contains(&d.value),
        "{what}: value {} outside [{lo}, {hi}]",
        d.value
    );
    for i in 0..3 {
        for j in 0..3 {
            assert_eq!(
                d.hessian[3 * i + j],
                d.hessian[3 * j + i],
                "{what}: asymmetric"
            );
        }
    }
}

fn calls() -> usize {
    std::env::var("RADDIFF_STRESS_CALLS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000)
}

#[test]
fn kernels_survive_random_and_adversarial_inputs_through_the_c_abi() {
    let mut rng = Rng(0x5eed);
    let mut solid = Tally::default();
    let mut segment = Tally::default();
    let mut homogeneous = Tally::default();
    let mut marched = Tally::default();
    let rounds = calls() / 4;
    for round in 0..rounds {
        let finite_only = round % 8 != 0;
        let order = rng.below(3) as u32;

        // Triangle solid angle: random points, then exact singular placements of x.
        let a = rng.v3(finite_only);
        let b = match rng.below(6) {
            0 => a,
            _ => rng.v3(finite_only),
        };
        let c = match rng.below(6) {
            0 => lerp3(a, b, 2.0), // collinear
            1 => b,
            _ => rng.v3(finite_only),
        };
        let x = match rng.below(8) {
            0 => a,
            1 => lerp3(a, b, 0.5),                  // on an edge
            2 => lerp3(lerp3(a, b, 0.5), c, 0.5),   // in the plane, inside
            3 => lerp3(a, b, 3.0),                  // on an edge's line
            4 => lerp3(lerp3(a, b, 0.25), c, 1e-9), // just inside near an edge
            _ => rng.v3(finite_only),
        };
        let finite = [a, b, c, x].iter().all(finite3);
        let mut d = d3_sentinel();
        let status = raddiff_triangle_solid_angle(x, a, b, c, order, &mut d);
        let untouched = d == d3_sentinel();
        solid.record(status, finite, untouched, "triangle_solid_angle");
        if status == raddiff_status::RADDIFF_OK {
            check_d3(
                &d,
                0.0,
                2.0 * PI,
                &format!("triangle_solid_angle({x:?}, {a:?}, {b:?}, {c:?})"),
            );
        }

        // Segment form factor.
        let (pa, pb) = (rng.v2(finite_only), rng.v2(finite_only));
        let pb = if rng.below(8) == 0 { pa } else { pb };
        let px = match rng.below(6) {
            0 => pa,
            1 => raddiff_vec2 {
                x: 0.5 * (pa.x + pb.x),
                y: 0.5 * (pa.y + pb.y),
            },
            2 => raddiff_vec2 {
                x: pa.x + 2.0 * (pb.x - pa.x),
                y: pa.y + 2.0 * (pb.y - pa.y),
            },
            _ => rng.v2(finite_only),
        };
        let finite = [pa, pb, px].iter().all(finite2);
        let mut d2 = d2_sentinel();
        let status = raddiff_segment_form_factor_2d(px, pa, pb, order, &mut d2);
        let untouched = d2 == d2_sentinel();
        segment.record(status, finite, untouched, "segment_form_factor_2d");
        if status == raddiff_status::RADDIFF_OK {
            assert!(
                d2.value.is_finite()
                    && d2.gradient.iter().all(|v| v.is_finite())
                    && d2.hessian.iter().all(|v| v.is_finite()),
                "segment({px:?}, {pa:?}, {pb:?}, {order}): non-finite {d2:?}"
            );
            assert!(
                (0.0..=0.5).contains(&d2.value),
                "segment value {}",
                d2.value
            );
            assert_eq!(d2.hessian[1], d2.hessian[2]);
        }

        // Homogeneous transmittance.
        let sigma = match rng.below(5) {
            0 => 0.0,
            1 => rng.coord(finite_only).abs(),
            _ => 10f64.powf(rng.unit() * 20.0 - 10.0),
        };
        let y = if rng.below(6) == 0 {
            x
        } else {
            rng.v3(finite_only)
        };
        let finite = finite3(&x) && finite3(&y) && sigma.is_finite();
        let mut d = d3_sentinel();
        let status = raddiff_transmittance(x, y, sigma, order, &mut d);
        let untouched = d == d3_sentinel();
        homogeneous.record(status, finite, untouched, "transmittance");
        if status == raddiff_status::RADDIFF_OK {
            check_d3(&d, 0.0, 1.0, "transmittance");
        }

        // Marched transmittance: order <= gradient and valid samples are the "finite" inputs.
        let count = rng.below(6) as usize;
        let mut sig: Vec<f64> = (0..count)
            .map(|_| match rng.below(4) {
                0 => 0.0,
                1 => rng.coord(finite_only).abs(),
                _ => rng.unit() * 3.0,
            })
            .collect();
        if count > 0 && rng.below(20) == 0 {
            sig[0] = -1.0;
        }
        let grads: Vec<raddiff_vec3> = (0..count).map(|_| rng.v3(finite_only)).collect();
        let with_grad = rng.below(2) == 0;
        let valid = count >= 1
            && order <= RADDIFF_ORDER_GRADIENT
            && finite3(&x)
            && finite3(&y)
            && sig.iter().all(|s| s.is_finite() && *s >= 0.0)
            && (!with_grad || grads.iter().all(finite3));
        let mut d = d3_sentinel();
        let status = raddiff_transmittance_marched(
            x,
            y,
            if count == 0 && rng.below(2) == 0 {
                std::ptr::null()
            } else {
                sig.as_ptr()
            },
            if with_grad {
                grads.as_ptr()
            } else {
                std::ptr::null()
            },
            count,
            order,
            &mut d,
        );
        let untouched = d == d3_sentinel();
        marched.record(status, valid, untouched, "transmittance_marched");
        if status == raddiff_status::RADDIFF_OK {
            check_d3(&d, 0.0, 1.0, "transmittance_marched");
        }
    }
    println!("solid angle {solid:?}\nsegment {segment:?}\ntransmittance {homogeneous:?}\nmarched {marched:?}");
    // The adversarial mixture must actually reach the singular paths.
    assert!(solid.degenerate > 0 && segment.degenerate > 0 && homogeneous.degenerate > 0);
    assert!(solid.ok > rounds / 2 && segment.ok > rounds / 2);
}

#[test]
fn exact_singular_configurations_give_documented_results() {
    use raddiff_status::*;
    let v = |x: f64, y: f64, z: f64| raddiff_vec3 { x, y, z };
    let (a, b, c) = (v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0));
    for order in 0..3 {
        let mut d = d3_sentinel();
        // Vertex, edge: degenerate; plane inside 2π, outside 0, with zero derivatives.
        for x in [
            a,
            b,
            c,
            v(0.5, 0.0, 0.0),
            v(0.5, 0.5, 0.0),
            v(0.0, 0.25, 0.0),
        ] {
            assert_eq!(
                raddiff_triangle_solid_angle(x, a, b, c, order, &mut d),
                RADDIFF_ERROR_DEGENERATE
            );
        }
        assert_eq!(
            raddiff_triangle_solid_angle(v(0.25, 0.25, 0.0), a, b, c, order, &mut d),
            RADDIFF_OK
        );
        assert_eq!(d.value, 2.0 * PI);
        assert!(d.gradient.iter().chain(d.hessian.iter()).all(|&g| g == 0.0));
        assert_eq!(
            raddiff_triangle_solid_angle(v(2.0, 3.0, 0.0), a, b, c, order, &mut d),
            RADDIFF_OK
        );
        assert_eq!(d.value, 0.0);
        // Collinear / coincident vertices: no solid angle.
        assert_eq!(
            raddiff_triangle_solid_angle(v(0.0, 0.0, 1.0), a, b, v(2.0, 0.0, 0.0), order, &mut d),
            RADDIFF_OK
        );
        assert_eq!(d.value, 0.0);
        assert_eq!(
            raddiff_triangle_solid_angle(v(0.0, 0.0, 1.0), a, a, a, order, &mut d),
            RADDIFF_OK
        );
        assert_eq!(d.value, 0.0);
        // Flatland: endpoints degenerate; on the segment 1/2, beyond 0; zero-length 0.
        let w = |x: f64, y: f64| raddiff_vec2 { x, y };
        let mut d2 = d2_sentinel();
        assert_eq!(
            raddiff_segment_form_factor_2d(w(0.0, 0.0), w(0.0, 0.0), w(1.0, 0.0), order, &mut d2),
            RADDIFF_ERROR_DEGENERATE
        );
        assert_eq!(
            raddiff_segment_form_factor_2d(w(0.5, 0.0), w(0.0, 0.0), w(1.0, 0.0), order, &mut d2),
            RADDIFF_OK
        );
        assert_eq!(d2.value, 0.5);
        assert_eq!(
            raddiff_segment_form_factor_2d(w(2.0, 0.0), w(0.0, 0.0), w(1.0, 0.0), order, &mut d2),
            RADDIFF_OK
        );
        assert_eq!(d2.value, 0.0);
        assert_eq!(
            raddiff_segment_form_factor_2d(w(2.0, 1.0), w(1.0, 1.0), w(1.0, 1.0), order, &mut d2),
            RADDIFF_OK
        );
        assert_eq!(d2.value, 0.0);
    }
    // Huge and tiny configurations keep working: the octant seen from far-scaled origins.
    // At 1e-300 the Hessian (~1/s²) overflows: RADDIFF_ERROR_DEGENERATE, value and gradient are fine.
    let mut d = d3_sentinel();
    let tiny = 1e-300;
    let octant = |s: f64| (v(s, 0.0, 0.0), v(0.0, s, 0.0), v(0.0, 0.0, s));
    let (p, q, r) = octant(tiny);
    assert_eq!(
        raddiff_triangle_solid_angle(v(0.0, 0.0, 0.0), p, q, r, 2, &mut d),
        RADDIFF_ERROR_DEGENERATE
    );
    assert_eq!(
        raddiff_triangle_solid_angle(v(0.0, 0.0, 0.0), p, q, r, 1, &mut d),
        RADDIFF_OK
    );
    assert!((d.value - PI / 2.0).abs() < 1e-15 && d.gradient[0].is_finite());
    for s in [1e-150, 1e-6, 1e6, 1e150, 1e300] {
        let mut d = d3_sentinel();
        let (p, q, r) = octant(s);
        assert_eq!(
            raddiff_triangle_solid_angle(v(0.0, 0.0, 0.0), p, q, r, 2, &mut d),
            RADDIFF_OK,
            "scale {s}: {}",
            last_error()
        );
        assert!((d.value - PI / 2.0).abs() < 1e-15, "scale {s}: {}", d.value);
        // Gradient scales as 1/s.
        assert!((d.gradient[0] * s - d.gradient[1] * s).abs() < 1e-14);
    }
}
