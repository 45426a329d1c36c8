//! The last step of a linear-space lookup: Σᵢ wᵢ (Eᵢ + Δxᵢ·∇ₜEᵢ + (nᵢ×n)·∇ᵣEᵢ) / Σᵢ wᵢ over the
//! covering records, every channel.
//!
//! The arithmetic is fixed so that every CPU gives the same bits:
//! * per record, the offsets qₖ = (Δx·sₜ, (nᵢ×n)·sᵣ) (sₜ, sᵣ the record's gradient scales) are
//!   computed in `f64`, clamped to ±[`Q_MAX`] and rounded to `f32`;
//! * per channel, with pₖ = qₖ·hₖ in `f32` (hₖ the six stored binary16 components: translational
//!   0-2, rotational 3-5), the extrapolation is δ = (p₂ + (p₀ + p₄)) + (p₃ + (p₁ + p₅)) in `f32`;
//! * the k-th record of the list (content order) is accumulated, in `f64`, into lane k mod 4:
//!   aₗ += wᵢ·(Eᵢ + δ); the result is ((a₀ + a₁) + (a₂ + a₃)) / Σwᵢ, clamped to the `f32` range.
//!
//! That order is what four records at a time in AVX registers compute (F16C converts the binary16
//! components); the portable code performs the same operations one record at a time.

use glam::DVec3;

use super::interp::Used;
use super::record::{f16_to_f64, Channel};

/// Accumulation lanes (records at a time in the vector code).
const LANES: usize = 4;

/// Bound of the offsets qₖ: six products qₖhₖ (|hₖ| ≤ 1) then sum to less than `f32::MAX`, so the
/// extrapolation is always finite.
const Q_MAX: f64 = f32::MAX as f64 / 8.0;

const F32_MAX: f64 = f32::MAX as f64;

/// Channel accumulators kept on the stack up to this many channels.
const STACK_CHANNELS: usize = 16;

/// Writes the blend of `used` (content order, weights summing to `weight_sum` > 0) at query `x`
/// with unit normal `n` (`surface`: whether the rotational term applies) into `out`.
pub(crate) fn blend_linear(
    surface: bool,
    used: &[Used<'_>],
    weight_sum: f64,
    x: DVec3,
    n: DVec3,
    out: &mut [f32],
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") && std::arch::is_x86_feature_detected!("f16c") {
        // SAFETY: the CPU has AVX and F16C (checked just above).
        return unsafe { blend_avx(surface, used, weight_sum, x, n, out) };
    }
    blend_portable(surface, used, weight_sum, x, n, out)
}

/// The offsets qₖ of one record, rounded to `f32` (see the module docs).
#[inline(always)]
fn offsets(surface: bool, u: &Used<'_>, x: DVec3, n: DVec3) -> [f32; 6] {
    let gs = u.head.gradient_scale as f64;
    let d = x - u.head.position();
    let t = [d.x * gs, d.y * gs, d.z * gs];
    let r = if surface {
        let rs = u.head.rotation_scale as f64;
        let c = u.normal.cross(n);
        [c.x * rs, c.y * rs, c.z * rs]
    } else {
        [0.0; 3]
    };
    // min then max, not clamp: a NaN (an infinite offset times a zero scale) becomes Q_MAX, as
    // in the vector code, instead of propagating
    #[allow(clippy::manual_clamp)]
    [t[0], t[1], t[2], r[0], r[1], r[2]].map(|v| v.min(Q_MAX).max(-Q_MAX) as f32)
}

/// δ of one channel (see the module docs).
#[inline(always)]
fn extrapolation(ch: &Channel, q: &[f32; 6]) -> f32 {
    let h = |b: u16| f16_to_f64(b) as f32; // exact: binary16 ⊂ binary32
    let p = [
        q[0] * h(ch.gradient[0]),
        q[1] * h(ch.gradient[1]),
        q[2] * h(ch.gradient[2]),
        q[3] * h(ch.rotation[0]),
        q[4] * h(ch.rotation[1]),
        q[5] * h(ch.rotation[2]),
    ];
    (p[2] + (p[0] + p[4])) + (p[3] + (p[1] + p[5]))
}

