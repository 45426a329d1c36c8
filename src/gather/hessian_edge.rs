//! Interim per-edge form-factor term, used until `kernels::edge_form_factor` lands on main (then
//! this file is deleted). Plain closed forms in the edge frame, without the kernel's cancellation
//! safeguards.

use glam::{DMat3, DVec3};

use crate::error::{Error, Result};
use crate::{Deriv3, Order};

const INV_2PI: f64 = 0.5 * std::f64::consts::FRAC_1_PI;

fn sym(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x + b * a.x, a * b.y + b * a.y, a * b.z + b * a.z)
}

fn outer(a: DVec3) -> DMat3 {
    DMat3::from_cols(a * a.x, a * a.y, a * a.z)
}

/// `(1/2π) β n·(r_a × r_b)/‖r_a × r_b‖` with derivatives w.r.t. `x` (`r = v − x`).
pub(crate) fn edge_form_factor(
    x: DVec3,
    n: DVec3,
    a: DVec3,
    b: DVec3,
    order: Order,
) -> Result<Deriv3> {
    let ra = a - x;
    let e = b - a;
    let len = e.length();
    if len == 0.0 {
        return Ok(Deriv3::constant(0.0));
    }
    let eh = e / len;
    let w = ra.cross(e);
    let h = w.length() / len;
    if h == 0.0 {
        return Err(Error::Degenerate("point on the edge's line".into()));
    }
    let sa = ra.dot(eh);
    let sb = sa + len;
    let p = ra - eh * sa;
    let h2 = h * h;
    let a1 = (h * len).atan2(h2 + sa * sb) / h;
    let nu = n.dot(w) / len;
    let mut out = Deriv3::constant(INV_2PI * nu * a1);
    if !order.gradient() {
        return Ok(out);
    }
    let ra2 = sa * sa + h2;
    let rb2 = sb * sb + h2;
    let a2 = ((sb / rb2 - sa / ra2) + a1) / (2.0 * h2);
    let b2 = 0.5 * (1.0 / ra2 - 1.0 / rb2);
    let nxe = n.cross(eh);
    let g = p * a2 + eh * b2;
    out.gradient = INV_2PI * (nxe * a1 + 2.0 * nu * g);
    if order.hessian() {
        let a3 = ((sb / (rb2 * rb2) - sa / (ra2 * ra2)) + 3.0 * a2) / (4.0 * h2);
        let b3 = 0.25 * (1.0 / (ra2 * ra2) - 1.0 / (rb2 * rb2));
        let c3 = a2 - h2 * a3;
        let hi = DMat3::IDENTITY * (-2.0 * a2)
            + (outer(p) * a3 + sym(p, eh) * b3 + outer(eh) * c3) * 8.0;
        out.hessian = (sym(nxe, g) * 2.0 + hi * nu) * INV_2PI;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_match_finite_differences() {
        let n = DVec3::new(0.1, -0.2, 1.0).normalize();
        let cases = [
            (DVec3::new(0.3, 0.1, 1.0), DVec3::new(-0.4, 0.5, 1.3)),
            (DVec3::new(1.0, 0.0, 0.2), DVec3::new(3e5, 2e5, 1e5)),
            (DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 2.0, 0.0)),
        ];
        for (a, b) in cases {
            let d = edge_form_factor(DVec3::ZERO, n, a, b, Order::Hessian).unwrap();
            let h = 1e-5;
            for i in 0..3 {
                let e = DVec3::AXES[i] * h;
                let p = edge_form_factor(e, n, a, b, Order::Hessian).unwrap();
                let m = edge_form_factor(-e, n, a, b, Order::Hessian).unwrap();
                let fd = (p.value - m.value) / (2.0 * h);
                assert!(
                    (fd - d.gradient[i]).abs() < 1e-7,
                    "{a} {b} grad {i}: {fd} vs {}",
                    d.gradient[i]
                );
                let col = (p.gradient - m.gradient) / (2.0 * h);
                assert!(
                    (col - d.hessian.col(i)).abs().max_element() < 1e-6,
                    "{a} {b} hess {i}: {col} vs {}",
                    d.hessian.col(i)
                );
            }
        }
    }
}
