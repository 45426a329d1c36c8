use super::*;
use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::quadrature::lanes::{rule_piece_sums, PortableSums};
use crate::kernels::form_factor::quadrature::rules::{
    gauss_legendre_3, gauss_legendre_4, gauss_legendre_5, gauss_legendre_6, gauss_legendre_8,
};
use crate::kernels::form_factor::quadrature::rules::{Rule, FAR_FIELD_RULES};
use crate::kernels::form_factor::quadrature::tensor::{fan_geometry, rule_on};
use crate::test_rng::lcg;

/// A random visible loop for the subdivided quadrature: a triangle or a convex quad of size
/// 1e-2..1e2 (some of them slivers), `x` 1.05-3 sizes from its centre and 1e-8..1 sizes
/// from its plane, so that the bisection takes from one piece to hundreds.
fn quadrature_loop(state: &mut u64) -> (Vec<ClipVertex>, DVec3) {
    let mut c = || lcg(state);
    let scale = 10f64.powf(4.0 * c() - 2.0);
    let m = 3 + usize::from(c() < 0.5);
    let thin = if c() < 0.2 { 1e-3 } else { 1.0 };
    let offset = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * 10.0 * scale;
    let verts: Vec<DVec3> = (0..m)
        .map(|k| {
            let a = (k as f64 + 0.3 * c()) / m as f64 * std::f64::consts::TAU;
            DVec3::new(a.cos(), thin * a.sin(), 0.0) * scale + offset
        })
        .collect();
    let a = c() * std::f64::consts::TAU;
    let d = 1.05 + 2.0 * c();
    let h = 10f64.powf(-8.0 * c()) * if c() < 0.5 { 1.0 } else { -1.0 };
    let x = offset + DVec3::new(d * a.cos(), d * a.sin(), h) * scale;
    let n = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize();
    let loop_ = verts
        .iter()
        .map(|&u| ClipVertex {
            u,
            r: u - x,
            r_lo: DVec3::ZERO,
            on_line: false,
        })
        .collect();
    (loop_, n)
}

fn deriv_bits(d: &Deriv3) -> Vec<u64> {
    let mut b = vec![d.value.to_bits()];
    b.extend(d.gradient.to_array().map(f64::to_bits));
    b.extend(d.hessian.to_cols_array().map(f64::to_bits));
    b
}

/// The subdivided quadrature's AVX2+FMA build gives the portable build's bits at every
/// order, and the gradient's bits do not depend on the order (nor the value's).
#[cfg(target_arch = "x86_64")]
#[test]
fn subdivided_quadrature_fma_twin_keeps_the_bits() {
    if !crate::simd::avx2_fma() {
        return;
    }
    let mut state = 1866;
    let mut answered = 0;
    for k in 0..400 {
        let (verts, n) = quadrature_loop(&mut state);
        let exact = k % 2 == 0;
        let mut by_order = Vec::new();
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            let portable =
                subdivided_quadrature_with::<PortableSums>(&verts, n, order, exact, MAX_PIECES);
            // SAFETY: checked above that the CPU has AVX2 and FMA.
            let fused = unsafe { subdivided_quadrature_fma(&verts, n, order, exact, MAX_PIECES) };
            assert_eq!(
                portable.as_ref().map(deriv_bits),
                fused.as_ref().map(deriv_bits),
                "{k} {order:?}"
            );
            answered += usize::from(portable.is_some());
            by_order.push(portable);
        }
        if let [Some(v), Some(g), Some(h)] = &by_order[..] {
            assert_eq!(v.value.to_bits(), h.value.to_bits(), "{k}");
            assert_eq!(g.value.to_bits(), h.value.to_bits(), "{k}");
            assert_eq!(g.gradient, h.gradient, "{k}");
        }
    }
    // 819 of 1200 when written: the closest loops take more than `MAX_PIECES`.
    assert!(answered > 700, "{answered}");
}

/// The pieces' sums four nodes at a time agree with the scalar rule (`triangle_rule`, one
/// node at a time) to rounding, for every far-field rule and order, on pieces 16 to 1e4
/// radii away.
#[test]
fn lane_piece_sums_agree_with_the_scalar_rule() {
    let mut state = 1867;
    let mut worst = 0.0f64;
    for k in 0..600 {
        let mut c = || lcg(&mut state);
        let p = |c: &mut dyn FnMut() -> f64| DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5);
        let centre = p(&mut c).normalize() * 10f64.powf(1.2 + 3.0 * c());
        let t: Vec<ClipVertex> = (0..3)
            .map(|_| {
                let u = centre + p(&mut c);
                ClipVertex {
                    u,
                    r: u,
                    r_lo: DVec3::ZERO,
                    on_line: false,
                }
            })
            .collect();
        let n = p(&mut c).normalize();
        let geometry = fan_geometry(&t[0], &t[1], &t[2], false);
        let (_, points) = FAR_FIELD_RULES[k % FAR_FIELD_RULES.len()];
        let rule = Rule(match points {
            3 => gauss_legendre_3(),
            4 => gauss_legendre_4(),
            5 => gauss_legendre_5(),
            6 => gauss_legendre_6(),
            _ => gauss_legendre_8(),
        });
        let n_lanes = crate::kernels::numeric::lanes::V3::splat(n);
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            let want = rule_on(&t[0], &t[1], &t[2], n, order, geometry, rule);
            let sums = match order {
                Order::Value => rule_piece_sums::<PortableSums, false, false>(
                    &t[0], &t[1], &t[2], &n_lanes, rule,
                ),
                Order::Gradient => rule_piece_sums::<PortableSums, true, false>(
                    &t[0], &t[1], &t[2], &n_lanes, rule,
                ),
                Order::Hessian => {
                    rule_piece_sums::<PortableSums, true, true>(&t[0], &t[1], &t[2], &n_lanes, rule)
                }
            };
            let got = sums.assemble(n, geometry, order);
            let rel = |a: f64, b: f64, scale: f64| (a - b).abs() / scale;
            worst = worst.max(rel(got.value, want.value, want.value.abs()));
            if order.gradient() {
                let g = want.gradient.abs().max_element();
                worst = worst.max(rel(got.gradient.x, want.gradient.x, g));
                worst = worst.max(rel(got.gradient.y, want.gradient.y, g));
                worst = worst.max(rel(got.gradient.z, want.gradient.z, g));
            }
            if order.hessian() {
                let (a, b) = (got.hessian.to_cols_array(), want.hessian.to_cols_array());
                let h = b.iter().fold(0.0f64, |m, e| m.max(e.abs()));
                for (x, y) in a.iter().zip(&b) {
                    worst = worst.max(rel(*x, *y, h));
                }
            }
        }
    }
    assert!(worst < 1e-13, "{worst:e}");
}
