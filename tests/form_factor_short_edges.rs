//! Edge terms of short edges seen from near the extension of their line, against the 320-bit
//! reference: the closed-form moments' axial series were differenced in a way that cancelled by
//! ~distance/length (`EdgeFrame::moments`), which the gradient and Hessian of the edge term
//! inherited.

mod form_factor_support;

use form_factor_support::*;
use raddiff::{kernels, Order};

/// Edges 1e-8..1e-3 of their distance long, x within 1e-3..1e-1 of its distance of the edge's
/// line (beyond an end, where the moments take their axial series), random directions and
/// normals: value, gradient and Hessian within 1e-12 of the reference's largest entry (each part).
#[test]
fn short_axial_edges_match_the_reference() {
    let mut rng = Rng(1827);
    let mut big = Big::new();
    let mut worst = [0.0f64; 3];
    for _ in 0..60 {
        let dir = rng.unit();
        let off = dir.any_orthonormal_vector();
        let distance = 10f64.powf(rng.range(-1.0, 1.0));
        let side = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
        let x = rng.vec(1.0);
        let a = x + dir * (side * distance) + off * (distance * 10f64.powf(rng.range(-3.0, -1.0)));
        let b = a + dir * (side * distance * 10f64.powf(rng.range(-8.0, -3.0)));
        let n = rng.unit();
        let got = kernels::edge_form_factor(x, n, a, b, Order::Hessian).unwrap();
        let reference = big.edge_reference(x, n, a, b);
        max3(&mut worst, errors(&got, &reference));
    }
    println!("short axial edges: worst {worst:?}");
    assert!(within(worst, [1e-12; 3]), "{worst:?}");
}
