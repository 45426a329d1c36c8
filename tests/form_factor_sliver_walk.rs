//! Slivers (issue 18) walked through their thinness and the distance of x: apex heights 1e-3 down
//! to 1e-12 of the length, caps and needles, sizes 1e-3..1e3, x from 1e-4 lengths (where the
//! sliver rule declines and the robust path answers) to 3 lengths away, through
//! `triangle_form_factor` at every order, against the 320-bit astro-float reference of
//! `form_factor_support` at the hard-regime contract (relative 1e-10 value, 1e-9 gradient, 1e-8
//! Hessian, each normalized by its largest entry). Run with `--nocapture` for the worst errors per
//! distance.
//!
//! x within 1e-3 of the sliver's extent from its plane used to go to the edge sum (the sliver
//! rule was not tried "near the plane"), whose errors grew as 1/height: up to 2.8e-6 (value) at
//! 3e-2 lengths and 1.6e-5 at 1e-3 lengths for apex 1e-12 on this walk at 23482ac; the sliver rule
//! now takes those (worst 4e-13).
//!
//! Slivers thinner than ~1e-9 used to be refused as "not planar" (`Plane::new` measured the
//! rounding of a triangle's normal against `PLANARITY_TOLERANCE`); triangles now skip that check,
//! and the walk asserts that none is refused.

mod form_factor_support;

use form_factor_support::*;
use raddiff::{kernels, Order};

/// One walk: for each distance (in lengths) 4 slivers (caps and needles) with apex heights
/// 1e-3..1e-12, at every order. Returns per distance the worst errors, the number of results
/// compared and the number of refusals.
fn walk(seed: u64, distances: &[f64]) -> Vec<(f64, [f64; 3], usize, usize)> {
    let mut big = Big::new();
    let mut rng = Rng(seed);
    let mut out = Vec::new();
    for &distance in distances {
        let (mut worst, mut count, mut refused) = ([0.0f64; 3], 0, 0);
        // apex 1e-6 and thinner: the sliver rule's domain (unless x is too close)
        let mut worst_thin = [0.0f64; 3];
        for rep in 0..4 {
            let s = 10f64.powf(rng.range(-3.0, 3.0));
            let a = rng.vec(s);
            let b = a + rng.unit() * s;
            let ab = (b - a).normalize();
            let perp = ab.any_orthonormal_vector();
            // caps: the apex over the inside of the long edge; needles: over an end
            let along = if rep % 2 == 0 {
                rng.range(0.1, 0.9)
            } else {
                rng.range(-0.02, 0.02)
            };
            let foot = a + (b - a) * along;
            // x beside the long edge at `distance` lengths from its line, in a random direction
            let side = {
                let u = rng.unit();
                (u - ab * u.dot(ab)).normalize()
            };
            let x = a + (b - a) * rng.range(0.0, 1.0) + side * (distance * s);
            for k in 0..10 {
                let height = 10f64.powf(-3.0 - k as f64);
                let t = [a, b, foot + perp * (s * height)];
                // Facing the edge, tilted by up to ~the angle under which x sees the sliver's
                // width (close to it only a thin cone of normals sees all of it).
                let tilt = (0.3 * distance).min(0.3);
                let Some(n) = (0..1000)
                    .map(|_| (-side + rng.unit() * tilt).normalize())
                    .find(|n| t.iter().all(|v| n.dot(*v - x) > 0.0))
                else {
                    continue;
                };
                let r = big.polygon_reference(x, n, &t, true);
                let mut value = None;
                for order in [Order::Value, Order::Gradient, Order::Hessian] {
                    let Ok(d) = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], order) else {
                        refused += 1;
                        continue;
                    };
                    let e = errors(&d, &r);
                    let e = [
                        e[0],
                        if order.gradient() { e[1] } else { 0.0 },
                        if order.hessian() { e[2] } else { 0.0 },
                    ];
                    max3(&mut worst, e);
                    if height <= 1e-6 {
                        max3(&mut worst_thin, e);
                    }
                    let v = *value.get_or_insert(d.value);
                    assert_eq!(v.to_bits(), d.value.to_bits(), "value depends on the order");
                    count += 1;
                }
            }
        }
        println!(
            "slivers, apex 1e-3..1e-12, x {distance:.0e} lengths away: n={count} (refused {refused}) worst error value {:.1e} gradient {:.1e} Hessian {:.1e}",
            worst[0], worst[1], worst[2]
        );
        println!(
            "    of which apex 1e-6..1e-12: worst error value {:.1e} gradient {:.1e} Hessian {:.1e}",
            worst_thin[0], worst_thin[1], worst_thin[2]
        );
        out.push((distance, worst, count, refused));
    }
    out
}

