use super::*;
use crate::kernels::form_factor::quadrature::tensor::{tensor_nodes, tensor_rule};
use crate::kernels::form_factor::sliver::rule::rules;
use crate::test_rng::lcg;
use crate::{Deriv3, Order};

fn paired_sums(
    piece: &PieceFrame,
    n: DVec3,
    order: Order,
    geometry: (DVec3, f64),
    along: (f64, f64, &[[[f64; 4]; 2]]),
    t_rule: &[(f64, f64)],
) -> Deriv3 {
    let mut sums = PortableSums::new();
    let n2 = V3::splat(n);
    match order {
        Order::Value => sums.add::<false, false>(piece, &n2, along, t_rule),
        Order::Gradient => sums.add::<true, false>(piece, &n2, along, t_rule),
        Order::Hessian => sums.add::<true, true>(piece, &n2, along, t_rule),
    }
    sums.total().assemble(n, geometry, order)
}

/// The grouped sums agree with the scalar tensor rule (`quadrature::tensor::tensor_rule`, one node
/// at a time, the piece's share on its geometry instead of its weights) to rounding, for every rule
/// along (padded with zero weights to a multiple of four) and across, on sub-intervals, at every
/// order; and the value is the same, bit for bit, at every order.
#[test]
fn paired_sums_match_the_scalar_tensor_rule() {
    let mut state = 1819;
    let mut compared = 0;
    for k in 0..600 {
        let mut c = || lcg(&mut state);
        let r_p = DVec3::new(c() - 0.5, c() - 0.5, c() + 0.2);
        let ab = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5);
        let bc = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * 10f64.powf(-6.0 * c());
        let n = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize();
        let part = c();
        let geometry = (ab.cross(bc), ab.cross(bc).dot(r_p));
        let scaled = (geometry.0 * part, geometry.1 * part);
        let (s0, s1) = if k % 3 == 0 {
            (0.0, 1.0)
        } else {
            let (p, q) = (c(), c());
            (p.min(q), p.max(q))
        };
        let s_rule = rules().by_points[8 + k % 9];
        let s_paired = rules().quads[8 + k % 9];
        let t_rule = rules().by_points[[2, 3, 4, 8][k % 4]];
        let frame = PieceFrame { r_p, ab, bc, part };
        let nodes = tensor_nodes((s0, s1, s_rule), t_rule);
        let mut value = None;
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            let d = paired_sums(&frame, n, order, geometry, (s0, s1, s_paired), t_rule);
            let r = tensor_rule(r_p, ab, bc, n, order, scaled, &nodes);
            let max = |m: glam::DMat3| {
                m.to_cols_array()
                    .iter()
                    .fold(0.0, |a: f64, v| a.max(v.abs()))
            };
            assert!(
                (d.value - r.value).abs() <= 1e-14 * r.value.abs(),
                "{k} {order:?}: {} {}",
                d.value,
                r.value
            );
            let g = r.gradient.abs().max_element();
            assert!((d.gradient - r.gradient).abs().max_element() <= 1e-14 * g);
            assert!(max(d.hessian - r.hessian) <= 1e-14 * max(r.hessian));
            let v = *value.get_or_insert(d.value);
            assert_eq!(v.to_bits(), d.value.to_bits(), "{k} {order:?}");
            compared += 1;
        }
    }
    assert_eq!(compared, 1800);
}
