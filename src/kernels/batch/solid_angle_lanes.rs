//! The unsigned triangle solid angle in SIMD lanes, with a per-lane certificate and the single
//! kernel as the fallback.
//!
//! Each lane evaluates the generic branch of `kernels::solid_angle` (same formulas, see that
//! module's documentation): positions relative to x scaled by a power of two, the normal from the
//! two shortest edges, `A` at the nearest vertex, `Ω = 2 atan2(|A|, D)` and the closed-form
//! gradient and Hessian. The batch is structure-of-arrays and the lane code has no branches (regimes
//! become selects; `atan2` is the gather's branch-free polynomial), so the compiler vectorizes it;
//! a copy compiled for AVX2 + FMA (or AVX-512) is chosen at run time.
//!
//! A lane is accepted only where the single kernel itself takes that generic branch, with margin:
//!
//! * `A² · 4096 ≥ s_v² ‖e_i‖² ‖e_j‖²`: the rounding error of `A` (below ~4 ε s_v ‖e_i‖ ‖e_j‖)
//!   stays under ~3e-14 relative (the kernel's own threshold is 1024, below which it recomputes `A`
//!   in double-double: x near the triangle's plane);
//! * `A² + D² ≥ 1e-2 (s_0 s_1 s_2)²`: `D` and `∇D` do not cancel by more than 10x (their rounding
//!   errors, below ~32 ε s_0 s_1 s_2, then move the angle by less than ~7e-14; the kernel refines
//!   them in double-double below 1e-6: x near an edge);
//! * the largest coordinate of `y_k − x` within 2^±960 (no overflow or underflow of the products up
//!   to `1/g²` once scaled), every output finite.
//!
//! Other lanes (x near the plane, an edge or a vertex, degenerate triangles, extreme scales) are
//! evaluated by the single kernel, so every result is the single kernel's to its accuracy contract.
//! The only differences in accepted lanes are rounding: FMA contractions in the vector copies and
//! the polynomial `atan2` (2 ulps).

use glam::DVec3;

use super::element_error::label;
use crate::kernels::numeric::atan2::atan2_upper;
use crate::kernels::numeric::fma::fmadd;
use crate::simd::{best_isa, Isa};
use crate::{Deriv3, Order};

/// Lanes per batch (a multiple of the widest vector, 8 f64).
const BATCH: usize = 32;

/// Outputs per lane: value, gradient (3), Hessian (xx, xy, xz, yy, yz, zz).
const OUTPUTS: usize = 10;

/// Structure-of-arrays batch: vertices relative to x, edges, outputs, certificates.
struct Lanes {
    /// `r[k][axis][lane] = y_k − x`.
    r: [[[f64; BATCH]; 3]; 3],
    /// `e[k][axis][lane]`: the edge opposite vertex k along the cycle (a, b, c), from the
    /// coordinates themselves (differences of the `r_k` would lose distance/size digits).
    e: [[[f64; BATCH]; 3]; 3],
    /// `out[k][lane]` (structure of arrays: strided stores would keep the loop scalar).
    out: [[f64; BATCH]; OUTPUTS],
    /// 1 where the lane's certificate holds (an integer, not a `bool`, so that it vectorizes).
    ok: [u64; BATCH],
}

impl Lanes {
    fn new() -> Box<Lanes> {
        Box::new(Lanes {
            r: [[[0.0; BATCH]; 3]; 3],
            e: [[[0.0; BATCH]; 3]; 3],
            out: [[0.0; BATCH]; OUTPUTS],
            ok: [0; BATCH],
        })
    }

    #[inline(always)]
    fn set(&mut self, i: usize, x: DVec3, y: [DVec3; 3]) {
        let r = [y[0] - x, y[1] - x, y[2] - x];
        let e = [y[2] - y[1], y[0] - y[2], y[1] - y[0]];
        for k in 0..3 {
            for axis in 0..3 {
                self.r[k][axis][i] = r[k][axis];
                self.e[k][axis][i] = e[k][axis];
            }
        }
    }
}

