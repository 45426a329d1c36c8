//! The first step of a lookup: the weight of every candidate record at the query (0 for those
//! that do not cover it), and the records with a positive weight.
//!
//! The candidates of a lookup are few (about eight) but each needs a distance, a normal decoded
//! from the record's quaternion and the kernel's weight: two square roots and three divisions. On
//! x86-64 with AVX, four candidates are weighed at once; every lane performs the same IEEE
//! operations in the same order as the scalar code (no fused multiply-add), so the weights are
//! bit for bit those of [`record_weight`] and results do not depend on the CPU.

use glam::DVec3;
use smallvec::SmallVec;

use super::interp::{Interpolation, Kernel, Used, WARD_FLOOR};
use super::record::{Channel, Domain, Head};

/// The candidates with a positive weight, in candidate order.
pub(crate) type UsedRecords<'a> = SmallVec<[Used<'a>; 16]>;

/// Weight and normal of one record at query `x` with unit normal `n` (surface domain; ignored in
/// volumes). The normal is the record's third frame axis (zero for isotropic volume records).
#[inline]
pub(crate) fn record_weight(kernel: &Kernel, head: &Head, x: DVec3, n: DVec3) -> (f64, DVec3) {
    let surface = kernel.domain == Domain::Surface;
    // isotropic records (the common case) need only the normal, not the whole frame
    let scale = kernel.lookup_scale;
    let (t, normal) = if head.is_isotropic() {
        let t = (x - head.position()).length() / (head.radii[0] as f64 * scale);
        (t, if surface { head.axis2() } else { DVec3::ZERO })
    } else {
        let frame = head.frame();
        (head.normalized_distance(&frame, x, scale), frame.0[2])
    };
    let cos_n = if surface { normal.dot(n) } else { 1.0 };
    (
        guarded(kernel, kernel.weight(t, cos_n), x, n, head, normal),
        normal,
    )
}

/// `weight`, or 0 when the kernel's leak guard or open-fraction test refuses the record `head`
/// (unit `normal`) at the query (`x`, `n`).
#[inline(always)]
pub(crate) fn guarded(
    kernel: &Kernel,
    weight: f64,
    x: DVec3,
    n: DVec3,
    head: &Head,
    normal: DVec3,
) -> f64 {
    if weight > 0.0
        && kernel.refuses(
            x,
            n,
            head.position(),
            normal,
            head.radii[2] as f64 * kernel.lookup_scale,
            head.open_fraction,
        )
    {
        0.0
    } else {
        weight
    }
}

/// Appends to `used` every record among `ids` (slot addresses, resolved by `stored`) with a positive weight at
/// (`x`, `n`).
#[inline(always)]
pub(crate) fn weigh<'a>(
    kernel: &Kernel,
    x: DVec3,
    n: DVec3,
    ids: &[usize],
    stored: impl Fn(usize) -> (&'a Head, &'a [Channel]),
    used: &mut UsedRecords<'a>,
) {
    #[cfg(target_arch = "x86_64")]
    if ids.len() >= 2 && crate::simd::avx() {
        // SAFETY: the CPU has AVX (checked just above).
        return unsafe { weigh_avx(kernel, x, n, ids, stored, used) };
    }
    for &id in ids {
        let (head, channels) = stored(id);
        push(used, record_weight(kernel, head, x, n), head, channels);
    }
}

/// Appends the record to `used` if its weight is positive (the covering records).
#[inline(always)]
pub(crate) fn push<'a>(
    used: &mut UsedRecords<'a>,
    (weight, normal): (f64, DVec3),
    head: &'a Head,
    channels: &'a [Channel],
) {
    if weight > 0.0 {
        used.push(Used {
            order: head.position[0].to_bits(),
            weight,
            normal,
            head,
            channels,
        });
    }
}

/// [`weigh`] four candidates at a time.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn weigh_avx<'a>(
    kernel: &Kernel,
    x: DVec3,
    n: DVec3,
    ids: &[usize],
    stored: impl Fn(usize) -> (&'a Head, &'a [Channel]),
    used: &mut UsedRecords<'a>,
) {
    for group in ids.chunks(4) {
        let last = group.len() - 1;
        let records: [(&Head, &[Channel]); 4] = std::array::from_fn(|k| stored(group[k.min(last)]));
        let heads = records.map(|r| r.0);
        // SAFETY: AVX is enabled on this function.
        let (weights, normals) = unsafe { weigh4(kernel, x, n, heads) };
        for (k, &(head, channels)) in records.iter().enumerate().take(group.len()) {
            let lane = if head.is_isotropic() {
                (
                    guarded(kernel, weights[k], x, n, head, normals[k]),
                    normals[k],
                )
            } else {
                record_weight(kernel, head, x, n)
            };
            push(used, lane, head, channels);
        }
    }
}

