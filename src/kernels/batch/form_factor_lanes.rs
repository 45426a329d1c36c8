//! The triangle form factor's value in SIMD lanes: the cancellation-free far form of Lambert's sum
//! (`form_factor::lambert::far`) with its per-lane certificate, and the single kernel as the
//! fallback.
//!
//! Each lane evaluates exactly what the single kernel's value path evaluates when it takes the far
//! form (`lambert::sum::triangle_value` → `lambert::far::far_sum`): the same operations in the same
//! order, with no FMA contraction (Rust never contracts, and the lane code uses plain products and
//! sums) and correctly rounded `sqrt` and division in every instruction set. An accepted lane is
//! therefore the single call's value **bit for bit**, a stronger statement than the 1e-14 relative
//! the batch contract asks for (the tests assert equality). The batch is structure-of-arrays and
//! the lane code has no branches (the certificate is a product of comparisons), so the compiler
//! vectorizes it; a copy compiled for AVX2 (or AVX-512) is chosen at run time.
//!
//! A lane is accepted exactly where the single kernel itself accepts the far form: every `y_k − x`
//! in range, every vertex certainly above the tangent plane, every edge small against its distance
//! (`20 ‖e_i‖² ≤ ρ_{i+1}²`), the far form's rounding bound within 5e-13 of the result and the result
//! above 1e-250. Other lanes (near triangles, clipped ones, declined bounds, zero area) are
//! evaluated by the single kernel (Lambert's sum, then its fallbacks).

use glam::DVec3;

use crate::error::Result;
use crate::kernels::form_factor::edge::INV_2PI;
use crate::kernels::form_factor::lambert::far::{psi, FAR_RATIO2};
use crate::kernels::form_factor::tolerance::FAST_TOLERANCE;
use crate::kernels::form_factor::validate::unit;
use crate::simd::Isa;
use crate::Deriv3;

/// Lanes per batch (a multiple of the widest vector, 8 f64).
const BATCH: usize = 32;

const U: f64 = 0.5 * f64::EPSILON;

/// Structure-of-arrays batch: `v[k][axis][lane]` the triangle's vertices, `x` the receiver, `n`
/// its unit normal (NaN when the kernel would reject it, which fails every comparison), the value
/// and the certificate (an integer, not a `bool`, so that it vectorizes).
struct Lanes {
    v: [[[f64; BATCH]; 3]; 3],
    x: [[f64; BATCH]; 3],
    n: [[f64; BATCH]; 3],
    out: [f64; BATCH],
    ok: [u64; BATCH],
}

impl Lanes {
    fn new() -> Box<Lanes> {
        Box::new(Lanes {
            v: [[[0.0; BATCH]; 3]; 3],
            x: [[0.0; BATCH]; 3],
            n: [[0.0; BATCH]; 3],
            out: [0.0; BATCH],
            ok: [0; BATCH],
        })
    }

    #[inline(always)]
    fn set(&mut self, i: usize, x: DVec3, n: DVec3, y: [DVec3; 3]) {
        for axis in 0..3 {
            for (vk, yk) in self.v.iter_mut().zip(&y) {
                vk[axis][i] = yk[axis];
            }
            self.x[axis][i] = x[axis];
            self.n[axis][i] = n[axis];
        }
    }
}

// glam's formulas, operation for operation (the bit-for-bit claim rests on it).

#[inline(always)]
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
fn abs(a: [f64; 3]) -> [f64; 3] {
    [a[0].abs(), a[1].abs(), a[2].abs()]
}

#[inline(always)]
fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

#[inline(always)]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] * b[0]) + (a[1] * b[1]) + (a[2] * b[2])
}

#[inline(always)]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - b[1] * a[2],
        a[2] * b[0] - b[2] * a[0],
        a[0] * b[1] - b[0] * a[1],
    ]
}

#[inline(always)]
fn norm1(a: [f64; 3]) -> f64 {
    let a = abs(a);
    a[0] + a[1] + a[2]
}

/// `lambert::in_range`: the largest coordinate within (1e-30, 1e30).
#[inline(always)]
fn in_range(r: [f64; 3]) -> bool {
    let a = abs(r);
    let max = |p: f64, q: f64| if p > q { p } else { q };
    let m = max(max(a[0], a[1]), a[2]);
    (m > 1e-30) & (m < 1e30)
}