/// `if c { a } else { b }` as a bitwise blend (a plain `if` between loads can become a load from a
/// selected address, which the vectorizer rejects).
#[inline(always)]
fn sel(c: bool, a: f64, b: f64) -> f64 {
    let mask = 0u64.wrapping_sub(c as u64);
    f64::from_bits((a.to_bits() & mask) | (b.to_bits() & !mask))
}

#[inline(always)]
fn sel3(c: bool, a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [sel(c, a[0], b[0]), sel(c, a[1], b[1]), sel(c, a[2], b[2])]
}

#[inline(always)]
fn dot<const FMA: bool>(a: [f64; 3], b: [f64; 3]) -> f64 {
    fmadd::<FMA>(a[0], b[0], fmadd::<FMA>(a[1], b[1], a[2] * b[2]))
}

#[inline(always)]
fn cross<const FMA: bool>(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        fmadd::<FMA>(a[1], b[2], -(a[2] * b[1])),
        fmadd::<FMA>(a[2], b[0], -(a[0] * b[2])),
        fmadd::<FMA>(a[0], b[1], -(a[1] * b[0])),
    ]
}

/// Rescaled lanes need `1/g² ~ extent^-12` in range: exponents of the extent within ±960 of 1
/// keep every product far from the f64 limits after scaling to about 1.
const EXPONENT_MIN: u64 = 1023 - 960;
const EXPONENT_MAX: u64 = 1023 + 960;

