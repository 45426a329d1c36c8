//! Baselines the kernel benches (`benches/solid_angle_transmittance.rs`) and the `kernels` example
//! time raddiff against, written as a user would: central finite differences, num-dual
//! second-order dual numbers, and the textbook Van Oosterom-Strackee solid angle (in plain `f64`,
//! and generic over dual numbers).

#![allow(dead_code)] // each includer uses its own subset
#![allow(clippy::needless_range_loop)] // index loops mirror the finite-difference stencils

use glam::{DMat3, DVec3};
use nalgebra::{SMatrix, SVector};
use num_dual::{Dual2SVec64, DualNum};
use raddiff::Deriv3;

/// Second-order dual numbers in three variables.
pub type D3 = Dual2SVec64<3>;

/// Central finite-difference Hessian of `f` at `x` with step `h` (19 evaluations).
pub fn fd_hessian3(f: &dyn Fn(DVec3) -> f64, x: DVec3, h: f64) -> DMat3 {
    let f0 = f(x);
    let mut m = [[0.0; 3]; 3];
    let unit = |i: usize| {
        let mut e = DVec3::ZERO;
        e[i] = h;
        e
    };
    for i in 0..3 {
        let ei = unit(i);
        m[i][i] = (f(x + ei) - 2.0 * f0 + f(x - ei)) / (h * h);
        for j in (i + 1)..3 {
            let ej = unit(j);
            let v =
                (f(x + ei + ej) - f(x + ei - ej) - f(x - ei + ej) + f(x - ei - ej)) / (4.0 * h * h);
            m[i][j] = v;
            m[j][i] = v;
        }
    }
    DMat3::from_cols_array_2d(&m)
}

/// The textbook Van Oosterom-Strackee formula, `2 atan2(|r_0·(r_1×r_2)|, D)`, in plain `f64` as a
/// user writes it: the value baseline (the generic form below is the dual numbers' baseline).
pub fn textbook_solid_angle_f64(x: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (r0, r1, r2) = (a - x, b - x, c - x);
    let (l0, l1, l2) = (r0.length(), r1.length(), r2.length());
    let num = r0.dot(r1.cross(r2)).abs();
    let den = l0 * l1 * l2 + r0.dot(r1) * l2 + r1.dot(r2) * l0 + r2.dot(r0) * l1;
    2.0 * num.atan2(den)
}

/// The textbook Van Oosterom-Strackee formula, `2 atan2(|r_0·(r_1×r_2)|, D)`, generic over f64 and
/// dual numbers (the baseline of num-dual's Hessian).
pub fn textbook_solid_angle<D: DualNum<Primitive = f64> + Copy>(
    x: [D; 3],
    a: DVec3,
    b: DVec3,
    c: DVec3,
) -> D {
    let r = [a, b, c].map(|y| {
        [
            D::from(y.x) - x[0],
            D::from(y.y) - x[1],
            D::from(y.z) - x[2],
        ]
    });
    let dot = |p: &[D; 3], q: &[D; 3]| p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
    let s = r.each_ref().map(|v| dot(v, v).sqrt());
    let cross = [
        r[1][1] * r[2][2] - r[1][2] * r[2][1],
        r[1][2] * r[2][0] - r[1][0] * r[2][2],
        r[1][0] * r[2][1] - r[1][1] * r[2][0],
    ];
    let a_num = dot(&r[0], &cross);
    let d = s[0] * s[1] * s[2]
        + dot(&r[0], &r[1]) * s[2]
        + dot(&r[1], &r[2]) * s[0]
        + dot(&r[2], &r[0]) * s[1];
    let a_abs = if a_num.re() < 0.0 { -a_num } else { a_num };
    a_abs.atan2(d) * 2.0
}

/// Value, gradient and Hessian of `f` at `x` by num-dual's second-order dual numbers.
pub fn dual_hessian3(f: impl Fn(&SVector<D3, 3>) -> D3, x: DVec3) -> Deriv3 {
    let (v, g, h): (f64, SVector<f64, 3>, SMatrix<f64, 3, 3>) =
        num_dual::hessian(|v: SVector<D3, 3>| f(&v), &SVector::from([x.x, x.y, x.z]));
    Deriv3 {
        value: v,
        gradient: DVec3::new(g[0], g[1], g[2]),
        hessian: DMat3::from_cols_array(&[
            h[(0, 0)],
            h[(1, 0)],
            h[(2, 0)],
            h[(0, 1)],
            h[(1, 1)],
            h[(2, 1)],
            h[(0, 2)],
            h[(1, 2)],
            h[(2, 2)],
        ]),
    }
}
