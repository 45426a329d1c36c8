//! Interpolation: which records are used at a query, how much each weighs, how each extrapolates.
//!
//! Notation: record i at xᵢ with unit normal nᵢ, value Eᵢ, translational gradient ∇ₜEᵢ, rotational
//! gradient ∇ᵣEᵢ (Ward-Heckbert convention, derivative with respect to the rotation vector of the
//! normal); query at x with unit normal n; Δx = x − xᵢ. The normalized distance t is the record's
//! ellipsoid norm of Δx (thesis eq. 6.12): t = √(Σₖ (Δx·aₖ / Rₖ)²) with the surface frame
//! (a₀, a₁, nᵢ) and radii (R₀, R₁, min(R₀, R₁)), or the volume frame and radii. t < 1 inside.
//! Δn_max is the configuration's maximum normal deviation (surface domain only).
//!
//! | scheme | weight wᵢ (0 outside) | valid where | extrapolated value |
//! |---|---|---|---|
//! | [`Ward`](Interpolation::Ward) (thesis eq. 3.13, Křivánek-Gautron) | 1/max(t+ρ, 10⁻⁹) − 1 | t+ρ < 1 | Eᵢ + Δx·∇ₜEᵢ + (nᵢ×n)·∇ᵣEᵢ (eq. 3.19) |
//! | [`WardClassic`](Interpolation::WardClassic) (eq. 3.12) | 1/max(t+ρ, 10⁻⁹) | t+ρ < 1 | as Ward |
//! | [`WardTabellion`](Interpolation::WardTabellion) (eq. 3.14) | 1 − (t+ρ) | t+ρ < 1 | as Ward |
//! | [`Tent`](Interpolation::Tent) (eq. 6.11-6.13) | (1−t)·(n·nᵢ − cos Δn_max)/(1 − cos Δn_max) | t < 1, n·nᵢ > cos Δn_max | as Ward (eq. 6.10) |
//! | [`Cubic`](Interpolation::Cubic) (Marco eq. 23) | (3d² − 2d³)·k_n, d = 1 − t | as Tent | as Ward |
//! | [`Log`](Interpolation::Log) (Marco eq. 4) | as Cubic | as Tent | exp of the weighted mean of ln Eᵢ + (Δx·∇ₜEᵢ + (nᵢ×n)·∇ᵣEᵢ)/Eᵢ |
//!
//! with ρ = √(1 − n·nᵢ)/a and a = √(1 − cos Δn_max). Ward's criterion wᵢ > 1/a (eq. 3.11) with
//! wᵢ = 1/(‖Δx‖/R + √(1 − n·nᵢ)) (eq. 3.12) is, after multiplying by a and writing the record radius
//! as aR (so t = ‖Δx‖/(aR)), exactly t + ρ < 1: a record alone is valid up to its radius for equal
//! normals and up to Δn_max for equal positions. The constant factor a is dropped from the weights
//! (it cancels in the normalized sum). k_n is the normal tent factor of eq. 6.11 (1 in volumes);
//! in the volume domain ρ = 0, n·nᵢ is not tested and the rotational term is absent.
//!
//! Conventions and deviations from the papers, on purpose:
//! * Rotation term: eq. 3.19 uses (nᵢ × n)·∇ᵣ; eq. 6.10 prints n × nᵢ, the opposite sign. With
//!   n = nᵢ + θ × nᵢ for a small rotation vector θ, nᵢ × n = θ − (θ·nᵢ)nᵢ, so eq. 3.19's sign is the
//!   first-order Taylor term of a gradient taken with respect to θ. Tested on E(n) = max(0, n·d).
//! * Log: a channel whose value is ≤ 0 in any used record cannot be extrapolated in log space and
//!   falls back to the linear (Cubic) result for that channel; the exponent is capped so the result
//!   stays a finite `f32`.
//! * Every result is clamped to the finite `f32` range. First-order extrapolation may produce
//!   negative values from positive records; clamp them yourself if your quantity is non-negative.

use std::borrow::Cow;

use glam::DVec3;