fn within_contract(worst: &[f64; 3]) -> bool {
    worst.iter().zip(HARD).all(|(e, t)| *e <= t)
}

/// From 1e-4 lengths (x near the sliver's plane: the sliver rule, which needs x far from the
/// sliver compared with its width only) to beyond the far-field switch (3 lengths, where the
/// far-field rule takes the thicker slivers).
#[test]
fn sliver_walk_apex_1e3_to_1e12_against_the_reference() {
    let rows = walk(1812, &[1e-4, 1e-3, 1e-2, 3e-2, 0.3, 3.0]);
    let total: usize = rows.iter().map(|r| r.2).sum();
    assert!(total >= 450, "too few configurations ({total})");
    for (distance, worst, _, _) in &rows {
        assert!(
            within_contract(worst),
            "x {distance} lengths away: errors {worst:?} exceed the hard-regime targets"
        );
    }
}

/// Slivers down to apex 1e-12 of their length are evaluated, not refused as "not planar" (a
/// triangle is planar; the check measured the rounding of its normal).
#[test]
fn thin_slivers_are_not_refused() {
    for (distance, _, _, refused) in walk(1814, &[3e-2, 0.3]) {
        assert_eq!(refused, 0, "x {distance} lengths away");
    }
}

/// Continuity where x crosses the near-plane boundary (height 1e-3 of the largest vertex
/// distance): beyond it `triangle_form_factor` takes the sliver rule's direct entry, within it
/// `evaluate` recomputes the height and takes the same rule. On both sides (1e-9 apart in
/// height, found by bisection on the kernel's own measure) the errors against the reference, and their signed difference (the jump of the
/// error across the switch) within 1e-13 of the value and of the largest derivative entries.
#[test]
fn near_plane_boundary_is_continuous_for_slivers() {
    let mut big = Big::new();
    let mut rng = Rng(1815);
    let mut worst_jump = [0.0f64; 3];
    let mut compared = 0;
    for k in 0..12 {
        let s = 10f64.powf(rng.range(-3.0, 3.0));
        let a = rng.vec(s);
        let b = a + rng.unit() * s;
        let ab = (b - a).normalize();
        let perp = ab.any_orthonormal_vector();
        let height = 10f64.powf(-6.0 - 4.0 * rng.uniform());
        let t = [
            a,
            b,
            a + (b - a) * rng.range(0.1, 0.9) + perp * (s * height),
        ];
        // in the plane, beside the sliver, 0.05..1 lengths from its long edge
        let q = a + (b - a) * rng.range(-0.5, 1.5) - perp * (s * 10f64.powf(rng.range(-1.3, 0.0)));
        let side = if k % 2 == 0 { 1.0 } else { -1.0 };
        // The kernel's measure: the rounded plane normal's height of the nearest vertex over the
        // largest vertex distance; bisect the offset along the normal for where it is 1e-3.
        let plane_n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        let ratio = |lambda: f64| {
            let x = q + plane_n * (side * lambda);
            let r = t.map(|v| v - x);
            let nearest = r
                .iter()
                .min_by(|p, q| p.length_squared().total_cmp(&q.length_squared()))
                .copied()
                .unwrap();
            let r_max = r.iter().map(|v| v.length()).fold(0.0, f64::max);
            plane_n.dot(nearest).abs() / r_max
        };
        let (mut lo, mut hi) = (1e-6 * s, 1e2 * s);
        while hi / lo - 1.0 > 1e-9 {
            let mid = (lo * hi).sqrt();
            if ratio(mid) < 1e-3 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        assert!(ratio(lo) < 1e-3 && ratio(hi) >= 1e-3);
        let mut errs = Vec::new();
        for lambda in [lo, hi] {
            let x = q + plane_n * (side * lambda);
            let n = (0..1000)
                .map(|_| (plane_n * -side + rng.unit() * 0.5).normalize())
                .find(|n| t.iter().all(|v| n.dot(*v - x) > 0.0))
                .expect("a normal facing the sliver");
            let r = big.polygon_reference(x, n, &t, true);
            let d = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Hessian).unwrap();
            let e = errors(&d, &r);
            assert!(within_contract(&e), "{k}: {e:?}");
            // signed errors, normalized like `errors`
            let g = r.gradient.abs().max_element();
            let h = r
                .hessian
                .to_cols_array()
                .iter()
                .fold(0.0f64, |m, v| m.max(v.abs()));
            errs.push([
                (d.value - r.value) / r.value.abs(),
                (d.gradient - r.gradient).max_element() / g,
                (d.hessian - r.hessian)
                    .to_cols_array()
                    .iter()
                    .fold(0.0f64, |m, v| m.max(*v))
                    / h,
            ]);
            compared += 1;
        }
        for i in 0..3 {
            worst_jump[i] = worst_jump[i].max((errs[0][i] - errs[1][i]).abs());
        }
    }
    println!(
        "near-plane boundary, slivers apex 1e-6..1e-10: n={compared} jump of the error value {:.1e} gradient {:.1e} Hessian {:.1e}",
        worst_jump[0], worst_jump[1], worst_jump[2]
    );
    assert!(worst_jump.iter().all(|j| *j <= 1e-13), "{worst_jump:?}");
}

