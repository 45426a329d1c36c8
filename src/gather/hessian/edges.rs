//! The mesh's edge terms, evaluated in batches for a whole gather.
//!
//! The same closed form as `kernels::form_factor::edge_term` (the edge integral of the point-to-
//! polygon form factor; see there for the derivation), specialised for the gather's mesh:
//!
//! * the positions are validated once per gather (finite, rescaled by a power of two), so no edge
//!   returns a `Result`;
//! * edges are collected into structure-of-arrays batches of [`BATCH`] and evaluated without
//!   branches (every lane computes the same expressions, regimes are selected), so the compiler
//!   vectorises the batch; on x86-64 a copy compiled for AVX2 + FMA is chosen at run time;
//! * `atan2` is [`atan2_upper`], a branch-free polynomial evaluation (std's is a libm call that
//!   cannot be vectorised);
//! * the Hessian is assembled as its 6 unique entries from scalar coefficients, and weighted by the
//!   radiance differences only in the per-channel sums.
//!
//! Every edge is measured from its nearer end, exactly as the general kernel is called (see
//! `hessian::edge_term`). Edges in the general kernel's special regimes (x near the extension of the
//! edge's line, where it switches to series, or near the edge's line, where the closed form loses
//! digits) are flagged by the batch and evaluated by the general kernel itself, so they come out as
//! they always did.

use glam::{DMat3, DVec3};

use super::gather_mesh::edge_term;
use super::mesh::{Edge, NONE};
use crate::error::{Error, Result};
use crate::kernels::numeric::atan2::atan2_upper;
use crate::kernels::numeric::fma::fmadd;
use crate::{Deriv3, Order};

/// Edges evaluated together (a multiple of [`LANES`]).
pub(crate) const BATCH: usize = 64;

/// Width of the partial sums (the widest vector of f64 the batch code targets).
const LANES: usize = 4;

/// Intermediate values per edge (foot point, edge direction, moments, ν, sign).
const MID: usize = 14;

/// Outputs per edge: value, gradient (3), Hessian (xx, xy, xz, yy, yz, zz).
const OUTPUTS: usize = 10;

const INV_2PI: f64 = 0.5 * std::f64::consts::FRAC_1_PI;

/// Must match `form_factor::AXIAL_RATIO`: below `h / min(|s_a|, |s_b|) = 1/4` (x near the
/// extension of the edge's line) the closed form's `1/h²` recurrences cancel, and the general kernel
/// and [`evaluate_lanes`]`::<_, _, true>` use series in `(h/s)²` instead.
const AXIAL_RATIO_SQUARED_INV: f64 = 16.0;

/// Below this sine of the angle between `r_a` and the edge (x near the edge's line), the closed
/// form's foot point and `1/h` powers lose more than about 1e-8 relative (4 digits): the edge goes
/// to the general kernel so that the result is the reference's.
const NEAR_LINE_SINE_SQUARED: f64 = 1e-8;

/// Below this `L·hL·ρ_a²ρ_b²` an edge goes to the general kernel (the reciprocal would lose
/// precision to subnormals; it takes hits 1e-75 times closer than the farthest).
const TINY_DENOMINATOR: f64 = 1e-250;

/// `general` flags of a lane.
const CLOSED_FORM: u64 = 0;
const AXIAL: u64 = 1;
const GENERAL: u64 = 2;

/// Structure-of-arrays storage of one batch: the edges' end points relative to x (scaled) with
/// their squared lengths, and the outputs.
#[derive(Clone)]
struct Batch {
    a: [[f64; BATCH]; 3],
    b: [[f64; BATCH]; 3],
    a2: [f64; BATCH],
    b2: [f64; BATCH],
    /// Per edge: value, gradient, Hessian (6 entries) of the edge term `a → b`, times 2π.
    out: [[f64; BATCH]; OUTPUTS],
    /// Per-lane intermediate results between the two passes of [`evaluate_lanes`].
    mid: [[f64; BATCH]; MID],
    /// [`CLOSED_FORM`], or [`AXIAL`] / [`GENERAL`] where the lane's outputs are 0 and the edge must
    /// be evaluated by the axial batch or the general kernel.
    general: [u64; BATCH],
}

impl Batch {
    fn new() -> Box<Batch> {
        Box::new(Batch {
            a: [[0.0; BATCH]; 3],
            b: [[0.0; BATCH]; 3],
            a2: [0.0; BATCH],
            b2: [0.0; BATCH],
            out: [[0.0; BATCH]; OUTPUTS],
            mid: [[0.0; BATCH]; MID],
            general: [0; BATCH],
        })
    }

