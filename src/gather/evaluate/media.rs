//! The terms a participating medium adds to a gather (Jarosz et al. 2008): each stratum's
//! surface radiance attenuated by the transmittance to its hit, plus the medium's radiance
//! marched along the stratum's ray, and the gradients of both (eq. 14-18, 22-26). Only gathers
//! with `sigma_t > 0` or media radiance reach this module; surface gathers skip it.

use glam::DVec3;

use crate::error::Result;
use crate::gather::input::{GatherInput, MediaRadiance};
use crate::{kernels, Order};

/// A gather's input and its per-stratum weight, for the media terms.
pub(super) struct MediaTerms<'g, 'a> {
    pub(super) input: &'g GatherInput<'a>,
    /// The weight of each stratum's radiance in the irradiance (or fluence).
    pub(super) weight: f64,
}

impl MediaTerms<'_, '_> {
    /// Multiplies each stratum's radiance by the transmittance to its hit (zero for a miss); with
    /// `want_gradient`, sets `gradient` to the cell-radiance gradient `weight · Σ ∇T·L` (eq.
    /// 17-18), one vector per channel.
    pub(super) fn attenuate(
        &self,
        rad: &mut [f64],
        want_gradient: bool,
        gradient: &mut Vec<DVec3>,
    ) -> Result<()> {
        let ch = self.input.channels;
        let sigma = self.input.sigma_t;
        let order = if want_gradient {
            *gradient = vec![DVec3::ZERO; ch];
            Order::Gradient
        } else {
            Order::Value
        };
        let weight = self.weight;
        for ((&r, &w), cell) in self
            .input
            .distance
            .iter()
            .zip(self.input.directions)
            .zip(rad.chunks_exact_mut(ch))
        {
            if r.is_infinite() {
                cell.fill(0.0);
                continue;
            }
            // Translation invariance: x at the origin keeps r exact however far x is from 0.
            let y = w * r;
            let d = -y;
            let m = d.abs().max_element();
            let lean = (1e-150..1e150).contains(&m).then(|| {
                // kernels::transmittance's own arithmetic for ordinary distances, inlined.
                let dist = d.length();
                let t = (-sigma * dist).exp();
                (t, (-sigma * t) * (d / dist))
            });
            let (t, grad) = match lean {
                Some((t, g)) if g.is_finite() => (t, g),
                // Extreme distances (and its overflow error): the kernel itself.
                _ => {
                    let d = kernels::transmittance(DVec3::ZERO, y, sigma, order)?;
                    (d.value, d.gradient)
                }
            };
            if want_gradient && t != 0.0 {
                for (g, &l) in gradient.iter_mut().zip(cell.iter()) {
                    *g += grad * (weight * l);
                }
            }
            for l in cell {
                *l *= t;
            }
        }
        Ok(())
    }

