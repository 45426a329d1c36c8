use super::super::solid_angle_lanes::tests::isas;
use super::*;
use crate::test_rng::Lcg;
use crate::Order;

#[test]
fn accepted_lanes_are_the_single_call_bit_for_bit_on_every_isa() {
    // Triangles of size 0.1 .. 1e-6 at distances 0.3 .. 1e3 from receivers with random normals:
    // near ones (declined: Lambert's sum), far ones (accepted), clipped ones (declined).
    let mut rng = Lcg(7);
    let mut elems = Vec::new();
    for k in 0..4000 {
        let size = [0.1, 1e-2, 1e-4, 1e-6][k % 4];
        let dist = [0.3, 1.0, 10.0, 1e3][(k / 4) % 4];
        let c = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, 1.0).normalize() * dist;
        let y = [
            c + rng.point(size),
            c + rng.point(size),
            c + rng.point(size),
        ];
        let x = rng.point(0.1);
        let n = (DVec3::Z + rng.point(1.5)).normalize();
        elems.push((x, n, y));
    }
    for isa in isas() {
        let mut accepted = 0;
        let single = |i: usize| {
            let (x, n, [a, b, c]) = elems[i];
            crate::kernels::form_factor::triangle_form_factor(x, n, a, b, c, Order::Value)
        };
        // The fallback marks its results with a unit gradient (value orders have none).
        let mut got = vec![(0.0, false); elems.len()];
        run_on(
            isa,
            elems.len(),
            |i| (elems[i].0, lane_normal(elems[i].1), elems[i].2),
            |i| {
                single(i).map(|mut d| {
                    d.gradient = DVec3::X;
                    d
                })
            },
            |i, d| got[i] = (d.value, d.gradient == DVec3::X),
        )
        .unwrap();
        for (i, (g, fell_back)) in got.iter().enumerate() {
            let reference = single(i).unwrap().value;
            accepted += !fell_back as usize;
            assert_eq!(g.to_bits(), reference.to_bits(), "{isa:?} element {i}");
        }
        // Far lanes (distance/size >= 10, unclipped) are the majority.
        assert!(accepted > 2000 && accepted < 4000, "{isa:?}: {accepted}");
    }
}