    #[inline(always)]
    fn set(&mut self, i: usize, a: DVec3, b: DVec3, a2: f64, b2: f64) {
        for k in 0..3 {
            self.a[k][i] = a[k];
            self.b[k][i] = b[k];
        }
        self.a2[i] = a2;
        self.b2[i] = b2;
    }

    fn ends(&self, i: usize) -> (DVec3, DVec3, f64, f64) {
        (
            DVec3::new(self.a[0][i], self.a[1][i], self.a[2][i]),
            DVec3::new(self.b[0][i], self.b[1][i], self.b[2][i]),
            self.a2[i],
            self.b2[i],
        )
    }

    /// Fills lanes `from..` with a harmless edge (weights 0 make them contribute nothing): one
    /// whose every output is finite in the batch kind being filled (`axial`: an edge in the axial
    /// regime, where the main batch's pad would divide by its zero `s_a`). A pad lane's outputs
    /// must not rely on the finiteness check to be dropped: `0 × NaN` would poison the sums
    /// wherever that check is not exact (valgrind's emulation of it is not).
    fn pad(&mut self, from: usize, axial: bool) {
        let (a, b) = if axial {
            (DVec3::X, DVec3::new(2.0, 0.05, 0.0))
        } else {
            (DVec3::X, DVec3::new(1.0, 1.0, 0.0))
        };
        for i in from..BATCH {
            self.set(i, a, b, a.length_squared(), b.length_squared());
        }
    }
}

/// `T₂(y) = Σ_k (−1)^k (k+1)/(2k+3) y^k` (`∫_s^∞ dσ/(σ²+h²)² = T₂((h/s)²)/s³`), the general
/// kernel's 20 terms, highest first.
const AXIAL_T2: [f64; 20] = {
    let mut t = [0.0; 20];
    let mut k = 0;
    while k < 20 {
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        t[19 - k] = sign * (k as f64 + 1.0) / (2.0 * k as f64 + 3.0);
        k += 1;
    }
    t
};

/// `T₃(y) = Σ_k (−1)^k (k+1)(k+2)/2 · y^k/(2k+5)` (`∫_s^∞ dσ/(σ²+h²)³ = T₃((h/s)²)/s⁵`), the
/// general kernel's 22 terms, highest first.
const AXIAL_T3: [f64; 22] = {
    let mut t = [0.0; 22];
    let mut k = 0;
    while k < 22 {
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        let kf = k as f64;
        t[21 - k] = sign * 0.5 * (kf + 1.0) * (kf + 2.0) / (2.0 * kf + 5.0);
        k += 1;
    }
    t
};

/// `(P(y_f), (P(y_n) − P(y_f))/(y_n − y_f))` for the polynomial `P` of coefficients `c` (highest
/// first): Horner's rule at `y_f` with its divided difference alongside, so that the difference of
/// two axial tails is never formed by subtraction (it cancelled by ~distance/length on short edges;
/// see `form_factor::axial_a2`).
#[inline(always)]
fn horner_divided<const FMA: bool, const N: usize>(c: &[f64; N], y_n: f64, y_f: f64) -> (f64, f64) {
    let (mut p, mut slope) = (c[0], 0.0);
    for &ci in &c[1..] {
        slope = fmadd::<FMA>(slope, y_n, p);
        p = fmadd::<FMA>(p, y_f, ci);
    }
    (p, slope)
}