    /// Adds the media radiance reaching x through each stratum, `Σ_s Q_s ∫ T dt` over the visible
    /// part of each step, to `rad`. With `want_gradient`, adds `weight · Σ_i ∇L_m,i` to `gradient`
    /// (sized to the channels first if empty): the gradient of each stratum's segment integral
    /// with its hit point held fixed (the Ward-Heckbert assumption), so that together with the
    /// wall terms on the total radiance the visibility gradient of surfaces occluding the medium
    /// (Jarosz 2008 eq. 22-26) appears at silhouettes, and nowhere else.
    pub(super) fn add_media(
        &self,
        rad: &mut [f64],
        media: &MediaRadiance<'_>,
        march: &March,
        want_gradient: bool,
        gradient: &mut Vec<DVec3>,
    ) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx2() {
            // SAFETY: the CPU has AVX2. (No FMA: results are bitwise those of the SSE2 build.)
            return unsafe { self.add_media_avx2(rad, media, march, want_gradient, gradient) };
        }
        self.add_media_any(rad, media, march, want_gradient, gradient)
    }

    /// [`MediaTerms::add_media`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn add_media_avx2(
        &self,
        rad: &mut [f64],
        media: &MediaRadiance<'_>,
        march: &March,
        want_gradient: bool,
        gradient: &mut Vec<DVec3>,
    ) {
        self.add_media_any(rad, media, march, want_gradient, gradient)
    }

    #[inline(always)]
    fn add_media_any(
        &self,
        rad: &mut [f64],
        media: &MediaRadiance<'_>,
        march: &March,
        want_gradient: bool,
        gradient: &mut Vec<DVec3>,
    ) {
        // Constant channel counts for the common cases, so the per-step loops unroll.
        match self.input.channels {
            1 => self.add_media_channels(rad, media, march, want_gradient, gradient, 1),
            3 => self.add_media_channels(rad, media, march, want_gradient, gradient, 3),
            ch => self.add_media_channels(rad, media, march, want_gradient, gradient, ch),
        }
    }

    /// [`MediaTerms::add_media`] for `ch` channels. Per stratum, the step weights of the visible
    /// part are computed once and shared by the channels, and the per-step terms are summed
    /// before the direction-dependent factors are applied:
    /// `Σ_s ω (q_s a_s / r) = ω (Σ_s q_s a_s) / r` and
    /// `Σ_s [∇q_s i0_s − (∇q_s − ω(ω·∇q_s)) i1_s / r] = Σ_s ∇q_s (i0_s − i1_s/r) + ω (ω·Σ_s ∇q_s i1_s) / r`.
    #[inline(always)]
    fn add_media_channels(
        &self,
        rad: &mut [f64],
        media: &MediaRadiance<'_>,
        march: &March,
        want_gradient: bool,
        gradient: &mut Vec<DVec3>,
        ch: usize,
    ) {
        let steps = media.steps;
        let weight = self.weight;
        if want_gradient && gradient.is_empty() {
            *gradient = vec![DVec3::ZERO; ch];
        }
        // Step weights of one stratum: ∫T, ∫T − σ∫tT, ∫T − ∫tT/r, ∫tT over the visible steps.
        let mut w0: Vec<f64> = march.full.iter().map(|w| w.0).collect();
        let mut w1: Vec<f64> = march.full.iter().map(|w| w.1).collect();
        let (mut wa, mut wg) = (vec![0.0; steps], vec![0.0; steps]);
        let mut total = vec![DVec3::ZERO; ch];
        for (i, (&r, &w)) in self
            .input
            .distance
            .iter()
            .zip(self.input.directions)
            .enumerate()
        {
            let used = march.weights(r, &mut w0, &mut w1);
            let visible = used.0;
            if visible == 0 {
                continue;
            }
            self.media_stratum(
                &mut rad[i * ch..(i + 1) * ch],
                media,
                march,
                want_gradient,
                (i, r, w),
                (&w0[..visible], &w1[..visible]),
                (&mut wa, &mut wg),
                &mut total,
                ch,
            );
            march.restore(&mut w0, &mut w1, used);
        }
        if want_gradient {
            for (g, t) in gradient.iter_mut().zip(total) {
                *g += t * weight;
            }
        }
    }

    /// The media terms of stratum `i` (see [`MediaTerms::add_media_channels`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn media_stratum(
        &self,
        rad: &mut [f64],
        media: &MediaRadiance<'_>,
        march: &March,
        grad: bool,
        (i, r, w): (usize, f64, DVec3),
        (w0, w1): (&[f64], &[f64]),
        (wa, wg): (&mut [f64], &mut [f64]),
        total: &mut [DVec3],
        ch: usize,
    ) {
        const GROUP: usize = 4;
        let (steps, end, sigma) = (media.steps, march.end(), march.sigma);
        let visible = w0.len();
        let q = &media.radiance[i * steps * ch..(i * steps + visible) * ch];
        let inv_r = if r.is_finite() { 1.0 / r } else { 0.0 };
        let hit_inside = r <= end;
        if grad {
            for ((a, g), (&i0, &i1)) in wa.iter_mut().zip(wg.iter_mut()).zip(w0.iter().zip(w1)) {
                *a = i0 - sigma * i1;
                *g = i0 - i1 * inv_r;
            }
        }
        let (wa, wg) = (&wa[..visible], &wg[..visible]);
        for c0 in (0..ch).step_by(GROUP) {
            let cw = GROUP.min(ch - c0);
            let mut e = [0.0; GROUP];
            for (q, &i0) in q.chunks_exact(ch).zip(w0) {
                for (e, &q) in e.iter_mut().zip(&q[c0..c0 + cw]) {
                    *e += q as f64 * i0;
                }
            }
            for (l, e) in rad[c0..c0 + cw].iter_mut().zip(e) {
                *l += e;
            }
            if !grad {
                continue;
            }
            let total = &mut total[c0..c0 + cw];
            if hit_inside {
                let mut a = [0.0; GROUP];
                for (q, &wa) in q.chunks_exact(ch).zip(wa) {
                    for (a, &q) in a.iter_mut().zip(&q[c0..c0 + cw]) {
                        *a += q as f64 * wa;
                    }
                }
                // d/dx of ∫_0^r e^{-σt} Q dt with the far end fixed (s-parametrization).
                for (t, a) in total.iter_mut().zip(a) {
                    *t -= w * (a * inv_r);
                }
            }
            let Some(gq) = media.gradient else {
                continue;
            };
            let gq = &gq[i * steps * ch * 3..(i * steps + visible) * ch * 3];
            // ∇q of the group's channels, flat: [3·c + axis].
            let mut g = [0.0; 3 * GROUP];
            for (gq, &cg) in gq.chunks_exact(3 * ch).zip(wg) {
                for (g, &v) in g.iter_mut().zip(&gq[3 * c0..3 * (c0 + cw)]) {
                    *g += v as f64 * cg;
                }
            }
            let mut h = [0.0; 3 * GROUP];
            if !hit_inside {
                for (gq, &i1) in gq.chunks_exact(3 * ch).zip(w1) {
                    for (h, &v) in h.iter_mut().zip(&gq[3 * c0..3 * (c0 + cw)]) {
                        *h += v as f64 * i1;
                    }
                }
            }
            for ((t, g), h) in total
                .iter_mut()
                .zip(g.chunks_exact(3))
                .zip(h.chunks_exact(3))
            {
                *t += DVec3::from_slice(g);
                if !hit_inside {
                    // Hit beyond the march (or a miss): the marched points keep their depth
                    // t and turn with the direction to the fixed hit, dω/dx = −(I − ωωᵀ)/r.
                    *t += w * (w.dot(DVec3::from_slice(h)) * inv_r);
                }
            }
        }
    }
}