use super::leak_guard::LeakGuard;
use super::open_fraction::{OpenFractionTest, OpenWindow};
use super::record::{packed_scale, Channel, Domain, Head};
use crate::error::{ensure_finite, Error, Result};

/// How covering records are weighted and extrapolated (formulas in the [module docs](crate::cache::interp)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Interpolation {
    /// Ward-Heckbert first-order extrapolation with Křivánek-Gautron weights 1/(t+ρ) − 1
    /// (thesis eq. 3.13, 3.19). `RADDIFF_INTERP_WARD` (0).
    Ward = 0,
    /// The anisotropic tent weights of the thesis (eq. 6.10-6.13). `RADDIFF_INTERP_TENT` (1).
    Tent = 1,
    /// Linear-space extrapolation with the cubic kernel 3d² − 2d³ (Marco et al. eq. 23).
    /// `RADDIFF_INTERP_CUBIC` (2).
    Cubic = 2,
    /// Log-space extrapolation of Jarosz et al. 2008 (Marco et al. eq. 4) with the cubic kernel.
    /// `RADDIFF_INTERP_LOG` (3).
    Log = 3,
    /// Ward-Heckbert extrapolation with Ward's original weights 1/(t+ρ) (thesis eq. 3.12), which
    /// do not vanish at the record boundary. `RADDIFF_INTERP_WARD_CLASSIC` (4).
    WardClassic = 4,
    /// Ward-Heckbert extrapolation with Tabellion-Lamorlette weights 1 − (t+ρ) (thesis eq. 3.14).
    /// `RADDIFF_INTERP_WARD_TABELLION` (5).
    WardTabellion = 5,
}

impl TryFrom<u32> for Interpolation {
    type Error = Error;
    fn try_from(v: u32) -> Result<Self> {
        Ok(match v {
            0 => Interpolation::Ward,
            1 => Interpolation::Tent,
            2 => Interpolation::Cubic,
            3 => Interpolation::Log,
            4 => Interpolation::WardClassic,
            5 => Interpolation::WardTabellion,
            _ => {
                return Err(Error::InvalidArgument(format!(
                "interpolation {v} is not one of RADDIFF_INTERP_WARD (0), _TENT (1), _CUBIC (2), \
                     _LOG (3), _WARD_CLASSIC (4), _WARD_TABELLION (5)"
            )))
            }
        })
    }
}

/// Precomputed per-cache constants of the weighting.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Kernel {
    pub interpolation: Interpolation,
    pub domain: Domain,
    pub(crate) cos_max: f64,
    pub(crate) inv_a: f64,
    /// The leak guard, when it is on and the domain has normals (surfaces).
    pub(crate) leak_guard: Option<LeakGuard>,
    /// The cache's open-fraction test (off: infinite tolerance).
    pub(crate) open_fraction_test: OpenFractionTest,
    /// The open fractions the current query admits: set per query by [`Kernel::for_query`],
    /// `None` when the test is off or the query has no open fraction.
    pub(crate) open_window: Option<OpenWindow>,
    /// The cache's lookup radius scale k ≥ 1 ([`CacheConfig::lookup_radius_scale`]
    /// (super::CacheConfig::lookup_radius_scale)): records are weighed over their radii times k
    /// (exactly the radii when k = 1, so that unscaled weights are bit for bit those without it).
    pub(crate) lookup_scale: f64,
}

/// Floor of t + ρ in Ward's weights: at a record's exact position and normal the weight is
/// 10⁹ (finite) instead of infinite, so that record dominates as the limit demands.
pub(crate) const WARD_FLOOR: f64 = 1e-9;

/// Largest exponent accepted in log-space extrapolation: keeps exp() a finite f32.
const LOG_EXPONENT_MAX: f64 = 88.0;