/// Evaluates every lane of the batch (see [`Batch`]): each edge from its nearer end (the term is
/// odd in the edge's direction, so the outputs are negated when that reverses it). With `AXIAL`
/// the moments `A_2`, `A_3` come from the series of the general kernel's axial regime (for lanes
/// that are in it); otherwise lanes in that regime are flagged [`AXIAL`].
#[inline(always)]
fn evaluate_lanes<const FMA: bool, const HESSIAN: bool, const AXIAL_LANES: bool>(
    b: &mut Batch,
    n: DVec3,
) {
    for i in 0..BATCH {
        let swap = b.a2[i] > b.b2[i];
        // A bitwise blend: a plain `if` on two loads becomes a load from a selected address,
        // which the vectoriser rejects.
        let mask = 0u64.wrapping_sub(swap as u64);
        let pick =
            |near: f64, far: f64| f64::from_bits((near.to_bits() & !mask) | (far.to_bits() & mask));
        let rx = pick(b.a[0][i], b.b[0][i]);
        let ry = pick(b.a[1][i], b.b[1][i]);
        let rz = pick(b.a[2][i], b.b[2][i]);
        let ex = pick(b.b[0][i], b.a[0][i]) - rx;
        let ey = pick(b.b[1][i], b.a[1][i]) - ry;
        let ez = pick(b.b[2][i], b.a[2][i]) - rz;
        let ra2 = pick(b.a2[i], b.b2[i]);
        let rb2 = pick(b.b2[i], b.a2[i]);
        let sign = if swap { -1.0 } else { 1.0 };
        let len2 = fmadd::<FMA>(ex, ex, fmadd::<FMA>(ey, ey, ez * ez));
        let len = len2.sqrt();
        // w = r × e
        let wx = fmadd::<FMA>(ry, ez, -(rz * ey));
        let wy = fmadd::<FMA>(rz, ex, -(rx * ez));
        let wz = fmadd::<FMA>(rx, ey, -(ry * ex));
        let w2 = fmadd::<FMA>(wx, wx, fmadd::<FMA>(wy, wy, wz * wz));
        // hL
        let wl = w2.sqrt();
        // One division for 1/L, 1/h = L/(hL) and 1/(ρ_a² ρ_b²). The product stays far from
        // overflow (positions are scaled to about 1, misses to 2^20); lanes where it could
        // underflow go to the general kernel.
        let rab2 = ra2 * rb2;
        let lw = len * wl;
        let denominator = lw * rab2;
        let q = 1.0 / denominator;
        let il = wl * rab2 * q;
        let ih = len * len * rab2 * q;
        let irab = lw * q;
        let (hx, hy, hz) = (ex * il, ey * il, ez * il);
        let h = wl * il;
        let h2 = h * h;
        let sa = fmadd::<FMA>(rx, hx, fmadd::<FMA>(ry, hy, rz * hz));
        let sb = sa + len;
        let sab = sa * sb;
        // Foot point p = r − s_a ê.
        let px = fmadd::<FMA>(-sa, hx, rx);
        let py = fmadd::<FMA>(-sa, hy, ry);
        let pz = fmadd::<FMA>(-sa, hz, rz);
        let d = h2 + sab; // r_a · r_b
        let (near, far) = (sa.abs().min(sb.abs()), sa.abs().max(sb.abs()));
        let axial = sab > 0.0 && AXIAL_RATIO_SQUARED_INV * h2 < near * near;
        let near_line = w2 < NEAR_LINE_SINE_SQUARED * ra2 * len2;
        // atan2 is accurate for small angles too, so A_1 needs no series in the axial regime.
        let a1 = atan2_upper::<FMA>(wl, d) * ih;
        let ssum = sa + sb;
        let lsum = len * ssum;
        let b2 = 0.5 * lsum * irab;
        let half_ih2 = 0.5 * ih * ih;
        let (inv_near, inv_far) = (1.0 / near, 1.0 / far);
        let (y_near, y_far) = (h2 * inv_near * inv_near, h2 * inv_far * inv_far);
        // Axial: A_m = T(y_n)/n^k − T(y_f)/f^k as (T(y_n) − T(y_f))/n^k + T(y_f)(1/n^k − 1/f^k),
        // with y_n − y_f = y_n (1 + q) len/f and 1/n^k − 1/f^k = (1 + q + … + q^{k−1}) len/(n^k f),
        // q = n/f: no subtraction of the two tails.
        let q = near * inv_far;
        let len_far = len * inv_far;
        let a2 = if AXIAL_LANES {
            let (t, slope) = horner_divided::<FMA, 20>(&AXIAL_T2, y_near, y_far);
            let inv3 = inv_near * inv_near * inv_near;
            let powers = 1.0 + q * (1.0 + q);
            len_far * inv3 * fmadd::<FMA>(y_near * (1.0 + q), slope, t * powers)
        } else {
            fmadd::<FMA>(len * (h2 - sab), irab, a1) * half_ih2
        };
        // ν = n·w / L.
        let nu = fmadd::<FMA>(n.x, wx, fmadd::<FMA>(n.y, wy, n.z * wz)) * il;
        let (mut a3, mut b3, mut c3) = (0.0, 0.0, 0.0);
        if HESSIAN {
            let irab2 = irab * irab;
            b3 = 0.25 * lsum * (ra2 + rb2) * irab2;
            a3 = if AXIAL_LANES {
                let (t, slope) = horner_divided::<FMA, 22>(&AXIAL_T3, y_near, y_far);
                let inv2 = inv_near * inv_near;
                let powers = 1.0 + q * (1.0 + q * (1.0 + q * (1.0 + q)));
                len_far
                    * (inv2 * inv2 * inv_near)
                    * fmadd::<FMA>(y_near * (1.0 + q), slope, t * powers)
            } else {
                let bracket = h2 * h2
                    - 2.0 * sab * h2
                    - sab * fmadd::<FMA>(sa, sa, fmadd::<FMA>(sa, sb, sb * sb));
                fmadd::<FMA>(len * bracket, irab2, 3.0 * a2) * (0.5 * half_ih2)
            };
            c3 = fmadd::<FMA>(-h2, a3, a2);
        }
        let general = near_line || denominator <= TINY_DENOMINATOR;
        let axial_flag = axial && !AXIAL_LANES;
        b.general[i] = if general {
            GENERAL
        } else if axial_flag {
            AXIAL
        } else {
            CLOSED_FORM
        };
        let m = &mut b.mid;
        m[0][i] = px;
        m[1][i] = py;
        m[2][i] = pz;
        m[3][i] = hx;
        m[4][i] = hy;
        m[5][i] = hz;
        m[6][i] = a1;
        m[7][i] = a2;
        m[8][i] = b2;
        m[9][i] = nu;
        m[10][i] = sign;
        if HESSIAN {
            m[11][i] = a3;
            m[12][i] = b3;
            m[13][i] = c3;
        }
    }
    // Second pass (fewer values live at once than in one loop: no spills with 16 registers).
    for i in 0..BATCH {
        let m = &b.mid;
        let (px, py, pz) = (m[0][i], m[1][i], m[2][i]);
        let (hx, hy, hz) = (m[3][i], m[4][i], m[5][i]);
        let (a1, a2, b2, nu, sign) = (m[6][i], m[7][i], m[8][i], m[9][i], m[10][i]);
        let (a3, b3, c3) = (m[11][i], m[12][i], m[13][i]);
        // u = n × ê.
        let ux = fmadd::<FMA>(n.y, hz, -(n.z * hy));
        let uy = fmadd::<FMA>(n.z, hx, -(n.x * hz));
        let uz = fmadd::<FMA>(n.x, hy, -(n.y * hx));
        // g = p A_2 + ê B_2 (= ∇I L / 2)
        let gx = fmadd::<FMA>(px, a2, hx * b2);
        let gy = fmadd::<FMA>(py, a2, hy * b2);
        let gz = fmadd::<FMA>(pz, a2, hz * b2);
        let two_nu = 2.0 * nu;
        let v = nu * a1;
        let g0 = fmadd::<FMA>(ux, a1, two_nu * gx);
        let g1 = fmadd::<FMA>(uy, a1, two_nu * gy);
        let g2 = fmadd::<FMA>(uz, a1, two_nu * gz);
        let mut hs = [0.0; 6];
        if HESSIAN {
            // H = 2 sym(u, g) + ν (−2 A_2 𝟙 + 8 (A_3 p pᵀ + B_3 sym(p, ê) + C_3 ê êᵀ))
            //   = 2 sym(u, g) + p Pᵀ + ê Qᵀ − 2 ν A_2 𝟙,
            // P = 8ν (A_3 p + B_3 ê), Q = 8ν (B_3 p + C_3 ê).
            let k = 8.0 * nu;
            let (ka3, kb3, kc3) = (k * a3, k * b3, k * c3);
            let qx = fmadd::<FMA>(kb3, px, kc3 * hx);
            let qy = fmadd::<FMA>(kb3, py, kc3 * hy);
            let qz = fmadd::<FMA>(kb3, pz, kc3 * hz);
            let bx = fmadd::<FMA>(ka3, px, kb3 * hx);
            let by = fmadd::<FMA>(ka3, py, kb3 * hy);
            let bz = fmadd::<FMA>(ka3, pz, kb3 * hz);
            let (g2x, g2y, g2z) = (2.0 * gx, 2.0 * gy, 2.0 * gz);
            let diag = -two_nu * a2;
            let entry = |ui: f64, gi: f64, pi: f64, hi: f64, uj: f64, gj: f64, bj: f64, qj: f64| {
                fmadd::<FMA>(ui, gj, fmadd::<FMA>(uj, gi, fmadd::<FMA>(pi, bj, hi * qj)))
            };
            hs[0] = entry(ux, g2x, px, hx, ux, g2x, bx, qx) + diag;
            hs[1] = entry(ux, g2x, px, hx, uy, g2y, by, qy);
            hs[2] = entry(ux, g2x, px, hx, uz, g2z, bz, qz);
            hs[3] = entry(uy, g2y, py, hy, uy, g2y, by, qy) + diag;
            hs[4] = entry(uy, g2y, py, hy, uz, g2z, bz, qz);
            hs[5] = entry(uz, g2z, pz, hz, uz, g2z, bz, qz) + diag;
        }
        let mut total = v + g0 + g1 + g2;
        if HESSIAN {
            total += hs[0] + hs[1] + hs[2] + hs[3] + hs[4] + hs[5];
        }
        let flag = if total.is_finite() {
            b.general[i]
        } else {
            GENERAL
        };
        b.general[i] = flag;
        // A select, not a product: the lanes left out may hold NaN.
        let skip = flag != CLOSED_FORM;
        let keep = |x: f64| if skip { 0.0 } else { sign * x };
        b.out[0][i] = keep(v);
        b.out[1][i] = keep(g0);
        b.out[2][i] = keep(g1);
        b.out[3][i] = keep(g2);
        if HESSIAN {
            b.out[4][i] = keep(hs[0]);
            b.out[5][i] = keep(hs[1]);
            b.out[6][i] = keep(hs[2]);
            b.out[7][i] = keep(hs[3]);
            b.out[8][i] = keep(hs[4]);
            b.out[9][i] = keep(hs[5]);
        }
    }
}