/// Weights and normals of four isotropic records (lanes of anisotropic records are computed, and
/// replaced by the caller). Same operations, in the same order, as [`record_weight`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn weigh4(kernel: &Kernel, x: DVec3, n: DVec3, h: [&Head; 4]) -> ([f64; 4], [DVec3; 4]) {
    use std::arch::x86_64::*;
    let surface = kernel.domain == Domain::Surface;
    let lanes = |f: &dyn Fn(&Head) -> f64| _mm256_setr_pd(f(h[0]), f(h[1]), f(h[2]), f(h[3]));
    let dx = _mm256_sub_pd(_mm256_set1_pd(x.x), lanes(&|h| h.position[0]));
    let dy = _mm256_sub_pd(_mm256_set1_pd(x.y), lanes(&|h| h.position[1]));
    let dz = _mm256_sub_pd(_mm256_set1_pd(x.z), lanes(&|h| h.position[2]));
    let d2 = _mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)),
        _mm256_mul_pd(dz, dz),
    );
    let radius = _mm256_mul_pd(
        _mm256_cvtps_pd(_mm_setr_ps(
            h[0].radii[0],
            h[1].radii[0],
            h[2].radii[0],
            h[3].radii[0],
        )),
        _mm256_set1_pd(kernel.lookup_scale),
    );
    let t = _mm256_div_pd(_mm256_sqrt_pd(d2), radius);
    let one = _mm256_set1_pd(1.0);
    let zero = _mm256_setzero_pd();
    let (mut ax, mut ay, mut az, cos_n) = (zero, zero, zero, one);
    let cos_n = if surface {
        // the quaternions, one per row, transposed to one component per vector
        let q = h.map(|h| _mm_loadu_ps(h.rotation.as_ptr()));
        let lo01 = _mm_unpacklo_ps(q[0], q[1]); // x0 x1 y0 y1
        let lo23 = _mm_unpacklo_ps(q[2], q[3]);
        let hi01 = _mm_unpackhi_ps(q[0], q[1]); // z0 z1 w0 w1
        let hi23 = _mm_unpackhi_ps(q[2], q[3]);
        let qx = _mm256_cvtps_pd(_mm_movelh_ps(lo01, lo23));
        let qy = _mm256_cvtps_pd(_mm_movehl_ps(lo23, lo01));
        let qz = _mm256_cvtps_pd(_mm_movelh_ps(hi01, hi23));
        let qw = _mm256_cvtps_pd(_mm_movehl_ps(hi23, hi01));
        let (xx, yy) = (_mm256_mul_pd(qx, qx), _mm256_mul_pd(qy, qy));
        let xx_yy = _mm256_add_pd(xx, yy);
        let norm2 = _mm256_add_pd(
            _mm256_add_pd(xx_yy, _mm256_mul_pd(qz, qz)),
            _mm256_mul_pd(qw, qw),
        );
        let s = _mm256_div_pd(_mm256_set1_pd(2.0), norm2);
        ax = _mm256_mul_pd(
            s,
            _mm256_add_pd(_mm256_mul_pd(qx, qz), _mm256_mul_pd(qw, qy)),
        );
        ay = _mm256_mul_pd(
            s,
            _mm256_sub_pd(_mm256_mul_pd(qy, qz), _mm256_mul_pd(qw, qx)),
        );
        az = _mm256_sub_pd(one, _mm256_mul_pd(s, xx_yy));
        _mm256_add_pd(
            _mm256_add_pd(
                _mm256_mul_pd(ax, _mm256_set1_pd(n.x)),
                _mm256_mul_pd(ay, _mm256_set1_pd(n.y)),
            ),
            _mm256_mul_pd(az, _mm256_set1_pd(n.z)),
        )
    } else {
        cos_n
    };
    let weight = kernel_weights(kernel, surface, t, cos_n);
    let store = |v: __m256d| {
        let mut a = [0.0f64; 4];
        _mm256_storeu_pd(a.as_mut_ptr(), v);
        a
    };
    let (ax, ay, az) = (store(ax), store(ay), store(az));
    (
        store(weight),
        std::array::from_fn(|k| DVec3::new(ax[k], ay[k], az[k])),
    )
}

/// Kernel weights (0 where a record does not cover the query) from four normalized distances `t`
/// and normal cosines `cos_n` (ignored in volumes): [`Kernel::weight`] lane by lane, the same
/// operations in the same order.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
pub(crate) fn kernel_weights(
    kernel: &Kernel,
    surface: bool,
    t: std::arch::x86_64::__m256d,
    cos_n: std::arch::x86_64::__m256d,
) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let one = _mm256_set1_pd(1.0);
    let zero = _mm256_setzero_pd();
    match kernel.interpolation {
        Interpolation::Ward | Interpolation::WardClassic | Interpolation::WardTabellion => {
            let rho = if surface {
                _mm256_mul_pd(
                    _mm256_sqrt_pd(_mm256_max_pd(_mm256_sub_pd(one, cos_n), zero)),
                    _mm256_set1_pd(kernel.inv_a),
                )
            } else {
                zero
            };
            let s = _mm256_add_pd(t, rho);
            let covers = _mm256_cmp_pd::<_CMP_LT_OQ>(s, one);
            let inv = || _mm256_div_pd(one, _mm256_max_pd(s, _mm256_set1_pd(WARD_FLOOR)));
            let w = match kernel.interpolation {
                Interpolation::Ward => _mm256_sub_pd(inv(), one),
                Interpolation::WardClassic => inv(),
                _ => _mm256_sub_pd(one, s),
            };
            _mm256_and_pd(w, covers)
        }
        Interpolation::Tent | Interpolation::Cubic | Interpolation::Log => {
            let mut covers = _mm256_cmp_pd::<_CMP_LT_OQ>(t, one);
            let kn = if surface {
                let cos_max = _mm256_set1_pd(kernel.cos_max);
                covers = _mm256_and_pd(covers, _mm256_cmp_pd::<_CMP_GT_OQ>(cos_n, cos_max));
                _mm256_min_pd(
                    _mm256_div_pd(_mm256_sub_pd(cos_n, cos_max), _mm256_sub_pd(one, cos_max)),
                    one,
                )
            } else {
                one
            };
            let d = _mm256_sub_pd(one, t);
            let kx = if kernel.interpolation == Interpolation::Tent {
                d
            } else {
                _mm256_mul_pd(
                    _mm256_mul_pd(d, d),
                    _mm256_sub_pd(_mm256_set1_pd(3.0), _mm256_mul_pd(_mm256_set1_pd(2.0), d)),
                )
            };
            _mm256_and_pd(_mm256_mul_pd(kx, kn), covers)
        }
    }
}

#[cfg(test)]
mod tests;