/// Evaluates every lane up to the order given by `GRADIENT` / `HESSIAN`, with its certificate.
#[inline(always)]
fn evaluate<const FMA: bool, const GRADIENT: bool, const HESSIAN: bool>(l: &mut Lanes) {
    for i in 0..BATCH {
        let load = |v: &[[f64; BATCH]; 3]| [v[0][i], v[1][i], v[2][i]];
        let mut r = [load(&l.r[0]), load(&l.r[1]), load(&l.r[2])];
        let mut e = [load(&l.e[0]), load(&l.e[1]), load(&l.e[2])];
        let mut extent = 0.0f64;
        for v in &r {
            for c in v {
                extent = extent.max(c.abs());
            }
        }
        // A power of two bringing the extent into [0.5, 1) (exact scaling, as the kernel does).
        let exponent = (extent.to_bits() >> 52) & 0x7ff;
        let in_range = (EXPONENT_MIN..=EXPONENT_MAX).contains(&exponent);
        let scale = f64::from_bits(2045u64.wrapping_sub(exponent).wrapping_shl(52) & (0x7ff << 52));
        // Index loops (fully unrolled): an iterator chain here stays a loop, and the lane loop
        // around it would not vectorize.
        for k in 0..3 {
            for c in 0..3 {
                r[k][c] *= scale;
                e[k][c] *= scale;
            }
        }
        let s = [
            dot::<FMA>(r[0], r[0]).sqrt(),
            dot::<FMA>(r[1], r[1]).sqrt(),
            dot::<FMA>(r[2], r[2]).sqrt(),
        ];
        let l2 = [
            dot::<FMA>(e[0], e[0]),
            dot::<FMA>(e[1], e[1]),
            dot::<FMA>(e[2], e[2]),
        ];
        // N from the two shortest edges: based at the vertex k opposite the longest, N = e_i × e_j
        // with (i, j) = (k + 1, k + 2) mod 3.
        let k0 = l2[0] >= l2[1] && l2[0] >= l2[2];
        let k1 = !k0 && l2[1] >= l2[2];
        let ei = sel3(k0, e[1], sel3(k1, e[2], e[0]));
        let ej = sel3(k0, e[2], sel3(k1, e[0], e[1]));
        let l2i = sel(k0, l2[1], sel(k1, l2[2], l2[0]));
        let l2j = sel(k0, l2[2], sel(k1, l2[0], l2[1]));
        let mut normal = cross::<FMA>(ei, ej);
        // A at the nearest vertex.
        let v0 = s[0] <= s[1] && s[0] <= s[2];
        let v1 = !v0 && s[1] <= s[2];
        let rv = sel3(v0, r[0], sel3(v1, r[1], r[2]));
        let sv = sel(v0, s[0], sel(v1, s[1], s[2]));
        let a_signed = dot::<FMA>(rv, normal);
        let a_ok = a_signed * a_signed * 4096.0 >= sv * sv * l2i * l2j && a_signed != 0.0;
        // Unsigned: flip the normal with A.
        let flip = sel(a_signed < 0.0, -1.0, 1.0);
        let a = a_signed * flip;
        for c in normal.iter_mut() {
            *c *= flip;
        }
        let d01 = dot::<FMA>(r[0], r[1]);
        let d12 = dot::<FMA>(r[1], r[2]);
        let d20 = dot::<FMA>(r[2], r[0]);
        let s012 = s[0] * s[1] * s[2];
        let d = fmadd::<FMA>(
            d01,
            s[2],
            fmadd::<FMA>(d12, s[0], fmadd::<FMA>(d20, s[1], s012)),
        );
        let g = fmadd::<FMA>(a, a, d * d);
        let d_ok = g >= 1e-2 * s012 * s012;
        let mut out = [0.0; OUTPUTS];
        out[0] = 2.0 * atan2_upper::<FMA>(a, d);
        if GRADIENT {
            let inv_s = [1.0 / s[0], 1.0 / s[1], 1.0 / s[2]];
            let p = [
                fmadd::<FMA>(s[1], s[2], d12),
                fmadd::<FMA>(s[2], s[0], d20),
                fmadd::<FMA>(s[0], s[1], d01),
            ];
            let c = [
                fmadd::<FMA>(p[0], inv_s[0], s[1] + s[2]),
                fmadd::<FMA>(p[1], inv_s[1], s[2] + s[0]),
                fmadd::<FMA>(p[2], inv_s[2], s[0] + s[1]),
            ];
            let mut grad_d = [0.0; 3];
            for (axis, gd) in grad_d.iter_mut().enumerate() {
                *gd = -fmadd::<FMA>(
                    r[0][axis],
                    c[0],
                    fmadd::<FMA>(r[1][axis], c[1], r[2][axis] * c[2]),
                );
            }
            let grad_a = [-normal[0], -normal[1], -normal[2]];
            let inv_g = 1.0 / g;
            let two_inv_g = 2.0 * inv_g;
            for axis in 0..3 {
                out[1 + axis] =
                    fmadd::<FMA>(grad_a[axis], d, -(grad_d[axis] * a)) * two_inv_g * scale;
            }
            if HESSIAN {
                let s_sum = s[0] + s[1] + s[2];
                let u =
                    [0, 1, 2].map(|k| [r[k][0] * inv_s[k], r[k][1] * inv_s[k], r[k][2] * inv_s[k]]);
                let u_sum = [
                    u[0][0] + u[1][0] + u[2][0],
                    u[0][1] + u[1][1] + u[2][1],
                    u[0][2] + u[1][2] + u[2][2],
                ];
                let w = [0, 1, 2].map(|k| fmadd::<FMA>(p[k], inv_s[k], s_sum));
                let c_sum = c[0] + c[1] + c[2];
                let inv_g2 = inv_g * inv_g;
                let q = 2.0 * d * a * inv_g2;
                let m = fmadd::<FMA>(d, d, -(a * a)) * inv_g2;
                let ha = -a * inv_g;
                // Scaled positions: the Hessian in world units is (2 ·) this times scale².
                let factor = 2.0 * scale * scale;
                let pairs = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];
                for (slot, &(x, y)) in pairs.iter().enumerate() {
                    let mut hd = s_sum * u_sum[x] * u_sum[y];
                    for k in 0..3 {
                        hd = fmadd::<FMA>(-w[k], u[k][x] * u[k][y], hd);
                    }
                    if x == y {
                        hd += c_sum;
                    }
                    let aa = fmadd::<FMA>(grad_a[x], grad_a[y], -(grad_d[x] * grad_d[y]));
                    let ad = fmadd::<FMA>(grad_a[x], grad_d[y], grad_d[x] * grad_a[y]);
                    let h = fmadd::<FMA>(hd, ha, -fmadd::<FMA>(aa, q, ad * m));
                    out[4 + slot] = h * factor;
                }
            }
        }
        let mut finite = true;
        for (k, o) in out.iter().enumerate() {
            finite &= o.is_finite();
            l.out[k][i] = *o;
        }
        l.ok[i] = (in_range && a_ok && d_ok && finite) as u64;
    }
}