/// `sums[k] += Σ_i w_i out_k[i]` for the first `outputs` outputs, in [`LANES`] partial sums.
#[inline(always)]
fn accumulate_lanes<const FMA: bool>(
    b: &Batch,
    w: &[f64; BATCH],
    outputs: usize,
    sums: &mut [[f64; LANES]; OUTPUTS],
) {
    for (sum, out) in sums.iter_mut().zip(&b.out).take(outputs) {
        for (ws, os) in w.chunks_exact(LANES).zip(out.chunks_exact(LANES)) {
            for l in 0..LANES {
                sum[l] = fmadd::<FMA>(ws[l], os[l], sum[l]);
            }
        }
    }
}

type Sums = [[f64; LANES]; OUTPUTS];

#[inline(always)]
fn run_batch<const FMA: bool, const AXIAL_LANES: bool>(
    b: &mut Batch,
    n: DVec3,
    hessian: bool,
    weights: &[[f64; BATCH]],
    sums: &mut [Sums],
) {
    let outputs = if hessian {
        evaluate_lanes::<FMA, true, AXIAL_LANES>(b, n);
        OUTPUTS
    } else {
        evaluate_lanes::<FMA, false, AXIAL_LANES>(b, n);
        4
    };
    for (w, s) in weights.iter().zip(sums.iter_mut()) {
        accumulate_lanes::<FMA>(b, w, outputs, s);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_batch_avx2<const AXIAL_LANES: bool>(
    b: &mut Batch,
    n: DVec3,
    hessian: bool,
    weights: &[[f64; BATCH]],
    sums: &mut [Sums],
) {
    run_batch::<true, AXIAL_LANES>(b, n, hessian, weights, sums)
}

#[cfg(all(target_arch = "x86_64", raddiff_avx512))]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,fma")]
unsafe fn run_batch_avx512<const AXIAL_LANES: bool>(
    b: &mut Batch,
    n: DVec3,
    hessian: bool,
    weights: &[[f64; BATCH]],
    sums: &mut [Sums],
) {
    run_batch::<true, AXIAL_LANES>(b, n, hessian, weights, sums)
}

/// The instruction sets the batch code is compiled for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Isa {
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx2,
    #[cfg(all(target_arch = "x86_64", raddiff_avx512))]
    Avx512,
}

/// The best [`Isa`] this CPU runs and `RADDIFF_SIMD` allows (see `crate::simd`).
fn best_isa() -> Isa {
    #[cfg(all(target_arch = "x86_64", raddiff_avx512))]
    if crate::simd::avx512() {
        return Isa::Avx512;
    }
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2_fma() {
        return Isa::Avx2;
    }
    Isa::Portable
}

fn run_batch_on<const AXIAL_LANES: bool>(
    isa: Isa,
    b: &mut Batch,
    n: DVec3,
    hessian: bool,
    weights: &[[f64; BATCH]],
    sums: &mut [Sums],
) {
    match isa {
        Isa::Portable => run_batch::<false, AXIAL_LANES>(b, n, hessian, weights, sums),
        // SAFETY: `best_isa` (or the caller) checked that the CPU has these features.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { run_batch_avx2::<AXIAL_LANES>(b, n, hessian, weights, sums) },
        // SAFETY: as above.
        #[cfg(all(target_arch = "x86_64", raddiff_avx512))]
        Isa::Avx512 => unsafe { run_batch_avx512::<AXIAL_LANES>(b, n, hessian, weights, sums) },
    }
}

fn run_batch_dispatch<const AXIAL_LANES: bool>(
    b: &mut Batch,
    n: DVec3,
    hessian: bool,
    weights: &[[f64; BATCH]],
    sums: &mut [Sums],
) {
    run_batch_on::<AXIAL_LANES>(best_isa(), b, n, hessian, weights, sums)
}

/// Edges waiting for evaluation, with their per-channel weights.
struct Queue {
    batch: Box<Batch>,
    weights: Vec<[f64; BATCH]>,
    boundary: [bool; BATCH],
    /// The caller's edge index per lane (where [`EdgeSums`] keeps per-edge terms).
    index: [u32; BATCH],
    /// How many of the queued edges are boundary edges.
    boundaries: usize,
    len: usize,
}

impl Queue {
    fn new(channels: usize) -> Queue {
        Queue {
            batch: Batch::new(),
            weights: vec![[0.0; BATCH]; channels],
            boundary: [false; BATCH],
            index: [0; BATCH],
            boundaries: 0,
            len: 0,
        }
    }

    /// Adds an edge; true when the batch is full.
    #[inline(always)]
    fn add(
        &mut self,
        ends: (DVec3, DVec3, f64, f64),
        delta: &[f64],
        boundary: bool,
        index: u32,
    ) -> bool {
        let i = self.len;
        self.batch.set(i, ends.0, ends.1, ends.2, ends.3);
        for (w, &d) in self.weights.iter_mut().zip(delta) {
            w[i] = d;
        }
        self.boundary[i] = boundary;
        self.index[i] = index;
        self.boundaries += boundary as usize;
        self.len += 1;
        self.len == BATCH
    }

    /// Pads the batch after its `len` edges (`axial`: the queue of the axial regime).
    fn pad(&mut self, axial: bool) {
        let count = self.len;
        if count < BATCH {
            self.batch.pad(count, axial);
            for w in &mut self.weights {
                w[count..].fill(0.0);
            }
        }
    }
}

/// `Σ_edges w_c f_edge` per channel `c` (and `Σ_boundary f_edge`, the geometric terms), in the
/// scaled units of the caller's positions, value/gradient/Hessian up to `order`.
pub(crate) struct EdgeSums {
    n: DVec3,
    order: Order,
    main: Queue,
    axial: Queue,
    /// Per channel partial sums (times 2π) of the batch-evaluated edges.
    sums: Vec<Sums>,
    /// Boundary edges' terms (times 2π for batch-evaluated ones, as is for the general kernel's).
    geometric: Deriv3,
    /// Per channel sums of the general kernel's terms.
    general: Vec<Deriv3>,
    delta: Vec<f64>,
    /// Value and gradient of every edge pushed with [`EdgeSums::push_kept`], by its index (empty
    /// unless asked for: the medium path needs each triangle's own form factor and gradient).
    terms: Vec<[f64; 4]>,
}

impl EdgeSums {
    /// Sums for `channels` channels; `n` is the unit normal, `order` at least `Gradient`.
    pub(crate) fn new(n: DVec3, order: Order, channels: usize) -> EdgeSums {
        EdgeSums {
            n,
            order,
            main: Queue::new(channels),
            axial: Queue::new(channels),
            sums: vec![[[0.0; LANES]; OUTPUTS]; channels],
            geometric: Deriv3::constant(0.0),
            general: vec![Deriv3::constant(0.0); channels],
            delta: vec![0.0; channels],
            terms: Vec::new(),
        }
    }

    /// Starts new sums on the same memory, as [`EdgeSums::new`] would; with `kept_edges > 0` the
    /// value and gradient of each edge pushed by [`EdgeSums::push_kept`] are also kept (indices
    /// below `kept_edges`; read them with [`EdgeSums::terms`] after [`EdgeSums::finish`]).
    pub(crate) fn reset(&mut self, n: DVec3, order: Order, channels: usize, kept_edges: usize) {
        self.n = n;
        self.order = order;
        for q in [&mut self.main, &mut self.axial] {
            q.weights.resize(channels, [0.0; BATCH]);
            q.len = 0;
            q.boundaries = 0;
        }
        self.sums.clear();
        self.sums.resize(channels, [[0.0; LANES]; OUTPUTS]);
        self.geometric = Deriv3::constant(0.0);
        self.general.clear();
        self.general.resize(channels, Deriv3::constant(0.0));
        self.delta.resize(channels, 0.0);
        self.terms.clear();
        self.terms.resize(kept_edges, [0.0; 4]);
    }

    /// The kept values and gradients (scaled units; see [`EdgeSums::reset`]).
    pub(crate) fn terms(&self) -> &[[f64; 4]] {
        &self.terms
    }

    /// Adds the edge `a → b` (finite positions relative to x, scaled; `a2`, `b2` their squared
    /// lengths) with weight `delta[c]` per channel; `boundary` also adds it to the geometric terms.
    #[inline]
    pub(crate) fn push(
        &mut self,
        a: DVec3,
        b: DVec3,
        a2: f64,
        b2: f64,
        delta: &[f64],
        boundary: bool,
    ) -> Result<()> {
        self.push_kept(a, b, a2, b2, delta, boundary, 0)
    }

    /// [`EdgeSums::push`], keeping the edge's value and gradient as edge `index` when the sums were
    /// reset with room for it ([`EdgeSums::reset`]).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn push_kept(
        &mut self,
        a: DVec3,
        b: DVec3,
        a2: f64,
        b2: f64,
        delta: &[f64],
        boundary: bool,
        index: u32,
    ) -> Result<()> {
        if self.main.add((a, b, a2, b2), delta, boundary, index) {
            self.flush_main()?;
        }
        Ok(())
    }

    /// Adds the mesh's edges for one channel: weight `tri[left] − tri[right]` (`right` = the last
    /// entry of `tri` on the horizon), edges of weight 0 skipped except on the boundary; `points`
    /// and `squared` as in [`EdgeSums::push`]. The same as pushing them one by one, in one tight
    /// loop.
    pub(crate) fn add_edges_one_channel(
        &mut self,
        edges: &[Edge],
        tri: &[f64],
        points: &[DVec3],
        squared: &[f64],
    ) -> Result<()> {
        let outside = tri.len() - 1;
        let mut i = self.main.len;
        for e in edges {
            let boundary = e.right == NONE;
            let right = if boundary { outside } else { e.right as usize };
            let d = tri[e.left as usize] - tri[right];
            if d == 0.0 && !boundary {
                continue;
            }
            let (a, b) = (e.a as usize, e.b as usize);
            let q = &mut self.main;
            q.batch.set(i, points[a], points[b], squared[a], squared[b]);
            q.weights[0][i] = d;
            q.boundary[i] = boundary;
            q.boundaries += boundary as usize;
            i += 1;
            if i == BATCH {
                self.main.len = BATCH;
                self.flush_main()?;
                i = 0;
            }
        }
        self.main.len = i;
        Ok(())
    }

    /// The medium path's edges for one channel: `weight` holds `W_Δ = L_Δ T_Δ` and `T_Δ` for every
    /// triangle (and a zero pair for the outside of the horizon); each edge is weighted by the
    /// differences of both across it and kept under its index, and skipped only when `T` is 0 on
    /// both sides. The same as pushing them one by one with [`EdgeSums::push_kept`], in one tight
    /// loop.
    pub(crate) fn add_edges_medium_one_channel(
        &mut self,
        edges: &[Edge],
        weight: &[f64],
        points: &[DVec3],
        squared: &[f64],
    ) -> Result<()> {
        let outside = weight.len() / 2 - 1;
        let mut i = self.main.len;
        for (index, e) in edges.iter().enumerate() {
            let right = if e.right == NONE {
                outside
            } else {
                e.right as usize
            };
            let (l, r) = (2 * e.left as usize, 2 * right);
            let (tl, tr) = (weight[l + 1], weight[r + 1]);
            if tl == 0.0 && tr == 0.0 {
                continue;
            }
            let (a, b) = (e.a as usize, e.b as usize);
            let q = &mut self.main;
            q.batch.set(i, points[a], points[b], squared[a], squared[b]);
            q.weights[0][i] = weight[l] - weight[r];
            q.weights[1][i] = tl - tr;
            q.boundary[i] = false;
            q.index[i] = index as u32;
            i += 1;
            if i == BATCH {
                self.main.len = BATCH;
                self.flush_main()?;
                i = 0;
            }
        }
        self.main.len = i;
        Ok(())
    }

    fn flush_main(&mut self) -> Result<()> {
        let count = self.main.len;
        if count == 0 {
            return Ok(());
        }
        self.main.pad(false);
        let hessian = self.order.hessian();
        let q = &mut self.main;
        run_batch_dispatch::<false>(&mut q.batch, self.n, hessian, &q.weights, &mut self.sums);
        if !self.terms.is_empty() {
            keep_terms(&mut self.terms, q, count);
        }
        // Most batches have neither flagged nor boundary edges (an OR reduction vectorises).
        let flagged = q.batch.general.iter().fold(0, |f, &g| f | g) != CLOSED_FORM;
        if !flagged && q.boundaries == 0 {
            q.len = 0;
            return Ok(());
        }
        for i in 0..count {
            let flag = self.main.batch.general[i];
            let boundary = self.main.boundary[i];
            if flag == CLOSED_FORM {
                if boundary {
                    add_lane(&mut self.geometric, &self.main.batch, i, self.order);
                }
            } else if flag == AXIAL {
                let ends = self.main.batch.ends(i);
                for (d, w) in self.delta.iter_mut().zip(&self.main.weights) {
                    *d = w[i];
                }
                let index = self.main.index[i];
                if self.axial.add(ends, &self.delta, boundary, index) {
                    self.flush_axial()?;
                }
            } else {
                Self::general(
                    &mut self.general,
                    &mut self.geometric,
                    &mut self.terms,
                    &self.main,
                    i,
                    self.n,
                    self.order,
                )?;
            }
        }
        self.main.len = 0;
        self.main.boundaries = 0;
        Ok(())
    }

    fn flush_axial(&mut self) -> Result<()> {
        let count = self.axial.len;
        if count == 0 {
            return Ok(());
        }
        self.axial.pad(true);
        let hessian = self.order.hessian();
        let q = &mut self.axial;
        run_batch_dispatch::<true>(&mut q.batch, self.n, hessian, &q.weights, &mut self.sums);
        if !self.terms.is_empty() {
            keep_terms(&mut self.terms, q, count);
        }
        for i in 0..count {
            if self.axial.batch.general[i] != CLOSED_FORM {
                Self::general(
                    &mut self.general,
                    &mut self.geometric,
                    &mut self.terms,
                    &self.axial,
                    i,
                    self.n,
                    self.order,
                )?;
            } else if self.axial.boundary[i] {
                add_lane(&mut self.geometric, &self.axial.batch, i, self.order);
            }
        }
        self.axial.len = 0;
        self.axial.boundaries = 0;
        Ok(())
    }

    /// Lane `i` of `q` through the general kernel (exactly as the reference evaluates it).
    fn general(
        sums: &mut [Deriv3],
        geometric: &mut Deriv3,
        terms: &mut [[f64; 4]],
        q: &Queue,
        i: usize,
        n: DVec3,
        order: Order,
    ) -> Result<()> {
        let (a, b, _, _) = q.batch.ends(i);
        // The general kernel's terms are not scaled by 2π: scale them so that they can share the
        // geometric sum with the lanes' (the general ones are rare).
        let f = edge_term(n, a, b, order)?;
        if let Some(t) = terms.get_mut(q.index[i] as usize) {
            *t = [f.value, f.gradient.x, f.gradient.y, f.gradient.z];
        }
        for (acc, w) in sums.iter_mut().zip(&q.weights) {
            add_scaled(acc, &f, w[i], order);
        }
        if q.boundary[i] {
            add_scaled(geometric, &f, 2.0 * std::f64::consts::PI, order);
        }
        Ok(())
    }

    /// Per channel sums and the geometric terms (scaled units).
    pub(crate) fn finish(&mut self) -> Result<(Vec<Deriv3>, Deriv3)> {
        self.flush_main()?;
        self.flush_axial()?;
        let mut out = Vec::with_capacity(self.sums.len());
        for (s, general) in self.sums.iter().zip(&self.general) {
            let mut total = [0.0; OUTPUTS];
            for (t, lanes) in total.iter_mut().zip(s) {
                *t = lanes.iter().sum::<f64>() * INV_2PI;
            }
            let mut d = deriv_of(&total);
            add_scaled(&mut d, general, 1.0, self.order);
            if !self.order.hessian() {
                d.hessian = DMat3::ZERO;
            }
            out.push(d);
        }
        let mut geometric = Deriv3::constant(0.0);
        add_scaled(&mut geometric, &self.geometric, INV_2PI, self.order);
        if !out.iter().all(|d| d.is_finite()) || !geometric.is_finite() {
            return Err(Error::Degenerate(
                "occlusion derivatives overflow for this gather".into(),
            ));
        }
        Ok((out, geometric))
    }
}

