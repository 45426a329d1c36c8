//! Issue 18, grazing receivers: `n` within 1e-9..1e-3 rad of the triangle's normal, `x` 1e-3 to
//! 1e-12 of the size from its plane, its foot outside the triangle (beyond an edge or a vertex)
//! or over the interior, scales 1e-3..1e3. The tangent plane of `x` then meets the triangle's
//! plane `h_P/tilt` from the foot: across the triangle, at its edge or far beyond it, as the
//! height and the tilt walk. Value, gradient and Hessian against the 320-bit astro-float reference
//! of `form_factor_support`; run with `--nocapture` for the worst errors per tilt and height.
//!
//! The value and the Hessian meet the hard-regime contract everywhere (measured worst 8.8e-11 and
//! 2.8e-10; the value's worst is a normal `n` one ulp off unit length, whose normalization tilts
//! it by an ulp, which at 2e-9 rad moves the value by up to 6.7e-10 per ulp). The gradient meets
//! it down to ~1e-6 rad (7.3e-10 at 1.9e-6 rad); below, it comes from the quadrature, whose
//! `n·r = n_N h_P + n_t·q` is rounded to `u‖r‖` while the gradient's tilt-dependent part is
//! O(`‖n_t‖`): measured errors scale like `u/tilt` (at most 6.3 u/tilt: 4.4e-9 at 2.5e-7 rad, 4.4e-8
//! at 2.6e-8 rad, 3.9e-7 at 2.1e-9 rad), and the test asserts `max(1e-9, 16 u/tilt)` there as a
//! guard, not as the contract.

mod form_factor_support;

use form_factor_support::*;
use glam::DVec3;
use raddiff::{kernels, Order};

fn f3(e: [f64; 3]) -> String {
    format!("[{:.1e}, {:.1e}, {:.1e}]", e[0], e[1], e[2])
}

/// The example of the issue: `n` 2.3e-6 rad from the normal, `x` 1e-3 (1e-6 of the size) below
/// the plane, outside the triangle, F ≈ 2.5e-16 (the value erred by 1.7e-9, the gradient 4.4e-9).
#[test]
fn the_issue_example() {
    let mut big = Big::new();
    let x = DVec3::new(517.6545109260119, -163.75591045878275, 1158.6318890320965);
    let n = DVec3::new(-0.20310917808299947, 0.2697565087298581, 0.9412640903467668);
    let t = [
        DVec3::new(0.0, 0.0, 1000.0),
        DVec3::new(1000.0, 55.06469822946615, 1200.0),
        DVec3::new(268.4716350632676, 900.0, 800.0),
    ];
    let r = big.polygon_reference(x, n, &t, true);
    for order in [Order::Value, Order::Gradient, Order::Hessian] {
        let d = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], order).unwrap();
        let e = errors(&d, &r);
        println!("issue example, {order:?}: errors {}", f3(e));
        assert!(e[0] <= HARD[0], "value error {:e}", e[0]);
        if order.gradient() {
            assert!(e[1] <= HARD[1], "gradient error {:e}", e[1]);
        }
        if order.hessian() {
            assert!(e[2] <= HARD[2], "Hessian error {:e}", e[2]);
        }
    }
}

/// A receiver normal `tilt` rad from `±normal`, tilted toward the in-plane unit `axis`.
fn tilted(normal: DVec3, axis: DVec3, tilt: f64) -> DVec3 {
    (normal * tilt.cos() + axis * tilt.sin()).normalize()
}

#[test]
fn grazing_receivers_walk_to_the_plane() {
    let mut big = Big::new();
    let mut rng = Rng(18_007);
    let mut overall = [0.0f64; 3];
    let mut compared = 0;
    for kt in 3..=9 {
        let tilt = 10f64.powi(-kt) * rng.range(1.0, 3.0);
        for kh in 3..=12 {
            let rel_h = 10f64.powi(-kh) * rng.range(1.0, 3.0);
            let mut worst = [0.0f64; 3];
            for j in 0..3 {
                let size = 10f64.powf(rng.range(-3.0, 3.0));
                let t = rng.fat_triangle(size);
                let normal = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
                let centroid = (t[0] + t[1] + t[2]) / 3.0;
                // j = 0: beyond edge (0, 1); 1: beyond vertex 2; 2: over the interior.
                let foot = match j {
                    0 => {
                        (t[0] + t[1]) * 0.5 + ((t[0] + t[1]) * 0.5 - centroid) * rng.range(0.2, 1.0)
                    }
                    1 => t[2] + (t[2] - centroid) * rng.range(0.2, 1.0),
                    _ => centroid + (t[0] - centroid) * rng.range(0.0, 0.5),
                };
                let side = if rng.uniform() < 0.5 { 1.0 } else { -1.0 };
                let x = foot + normal * (side * rel_h * size);
                // Facing the plane, tilted about a random in-plane axis.
                let a = rng.unit();
                let axis = (a - normal * a.dot(normal)).normalize();
                let n = tilted(-normal * side, axis, tilt);
                let r = big.polygon_reference(x, n, &t, true);
                let d = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Hessian)
                    .unwrap_or_else(|e| panic!("{e} at x={x:?} n={n:?} t={t:?}"));
                let v =
                    kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Value).unwrap();
                assert_eq!(
                    v.value.to_bits(),
                    d.value.to_bits(),
                    "x={x:?} n={n:?} t={t:?}"
                );
                let e = errors(&d, &r);
                // The gradient's known gap (see the module documentation): the contract down to
                // ~1e-6 rad, below it a guard at the measured scaling (≤ 6.3 u/tilt).
                let gradient_bound = HARD[1].max(16.0 * f64::EPSILON / tilt);
                let bound = [HARD[0], gradient_bound, HARD[2]];
                assert!(
                    e.iter().zip(bound).all(|(e, b)| *e <= b),
                    "errors {} (bound {}) at tilt {tilt:e}, h_P {rel_h:e}: x={x:?} n={n:?} t={t:?}",
                    f3(e),
                    f3(bound)
                );
                for k in 0..3 {
                    worst[k] = worst[k].max(e[k]);
                }
                compared += 1;
            }
            println!(
                "tilt {tilt:.1e} rad, h_P {rel_h:.1e} sizes: worst {}",
                f3(worst)
            );
            for k in 0..3 {
                overall[k] = overall[k].max(worst[k]);
            }
        }
    }
    println!("grazing: {compared} configurations, worst {}", f3(overall));
    assert_eq!(compared, 7 * 10 * 3);
}
