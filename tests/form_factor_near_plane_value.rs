//! Issue 18: the value of `triangle_form_factor` with `x` near the triangle's plane, outside the
//! part its tangent plane leaves visible, where `Order::Value` takes the near-plane route
//! (`near_plane::triangle`, a replay of the robust path's near-plane split). Walks of the
//! height `h_P` from 1e-2 to 1e-12 of the size, on both sides of the plane, for several tilts of
//! the receiver and scales 1e-3..1e3, with `x`'s foot near a clip vertex: on the extension of a
//! line through a point of an edge into the triangle, the tangent plane tilted about that line (so
//! the clip line runs parallel to it, `h_P/tan θ` away, and crosses the edge next to that point),
//! at 100, 20, 10.5, 9.5 and 2 `h_P` from the edge point. That takes the foot's distance from the
//! edge's line across the split's limit (`10 h_P`; the route answers beyond it, and below it the
//! robust path's quadrature takes over). Each value against the 320-bit reference of
//! `form_factor_support` at the hard-regime contract (1e-10 relative), and equal bit for bit to the
//! Hessian order's value. Run with `--nocapture` for the worst errors per height.

mod form_factor_support;

use form_factor_support::*;
use glam::DVec3;
use raddiff::{kernels, Order};

/// The value part of the hard-regime contract of issue 18.
const HARD_VALUE: f64 = 1e-10;

/// Tilts of the receiver from the triangle's normal (radians).
const TILTS: [f64; 4] = [0.1, 0.5, 1.0, 1.45];

/// A fat random triangle (scale 1e-3..1e3) and, outside it beside edge (0, 1), a point `c` on that
/// edge's line (the clip vertex to be), an in-plane unit `out` away from the triangle across that
/// line, and the unit direction `along` of the line from `c` into the triangle (the clip line).
struct Setup {
    t: [DVec3; 3],
    normal: DVec3,
    size: f64,
    c: DVec3,
    out: DVec3,
    along: DVec3,
}

fn setup(rng: &mut Rng) -> Setup {
    let size = 10f64.powf(rng.range(-3.0, 3.0));
    let t = rng.fat_triangle(size);
    let normal = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
    let e = t[1] - t[0];
    let out = normal.cross(e.normalize());
    let out = if out.dot(t[2] - t[0]) > 0.0 {
        -out
    } else {
        out
    };
    // A point of the edge itself (the clip line enters the triangle through it).
    let c = t[0] + e * rng.range(0.2, 0.8);
    let inner = t[0] + e * rng.range(0.1, 0.9) * 0.5 + (t[2] - t[0]) * rng.range(0.2, 0.5);
    let along = (inner - c).normalize();
    Setup {
        t,
        normal,
        size,
        c,
        out,
        along,
    }
}

#[test]
fn near_a_clip_vertex_walk_to_the_plane() {
    let mut big = Big::new();
    let mut rng = Rng(1871);
    let setups: Vec<Setup> = (0..8).map(|_| setup(&mut rng)).collect();
    let mut overall = 0.0f64;
    let mut compared = 0;
    for k in 2..=12 {
        let rel_h = 10f64.powi(-k) * rng.range(1.0, 3.0);
        let mut worst = 0.0f64;
        for (j, s) in setups.iter().enumerate() {
            let h = rel_h * s.size;
            for side in [1.0, -1.0] {
                for ratio in [100.0, 20.0, 10.5, 9.5, 2.0] {
                    // The foot `ratio · h` from the clip vertex, outside, along the clip line
                    // backwards (the foot is on the clip line's extension: the clip line runs
                    // from it through `c` into the triangle).
                    let foot = s.c - s.along * (ratio * h) + s.out * (1e-3 * ratio * h);
                    let theta = TILTS[(j + k as usize) % TILTS.len()];
                    // Tilted about the clip line, so the tangent plane cuts the triangle along it;
                    // the receiver faces the triangle's side that x is on or the other.
                    let across = s.normal.cross(s.along);
                    let face = if (j + k as usize) % 2 == 0 { 1.0 } else { -1.0 };
                    let n = (s.normal * (face * theta.cos()) + across * theta.sin()).normalize();
                    let x = foot + s.normal * (side * h);
                    let value =
                        kernels::triangle_form_factor(x, n, s.t[0], s.t[1], s.t[2], Order::Value)
                            .unwrap_or_else(|e| panic!("{e} at x={x:?} n={n:?} t={:?}", s.t));
                    let hessian =
                        kernels::triangle_form_factor(x, n, s.t[0], s.t[1], s.t[2], Order::Hessian)
                            .unwrap();
                    assert_eq!(
                        value.value.to_bits(),
                        hessian.value.to_bits(),
                        "value depends on the order at x={x:?} n={n:?} t={:?}",
                        s.t
                    );
                    let r = big.polygon_reference(x, n, &s.t, true);
                    let e = rel_scalar(value.value, r.value, 1e-300);
                    assert!(
                        e <= HARD_VALUE,
                        "error {e:e} at x={x:?} n={n:?} t={:?}: {} vs {}",
                        s.t,
                        value.value,
                        r.value
                    );
                    worst = worst.max(e);
                    compared += 1;
                }
            }
        }
        println!("near a clip vertex: h_P = {rel_h:.1e} sizes, worst value error {worst:.1e}");
        overall = overall.max(worst);
    }
    println!("near a clip vertex: {compared} values, worst error {overall:.1e}");
    assert!(compared == 11 * 8 * 2 * 5);
}