/// March steps `[s·Δ, (s+1)·Δ]`, weighted by the exact integrals of `exp(−σt)` and `t·exp(−σt)`
/// over the part of each step that is visible (media radiance constant within a step).
pub(super) struct March {
    pub(super) sigma: f64,
    pub(super) step: f64,
    pub(super) steps: usize,
    /// `(∫ exp(−σt) dt, ∫ t exp(−σt) dt)` over each full step.
    pub(super) full: Vec<(f64, f64)>,
    /// `exp(−σ·s·Δ)`: the transmittance to the start of each step.
    pub(super) start: Vec<f64>,
}

impl March {
    pub(super) fn new(sigma: f64, step: f64, steps: usize) -> March {
        let mut m = March {
            sigma,
            step,
            steps,
            full: Vec::new(),
            start: Vec::new(),
        };
        m.start = (0..steps)
            .map(|s| (-sigma * (s as f64 * step)).exp())
            .collect();
        m.full = (0..steps)
            .map(|s| m.segment(s as f64 * step, step))
            .collect();
        m
    }

    pub(super) fn end(&self) -> f64 {
        self.steps as f64 * self.step
    }

    /// `(∫_0^len exp(−σu) du, ∫_0^len u exp(−σu) du)`, without cancellation for small σ·len.
    #[inline(always)]
    fn integrals_over(&self, len: f64) -> (f64, f64) {
        let x = self.sigma * len;
        if x < 1e-3 {
            (
                len * (1.0 - x / 2.0 + x * x / 6.0),
                len * len * (0.5 - x / 3.0 + x * x / 8.0),
            )
        } else {
            let em = (-x).exp();
            (
                -(-x).exp_m1() / self.sigma,
                (1.0 - em * (1.0 + x)) / (self.sigma * self.sigma),
            )
        }
    }

    /// `(∫_a^{a+len} exp(−σt) dt, ∫_a^{a+len} t exp(−σt) dt)`, without cancellation for small
    /// σ·len.
    #[inline]
    pub(super) fn segment(&self, a: f64, len: f64) -> (f64, f64) {
        let (j0, j1) = self.integrals_over(len);
        let ta = (-self.sigma * a).exp();
        (ta * j0, ta * (a * j0 + j1))
    }

    /// [`March::segment`] from the start of step `s` (`a = s·Δ`), with the transmittance to `a`
    /// from the table: the same value.
    #[inline(always)]
    pub(super) fn segment_from_step(&self, s: usize, a: f64, len: f64) -> (f64, f64) {
        let (j0, j1) = self.integrals_over(len);
        let ta = self.start[s];
        (ta * j0, ta * (a * j0 + j1))
    }

    /// The weights [`March::visit`] gives over `[0, r)`, as `(i0[k], i1[k])` for `k < count`
    /// (all visible from 0: only the last one or two partly). `i0` and `i1` must hold the
    /// full-step weights ([`March::full`]) at `k < first`; entries from `first` on are written and
    /// must be restored with [`March::restore`]. Returns `(count, first)`.
    #[inline(always)]
    pub(super) fn weights(&self, r: f64, i0: &mut [f64], i1: &mut [f64]) -> (usize, usize) {
        let hi = r.min(self.end());
        if hi.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return (0, 0);
        }
        let q = hi / self.step;
        // ceil(q) for finite q ≥ 0, without a libm call.
        let last = {
            let t = q as usize;
            if (t as f64) < q {
                t + 1
            } else {
                t
            }
        }
        .min(self.steps);
        // Steps s with (s·Δ + Δ) <= hi are full; the predicate is monotone in s, so the count
        // follows from the estimate ⌊q⌋ corrected by the predicate itself.
        let full = |s: usize| s as f64 * self.step + self.step <= hi;
        let mut first = (q as usize).min(last);
        while first > 0 && !full(first - 1) {
            first -= 1;
        }
        while first < last && full(first) {
            first += 1;
        }
        let mut count = first;
        for s in first..last {
            let a = s as f64 * self.step;
            if hi <= a {
                continue;
            }
            (i0[count], i1[count]) = self.segment_from_step(s, a, hi - a);
            count += 1;
        }
        (count, first)
    }

    /// Puts the full-step weights back at `first..count` after [`March::weights`].
    #[inline(always)]
    pub(super) fn restore(&self, i0: &mut [f64], i1: &mut [f64], (count, first): (usize, usize)) {
        for k in first..count {
            (i0[k], i1[k]) = self.full[k];
        }
    }
}
