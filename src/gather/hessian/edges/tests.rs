use super::*;
use crate::kernels::form_factor::edge::EdgeFrame;

/// A small deterministic generator (xorshift) for test inputs.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn vec(&mut self, s: f64) -> DVec3 {
        DVec3::new(self.next() - 0.5, self.next() - 0.5, self.next() - 0.5) * (2.0 * s)
    }
}

fn available_isas() -> Vec<Isa> {
    #[allow(unused_mut)]
    let mut isas = vec![Isa::Portable];
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx2") && has!("fma") {
            isas.push(Isa::Avx2);
            #[cfg(raddiff_avx512)]
            if has!("avx512f") && has!("avx512vl") && has!("avx512dq") {
                isas.push(Isa::Avx512);
            }
        }
    }
    isas
}

/// Pad lanes are evaluated in closed form with finite outputs in both batch kinds and every
/// compiled version, so nothing depends on the finiteness check to drop them.
#[test]
fn pad_lanes_are_finite_closed_form_lanes() {
    let n = DVec3::new(0.3, -0.2, 0.9).normalize();
    for isa in available_isas() {
        let (w, mut s) = ([[0.0; BATCH]; 1], vec![[[0.0; LANES]; OUTPUTS]; 1]);
        let mut main = Batch::new();
        main.pad(0, false);
        run_batch_on::<false>(isa, &mut main, n, true, &w, &mut s);
        let mut axial = Batch::new();
        axial.pad(0, true);
        run_batch_on::<true>(isa, &mut axial, n, true, &w, &mut s);
        for b in [&main, &axial] {
            assert!(b.general.iter().all(|&f| f == CLOSED_FORM), "{isa:?}");
            assert!(b.out.iter().flatten().all(|v| v.is_finite()), "{isa:?}");
        }
        assert!(s.iter().flatten().flatten().all(|&v| v == 0.0));
    }
}

/// Every lane against `hessian::edge_term` (the general kernel from the nearer end), in both
/// compiled versions this CPU runs, for both regimes' batches.
#[test]
fn batch_lanes_match_the_general_kernel() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let n = DVec3::new(0.3, -0.2, 0.9).normalize();
    let mut seen = [0usize; 3];
    for order in [Order::Gradient, Order::Hessian] {
        for round in 0..40 {
            let mut b = Batch::new();
            let mut ends = Vec::new();
            for i in 0..BATCH {
                let scale = 10f64.powi((round % 7) - 3);
                let a = rng.vec(scale);
                let c = match i % 5 {
                    // far along nearly the same direction: the axial regime
                    0 => a * (1.0 + 1e3 * rng.next()) + rng.vec(scale * 0.05),
                    // short edges (1e-7..1e-5 of their distance) in the axial regime, where
                    // the difference of the two tails cancelled by distance/length
                    4 => {
                        let len = 10f64.powf(-7.0 + 2.0 * rng.next());
                        a * (1.0 + len) + rng.vec(scale * len * 0.05)
                    }
                    1 => rng.vec(scale * 1e3),
                    _ => rng.vec(scale),
                };
                b.set(i, a, c, a.length_squared(), c.length_squared());
                ends.push((a, c));
            }
            let (w, mut s) = ([[0.0; BATCH]; 1], vec![[[0.0; LANES]; OUTPUTS]; 1]);
            // Every compiled version this CPU runs, for both batch kinds.
            let mut main = Vec::new();
            let mut axial = Vec::new();
            for isa in available_isas() {
                let mut m = b.clone();
                run_batch_on::<false>(isa, &mut m, n, order.hessian(), &w, &mut s);
                let mut x = b.clone();
                run_batch_on::<true>(isa, &mut x, n, order.hessian(), &w, &mut s);
                main.push(m);
                axial.push(x);
            }
            for (i, &(a, c)) in ends.iter().enumerate() {
                let flag = main[0].general[i];
                assert!(main.iter().all(|m| m.general[i] == flag));
                seen[flag as usize] += 1;
                let want = super::super::gather_mesh::edge_term(n, a, c, order).unwrap();
                let lanes: Vec<&Batch> = if flag == CLOSED_FORM {
                    main.iter().map(|m| &**m).collect()
                } else if flag == AXIAL {
                    assert!(axial.iter().all(|x| x.general[i] == CLOSED_FORM));
                    axial.iter().map(|x| &**x).collect()
                } else {
                    vec![]
                };
                // Tolerances relative to the sizes of the terms each output sums (n·w,
                // for one, cancels when the edge is seen edge-on from n), and to ε/sin of the
                // angle between r and the edge (near its line the rounded r × e loses digits
                // in both evaluations).
                let (r, e) = if a.length_squared() <= c.length_squared() {
                    (a, c - a)
                } else {
                    (c, a - c)
                };
                let frame = EdgeFrame::new(r, e).unwrap();
                let m = frame.moments(Order::Hessian).unwrap();
                let (h, p) = (frame.h, frame.p.length());
                let g = p * m.a2 + m.b2;
                let scale_value = INV_2PI * h * m.a1;
                let scale_gradient = INV_2PI * (m.a1 + 2.0 * h * g);
                let scale_hessian = INV_2PI
                    * (4.0 * g + h * (2.0 * m.a2 + 8.0 * (m.a3 * p * p + 2.0 * m.b3 * p + m.c3)));
                let sin = r.cross(e).length() / (r.length() * e.length());
                let tol = 1e-13f64.max(1e-15 / sin);
                for lane in lanes {
                    let mut got = Deriv3::constant(0.0);
                    add_lane(&mut got, lane, i, order);
                    let k = INV_2PI;
                    let dv = (got.value * k - want.value).abs();
                    assert!(dv <= tol * scale_value, "{i} value {got:?} {want:?}");
                    let dg = (got.gradient * k - want.gradient).abs().max_element();
                    assert!(dg <= tol * scale_gradient, "{i} gradient {got:?} {want:?}");
                    if order.hessian() {
                        let dh = (got.hessian * k - want.hessian).abs().to_cols_array();
                        let dh = dh.iter().fold(0.0f64, |m, v| m.max(*v));
                        assert!(dh <= tol * scale_hessian, "{i} hessian {got:?} {want:?}");
                    }
                }
            }
        }
    }
    // Both regimes were exercised.
    assert!(seen[0] > 1000 && seen[1] > 100, "{seen:?}");
}
