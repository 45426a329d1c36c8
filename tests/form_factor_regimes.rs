//! The form factor's rule switches in the far field (issue 18): on both sides of every switch of
//! the far-field quadrature, the triangle and polygon entry points against the 320-bit astro-float
//! reference of `form_factor_support`, at the generic accuracy contract, and continuity across each
//! switch. Run with `--nocapture` to see the worst errors per switch.

mod form_factor_support;

use form_factor_support::*;
use raddiff::{kernels, Deriv3, Order};

/// The distance-over-radius ratios at which the far-field rule changes (`FAR_FIELD_RULES` in
/// `src/kernels/form_factor/quadrature/rules.rs`; 16 is the switch from the edge sum to
/// quadrature).
const SWITCHES: [f64; 5] = [16.0, 100.0, 280.0, 1.5e3, 3.6e4];

const GENERIC: [f64; 3] = [1e-12, 1e-12, 1e-10];
/// Largest relative change across a switch: the two sides are 2e-14 apart in distance (the
/// function itself changes by ~1e-13 there), so this is the two rules' disagreement.
const JUMP: [f64; 3] = [3e-13, 3e-13, 3e-12];

/// Relative differences between the two sides of a switch, normalized like the errors.
fn jump(p: &Deriv3, q: &Deriv3) -> [f64; 3] {
    let r = Reference {
        value: q.value,
        gradient: q.gradient,
        hessian: q.hessian,
    };
    errors(p, &r)
}

#[test]
fn far_field_rule_switches_against_the_reference() {
    let mut big = Big::new();
    let mut rng = Rng(18);
    let mut ok = true;
    for ratio in SWITCHES {
        let (mut worst, mut worst_jump, mut count) = ([0.0f64; 3], [0.0f64; 3], 0);
        for k in 0..8 {
            let s = 10f64.powf(rng.range(-3.0, 3.0));
            let t = rng.fat_triangle(s);
            let c = (t[0] + t[1] + t[2]) / 3.0;
            let radius = t.iter().map(|v| (*v - c).length()).fold(0.0, f64::max);
            let dir = rng.unit();
            // Even k: the receiver faces the triangle (nothing clipped: the triangle entry point's
            // far-field fast path); odd k: a random normal that clips part of it or none.
            let n = if k % 2 == 0 {
                let towards = -dir;
                (towards + rng.unit() * 0.3).normalize()
            } else {
                loop {
                    let n = rng.unit();
                    let x = c + dir * ratio * radius;
                    if t.iter().any(|v| n.dot(*v - x) > 0.0) {
                        break n;
                    }
                }
            };
            let mut sides = Vec::new();
            for side in [1.0 - 1e-14, 1.0 + 1e-14] {
                let x = c + dir * (ratio * radius * side);
                let r = big.polygon_reference(x, n, &t, true);
                let tri =
                    kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Hessian).unwrap();
                let poly = kernels::polygon_form_factor(x, n, &t, Order::Hessian).unwrap();
                let value = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Value)
                    .unwrap()
                    .value;
                assert_eq!(value, tri.value, "value depends on the order");
                max3(&mut worst, errors(&tri, &r));
                max3(&mut worst, errors(&poly, &r));
                count += 2;
                sides.push(tri);
            }
            max3(&mut worst_jump, jump(&sides[0], &sides[1]));
        }
        println!(
            "switch at {ratio:>7}: n={count:<3} worst error value {:.1e} gradient {:.1e} Hessian {:.1e}; jump across {:.1e} {:.1e} {:.1e}",
            worst[0], worst[1], worst[2], worst_jump[0], worst_jump[1], worst_jump[2]
        );
        ok &= worst.iter().zip(GENERIC).all(|(e, t)| *e <= t);
        ok &= worst_jump.iter().zip(JUMP).all(|(e, t)| *e <= t);
    }
    assert!(
        ok,
        "errors exceed the generic targets or the jumps {JUMP:?}"
    );
}

/// Slivers: walks the apex height from 3e-3 down to 3e-6 of the length, across the switch from
/// the edge sum (cancelling by up to `THIN_CANCELLATION_LIMIT` = 1e4, about the inverse aspect
/// ratio) to the subdivided quadrature, through both entry points, against the reference at the
/// hard-regime contract.
#[test]
fn slivers_across_the_edge_sum_limit_against_the_reference() {
    let mut big = Big::new();
    let mut rng = Rng(1804);
    let mut worst = [0.0f64; 3];
    let mut count = 0;
    for _ in 0..6 {
        let s = 10f64.powf(rng.range(-3.0, 3.0));
        let a = rng.vec(s);
        let b = a + rng.unit() * s;
        let perp = (b - a).any_orthonormal_vector();
        let foot = a + (b - a) * rng.range(0.2, 0.8);
        let x = (a + b) * 0.5 + rng.vec(s);
        for k in 0..13 {
            let height = 10f64.powf(-2.5 - 0.25 * k as f64);
            let t = [a, b, foot + perp * (s * height)];
            let n = loop {
                let n = rng.unit();
                if t.iter().all(|v| n.dot(*v - x) > 0.0) {
                    break n;
                }
            };
            let r = big.polygon_reference(x, n, &t, true);
            let tri =
                kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Hessian).unwrap();
            let value =
                kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Value).unwrap();
            assert_eq!(value.value, tri.value, "value depends on the order");
            let poly = kernels::polygon_form_factor(x, n, &t, Order::Hessian).unwrap();
            max3(&mut worst, errors(&tri, &r));
            max3(&mut worst, errors(&poly, &r));
            count += 2;
        }
    }
    println!(
        "slivers, apex 3e-3..3e-6: n={count} worst error value {:.1e} gradient {:.1e} Hessian {:.1e}",
        worst[0], worst[1], worst[2]
    );
    assert!(
        worst.iter().zip(HARD).all(|(e, t)| *e <= t),
        "errors exceed the hard-regime targets"
    );
}

