use super::*;
use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::quadrature::lanes::PortableSums;
use crate::kernels::form_factor::quadrature::subdivide::subdivided_quadrature;
use crate::kernels::form_factor::quadrature::tensor::fan_geometry;
use crate::kernels::form_factor::robust::evaluate;
use crate::kernels::form_factor::scaled::{Points, Scaled};
use crate::kernels::form_factor::sliver::direct::direct_sliver;
use crate::kernels::form_factor::sliver::geometry::sliver_geometry;
use crate::test_rng::lcg;

fn vertex(v: DVec3, x: DVec3) -> ClipVertex {
    ClipVertex {
        u: v,
        r: v - x,
        r_lo: DVec3::ZERO,
        on_line: false,
    }
}

/// The table holds every rule used, and each rule along integrates the polynomials it should
/// (degree ≤ 2m − 1) on [0, 1].
#[test]
fn rules_along_integrate_their_polynomials() {
    for &(_, m) in &ACROSS {
        assert_eq!(rules().by_points[m].len(), m);
    }
    for &(_, m) in &ALONG {
        let r = rules().by_points[m];
        assert_eq!(r.len(), m);
        for degree in 0..2 * m as i32 {
            let q: f64 = r.iter().map(|&(s, w)| w * s.powi(degree)).sum();
            let exact = 1.0 / (degree + 1) as f64;
            // powi rounds once per factor, and a node's rounding moves s^d by d ulps
            let tolerance = 1e-15 * (degree + 1) as f64 * exact;
            assert!(
                (q - exact).abs() <= tolerance,
                "{m} points, degree {degree}: {q}"
            );
        }
    }
}

/// The Bernstein-ellipse parameter of the point `z = re + i·im` for the interval [−1, 1]: the
/// sum of the semi-axes of the ellipse with foci ±1 through `z`.
fn bernstein(re: f64, im: f64) -> f64 {
    let (im2, lo, hi) = (im * im, re - 1.0, re + 1.0);
    let a = 0.5 * ((lo * lo + im2).sqrt() + (hi * hi + im2).sqrt());
    a + (a * a - 1.0).max(0.0).sqrt()
}

/// The `ρ` of a piece's whole length.
fn rho_whole(piece: &ThinPiece) -> f64 {
    bernstein((piece.s_foot - 0.5) / 0.5, piece.pole_over_length / 0.5)
}

/// The ellipse tests choose the rules that the Bernstein parameter `ρ` (from its square
/// roots) chooses, along and across, for poles on both sides of every threshold: each random
/// point is classified by both wherever its `ρ` is not within 1e-12 of a threshold.
#[test]
fn ellipse_tests_choose_the_rules_of_the_bernstein_parameter() {
    let mut state = 1821;
    let mut compared = 0;
    for _ in 0..20_000 {
        let mut c = || lcg(&mut state);
        let re = 10f64.powf(2.0 * c() - 1.0) * if c() < 0.5 { -1.0 } else { 1.0 };
        let im = 10f64.powf(2.0 * c() - 1.0);
        let rho = bernstein(re, im);
        let near = |r: f64| (rho / r - 1.0).abs() < 1e-12;
        if ALONG.iter().any(|&(r, _)| near(r)) {
            continue;
        }
        let expected = ALONG.iter().find(|(r, _)| rho >= *r).map(|r| r.1);
        let (re2, im2) = (re * re, im * im);
        let chosen = rules()
            .along
            .iter()
            .find(|&&(ia2, ib2, _)| re2 * ia2 + im2 * ib2 >= 1.0)
            .map(|r| r.2);
        assert_eq!(chosen, expected, "{re} {im}");
        // Across: x beside the segment, at `im` half-widths.
        let im = 10f64.powf(6.0 * c());
        let rho = bernstein(0.0, im);
        if ACROSS.iter().any(|&(r, _)| (rho / r - 1.0).abs() < 1e-12) {
            continue;
        }
        let expected = ACROSS.iter().find(|(r, _)| rho >= *r).map(|r| r.1);
        let chosen = rules().across.iter().find(|&&(b, _)| im >= b).map(|r| r.1);
        assert_eq!(chosen, expected, "{im}");
        compared += 1;
    }
    assert!(compared > 19_000, "{compared}");
}

