use super::*;
use crate::kernels::form_factor::clip::{clip, TriangleLoop};
use crate::kernels::form_factor::plane::triangle_plane;
use crate::kernels::form_factor::quadrature::lanes::PortableSums;
use crate::test_rng::lcg;

/// The AVX2+FMA builds of the clipped entry and of the visible part's rule give the portable
/// builds' bits, on slivers (apex 1e-5..1e-12 of the length, sizes 1e-3..1e3) cut by random
/// tangent planes through x 1e-3..10 lengths away, at every order (and answer for most).
#[cfg(target_arch = "x86_64")]
#[test]
fn fma_twins_keep_the_bits() {
    if !crate::simd::avx2_fma() {
        return;
    }
    let bits = |d: &Deriv3| {
        let mut b = vec![d.value.to_bits()];
        b.extend(d.gradient.to_array().map(f64::to_bits));
        b.extend(d.hessian.to_cols_array().map(f64::to_bits));
        b
    };
    let mut state = 1828;
    let (mut answered, mut cut) = (0, 0);
    for _ in 0..3000 {
        let mut c = || lcg(&mut state);
        let scale = 10f64.powf(6.0 * c() - 3.0);
        let a = DVec3::new(c(), c(), c()) * scale;
        let b = a + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize() * scale;
        let perp = (b - a).any_orthonormal_vector();
        let apex = a + (b - a) * (1.2 * c() - 0.1) + perp * (10f64.powf(-5.0 - 7.0 * c()) * scale);
        let x = (a + b) * 0.5
            + DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * (scale * 10f64.powf(4.0 * c() - 3.0));
        let n = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize();
        let v = [a, b, apex];
        let r = v.map(|vk| vk - x);
        let u = [DVec3::ZERO, b - a, apex - a];
        let err = |p: f64, q: f64| crate::kernels::numeric::dd::two_sum(p, -q).1;
        let r_lo = v.map(|vk| DVec3::new(err(vk.x, x.x), err(vk.y, x.y), err(vk.z, x.z)));
        let Some(plane) = triangle_plane(&u) else {
            continue;
        };
        let mut clipped = TriangleLoop::new();
        if !clip(&u, &r, &r_lo, n, &mut clipped) || clipped.len < 3 {
            continue;
        }
        cut += 1;
        let h_p = plane.normal.dot(r[0]);
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            let loop_ = clipped.as_slice();
            let portable = clipped_sliver_quadrature_with::<PortableSums>(loop_, n, order);
            // SAFETY: checked above that the CPU has AVX2 and FMA.
            let fused = unsafe { clipped_sliver_quadrature_fma(loop_, n, order) };
            assert_eq!(
                portable.as_ref().map(|(d, _)| bits(d)),
                fused.as_ref().map(|(d, _)| bits(d))
            );
            let portable =
                clipped_sliver_with::<PortableSums>(&u, &r, &r_lo, n, order, &plane, h_p);
            // SAFETY: as above.
            let fused = unsafe { clipped_sliver_fma(&u, &r, &r_lo, n, order, &plane, h_p) };
            assert_eq!(portable.as_ref().map(bits), fused.as_ref().map(bits));
            answered += usize::from(portable.is_some());
        }
    }
    assert!(cut > 1000 && answered > 2000, "{cut} {answered}");
}