impl Kernel {
    pub(crate) fn new(
        interpolation: Interpolation,
        domain: Domain,
        max_normal_deviation: f64,
    ) -> Result<Self> {
        ensure_finite(max_normal_deviation, "max_normal_deviation")?;
        if domain == Domain::Surface
            && !(max_normal_deviation > 0.0 && max_normal_deviation <= std::f64::consts::PI)
        {
            return Err(Error::InvalidArgument(format!(
                "max_normal_deviation must be in (0, pi] radians (got {max_normal_deviation})"
            )));
        }
        let cos_max = max_normal_deviation.cos();
        let a = (1.0 - cos_max).max(0.0).sqrt();
        Ok(Kernel {
            interpolation,
            domain,
            cos_max,
            inv_a: if a > 0.0 { 1.0 / a } else { 0.0 },
            leak_guard: None,
            open_fraction_test: OpenFractionTest::OFF,
            open_window: None,
            lookup_scale: 1.0,
        })
    }

    /// The same kernel weighing records over `scale` times their radii (a valid
    /// [`CacheConfig::lookup_radius_scale`](super::CacheConfig::lookup_radius_scale)).
    pub(crate) fn with_lookup_radius_scale(mut self, scale: f64) -> Self {
        self.lookup_scale = scale;
        self
    }

    /// Whether records are weighed over more than their own radii.
    #[inline]
    pub(crate) fn is_scaled(&self) -> bool {
        self.lookup_scale != 1.0
    }

    /// The same kernel at the records' own radii: the one that decides whether a query is
    /// covered.
    pub(crate) fn at_own_radii(&self) -> Kernel {
        self.with_lookup_radius_scale(1.0)
    }

    /// The same kernel with `guard` (ignored when off or in the volume domain).
    pub(crate) fn with_leak_guard(mut self, guard: LeakGuard) -> Self {
        self.leak_guard = (guard.is_on() && self.domain == Domain::Surface).then_some(guard);
        self
    }

    /// The same kernel with the open-fraction test `test`.
    pub(crate) fn with_open_fraction_test(mut self, test: OpenFractionTest) -> Self {
        self.open_fraction_test = test;
        self
    }

    /// The kernel of one query: the cache's, with the open fractions a query of open fraction
    /// `open` admits (`None`: a query without one, which the test never refuses records at). The
    /// cache's own kernel, borrowed, when nothing is refused (no open fraction, or the test off).
    #[inline]
    pub(crate) fn for_query(&self, open: Option<f64>) -> Cow<'_, Kernel> {
        self.for_query_within(open, self.open_fraction_test.tolerance)
    }

    /// [`Kernel::for_query`] at the test's coverage tolerance: the kernel of the second read of a
    /// query that no record passes (the test keeping coverage).
    #[inline]
    pub(crate) fn for_coverage_query(&self, open: Option<f64>) -> Cow<'_, Kernel> {
        self.for_query_within(open, self.open_fraction_test.coverage_tolerance)
    }

    /// The kernel of a query of open fraction `open` admitting the records within `tolerance`.
    #[inline]
    fn for_query_within(&self, open: Option<f64>, tolerance: f64) -> Cow<'_, Kernel> {
        match open.and_then(|v| OpenWindow::new(tolerance, v)) {
            None => Cow::Borrowed(self),
            Some(window) => Cow::Owned(Kernel {
                open_window: Some(window),
                ..*self
            }),
        }
    }

    /// Whether the leak guard or the open-fraction test refuses the record at `position` (unit
    /// `normal`, radius `normal_radius` along it, open fraction coded `open_code`) at the query
    /// `x` with unit normal `n`.
    #[inline]
    pub(crate) fn refuses(
        &self,
        x: DVec3,
        n: DVec3,
        position: DVec3,
        normal: DVec3,
        normal_radius: f64,
        open_code: u32,
    ) -> bool {
        let leaks = match self.leak_guard {
            Some(guard) => !guard.admits(x, n, position, normal, normal_radius),
            None => false,
        };
        leaks || self.open_window.is_some_and(|w| w.refuses(open_code))
    }

    /// Weight of a record at normalized distance `t` whose normal has cosine `cos_n` with the
    /// query normal (ignored in volumes); 0 when the record does not cover the query.
    #[inline]
    pub(crate) fn weight(&self, t: f64, cos_n: f64) -> f64 {
        let surface = self.domain == Domain::Surface;
        match self.interpolation {
            Interpolation::Ward | Interpolation::WardClassic | Interpolation::WardTabellion => {
                let rho = if surface {
                    (1.0 - cos_n).max(0.0).sqrt() * self.inv_a
                } else {
                    0.0
                };
                let s = t + rho;
                if s >= 1.0 {
                    return 0.0;
                }
                match self.interpolation {
                    Interpolation::Ward => 1.0 / s.max(WARD_FLOOR) - 1.0,
                    Interpolation::WardClassic => 1.0 / s.max(WARD_FLOOR),
                    _ => 1.0 - s,
                }
            }
            Interpolation::Tent | Interpolation::Cubic | Interpolation::Log => {
                if t >= 1.0 {
                    return 0.0;
                }
                let kn = if surface {
                    if cos_n <= self.cos_max {
                        return 0.0;
                    }
                    ((cos_n - self.cos_max) / (1.0 - self.cos_max)).min(1.0)
                } else {
                    1.0
                };
                let d = 1.0 - t;
                let kx = if self.interpolation == Interpolation::Tent {
                    d
                } else {
                    d * d * (3.0 - 2.0 * d)
                };
                kx * kn
            }
        }
    }
}

