//! Accuracy of the flatland segment form factor (`segment_form_factor_2d`) against independent
//! 320-bit references (the angle in astro-float from the exact inputs, derivatives by 320-bit
//! central differences), in every regime: generic, near the segment's line, near an endpoint, far
//! away. `cargo test --release --test segment_accuracy -- --nocapture` prints the worst errors.

mod kernel_reference;

use glam::DVec2;
use kernel_reference::*;
use raddiff::{kernels, Order};

// ---------------------------------------------------------------------------------------------
// Flatland segment form factor.

fn check_segment(hp: &mut Hp, x: DVec2, a: DVec2, b: DVec2, worst: &mut Worst) {
    let d = kernels::segment_form_factor_2d(x, a, b, Order::Hessian)
        .unwrap_or_else(|e| panic!("{e} at x={x:?} a={a:?} b={b:?}"));
    let dir = (b - a).normalize();
    let h = (x - a).perp_dot(dir).abs();
    let rho = h.min((x - a).length()).min((x - b).length());
    let r = central2(hp, x, 1e-25 * rho, &mut |hp, xs, ys| {
        segment_hp(hp, xs, ys, a, b)
    });
    let errs = (
        rel(d.value, r.value),
        rel2(d.gradient, r.gradient),
        rel22(d.hessian, r.hessian),
    );
    if errs.0 > 1e-10 || errs.1 > 1e-9 || errs.2 > 1e-8 {
        eprintln!(
            "large error {errs:?} at x={x:?} a={a:?} b={b:?}\n  got {d:?}\n  ref {} {:?} {:?}",
            r.value, r.gradient, r.hessian
        );
    }
    worst.add(errs.0, errs.1, errs.2);
}

fn rand2(rng: &mut Rng) -> DVec2 {
    let v = rng.in_ball();
    DVec2::new(v.x, v.y)
}

fn dir2(rng: &mut Rng) -> DVec2 {
    let a = rng.range(0.0, std::f64::consts::TAU);
    DVec2::new(a.cos(), a.sin())
}

#[test]
fn segment_form_factor_all_regimes() {
    let mut hp = Hp::new();
    let mut rng = Rng(7);
    let mut generic = Worst::default();
    let mut far = Worst::default();
    let mut line = Worst::default();
    let mut ends = Worst::default();
    let mut huge = Worst::default();
    let mut tiny = Worst::default();
    for i in 0..2 * samples() {
        let l = rng.log_range(-3.0, 3.0);
        let a = rand2(&mut rng) * 5.0 * l;
        let b = a + dir2(&mut rng) * l * rng.range(0.3, 1.0);
        let len = (b - a).length();
        let dir = (b - a) / len;
        let normal = dir.perp();
        // Generic: within 3 lengths, not close to the line.
        let x = a + rand2(&mut rng) * 3.0 * l;
        if (x - a).perp_dot(dir).abs() > 0.05 * len {
            check_segment(&mut hp, x, a, b, &mut generic);
        }
        let x = (a + b) * 0.5 + dir2(&mut rng) * len * rng.log_range(3.0, 6.0);
        check_segment(&mut hp, x, a, b, &mut far);
        // Near the line, beside the segment or beyond its ends.
        let t = if i % 2 == 0 {
            rng.range(0.05, 0.95)
        } else {
            rng.range(1.1, 3.0)
        };
        let side = if i % 4 < 2 { 1.0 } else { -1.0 };
        let x = a + (b - a) * t + normal * side * len * rng.log_range(-12.0, -6.0);
        check_segment(&mut hp, x, a, b, &mut line);
        let x = if i % 2 == 0 { a } else { b } + dir2(&mut rng) * len * rng.log_range(-9.0, -5.0);
        check_segment(&mut hp, x, a, b, &mut ends);
        let off = DVec2::new(1e6, -3e6);
        let (ha, hb) = (off + a / l, off + b / l);
        let x = ha + rand2(&mut rng) * 3.0;
        if (x - ha).perp_dot((hb - ha).normalize()).abs() > 1e-2 {
            check_segment(&mut hp, x, ha, hb, &mut huge);
        }
        let (ta, tb) = (a / l * 1e-6, b / l * 1e-6);
        let x = ta + rand2(&mut rng) * 3e-6;
        if (x - ta).perp_dot((tb - ta).normalize()).abs() > 5e-8 {
            check_segment(&mut hp, x, ta, tb, &mut tiny);
        }
    }
    generic.check(
        "segment FF, generic 1e-3..1e3",
        GENERIC.0,
        GENERIC.1,
        GENERIC.2,
    );
    far.check("segment FF, 1e3..1e6 lengths away", HARD.0, HARD.1, HARD.2);
    line.check(
        "segment FF, 1e-12..1e-6 off the line",
        HARD.0,
        HARD.1,
        HARD.2,
    );
    ends.check(
        "segment FF, 1e-9..1e-5 from an endpoint",
        HARD.0,
        HARD.1,
        HARD.2,
    );
    huge.check("segment FF, coordinates ~1e6", HARD.0, HARD.1, HARD.2);
    tiny.check(
        "segment FF, coordinates ~1e-6",
        GENERIC.0,
        GENERIC.1,
        GENERIC.2,
    );
}