/// Evaluates every lane: `out` the form factor, `ok` whether the far form certified it.
#[inline(always)]
fn evaluate(l: &mut Lanes) {
    for i in 0..BATCH {
        let load = |v: &[[f64; BATCH]; 3]| [v[0][i], v[1][i], v[2][i]];
        let v = [load(&l.v[0]), load(&l.v[1]), load(&l.v[2])];
        let (x, n) = (load(&l.x), load(&l.n));
        let r = [sub(v[0], x), sub(v[1], x), sub(v[2], x)];
        // lambert::unclipped: in range, nothing clipped.
        let mut ok = true;
        for rk in &r {
            ok &= in_range(*rk);
            ok &= dot(n, *rk) > 8.0 * f64::EPSILON * dot(abs(n), abs(*rk));
        }
        let rho2 = [dot(r[0], r[0]), dot(r[1], r[1]), dot(r[2], r[2])];
        // far_sum's regime (it includes triangle_value's first-edge test).
        let e = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
        for k in 0..3 {
            ok &= FAR_RATIO2 * dot(e[k], e[k]) <= rho2[(k + 1) % 3];
        }
        let rho = [rho2[0].sqrt(), rho2[1].sqrt(), rho2[2].sqrt()];
        let inv = [1.0 / rho[0], 1.0 / rho[1], 1.0 / rho[2]];
        let mut delta = [[0.0; 3]; 3];
        let mut dn = [0.0; 3];
        for k in 1..3 {
            let d = sub(v[k], v[0]);
            let rs = [r[0][0] + r[k][0], r[0][1] + r[k][1], r[0][2] + r[k][2]];
            let q = dot(d, rs) / (rho[0] + rho[k]);
            delta[k] = scale(sub(d, scale(r[0], q * inv[0])), inv[k]);
            dn[k] = norm1(d) * inv[k];
        }
        // far_sum's accumulators start at 0 (`0 + t` is `t` but for the sign of a zero, which
        // fails the certificate anyway); kept for the same bits.
        let c12 = cross(delta[1], delta[2]);
        let area = [0.0 + c12[0], 0.0 + c12[1], 0.0 + c12[2]];
        let (a, b) = (norm1(delta[1]), norm1(delta[2]));
        let b_prop = 0.0 + (dn[1] * b + a * dn[2]);
        let b_round = 0.0 + a * b;
        let main = dot(n, area);
        let (mut corr, mut corr_mag, mut b_corr) = (0.0, 0.0, 0.0);
        for k in 0..3 {
            let j = (k + 1) % 3;
            let w = cross(r[k], e[k]);
            let pp = inv[k] * inv[j];
            let p = psi(dot(w, w) * (pp * pp));
            let c = p * (dot(n, w) * pp);
            corr += c;
            corr_mag += c.abs();
            b_corr += p * norm1(e[k]) * inv[j];
        }
        let total = main + corr;
        let err = U
            * (36.0 * b_prop
                + 8.0 * b_round
                + 84.0 * b_corr
                + 3.0 * (main.abs() + corr_mag)
                + 2.0 * total.abs());
        ok &= (err <= FAST_TOLERANCE * total.abs()) & (total.abs() > 1e-250);
        // triangle_value: the sum's sign is the orientation; the form factor is two-sided.
        l.out[i] = (total.abs() * INV_2PI).min(1.0);
        l.ok[i] = ok as u64;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn evaluate_avx2(l: &mut Lanes) {
    evaluate(l)
}

#[cfg(all(target_arch = "x86_64", raddiff_avx512))]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,fma")]
unsafe fn evaluate_avx512(l: &mut Lanes) {
    evaluate(l)
}

fn evaluate_on(isa: Isa, l: &mut Lanes) {
    match isa {
        Isa::Portable => evaluate(l),
        // SAFETY: `best_isa` (or the test choosing it) checked that the CPU has these features.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { evaluate_avx2(l) },
        // SAFETY: as above.
        #[cfg(all(target_arch = "x86_64", raddiff_avx512))]
        Isa::Avx512 => unsafe { evaluate_avx512(l) },
    }
}

/// The kernel's renormalized normal, or NaN (every lane comparison then fails) where the kernel
/// rejects it.
#[inline]
pub(super) fn lane_normal(n: DVec3) -> DVec3 {
    unit(n).unwrap_or(DVec3::NAN)
}

/// Runs the lanes over `count` elements, element `i` being receiver, normal (from [`lane_normal`])
/// and triangle `get(i)`: `each(i, Some(value))` where the far form certified the value,
/// `each(i, None)` elsewhere, in increasing `i`; an error from `each` stops the run.
fn batches(
    isa: Isa,
    count: usize,
    get: impl Fn(usize) -> (DVec3, DVec3, [DVec3; 3]),
    mut each: impl FnMut(usize, Option<f64>) -> Result<()>,
) -> Result<()> {
    if count == 0 {
        return Ok(());
    }
    let mut lanes = Lanes::new();
    let mut start = 0;
    while start < count {
        let m = BATCH.min(count - start);
        for i in 0..m {
            let (x, n, y) = get(start + i);
            lanes.set(i, x, n, y);
        }
        // Unused lanes get a harmless far triangle (their outputs are ignored).
        for i in m..BATCH {
            let y = [
                DVec3::Z * 10.0,
                DVec3::new(0.1, 0.0, 10.0),
                DVec3::new(0.0, 0.1, 10.0),
            ];
            lanes.set(i, DVec3::ZERO, DVec3::Z, y);
        }
        evaluate_on(isa, &mut lanes);
        for i in 0..m {
            each(start + i, (lanes.ok[i] != 0).then_some(lanes.out[i]))?;
        }
        start += m;
    }
    Ok(())
}

/// The form factor value of `count` elements, element `i` being receiver, normal (from
/// [`lane_normal`]) and triangle `get(i)`, handed to `sink(i, value)` in increasing `i`. Lanes
/// not certified take `fallback(i)` (the single call), whose error stops the run.
pub(super) fn run_on(
    isa: Isa,
    count: usize,
    get: impl Fn(usize) -> (DVec3, DVec3, [DVec3; 3]),
    fallback: impl Fn(usize) -> Result<Deriv3>,
    mut sink: impl FnMut(usize, Deriv3),
) -> Result<()> {
    batches(isa, count, get, |i, value| {
        let d = match value {
            Some(f) => Deriv3::constant(f),
            None => fallback(i)?,
        };
        sink(i, d);
        Ok(())
    })
}

/// `lambert::triangle_value` (Lambert's certified value, `None` where it declines) of `count`
/// elements given as for [`run_on`], into `out[i]`: from the lanes where they certify the far
/// form (the same bits), from `scalar(i)` (that call) elsewhere.
pub(super) fn lambert_values(
    isa: Isa,
    count: usize,
    get: impl Fn(usize) -> (DVec3, DVec3, [DVec3; 3]),
    scalar: impl Fn(usize) -> Option<f64>,
    out: &mut [Option<f64>],
) {
    let done = batches(isa, count, get, |i, value| {
        out[i] = value.or_else(|| scalar(i));
        Ok(())
    });
    debug_assert!(done.is_ok());
}

#[cfg(test)]
mod tests;