/// A covering record met during a lookup.
#[derive(Clone, Copy)]
pub(crate) struct Used<'a> {
    /// The bits of the record's x coordinate: the first key of the content order.
    pub order: u64,
    pub weight: f64,
    /// The record's unit normal (surface domain).
    pub normal: DVec3,
    pub head: &'a Head,
    pub channels: &'a [Channel],
}

/// Channels accumulated per pass over the records (stack buffers, no allocation).
const BLOCK: usize = 16;

/// Weighted sum of the log-space extrapolations of `used` (in content order, weights summing to
/// `weight_sum` > 0) at (x, n), written to `out` (one float per channel). The linear-space
/// schemes blend through [`blend_linear`](super::blend::blend_linear).
pub(crate) fn blend_log(
    kernel: &Kernel,
    used: &[Used<'_>],
    weight_sum: f64,
    x: DVec3,
    n: DVec3,
    out: &mut [f32],
) {
    let log = true;
    let surface = kernel.domain == Domain::Surface;
    let inv_sum = 1.0 / weight_sum;
    // Per record: offset and normal change, decoded once for all channel blocks.
    for (block, out) in out.chunks_mut(BLOCK).enumerate() {
        let base = block * BLOCK;
        let mut linear = [0.0f64; BLOCK];
        let mut logs = [0.0f64; BLOCK];
        let mut log_ok = [log; BLOCK];
        for u in used {
            let dx = x - u.head.position();
            // offsets pre-multiplied by the records' binary16 scales (see Channel::gradient_unscaled)
            let dx =
                (u.head.gradient_scale != 0.0).then(|| dx * packed_scale(u.head.gradient_scale));
            let dn = (surface && u.head.rotation_scale != 0.0)
                .then(|| u.normal.cross(n) * packed_scale(u.head.rotation_scale));
            let w = u.weight;
            for (c, ch) in u.channels[base..base + out.len()].iter().enumerate() {
                let v = ch.value as f64;
                let mut delta = 0.0;
                if let Some(dx) = dx {
                    delta += dx.dot(ch.gradient_unscaled());
                }
                if let Some(dn) = dn {
                    delta += dn.dot(ch.rotation_unscaled());
                }
                linear[c] += w * (v + delta);
                if log {
                    if v > 0.0 {
                        logs[c] += w * (v.ln() + delta / v);
                    } else {
                        log_ok[c] = false;
                    }
                }
            }
        }
        for (c, o) in out.iter_mut().enumerate() {
            let value = if log_ok[c] {
                (logs[c] * inv_sum).min(LOG_EXPONENT_MAX).exp()
            } else {
                linear[c] * inv_sum
            };
            *o = value.clamp(-(f32::MAX as f64), f32::MAX as f64) as f32;
        }
    }
}

#[cfg(test)]
mod tests;
