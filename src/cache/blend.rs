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

use std::marker::PhantomData;

use glam::DVec3;
use smallvec::SmallVec;

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

/// Four covering records, one per lane, as the blend reads them (structure of arrays, so that
/// the vector code loads each quantity of four records at once).
#[derive(Debug, Clone, Copy)]
struct Lanes {
    weight: [f64; LANES],
    position: [[f64; LANES]; 3],
    /// The record's unit normal (surface domain; unused in volumes).
    normal: [[f64; LANES]; 3],
    gradient_scale: [f32; LANES],
    rotation_scale: [f32; LANES],
    /// The records' first channels (null in the unused lanes of the last block).
    channels: [*const Channel; LANES],
}

impl Default for Lanes {
    fn default() -> Self {
        Self {
            weight: [0.0; LANES],
            position: [[0.0; LANES]; 3],
            normal: [[0.0; LANES]; 3],
            gradient_scale: [0.0; LANES],
            rotation_scale: [0.0; LANES],
            channels: [std::ptr::null(); LANES],
        }
    }
}

/// The covering records of one lookup in content order, the k-th in lane k mod 4 of block k / 4,
/// with the sum of their weights (added in the same order).
pub(crate) struct Covering<'a> {
    blocks: SmallVec<[Lanes; 4]>,
    len: usize,
    channels: usize,
    weight_sum: f64,
    /// The channels pointed to are borrowed from the cache for `'a`.
    records: PhantomData<&'a [Channel]>,
}

impl<'a> Covering<'a> {
    /// An empty list for records of `channels` channels.
    #[inline]
    pub(crate) fn new(channels: usize) -> Self {
        Self {
            blocks: SmallVec::new(),
            len: 0,
            channels,
            weight_sum: 0.0,
            records: PhantomData,
        }
    }

    /// Appends a record (the next in content order) with its weight at the query, position,
    /// unit normal, gradient scales and channels.
    #[inline(always)]
    pub(crate) fn push(
        &mut self,
        weight: f64,
        position: [f64; 3],
        normal: [f64; 3],
        (gradient_scale, rotation_scale): (f32, f32),
        channels: &'a [Channel],
    ) {
        // the blend reads `self.channels` channels behind every pointer
        assert_eq!(channels.len(), self.channels);
        let lane = self.len % LANES;
        if lane == 0 {
            self.blocks.push(Lanes::default());
        }
        let Some(b) = self.blocks.last_mut() else {
            return;
        };
        b.weight[lane] = weight;
        for i in 0..3 {
            b.position[i][lane] = position[i];
            b.normal[i][lane] = normal[i];
        }
        b.gradient_scale[lane] = gradient_scale;
        b.rotation_scale[lane] = rotation_scale;
        b.channels[lane] = channels.as_ptr();
        self.len += 1;
        self.weight_sum += weight;
    }