/// Slivers beyond the edge sum's limit (apex 1e-4..1e-8 of the length), in both shapes: caps
/// (a flat obtuse triangle, the apex over the middle of the long edge) and needles (two long edges
/// and a short base, the apex at the end), seen from 0.05..3 lengths away, through both entry
/// points and every order, against the reference at the hard-regime contract. These take the
/// anisotropic sliver rule (`src/kernels/form_factor/sliver/rule.rs`).
#[test]
fn thin_slivers_caps_and_needles_against_the_reference() {
    let mut big = Big::new();
    let mut rng = Rng(1818);
    let mut worst = [0.0f64; 3];
    let mut count = 0;
    for k in 0..20 {
        let s = 10f64.powf(rng.range(-3.0, 3.0));
        let a = rng.vec(s);
        let b = a + rng.unit() * s;
        let perp = (b - a).any_orthonormal_vector();
        let needle = k % 2 == 1;
        // the apex's foot on ab: near an end for needles, inside for caps
        let along = if needle {
            rng.range(-0.02, 0.02)
        } else {
            rng.range(0.1, 0.9)
        };
        let foot = a + (b - a) * along;
        let x = (a + b) * 0.5 + rng.unit() * (s * 10f64.powf(rng.range(-0.3, 0.5)));
        for j in 0..9 {
            let height = 10f64.powf(-4.0 - 0.5 * j as f64);
            let t = [a, b, foot + perp * (s * height)];
            let Some(n) = (0..1000)
                .map(|_| rng.unit())
                .find(|n| t.iter().all(|v| n.dot(*v - x) > 0.0))
            else {
                continue;
            };
            let r = big.polygon_reference(x, n, &t, true);
            let tri =
                kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Hessian).unwrap();
            let grad =
                kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Gradient).unwrap();
            let value =
                kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Value).unwrap();
            let poly = kernels::polygon_form_factor(x, n, &t, Order::Hessian).unwrap();
            let e = errors(&tri, &r);
            max3(&mut worst, e);
            max3(&mut worst, errors(&poly, &r));
            max3(
                &mut worst,
                [rel_scalar(value.value, r.value, 1e-300), 0.0, 0.0],
            );
            max3(
                &mut worst,
                [0.0, rel_vec(grad.gradient, r.gradient, 1e-300), 0.0],
            );
            count += 4;
        }
    }
    println!(
        "slivers, caps and needles, apex 1e-4..1e-8: n={count} worst error value {:.1e} gradient {:.1e} Hessian {:.1e}",
        worst[0], worst[1], worst[2]
    );
    assert!(count >= 100, "too few configurations ({count})");
    assert!(
        worst.iter().zip(HARD).all(|(e, t)| *e <= t),
        "errors exceed the hard-regime targets"
    );
}

/// x just above the interior of a triangle (1e-4..1e-10 of its size from the plane) with a random
/// receiver normal (usually clipping it): the edge sum does not cancel there, and the kernel keeps
/// it without the near-plane recomputation. Against the reference at the hard-regime contract.
#[test]
fn near_the_plane_over_the_interior_against_the_reference() {
    let mut big = Big::new();
    let mut rng = Rng(1806);
    let mut worst = [0.0f64; 3];
    let mut count = 0;
    for k in 0..24 {
        let s = 10f64.powf(rng.range(-3.0, 3.0));
        let t = rng.fat_triangle(s);
        let normal = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        let (u, v) = (rng.range(0.05, 0.9), rng.uniform());
        let v = v * (0.95 - u);
        let p = t[0] + u * (t[1] - t[0]) + v * (t[2] - t[0]);
        let height = 10f64.powf(-4.0 - 2.0 * (k % 4) as f64) * s;
        let x = p + normal * height * if k % 2 == 0 { 1.0 } else { -1.0 };
        let n = loop {
            let n = rng.unit();
            if t.iter().any(|v| n.dot(*v - x) > 0.0) {
                break n;
            }
        };
        let r = big.polygon_reference(x, n, &t, true);
        let tri = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Hessian).unwrap();
        let value = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Value).unwrap();
        assert_eq!(value.value, tri.value, "value depends on the order");
        max3(&mut worst, errors(&tri, &r));
        count += 1;
    }
    println!(
        "1e-4..1e-10 above the interior: n={count} worst error value {:.1e} gradient {:.1e} Hessian {:.1e}",
        worst[0], worst[1], worst[2]
    );
    assert!(
        worst.iter().zip(HARD).all(|(e, t)| *e <= t),
        "errors exceed the hard-regime targets"
    );
}
