use super::*;
use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::quadrature::tensor::far_field;
use crate::kernels::form_factor::robust::form_factor;
use crate::Order;

/// The switch ratios of [`FAR_FIELD_RULES`] above 16 satisfy the documented tolerances of
/// [`far_field_error_bound`] (1e-14 value and gradient, 1e-12 Hessian) at the switch, and so
/// beyond it (the bound grows with ρ); the next cheaper rule would not (each ratio is within
/// 10 % of the smallest the bound allows).
#[test]
fn far_field_switches_satisfy_the_a_priori_bound() {
    let tolerance = [1e-14, 1e-14, 1e-12];
    let fits = |points: usize, ratio: f64| {
        far_field_error_bound(points, 1.0 / ratio)
            .iter()
            .zip(tolerance)
            .all(|(e, t)| *e <= t)
    };
    for (ratio, points) in FAR_FIELD_RULES {
        if ratio > FAR_FIELD_RATIO {
            assert!(fits(points, ratio), "{points} points at {ratio}");
            assert!(!fits(points, ratio / 1.1), "{points} points at {ratio}/1.1");
        }
        // The rule returned at and just below each switch.
        let rule = far_field_rule(ratio, 1.0).unwrap();
        assert_eq!(rule.0.len(), points);
    }
    for w in FAR_FIELD_RULES.windows(2) {
        let below = far_field_rule(w[0].0 * (1.0 - 1e-15), 1.0).unwrap();
        assert_eq!(below.0.len(), w[1].1);
    }
    assert!(far_field_rule(FAR_FIELD_RATIO * (1.0 - 1e-15), 1.0).is_none());
    assert!(far_field_rule(f64::NAN, 1.0).is_none());
    // The 8x8 rule between 16 and 31 radii is kept on measurement, not on this bound.
    let at_16 = far_field_error_bound(8, 1.0 / 16.0);
    assert!(at_16[0] > 1e-14 && at_16[0] < 1e-12, "{at_16:?}");
    assert!(at_16[2] > 1e-12 && at_16[2] < 1e-8, "{at_16:?}");
    assert!(fits(8, 31.0));
}

/// The bound against the measured quadrature error of the value of a flat-on triangle (the
/// exact form factor of a parallel receiver from the edge sum at a moderate distance where it
/// does not cancel): the bound holds, and overestimates.
#[test]
fn far_field_bound_holds_for_each_rule() {
    let tri = [
        DVec3::new(-0.4, -0.3, 0.0),
        DVec3::new(0.7, -0.1, 0.0),
        DVec3::new(0.0, 0.8, 0.0),
    ];
    let c = (tri[0] + tri[1] + tri[2]) / 3.0;
    let radius = tri.iter().map(|v| (*v - c).length()).fold(0.0, f64::max);
    let n = DVec3::new(0.3, 0.1, 1.0).normalize();
    for (points, rule) in [
        (3, gauss_legendre_3()),
        (4, gauss_legendre_4()),
        (5, gauss_legendre_5()),
        (6, gauss_legendre_6()),
    ] {
        // Close enough that the error is well above rounding: 2-4 radii.
        for ratio in [2.0, 3.0, 4.0] {
            let x = c - DVec3::new(0.2, -0.1, 1.0).normalize() * (ratio * radius);
            let verts: Vec<ClipVertex> = tri
                .iter()
                .map(|v| ClipVertex {
                    u: *v - tri[0],
                    r: *v - x,
                    r_lo: DVec3::ZERO,
                    on_line: false,
                })
                .collect();
            let got = far_field(&verts, n, Order::Value, false, Rule(rule)).value;
            let reference = form_factor(x, n, &tri, Order::Value).unwrap().value;
            let err = (got.abs() - reference).abs() / reference;
            let bound = far_field_error_bound(points, 1.0 / ratio)[0];
            assert!(
                err <= bound,
                "{points} points, ratio {ratio}: {err:e} > {bound:e}"
            );
            assert!(
                err > 1e-15,
                "{points} points, ratio {ratio}: error {err:e} at rounding"
            );
        }
    }
}