/// Continuity at every switch along: x below a cap at the distance where the first piece's
/// `ρ` crosses each threshold, on both sides (1e-9 apart), against the isotropic subdivision
/// (an independent rule) and against each other (the jump of the error).
#[test]
fn switches_along_are_continuous() {
    let n = DVec3::new(0.1, -0.2, 1.0).normalize();
    let tri = [DVec3::ZERO, DVec3::X, DVec3::new(0.5, 1e-6, 0.0)];
    let at = |depth: f64| {
        let x = DVec3::new(0.4, 0.3 * depth, -depth);
        tri.map(|v| vertex(v, x))
    };
    let first_piece = |t: &[ClipVertex; 3]| {
        let ab = t[1].u - t[0].u;
        let share = (t[2].u - t[0].u).dot(ab) / ab.length_squared();
        let f = ClipVertex {
            u: t[0].u + share * ab,
            r: t[0].r + share * (t[1].r - t[0].r),
            r_lo: DVec3::ZERO,
            on_line: false,
        };
        ThinPiece::new(&t[0], &f, &t[2], rules()).unwrap()
    };
    let mut seen = 0;
    for &(threshold, points) in &ALONG {
        // ρ grows with the depth of x: bisect for the depth where it meets the threshold.
        let (mut lo, mut hi) = (1e-3f64, 1e3f64);
        for _ in 0..200 {
            let mid = (lo * hi).sqrt();
            if rho_whole(&first_piece(&at(mid))) < threshold {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let mut errors = Vec::new();
        for depth in [hi * (1.0 - 1e-9), hi * (1.0 + 1e-9)] {
            let t = at(depth);
            let piece = first_piece(&t);
            let chosen = ALONG
                .iter()
                .find(|(r, _)| rho_whole(&piece) >= *r)
                .map(|r| r.1);
            errors.push(chosen);
            let d = sliver_quadrature(&t, n, Order::Hessian).unwrap();
            let r = subdivided_quadrature(&t, n, Order::Hessian, true, 100_000).unwrap();
            let max = |m: glam::DMat3| {
                m.to_cols_array()
                    .iter()
                    .fold(0.0, |a: f64, v| a.max(v.abs()))
            };
            let e = [
                (d.value - r.value) / r.value.abs(),
                ((d.gradient - r.gradient).abs().max_element()) / r.gradient.abs().max_element(),
                max(d.hessian - r.hessian) / max(r.hessian),
            ];
            assert!(
                e[0].abs() <= 2e-14 && e[1] <= 2e-14 && e[2] <= 1e-13,
                "{points} points at ρ = {threshold}: {e:?}"
            );
        }
        // the switch happens there: the finer rule below, this one above
        let below = errors[0].unwrap_or(usize::MAX);
        assert!(below > points && errors[1] == Some(points), "{errors:?}");
        seen += 1;
    }
    assert_eq!(seen, ALONG.len());
}

/// The sliver's geometry agrees with the double-double fan geometry (an independent
/// evaluation from the same exact differences) to a few ulps of `‖N‖` and of `N·r_a`, for
/// apex 1e-4..1e-12 of the length and x 1e-6..1e2 lengths from the plane.
#[test]
fn sliver_geometry_matches_the_double_double_fan_geometry() {
    let mut state = 1817;
    for _ in 0..2000 {
        let mut c = || lcg(&mut state);
        let scale = 10f64.powf(6.0 * c() - 3.0);
        let a = DVec3::new(c(), c(), c()) * scale;
        let b = a + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize() * scale;
        let perp = (b - a).any_orthonormal_vector();
        let apex = a + (b - a) * c() + perp * (scale * 10f64.powf(-4.0 - 8.0 * c()));
        let normal = (b - a).cross(perp).normalize();
        let x = (a + b) * 0.5
            + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * scale
            + normal * (scale * 10f64.powf(-6.0 + 8.0 * c()));
        let exact = |v: DVec3| {
            let r = v - x;
            let err = |p: f64, q: f64| crate::kernels::numeric::dd::two_sum(p, -q).1;
            ClipVertex {
                u: v - a,
                r,
                r_lo: DVec3::new(err(v.x, x.x), err(v.y, x.y), err(v.z, x.z)),
                on_line: false,
            }
        };
        let t = [exact(a), exact(b), exact(apex)];
        let (n1, c1) = sliver_geometry(&t[0], &t[1], &t[2]);
        let (n2, c2) = fan_geometry(&t[0], &t[1], &t[2], true);
        assert!(
            (n1 - n2).length() <= 4.0 * f64::EPSILON * n2.length(),
            "{n1} {n2}"
        );
        assert!(
            (c1 - c2).abs() <= 8.0 * f64::EPSILON * c2.abs(),
            "{c1} {c2}"
        );
    }
}

/// A sliver of length `scale` (1e-3..1e3) with its apex 1e-5..1e-12 of the length off the
/// long edge, from `c`'s uniform draws: `(scale, [a, b, apex])`.
fn random_sliver(c: &mut impl FnMut() -> f64) -> (f64, [DVec3; 3]) {
    let scale = 10f64.powf(6.0 * c() - 3.0);
    let a = DVec3::new(c(), c(), c()) * scale;
    let b = a + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize() * scale;
    let perp = (b - a).any_orthonormal_vector();
    let height = 10f64.powf(-5.0 - 7.0 * c());
    let apex = a + (b - a) * (1.2 * c() - 0.1) + perp * (height * scale);
    (scale, [a, b, apex])
}

/// The direct entry gives `evaluate`'s bits whenever it answers, and answers for slivers seen
/// from afar, clipped or not: slivers with apex 1e-5..1e-12 of their length, x from 1e-7 (where
/// the rule declines) to 10 lengths away, receiver normals that clip the sliver or graze a
/// vertex.
#[test]
fn direct_entry_gives_the_bits_of_evaluate() {
    let mut state = 1818;
    let (mut taken, mut declined, mut clipped_taken) = (0, 0, 0);
    for k in 0..4000 {
        let mut c = || lcg(&mut state);
        let (scale, [a, b, apex]) = random_sliver(&mut c);
        let v = [a, b, apex];
        // Mostly 1e-3..10 lengths away, sometimes closer. Within ~1e-2 lengths x is usually
        // within 1e-3·r_max of the plane, which the robust path handles (declined here).
        let exponent = if k % 5 == 0 {
            -7.0 + 4.0 * c()
        } else {
            -3.0 + 4.0 * c()
        };
        let distance = 10f64.powf(exponent) * scale;
        let x = (a + b) * 0.5 + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * distance;
        let mut random_unit = || DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize();
        let n = match k % 4 {
            // every vertex above the tangent plane (if one of 100 tries finds such a normal)
            0 | 1 => (0..100)
                .map(|_| random_unit())
                .find(|n| v.iter().all(|vk| n.dot(*vk - x) > 0.0))
                .unwrap_or(DVec3::Z),
            2 => random_unit(),
            // grazing: the tangent plane through a vertex (up to rounding)
            _ => (a - x).any_orthonormal_vector(),
        };
        let r = v.map(|vk| vk - x);
        let u = [DVec3::ZERO, v[1] - v[0], v[2] - v[0]];
        let err = |p: f64, q: f64| crate::kernels::numeric::dd::two_sum(p, -q).1;
        let r_lo = v.map(|vk| DVec3::new(err(vk.x, x.x), err(vk.y, x.y), err(vk.z, x.z)));
        let scaled = Scaled {
            u: Points::from_slice(&u),
            r: Points::from_slice(&r),
            r_lo: Points::from_slice(&r_lo),
            inv_scale: 1.0,
        };
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            let Some(direct) = direct_sliver(&u, &r, &r_lo, n, order) else {
                declined += 1;
                continue;
            };
            taken += 1;
            clipped_taken += usize::from(r.iter().any(|rk| n.dot(*rk) <= 0.0));
            let robust = evaluate(&scaled, n, order).unwrap();
            let bits = |d: &Deriv3| {
                let mut b = vec![d.value.to_bits()];
                b.extend(d.gradient.to_array().map(f64::to_bits));
                b.extend(d.hessian.to_cols_array().map(f64::to_bits));
                b
            };
            assert_eq!(bits(&direct), bits(&robust), "{k} {order:?}");
        }
    }
    assert!(
        taken > 2000 && declined > 1000 && clipped_taken > 1000,
        "{taken} {declined} {clipped_taken}"
    );
}

/// The AVX2+FMA build of the rule gives the portable build's bits, on slivers with apex
/// 1e-5..1e-12 of their length, sizes 1e-3..1e3 and x 1e-3..10 lengths away, at every order
/// (and answers for most of them).
#[cfg(target_arch = "x86_64")]
#[test]
fn fma_twin_keeps_the_bits() {
    if !crate::simd::avx2_fma() {
        return;
    }
    let mut state = 1820;
    let mut answered = 0;
    // The rules along chosen for the whole of the first piece: every one is exercised.
    let mut used = [false; 25];
    for _ in 0..3000 {
        let mut c = || lcg(&mut state);
        let (scale, [a, b, apex]) = random_sliver(&mut c);
        let x = (a + b) * 0.5
            + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * (scale * 10f64.powf(4.0 * c() - 3.0));
        let n = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize();
        let t = [a, b, apex].map(|v| vertex(v, x));
        let ab = t[1].u - t[0].u;
        let share = ((t[2].u - t[0].u).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
        let f = ClipVertex {
            u: t[0].u + share * ab,
            r: t[0].r + share * (t[1].r - t[0].r),
            r_lo: DVec3::ZERO,
            on_line: false,
        };
        if let Some(points) =
            ThinPiece::new(&t[0], &f, &t[2], rules()).and_then(|p| p.along_points(0.0, 1.0))
        {
            used[points] = true;
        }
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            let portable = sliver_quadrature_with::<PortableSums>(&t, n, order);
            // SAFETY: checked above that the CPU has AVX2 and FMA.
            let fused = unsafe { sliver_quadrature_fma(&t, n, order) };
            let bits = |d: &Deriv3| {
                let mut b = vec![d.value.to_bits()];
                b.extend(d.gradient.to_array().map(f64::to_bits));
                b.extend(d.hessian.to_cols_array().map(f64::to_bits));
                b
            };
            assert_eq!(portable.as_ref().map(bits), fused.as_ref().map(bits));
            answered += usize::from(portable.is_some());
        }
    }
    assert!(answered > 6000, "{answered}");
    for &(_, points) in &ALONG {
        assert!(used[points], "{points} points along never chosen");
    }
}

/// Each threshold along keeps the module's bound `(64/15) (1 − σ/ρ)^{-4} σ^{-2m}` (Hessian
/// poles, `σ = ρ·2m/(2m + 4)`) under 1e-15 (1.52e-15 at 16 points), and is within 3%
/// of the smallest `ρ` that does: the table is the bound's, not a guess.
#[test]
fn thresholds_along_keep_the_error_bound() {
    let bound = |rho: f64, m: usize| {
        let m2 = 2.0 * m as f64;
        let sigma = rho * m2 / (m2 + 4.0);
        64.0 / 15.0 * (1.0 - sigma / rho).powi(-4) * sigma.powf(-m2)
    };
    for &(rho, m) in &ALONG {
        let limit = if m == 16 { 1.52e-15 } else { 1e-15 };
        assert!(
            bound(rho, m) <= limit,
            "{m} points at {rho}: {:e}",
            bound(rho, m)
        );
        assert!(
            bound(rho / 1.03, m) > 1e-15,
            "{m} points: {rho} is far from the bound"
        );
    }
}

/// The sliver rule is taken for a cap and a needle seen from afar, agrees with the isotropic
/// subdivision (an independent rule) to 1e-12, and declines when x is within a width of it.
#[test]
fn sliver_rule_agrees_with_the_subdivision_and_declines_near_x() {
    let n = DVec3::new(0.1, -0.2, 1.0).normalize();
    let x = DVec3::new(0.4, 0.1, -0.7);
    for apex in [DVec3::new(0.5, 1e-6, 0.0), DVec3::new(1.0, 1e-6, 0.0)] {
        let t = [DVec3::ZERO, DVec3::X, apex].map(|v| vertex(v, x));
        let d = sliver_quadrature(&t, n, Order::Hessian).expect("sliver rule declined");
        let r = subdivided_quadrature(&t, n, Order::Hessian, true, 100_000).unwrap();
        assert!(
            (d.value - r.value).abs() <= 1e-12 * r.value.abs(),
            "{d:?} {r:?}"
        );
        let g = r.gradient.abs().max_element();
        assert!((d.gradient - r.gradient).abs().max_element() <= 1e-12 * g);
        let max = |m: glam::DMat3| {
            m.to_cols_array()
                .iter()
                .fold(0.0, |a: f64, v| a.max(v.abs()))
        };
        assert!(max(d.hessian - r.hessian) <= 1e-11 * max(r.hessian));
    }
    // x 1e-7 above the cap's middle: the width is not small against the distance
    let near = DVec3::new(0.5, 5e-7, -1e-7);
    let t = [DVec3::ZERO, DVec3::X, DVec3::new(0.5, 1e-6, 0.0)].map(|v| vertex(v, near));
    assert!(sliver_quadrature(&t, n, Order::Value).is_none());
}
