use super::*;

/// The FMA build of the clipped-loop derivatives gives the portable build's bits, on random
/// triangles with `x` 1e-3..1e-12 of their size from the plane, over them and beside them
/// (beside them, the value order's near-plane route runs inside, with its value and loop).
#[cfg(target_arch = "x86_64")]
#[test]
fn clipped_derivatives_fma_twin_keeps_the_bits() {
    if !crate::simd::avx2_fma() {
        return;
    }
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut unit = move || crate::test_rng::lcg(&mut state);
    let bits = |d: &ClippedDerivs| -> Vec<u64> {
        let (tag, d) = match d {
            ClippedDerivs::Done(d) => (0, *d),
            ClippedDerivs::ValueElsewhere(d, route_tried) => (1 + u64::from(*route_tried), *d),
            ClippedDerivs::Declined(v) => {
                return vec![2, v.unwrap_or(f64::NAN).to_bits()];
            }
        };
        let mut out = vec![tag, d.value.to_bits()];
        out.extend(d.gradient.to_array().map(f64::to_bits));
        out.extend(d.hessian.to_cols_array().map(f64::to_bits));
        out
    };
    let mut answered = 0;
    for k in 0..4000 {
        let scale = [1e-3, 1.0, 1e3][k % 3];
        let mut p = || DVec3::new(unit() - 0.5, unit() - 0.5, 0.3 * unit()) * scale;
        let v = [p(), p(), p()];
        let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        let (a, b) = (2.4 * unit() - 0.7, 2.4 * unit() - 0.7);
        let foot = v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b;
        let side = if unit() < 0.5 { 1.0 } else { -1.0 };
        let x = foot + plane_n * (side * scale * 10f64.powf(-3.0 - 9.0 * unit()));
        let tilt = (10.0 + 70.0 * unit()).to_radians();
        let t = plane_n.any_orthonormal_vector();
        let n = (plane_n * side * tilt.cos() + t * tilt.sin()).normalize();
        for order in [Order::Gradient, Order::Hessian] {
            let portable = clipped_derivs_with(x, n, v, order, false);
            // SAFETY: checked above that the CPU has AVX2 and FMA.
            let fused = unsafe { clipped_derivs_fma(x, n, v, order) };
            assert_eq!(
                portable.as_ref().map(bits),
                fused.as_ref().map(bits),
                "at {x:?} {n:?} {v:?} {order:?}"
            );
            answered += usize::from(matches!(
                portable,
                Some(ClippedDerivs::Done(_) | ClippedDerivs::ValueElsewhere(..))
            ));
        }
    }
    assert!(answered > 500, "only {answered} answered");
}