#[inline(always)]
fn evaluate_order<const FMA: bool>(l: &mut Lanes, order: Order) {
    match order {
        Order::Value => evaluate::<FMA, false, false>(l),
        Order::Gradient => evaluate::<FMA, true, false>(l),
        Order::Hessian => evaluate::<FMA, true, true>(l),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn evaluate_avx2(l: &mut Lanes, order: Order) {
    evaluate_order::<true>(l, order)
}

#[cfg(all(target_arch = "x86_64", raddiff_avx512))]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,fma")]
unsafe fn evaluate_avx512(l: &mut Lanes, order: Order) {
    evaluate_order::<true>(l, order)
}

fn evaluate_on(isa: Isa, l: &mut Lanes, order: Order) {
    match isa {
        Isa::Portable => evaluate_order::<false>(l, order),
        // SAFETY: `best_isa` (or the test choosing it) checked that the CPU has these features.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { evaluate_avx2(l, order) },
        // SAFETY: as above.
        #[cfg(all(target_arch = "x86_64", raddiff_avx512))]
        Isa::Avx512 => unsafe { evaluate_avx512(l, order) },
    }
}

/// Lane `i`'s outputs as a [`Deriv3`] (parts above `order` zero).
fn lane_result(l: &Lanes, i: usize, order: Order) -> Deriv3 {
    let o: [f64; OUTPUTS] = std::array::from_fn(|k| l.out[k][i]);
    let mut d = Deriv3::constant(o[0]);
    if order.gradient() {
        d.gradient = DVec3::new(o[1], o[2], o[3]);
    }
    if order.hessian() {
        d.hessian = glam::DMat3::from_cols(
            DVec3::new(o[4], o[5], o[6]),
            DVec3::new(o[5], o[7], o[8]),
            DVec3::new(o[6], o[8], o[9]),
        );
    }
    d
}

/// Evaluates the unsigned solid angle of `count` elements, element `i` being the point and
/// triangle `get(i)` (validated finite by the caller), and hands each result to `sink(i, result)`
/// in increasing `i`. An element whose single-kernel evaluation fails stops the run with its error,
/// labelled `what i`.
pub(super) fn run(
    count: usize,
    get: impl Fn(usize) -> (DVec3, [DVec3; 3]),
    order: Order,
    what: &str,
    sink: impl FnMut(usize, Deriv3),
) -> crate::Result<()> {
    run_on(best_isa(), count, get, order, what, sink)
}

pub(super) fn run_on(
    isa: Isa,
    count: usize,
    get: impl Fn(usize) -> (DVec3, [DVec3; 3]),
    order: Order,
    what: &str,
    mut sink: impl FnMut(usize, Deriv3),
) -> crate::Result<()> {
    if count == 0 {
        return Ok(());
    }
    let mut lanes = Lanes::new();
    let mut start = 0;
    while start < count {
        let n = BATCH.min(count - start);
        for i in 0..n {
            let (x, y) = get(start + i);
            lanes.set(i, x, y);
        }
        // Unused lanes get a harmless triangle (their outputs are ignored).
        for i in n..BATCH {
            lanes.set(
                i,
                DVec3::ZERO,
                [DVec3::X + DVec3::Z, DVec3::Y + DVec3::Z, DVec3::Z],
            );
        }
        evaluate_on(isa, &mut lanes, order);
        for i in 0..n {
            let d = if lanes.ok[i] != 0 {
                lane_result(&lanes, i, order)
            } else {
                let (x, y) = get(start + i);
                crate::kernels::solid_angle::triangle_solid_angle(x, y[0], y[1], y[2], order)
                    .map_err(|e| label(e, what, start + i))?
            };
            sink(start + i, d);
        }
        start += n;
    }
    Ok(())
}

#[cfg(test)]
pub(super) mod tests;
