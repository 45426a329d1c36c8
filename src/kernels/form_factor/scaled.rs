//! The robust path's input: positions relative to the first vertex and to `x`, with the exact
//! rounding errors of the differences, rescaled by a power of two.

use glam::DVec3;
use smallvec::SmallVec;

use crate::error::{Error, Result};
use crate::kernels::form_factor::edge::ExactEnds;
use crate::kernels::numeric::dd;
use crate::kernels::numeric::pow2::{exponent, pow2};
use crate::{Deriv3, Order};

pub(crate) type Points = SmallVec<[DVec3; 8]>;

/// Positions relative to the first vertex (`u`) and to `x` (`r`), rescaled by an exact power of two
/// so that the largest coordinate is in [1, 2): huge and tiny scenes neither overflow nor lose
/// precision, and derivatives are scaled back exactly.
pub(crate) struct Scaled {
    pub u: Points,
    pub r: Points,
    /// The rounding errors of `r`: `r + r_lo` is exactly `(v − x)` in scaled units, and `r` is
    /// that sum rounded (a double-double's parts, read with [`dd::Dd3::from_parts`]) unless the
    /// rescaling pushed a component of `r_lo` below the normal range (coordinates ~1e-292 of the
    /// largest), where the pair is exact but not renormalized.
    pub r_lo: Points,
    /// d(scaled coordinate)/d(world coordinate).
    pub(crate) inv_scale: f64,
}

impl Scaled {
    pub(crate) fn new(x: DVec3, vertices: &[DVec3]) -> Result<Self> {
        // Filled in place with pushes: collecting into fresh small vectors and moving them into
        // the result cost about as much as the rest of a near-plane evaluation's set-up.
        let mut out = Scaled {
            u: Points::new(),
            r: Points::new(),
            r_lo: Points::new(),
            inv_scale: 1.0,
        };
        let mut pre = 1.0;
        for attempt in 0..2 {
            if attempt == 1 {
                // Differences of coordinates near ±f64::MAX overflow: scale first (exactly).
                pre = pow2(-4);
                out.u.clear();
                out.r.clear();
                out.r_lo.clear();
            }
            let v0 = vertices[0] * pre;
            let xs = x * pre;
            let mut finite = true;
            for v in vertices {
                let vs = *v * pre;
                let (u, r) = (vs - v0, vs - xs);
                finite &= u.is_finite() && r.is_finite();
                // The rounding error of each difference (two-sum): cheap, and lets
                // near-singular configurations be evaluated from exact coordinate differences.
                let err = |a: f64, b: f64| dd::two_sum(a, -b).1;
                out.u.push(u);
                out.r.push(r);
                out.r_lo.push(DVec3::new(
                    err(vs.x, xs.x),
                    err(vs.y, xs.y),
                    err(vs.z, xs.z),
                ));
            }
            if finite {
                break;
            }
        }
        let max_abs = out
            .u
            .iter()
            .chain(out.r.iter())
            .map(|v| v.abs().max_element())
            .fold(0.0, f64::max);
        if max_abs == 0.0 {
            return Err(Error::Degenerate("x and all vertices coincide".into()));
        }
        let k = exponent(max_abs);
        let s = pow2(-k);
        for v in out
            .u
            .iter_mut()
            .chain(out.r.iter_mut())
            .chain(out.r_lo.iter_mut())
        {
            *v *= s;
        }
        out.inv_scale = pre * s;
        Ok(out)
    }

    /// The exact endpoints of the edge from vertex `i` to vertex `j`, relative to `x`.
    pub(crate) fn exact_ends(&self, i: usize, j: usize) -> ExactEnds {
        ExactEnds {
            a: [self.r[i], self.r_lo[i]],
            b: [self.r[j], self.r_lo[j]],
        }
    }

    /// Converts derivatives in scaled units back to world units; non-finite results are refused.
    pub(crate) fn finish(&self, mut d: Deriv3, order: Order) -> Result<Deriv3> {
        if order.gradient() {
            d.gradient *= self.inv_scale;
        }
        if order.hessian() {
            d.hessian *= self.inv_scale * self.inv_scale;
        }
        if d.is_finite() {
            Ok(d)
        } else {
            Err(Error::Degenerate(
                "form factor derivatives overflow f64 for this configuration".into(),
            ))
        }
    }
}

#[cfg(test)]
mod tests;