/// x over the interior of a thin sliver (apex 1e-5..1e-9), 1e-4..1e-10 lengths above it: the
/// edge sum's terms share a sign there and it keeps the answer (the sliver rule, which would
/// bisect towards x, is not tried up front). Against the reference at the hard contract.
#[test]
fn over_thin_slivers_near_the_plane_against_the_reference() {
    let mut big = Big::new();
    let mut rng = Rng(1816);
    let mut worst = [0.0f64; 3];
    let mut compared = 0;
    for k in 0..16 {
        let s = 10f64.powf(rng.range(-3.0, 3.0));
        let a = rng.vec(s);
        let b = a + rng.unit() * s;
        let ab = (b - a).normalize();
        let perp = ab.any_orthonormal_vector();
        let apex = 10f64.powf(-5.0 - 4.0 * rng.uniform());
        let foot = a + (b - a) * rng.range(0.2, 0.8);
        let t = [a, b, foot + perp * (s * apex)];
        let plane_n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        // a point inside: between the foot of the apex and the apex, away from the long edge
        let inside = foot + perp * (s * apex * rng.range(0.2, 0.6));
        let height = s * 10f64.powf(-4.0 - 6.0 * rng.uniform());
        let side = if k % 2 == 0 { 1.0 } else { -1.0 };
        let x = inside + plane_n * (side * height);
        // tilted by less than the angle under which x sees the sliver's ends over the plane
        let tilt = 0.3 * height / s;
        let Some(n) = (0..1000)
            .map(|_| (plane_n * -side + rng.unit() * tilt).normalize())
            .find(|n| t.iter().all(|v| n.dot(*v - x) > 0.0))
        else {
            continue;
        };
        let r = big.polygon_reference(x, n, &t, true);
        let mut value = None;
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            let Ok(d) = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], order) else {
                continue;
            };
            let e = errors(&d, &r);
            max3(
                &mut worst,
                [
                    e[0],
                    if order.gradient() { e[1] } else { 0.0 },
                    if order.hessian() { e[2] } else { 0.0 },
                ],
            );
            let v = *value.get_or_insert(d.value);
            assert_eq!(v.to_bits(), d.value.to_bits(), "value depends on the order");
            compared += 1;
        }
    }
    println!(
        "over thin slivers, 1e-4..1e-10 lengths above: n={compared} worst error value {:.1e} gradient {:.1e} Hessian {:.1e}",
        worst[0], worst[1], worst[2]
    );
    assert!(compared >= 30, "too few configurations ({compared})");
    assert!(within_contract(&worst), "{worst:?}");
}