/// ((a₀ + a₁) + (a₂ + a₃)) / Σw, clamped to the `f32` range.
#[inline(always)]
fn finish(acc: [f64; LANES], inv_sum: f64) -> f32 {
    (((acc[0] + acc[1]) + (acc[2] + acc[3])) * inv_sum).clamp(-F32_MAX, F32_MAX) as f32
}

/// Record at a time: the reference for the vector code and the path of CPUs without AVX/F16C.
pub(crate) fn blend_portable(
    surface: bool,
    used: &[Used<'_>],
    weight_sum: f64,
    x: DVec3,
    n: DVec3,
    out: &mut [f32],
) {
    let mut stack = [[0.0f64; LANES]; STACK_CHANNELS];
    let mut heap = Vec::new();
    let acc: &mut [[f64; LANES]] = if out.len() <= STACK_CHANNELS {
        &mut stack[..out.len()]
    } else {
        heap.resize(out.len(), [0.0; LANES]);
        &mut heap
    };
    for (k, u) in used.iter().enumerate() {
        let q = offsets(surface, u, x, n);
        for (a, ch) in acc.iter_mut().zip(u.channels) {
            a[k % LANES] += u.weight * (ch.value as f64 + extrapolation(ch, &q) as f64);
        }
    }
    let inv_sum = 1.0 / weight_sum;
    for (o, a) in out.iter_mut().zip(acc.iter()) {
        *o = finish(*a, inv_sum);
    }
}

/// Four records at a time (AVX, F16C), the same operations as [`blend_portable`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,f16c")]
unsafe fn blend_avx(
    surface: bool,
    used: &[Used<'_>],
    weight_sum: f64,
    x: DVec3,
    n: DVec3,
    out: &mut [f32],
) {
    use std::arch::x86_64::*;
    let channels = out.len();
    let mut stack = [_mm256_setzero_pd(); STACK_CHANNELS];
    let mut heap = Vec::new();
    let acc: &mut [__m256d] = if channels <= STACK_CHANNELS {
        &mut stack[..channels]
    } else {
        heap.resize(channels, _mm256_setzero_pd());
        &mut heap
    };
    // every record has `channels` channels (the cache's count): the loads below rely on it
    assert!(used.iter().all(|u| u.channels.len() == channels));
    for group in used.chunks(LANES) {
        let last = group.len() - 1;
        // lanes past the group's end repeat its last record and are masked out
        let r: [&Used; LANES] = std::array::from_fn(|k| &group[k.min(last)]);
        let valid = _mm256_castsi256_pd(_mm256_setr_epi64x(
            -1,
            -((last >= 1) as i64),
            -((last >= 2) as i64),
            -((last >= 3) as i64),
        ));
        let w = lanes_pd(&r, |u| u.weight);
        let gs = _mm256_cvtps_pd(lanes_ps(&r, |u| u.head.gradient_scale));
        let tx = _mm256_sub_pd(_mm256_set1_pd(x.x), lanes_pd(&r, |u| u.head.position[0]));
        let ty = _mm256_sub_pd(_mm256_set1_pd(x.y), lanes_pd(&r, |u| u.head.position[1]));
        let tz = _mm256_sub_pd(_mm256_set1_pd(x.z), lanes_pd(&r, |u| u.head.position[2]));
        let t = [
            clamp_round(_mm256_mul_pd(tx, gs)),
            clamp_round(_mm256_mul_pd(ty, gs)),
            clamp_round(_mm256_mul_pd(tz, gs)),
        ];
        let rot = if surface {
            let rs = _mm256_cvtps_pd(lanes_ps(&r, |u| u.head.rotation_scale));
            let ux = lanes_pd(&r, |u| u.normal.x);
            let uy = lanes_pd(&r, |u| u.normal.y);
            let uz = lanes_pd(&r, |u| u.normal.z);
            let (nx, ny, nz) = (
                _mm256_set1_pd(n.x),
                _mm256_set1_pd(n.y),
                _mm256_set1_pd(n.z),
            );
            // glam's cross product, operand for operand
            let c = [
                _mm256_sub_pd(_mm256_mul_pd(uy, nz), _mm256_mul_pd(ny, uz)),
                _mm256_sub_pd(_mm256_mul_pd(uz, nx), _mm256_mul_pd(nz, ux)),
                _mm256_sub_pd(_mm256_mul_pd(ux, ny), _mm256_mul_pd(nx, uy)),
            ];
            [
                clamp_round(_mm256_mul_pd(c[0], rs)),
                clamp_round(_mm256_mul_pd(c[1], rs)),
                clamp_round(_mm256_mul_pd(c[2], rs)),
            ]
        } else {
            [_mm_setzero_ps(); 3]
        };
        // offsets paired as the transposed halves below: [q0 | q1], [q2 | q3], [q4 | q5]
        let q01 = _mm256_set_m128(t[1], t[0]);
        let q23 = _mm256_set_m128(rot[0], t[2]);
        let q45 = _mm256_set_m128(rot[2], rot[1]);
        let base = r.map(|u| u.channels.as_ptr() as *const __m128i);
        for (c, a) in acc.iter_mut().enumerate() {
            // SAFETY: c < channels = every record's channel count (asserted above); a `Channel` is
            // 16 bytes: value (binary16 slots 0-1), gradient (2-4), rotation (5-7).
            let (h0, h1, h2, h3) = unsafe {
                (
                    _mm_loadu_si128(base[0].add(c)),
                    _mm_loadu_si128(base[1].add(c)),
                    _mm_loadu_si128(base[2].add(c)),
                    _mm_loadu_si128(base[3].add(c)),
                )
            };
            let lo01 = _mm_unpacklo_epi16(h0, h1);
            let lo23 = _mm_unpacklo_epi16(h2, h3);
            let hi01 = _mm_unpackhi_epi16(h0, h1);
            let hi23 = _mm_unpackhi_epi16(h2, h3);
            // one binary16 slot per half vector, the four records across it
            let g0g1 = _mm256_cvtph_ps(_mm_unpackhi_epi32(lo01, lo23));
            let g2r0 = _mm256_cvtph_ps(_mm_unpacklo_epi32(hi01, hi23));
            let r1r2 = _mm256_cvtph_ps(_mm_unpackhi_epi32(hi01, hi23));
            let p01 = _mm256_mul_ps(g0g1, q01);
            let p23 = _mm256_mul_ps(g2r0, q23);
            let p45 = _mm256_mul_ps(r1r2, q45);
            let s = _mm256_add_ps(p23, _mm256_add_ps(p01, p45));
            let delta = _mm_add_ps(_mm256_castps256_ps128(s), _mm256_extractf128_ps(s, 1));
            // the values (first 32 bits of each channel), records across the vector
            let value = _mm_castsi128_ps(_mm_unpacklo_epi64(
                _mm_unpacklo_epi32(h0, h1),
                _mm_unpacklo_epi32(h2, h3),
            ));
            let term = _mm256_add_pd(_mm256_cvtps_pd(value), _mm256_cvtps_pd(delta));
            *a = _mm256_add_pd(*a, _mm256_and_pd(_mm256_mul_pd(w, term), valid));
        }
    }
    let inv_sum = 1.0 / weight_sum;
    for (o, a) in out.iter_mut().zip(acc.iter()) {
        let mut lanes = [0.0f64; LANES];
        _mm256_storeu_pd(lanes.as_mut_ptr(), *a);
        *o = finish(lanes, inv_sum);
    }
}

/// One `f64` per record, the records across the vector.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn lanes_pd(r: &[&Used<'_>; LANES], f: impl Fn(&Used<'_>) -> f64) -> std::arch::x86_64::__m256d {
    std::arch::x86_64::_mm256_setr_pd(f(r[0]), f(r[1]), f(r[2]), f(r[3]))
}

/// One `f32` per record, the records across the vector.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn lanes_ps(r: &[&Used<'_>; LANES], f: impl Fn(&Used<'_>) -> f32) -> std::arch::x86_64::__m128 {
    std::arch::x86_64::_mm_setr_ps(f(r[0]), f(r[1]), f(r[2]), f(r[3]))
}

/// Clamps to ±[`Q_MAX`] and rounds to `f32`, as [`offsets`] does (`min` then `max`: a NaN lane
/// would become `Q_MAX` in both).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn clamp_round(v: std::arch::x86_64::__m256d) -> std::arch::x86_64::__m128 {
    use std::arch::x86_64::*;
    _mm256_cvtpd_ps(_mm256_max_pd(
        _mm256_min_pd(v, _mm256_set1_pd(Q_MAX)),
        _mm256_set1_pd(-Q_MAX),
    ))
}