/// Stores the value and gradient of the batch's closed-form lanes (flagged lanes are stored when
/// the axial batch or the general kernel evaluates them).
fn keep_terms(terms: &mut [[f64; 4]], q: &Queue, count: usize) {
    let o = &q.batch.out;
    for i in 0..count {
        if q.batch.general[i] == CLOSED_FORM {
            terms[q.index[i] as usize] = [
                o[0][i] * INV_2PI,
                o[1][i] * INV_2PI,
                o[2][i] * INV_2PI,
                o[3][i] * INV_2PI,
            ];
        }
    }
}

fn deriv_of(o: &[f64; OUTPUTS]) -> Deriv3 {
    Deriv3 {
        value: o[0],
        gradient: DVec3::new(o[1], o[2], o[3]),
        hessian: DMat3::from_cols(
            DVec3::new(o[4], o[5], o[6]),
            DVec3::new(o[5], o[7], o[8]),
            DVec3::new(o[6], o[8], o[9]),
        ),
    }
}

/// `acc += lane i` (outputs up to `order`).
fn add_lane(acc: &mut Deriv3, b: &Batch, i: usize, order: Order) {
    let mut o = [0.0; OUTPUTS];
    let used = if order.hessian() { OUTPUTS } else { 4 };
    for (o, out) in o.iter_mut().zip(&b.out).take(used) {
        *o = out[i];
    }
    add_scaled(acc, &deriv_of(&o), 1.0, order);
}

fn add_scaled(acc: &mut Deriv3, d: &Deriv3, w: f64, order: Order) {
    acc.value += w * d.value;
    acc.gradient += d.gradient * w;
    if order.hessian() {
        acc.hessian += d.hessian * w;
    }
}

#[cfg(test)]
mod tests;