    /// Appends the records of `used` (the next ones in content order).
    pub(crate) fn extend_from_used(&mut self, used: &[Used<'a>]) {
        for u in used {
            self.push(
                u.weight,
                u.head.position,
                u.normal.to_array(),
                (u.head.gradient_scale, u.head.rotation_scale),
                u.channels,
            );
        }
    }

    /// The records of `used` (in content order).
    pub(crate) fn from_used(used: &[Used<'a>], channels: usize) -> Self {
        let mut covering = Self::new(channels);
        covering.extend_from_used(used);
        covering
    }

    /// Number of records.
    #[inline]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Σ wᵢ, added in content order.
    #[inline]
    pub(crate) fn weight_sum(&self) -> f64 {
        self.weight_sum
    }

    /// The k-th record: (block, lane).
    #[inline(always)]
    fn record(&self, k: usize) -> (&Lanes, usize) {
        (&self.blocks[k / LANES], k % LANES)
    }
}

/// Writes the blend of `covering` (weights summing to `covering.weight_sum()` > 0) at query `x`
/// with unit normal `n` (`surface`: whether the rotational term applies) into `out` (one float
/// per channel, as many as the records have). Each record's extrapolated value is raised to at
/// least `floor` (0, or −∞ for none) before it is weighted.
pub(crate) fn blend_linear(
    surface: bool,
    covering: &Covering<'_>,
    x: DVec3,
    n: DVec3,
    floor: f64,
    out: &mut [f32],
) {
    assert_eq!(out.len(), covering.channels);
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx_f16c() {
        let groups = covering.blocks.len();
        let query = BlendQuery {
            surface,
            x,
            n,
            floor,
        };
        // SAFETY: the CPU has AVX and F16C (checked just above); `push` checked that every
        // record has `out.len()` channels.
        return unsafe {
            blend_avx(&query, groups, covering.weight_sum, out, |i| {
                GroupInputs::of_lanes(&covering.blocks[i], (covering.len - i * LANES).min(LANES))
            })
        };
    }
    blend_portable(surface, covering, x, n, floor, out)
}

/// [`blend_linear`] of the records `used` (in content order, weights summing to `weight_sum`
/// > 0): the same operations, gathering each record's data from its `Used` entry.
pub(crate) fn blend_linear_used(
    surface: bool,
    used: &[Used<'_>],
    weight_sum: f64,
    x: DVec3,
    n: DVec3,
    floor: f64,
    out: &mut [f32],
) {
    let channels = out.len();
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx_f16c() {
        // every record has `channels` channels (the cache's count): the loads rely on it
        assert!(used.iter().all(|u| u.channels.len() == channels));
        let groups = used.len().div_ceil(LANES);
        let query = BlendQuery {
            surface,
            x,
            n,
            floor,
        };
        // SAFETY: the CPU has AVX and F16C (checked just above); channel counts checked above.
        return unsafe {
            blend_avx(&query, groups, weight_sum, out, |i| {
                GroupInputs::of_used(&used[i * LANES..used.len().min(i * LANES + LANES)])
            })
        };
    }
    blend_portable(
        surface,
        &Covering::from_used(used, channels),
        x,
        n,
        floor,
        out,
    )
}

/// The offsets qₖ of lane `l` of `b`, rounded to `f32` (see the module docs).
#[inline(always)]
fn offsets(surface: bool, b: &Lanes, l: usize, x: DVec3, n: DVec3) -> [f32; 6] {
    let gs = b.gradient_scale[l] as f64;
    let d = x - DVec3::new(b.position[0][l], b.position[1][l], b.position[2][l]);
    let t = [d.x * gs, d.y * gs, d.z * gs];
    let r = if surface {
        let rs = b.rotation_scale[l] as f64;
        let c = DVec3::new(b.normal[0][l], b.normal[1][l], b.normal[2][l]).cross(n);
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
    covering: &Covering<'_>,
    x: DVec3,
    n: DVec3,
    floor: f64,
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
    for k in 0..covering.len() {
        let (b, l) = covering.record(k);
        let q = offsets(surface, b, l, x, n);
        // SAFETY: `push` checked that the record has `covering.channels` = `out.len()` channels,
        // borrowed for the covering's lifetime.
        let channels = unsafe { std::slice::from_raw_parts(b.channels[l], out.len()) };
        for (a, ch) in acc.iter_mut().zip(channels) {
            let term = ch.value as f64 + extrapolation(ch, &q) as f64;
            // `vmaxpd`'s operation (`max` leaves the sign of a zero unspecified)
            let term = if term > floor { term } else { floor };
            a[l] += b.weight[l] * term;
        }
    }
    let inv_sum = 1.0 / covering.weight_sum();
    for (o, a) in out.iter_mut().zip(acc.iter()) {
        *o = finish(*a, inv_sum);
    }
}

/// One group of up to four records, the records across the vectors (f64 lanes).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct GroupInputs {
    /// Records in the group (1-4); the other lanes are masked out.
    count: usize,
    weight: std::arch::x86_64::__m256d,
    position: [std::arch::x86_64::__m256d; 3],
    normal: [std::arch::x86_64::__m256d; 3],
    gradient_scale: std::arch::x86_64::__m256d,
    rotation_scale: std::arch::x86_64::__m256d,
    /// The records' first channels (unused lanes repeat a valid record).
    channels: [*const Channel; LANES],
}

#[cfg(target_arch = "x86_64")]
impl GroupInputs {
    /// From a block of [`Covering`]: one load per quantity.
    #[target_feature(enable = "avx")]
    #[inline]
    fn of_lanes(b: &Lanes, count: usize) -> Self {
        use std::arch::x86_64::*;
        let load = |a: &[f64; LANES]| {
            // SAFETY: four f64 (unaligned load).
            unsafe { _mm256_loadu_pd(a.as_ptr()) }
        };
        let load_ps = |a: &[f32; LANES]| {
            // SAFETY: four f32 (unaligned load).
            unsafe { _mm256_cvtps_pd(_mm_loadu_ps(a.as_ptr())) }
        };
        Self {
            count,
            weight: load(&b.weight),
            position: b.position.each_ref().map(load),
            normal: b.normal.each_ref().map(load),
            gradient_scale: load_ps(&b.gradient_scale),
            rotation_scale: load_ps(&b.rotation_scale),
            channels: std::array::from_fn(|k| b.channels[if k < count { k } else { 0 }]),
        }
    }

    /// From 1-4 `Used` entries: one gather per quantity.
    #[target_feature(enable = "avx")]
    #[inline]
    fn of_used(group: &[Used<'_>]) -> Self {
        use std::arch::x86_64::*;
        let last = group.len() - 1;
        // lanes past the group's end repeat its last record (masked out)
        let r: [&Used; LANES] = std::array::from_fn(|k| &group[k.min(last)]);
        let pd = |f: &dyn Fn(&Used) -> f64| _mm256_setr_pd(f(r[0]), f(r[1]), f(r[2]), f(r[3]));
        let ps = |f: &dyn Fn(&Used) -> f32| {
            _mm256_cvtps_pd(_mm_setr_ps(f(r[0]), f(r[1]), f(r[2]), f(r[3])))
        };
        Self {
            count: group.len(),
            weight: pd(&|u| u.weight),
            position: [
                pd(&|u| u.head.position[0]),
                pd(&|u| u.head.position[1]),
                pd(&|u| u.head.position[2]),
            ],
            normal: [
                pd(&|u| u.normal.x),
                pd(&|u| u.normal.y),
                pd(&|u| u.normal.z),
            ],
            gradient_scale: ps(&|u| u.head.gradient_scale),
            rotation_scale: ps(&|u| u.head.rotation_scale),
            channels: r.map(|u| u.channels.as_ptr()),
        }
    }
}

/// Where and how [`blend_avx`] blends: the query point and unit normal, whether the rotational
/// term applies, and the floor of each record's extrapolated value.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct BlendQuery {
    surface: bool,
    x: DVec3,
    n: DVec3,
    floor: f64,
}

/// Four records at a time (AVX, F16C), the same operations as [`blend_portable`]; `group(i)`
/// gives the i-th of `groups` groups (records 4i..4i+4 in content order).
///
/// # Safety
/// The CPU must have AVX and F16C, and every record's channel pointer must point to `out.len()`
/// channels.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,f16c")]
#[inline]
unsafe fn blend_avx(
    query: &BlendQuery,
    groups: usize,
    weight_sum: f64,
    out: &mut [f32],
    group: impl Fn(usize) -> GroupInputs,
) {
    use std::arch::x86_64::*;
    let BlendQuery {
        surface,
        x,
        n,
        floor,
    } = *query;
    let channels = out.len();
    // max(term, floor) as f64::max: the term (finite) unless the floor is larger
    let floor_lanes = _mm256_set1_pd(floor);
    let mut stack = [_mm256_setzero_pd(); STACK_CHANNELS];
    let mut heap = Vec::new();
    let acc: &mut [__m256d] = if channels <= STACK_CHANNELS {
        &mut stack[..channels]
    } else {
        heap.resize(channels, _mm256_setzero_pd());
        &mut heap
    };
    for i in 0..groups {
        let g = group(i);
        let valid = _mm256_castsi256_pd(_mm256_setr_epi64x(
            -1,
            -((g.count > 1) as i64),
            -((g.count > 2) as i64),
            -((g.count > 3) as i64),
        ));
        let gs = g.gradient_scale;
        let t = [
            clamp_round(_mm256_mul_pd(
                _mm256_sub_pd(_mm256_set1_pd(x.x), g.position[0]),
                gs,
            )),
            clamp_round(_mm256_mul_pd(
                _mm256_sub_pd(_mm256_set1_pd(x.y), g.position[1]),
                gs,
            )),
            clamp_round(_mm256_mul_pd(
                _mm256_sub_pd(_mm256_set1_pd(x.z), g.position[2]),
                gs,
            )),
        ];
        let rot = if surface {
            let rs = g.rotation_scale;
            let [ux, uy, uz] = g.normal;
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
        let base = g.channels.map(|p| p as *const __m128i);
        for (c, a) in acc.iter_mut().enumerate() {
            // SAFETY: c < channels, each record's channel count (the caller's contract); a
            // `Channel` is 16 bytes: value (binary16 slots 0-1), gradient (2-4), rotation (5-7).
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
            let term = _mm256_max_pd(
                _mm256_add_pd(_mm256_cvtps_pd(value), _mm256_cvtps_pd(delta)),
                floor_lanes,
            );
            *a = _mm256_add_pd(*a, _mm256_and_pd(_mm256_mul_pd(g.weight, term), valid));
        }
    }
    let inv_sum = 1.0 / weight_sum;
    for (o, a) in out.iter_mut().zip(acc.iter()) {
        let mut lanes = [0.0f64; LANES];
        _mm256_storeu_pd(lanes.as_mut_ptr(), *a);
        *o = finish(lanes, inv_sum);
    }
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
