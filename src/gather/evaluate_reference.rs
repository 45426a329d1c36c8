//! The gather evaluation as it was before the single-pass rewrite (validation included), kept
//! verbatim as the reference the tests compare the fast path against and as the baseline of
//! `benches/gather.rs`. Compiled only with the `reference` feature, which the crate's tests and
//! benches turn on and users' builds leave off.

use std::f64::consts::PI;

use glam::DVec3;

use super::evaluate::{GatherValues, Wanted};
use super::input::{GatherInput, MediaRadiance};
use super::layout::{Frame, Layout, LayoutKind};
use super::walls::{ConcentricWalls, Walls};
use crate::error::{ensure_finite, Error, Result};
use crate::{kernels, Order};

/// A gather whose layout, frame and input passed validation; evaluate it once or several times
/// (a Hessian pass can reuse it without validating again).
#[derive(Debug, Clone, Copy)]
pub struct ReferenceGather<'a> {
    layout: Layout,
    frame: Frame,
    input: GatherInput<'a>,
}

impl<'a> ReferenceGather<'a> {
    /// Validates `layout`, `frame` (re-orthonormalized) and `input` (sizes, finite values, unit
    /// directions inside their strata, distances > 0 or `INFINITY`). `InvalidArgument` with a
    /// message naming the first problem.
    pub fn new(layout: &Layout, frame: &Frame, input: &GatherInput<'a>) -> Result<Self> {
        layout.validate()?;
        let frame = frame.orthonormalized()?;
        validate(input, layout, &frame)?;
        Ok(ReferenceGather {
            layout: *layout,
            frame,
            input: *input,
        })
    }

    /// The layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The orthonormalized frame.
    pub fn frame(&self) -> &Frame {
        &self.frame
    }

    /// The validated input.
    pub fn input(&self) -> &GatherInput<'a> {
        &self.input
    }

    /// Monte-Carlo weight of one stratum: `π/(MN)` (cosine-weighted hemisphere) or `4π/(MN)`.
    pub fn stratum_weight(&self) -> f64 {
        let sr = if self.layout.kind.is_hemisphere() {
            PI
        } else {
            4.0 * PI
        };
        sr / self.layout.len() as f64
    }

    /// Computes what `wanted` asks for.
    ///
    /// `Degenerate` if a result overflows (e.g. hits at ~1e-300 L).
    pub fn evaluate(&self, wanted: Wanted) -> Result<GatherValues> {
        let mut out = GatherValues::default();
        let ch = self.input.channels;
        let weight = self.stratum_weight();
        let plain = self.input.sigma_t == 0.0 && self.input.media.is_none();
        if plain && !wanted.gradient && !wanted.rotation_gradient {
            // Irradiance straight from the input: no per-stratum array needed.
            if wanted.irradiance {
                let mut e = vec![0.0; ch];
                for cell in self.input.radiance.chunks_exact(ch) {
                    for (e, &l) in e.iter_mut().zip(cell) {
                        *e += l as f64;
                    }
                }
                out.irradiance = e.into_iter().map(|e| e * weight).collect();
            }
        } else {
            // Radiance reaching x through each stratum: attenuated surface radiance plus media.
            let mut rad: Vec<f64> = self.input.radiance.iter().map(|&l| l as f64).collect();
            if self.input.sigma_t > 0.0 {
                self.attenuate(&mut rad, wanted, &mut out)?;
            }
            if let Some(media) = &self.input.media {
                let march = March::new(self.input.sigma_t, media.step, media.steps);
                self.add_media(&mut rad, media, &march, wanted, &mut out);
            }
            if wanted.irradiance {
                let mut e = vec![0.0; ch];
                for cell in rad.chunks_exact(ch) {
                    for (e, &l) in e.iter_mut().zip(cell) {
                        *e += l;
                    }
                }
                out.irradiance = e.into_iter().map(|e| e * weight).collect();
            }
            let walls = (self.layout.kind != LayoutKind::Concentric
                && (wanted.gradient || wanted.rotation_gradient))
                .then(|| Walls::new(&self.layout));
            if wanted.gradient {
                let local = match &walls {
                    Some(walls) => self.wall_gradient(walls, &rad),
                    None => {
                        let walls = ConcentricWalls::cached(&self.layout);
                        self.concentric_wall_gradient(&walls, &rad)
                    }
                };
                if out.gradient.is_empty() {
                    out.gradient = vec![DVec3::ZERO; ch];
                }
                for (g, l) in out.gradient.iter_mut().zip(local) {
                    *g += self.frame.to_world(l);
                }
            }
            if wanted.rotation_gradient {
                out.rotation_gradient = self.rotation_gradient(walls.as_ref(), &rad);
            }
        }
        if wanted.distances {
            let (mut inv_sum, mut min) = (0.0, f64::INFINITY);
            for &r in self.input.distance {
                inv_sum += r.recip();
                min = min.min(r);
            }
            out.harmonic_mean_distance = Some(self.layout.len() as f64 / inv_sum);
            out.min_distance = Some(min);
        }
        let finite = out.irradiance.iter().all(|v| v.is_finite())
            && out.gradient.iter().all(|v| v.is_finite())
            && out.rotation_gradient.iter().all(|v| v.is_finite())
            && out.harmonic_mean_distance.map_or(true, |v| !v.is_nan());
        if !finite {
            return Err(Error::Degenerate(
                "gather result overflows (hit distances or radiance too extreme)".into(),
            ));
        }
        Ok(out)
    }

    /// Multiplies each stratum's radiance by the transmittance to its hit (zero for a miss) and
    /// adds the cell-radiance gradient `weight · Σ ∇T·L` (eq. 17-18) to `out.gradient` when wanted.
    fn attenuate(&self, rad: &mut [f64], wanted: Wanted, out: &mut GatherValues) -> Result<()> {
        let ch = self.input.channels;
        let order = if wanted.gradient {
            out.gradient = vec![DVec3::ZERO; ch];
            Order::Gradient
        } else {
            Order::Value
        };
        let weight = self.stratum_weight();
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
            let d = kernels::transmittance(DVec3::ZERO, w * r, self.input.sigma_t, order)?;
            if wanted.gradient && d.value != 0.0 {
                for (g, &l) in out.gradient.iter_mut().zip(cell.iter()) {
                    *g += d.gradient * (weight * l);
                }
            }
            for l in cell {
                *l *= d.value;
            }
        }
        Ok(())
    }

    /// Adds the media radiance reaching x through each stratum, `Σ_s Q_s ∫ T dt` over the visible
    /// part of each step, to `rad`. When the gradient is wanted, adds `weight · Σ_i ∇L_m,i` to
    /// `out.gradient`: the gradient of each stratum's segment integral with its hit point held fixed
    /// (the Ward-Heckbert assumption), so that together with the wall terms on the total radiance
    /// the visibility gradient of surfaces occluding the medium (Jarosz 2008 eq. 22-26) appears at
    /// silhouettes, and nowhere else.
    fn add_media(
        &self,
        rad: &mut [f64],
        media: &MediaRadiance<'_>,
        march: &March,
        wanted: Wanted,
        out: &mut GatherValues,
    ) {
        let ch = self.input.channels;
        let steps = media.steps;
        let weight = self.stratum_weight();
        if wanted.gradient && out.gradient.is_empty() {
            out.gradient = vec![DVec3::ZERO; ch];
        }
        let end = march.end();
        for (i, (&r, &w)) in self
            .input
            .distance
            .iter()
            .zip(self.input.directions)
            .enumerate()
        {
            let e = &mut rad[i * ch..(i + 1) * ch];
            if !wanted.gradient {
                march.visit(0.0, r, |s, i0, _| {
                    let q = &media.radiance[(i * steps + s) * ch..(i * steps + s + 1) * ch];
                    for (e, &q) in e.iter_mut().zip(q) {
                        *e += q as f64 * i0;
                    }
                });
                continue;
            }
            let inv_r = if r.is_finite() { 1.0 / r } else { 0.0 };
            let hit_inside = r <= end;
            march.visit(0.0, r, |s, i0, i1| {
                let base = (i * steps + s) * ch;
                for (c, e) in e.iter_mut().enumerate() {
                    let q = media.radiance[base + c] as f64;
                    *e += q * i0;
                    let mut g = DVec3::ZERO;
                    if hit_inside {
                        // d/dx of ∫_0^r e^{-σt} Q dt with the far end fixed (s-parametrization).
                        g -= w * (q * (i0 - march.sigma * i1) * inv_r);
                    }
                    if let Some(grad) = media.gradient {
                        let k = (base + c) * 3;
                        let gq = DVec3::new(grad[k] as f64, grad[k + 1] as f64, grad[k + 2] as f64);
                        g += if hit_inside {
                            gq * (i0 - i1 * inv_r)
                        } else {
                            // Hit beyond the march (or a miss): the marched points keep their depth
                            // t and turn with the direction to the fixed hit, dω/dx = −(I − ωωᵀ)/r.
                            gq * i0 - (gq - w * w.dot(gq)) * (i1 * inv_r)
                        };
                    }
                    out.gradient[c] += g * weight;
                }
            });
        }
    }

    /// Ward-Heckbert wall terms on the total (surface + media) radiance, local frame, per channel.
    ///
    /// Each wall contributes `(L_a − L_b)/min(r_a, r_b)` times its wall vector; the vectors factor
    /// into a per-ring scalar and a per-column vector, so the loop accumulates scalars per column
    /// and applies the column vectors once at the end.
    fn wall_gradient(&self, walls: &Walls, rad: &[f64]) -> Vec<DVec3> {
        let (m, n) = (self.layout.m as usize, self.layout.n as usize);
        let ch = self.input.channels;
        let row_len = n * ch;
        // 1/r, 0 for a miss: 1/min(r_a, r_b) = max(1/r_a, 1/r_b).
        let inv_r: Vec<f64> = self.input.distance.iter().map(|&r| 1.0 / r).collect();
        let mut azimuth = vec![0.0; row_len];
        let mut ring = vec![0.0; row_len];
        let mut normal = vec![0.0; ch];
        for j in 0..m {
            let row = &rad[j * row_len..(j + 1) * row_len];
            let inv = &inv_r[j * n..(j + 1) * n];
            if n >= 2 {
                let span = walls.ring_span[j];
                for k in 0..n {
                    let kp = if k == 0 { n - 1 } else { k - 1 };
                    let s = inv[k].max(inv[kp]) * span;
                    if s == 0.0 {
                        continue;
                    }
                    for c in 0..ch {
                        azimuth[k * ch + c] += (row[k * ch + c] - row[kp * ch + c]) * s;
                    }
                }
            }
            if j >= 1 {
                let prev = &rad[(j - 1) * row_len..j * row_len];
                let inv_prev = &inv_r[(j - 1) * n..j * n];
                let (a, b) = walls.ring_wall[j];
                for k in 0..n {
                    let s = inv[k].max(inv_prev[k]);
                    if s == 0.0 {
                        continue;
                    }
                    for c in 0..ch {
                        let d = (row[k * ch + c] - prev[k * ch + c]) * s;
                        ring[k * ch + c] += d * a;
                        normal[c] += d * b;
                    }
                }
            }
        }
        let mut g: Vec<DVec3> = normal.iter().map(|&z| DVec3::new(0.0, 0.0, z)).collect();
        for k in 0..n {
            let (cos_k, sin_k) = walls.phi_wall[k];
            let (c1, c2) = walls.column[k];
            for (c, g) in g.iter_mut().enumerate() {
                let (az, rg) = (azimuth[k * ch + c], ring[k * ch + c]);
                g.x += rg * c1 - az * sin_k;
                g.y += rg * c2 + az * cos_k;
            }
        }
        g
    }

    /// The same wall terms for the concentric layout, whose wall vectors are computed by quadrature
    /// along the images of the grid lines (see [`ConcentricWalls`]).
    fn concentric_wall_gradient(&self, walls: &ConcentricWalls, rad: &[f64]) -> Vec<DVec3> {
        let (m, n) = (self.layout.m as usize, self.layout.n as usize);
        let ch = self.input.channels;
        let inv_r: Vec<f64> = self.input.distance.iter().map(|&r| 1.0 / r).collect();
        let mut g = vec![DVec3::ZERO; ch];
        let mut wall = |a: usize, b: usize, w: DVec3| {
            let s = inv_r[a].max(inv_r[b]);
            if s == 0.0 {
                return;
            }
            for (c, g) in g.iter_mut().enumerate() {
                *g += w * ((rad[a * ch + c] - rad[b * ch + c]) * s);
            }
        };
        for j in 1..m {
            for k in 0..n {
                wall(j * n + k, (j - 1) * n + k, walls.first((j - 1) * n + k));
            }
        }
        for j in 0..m {
            for k in 1..n {
                wall(j * n + k, j * n + k - 1, walls.second(j * (n - 1) + k - 1));
            }
        }
        g
    }

    /// `∫ L (n × ω) dω` per channel (world axes).
    fn rotation_gradient(&self, walls: Option<&Walls>, rad: &[f64]) -> Vec<DVec3> {
        let ch = self.input.channels;
        let mut g = vec![DVec3::ZERO; ch];
        let n = self.layout.n as usize;
        match (self.layout.kind, walls) {
            (LayoutKind::Sphere, _) => {}
            (LayoutKind::CosinePolar, Some(walls)) => {
                // ∫_cell sinθ e_φ dω = (∫ sin²θ dθ)(∫ e_φ dφ): per-column sums, then the vectors.
                let mut column = vec![0.0; n * ch];
                for (j, row) in rad.chunks_exact(n * ch).enumerate() {
                    let s = walls.ring_sin2[j];
                    for (acc, &l) in column.iter_mut().zip(row) {
                        *acc += s * l;
                    }
                }
                for k in 0..n {
                    let (c1, c2) = walls.column[k];
                    for (c, g) in g.iter_mut().enumerate() {
                        *g += DVec3::new(-c2, c1, 0.0) * column[k * ch + c];
                    }
                }
            }
            _ => {
                // Concentric strata are not θ/φ boxes: Monte Carlo with the cosine pdf,
                // (n × ω)/cosθ per sample, cosθ clamped where a jittered sample touches the horizon.
                let weight = self.stratum_weight();
                for (&w, cell) in self.input.directions.iter().zip(rad.chunks_exact(ch)) {
                    let l = self.frame.to_local(w);
                    let v = DVec3::new(-l.y, l.x, 0.0) * (weight / l.z.max(1e-6));
                    for (g, &l) in g.iter_mut().zip(cell) {
                        *g += v * l;
                    }
                }
            }
        }
        g.into_iter().map(|v| self.frame.to_world(v)).collect()
    }
}

/// The previous implementation of [`super::evaluate`]: validates, then evaluates.
pub fn evaluate(
    layout: &Layout,
    frame: &Frame,
    input: &GatherInput<'_>,
    wanted: Wanted,
) -> Result<GatherValues> {
    ReferenceGather::new(layout, frame, input)?.evaluate(wanted)
}

/// March steps `[s·Δ, (s+1)·Δ]`, weighted by the exact integrals of `exp(−σt)` and `t·exp(−σt)` over
/// the part of each step that is visible (media radiance constant within a step).
struct March {
    sigma: f64,
    step: f64,
    steps: usize,
    /// `(∫ exp(−σt) dt, ∫ t exp(−σt) dt)` over each full step.
    full: Vec<(f64, f64)>,
}

impl March {
    fn new(sigma: f64, step: f64, steps: usize) -> March {
        let mut m = March {
            sigma,
            step,
            steps,
            full: Vec::new(),
        };
        m.full = (0..steps)
            .map(|s| m.segment(s as f64 * step, step))
            .collect();
        m
    }

    fn end(&self) -> f64 {
        self.steps as f64 * self.step
    }

    /// `(∫_a^{a+len} exp(−σt) dt, ∫_a^{a+len} t exp(−σt) dt)`, without cancellation for small σ·len.
    #[inline]
    fn segment(&self, a: f64, len: f64) -> (f64, f64) {
        let x = self.sigma * len;
        // ∫_0^len exp(−σu) du and ∫_0^len u exp(−σu) du
        let (j0, j1) = if x < 1e-3 {
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
        };
        let ta = (-self.sigma * a).exp();
        (ta * j0, ta * (a * j0 + j1))
    }

    /// Calls `f(s, ∫ exp(−σt) dt, ∫ t exp(−σt) dt)` over `[lo, hi) ∩ step s` for every step
    /// overlapping `[lo, hi)`.
    #[inline]
    fn visit(&self, lo: f64, hi: f64, mut f: impl FnMut(usize, f64, f64)) {
        let hi = hi.min(self.end());
        if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
            return;
        }
        let first = ((lo / self.step).floor() as usize).min(self.steps);
        let last = ((hi / self.step).ceil() as usize).min(self.steps);
        for s in first..last {
            let a = s as f64 * self.step;
            let b = a + self.step;
            let (i0, i1) = if a >= lo && b <= hi {
                self.full[s]
            } else {
                let (a, b) = (a.max(lo), b.min(hi));
                if b <= a {
                    continue;
                }
                self.segment(a, b - a)
            };
            f(s, i0, i1);
        }
    }
}

fn size_error(what: &str, got: usize, want: Option<usize>, formula: &str) -> Error {
    match want {
        Some(w) => Error::InvalidArgument(format!(
            "{what} holds {got} values, expected {formula} = {w}"
        )),
        None => Error::InvalidArgument(format!("{what}: {formula} overflows")),
    }
}

fn check_len(what: &str, got: usize, want: Option<usize>, formula: &str) -> Result<()> {
    if want == Some(got) {
        Ok(())
    } else {
        Err(size_error(what, got, want, formula))
    }
}

fn check_all_finite(values: &[f32], what: &str) -> Result<()> {
    // Branch-free per block so the scan vectorizes; locate the culprit only on failure.
    for (b, block) in values.chunks(256).enumerate() {
        if block.iter().fold(false, |bad, v| bad | !v.is_finite()) {
            let i = b * 256 + block.iter().position(|v| !v.is_finite()).unwrap_or(0);
            return Err(Error::InvalidArgument(format!(
                "{what}[{i}] is not finite ({})",
                values[i]
            )));
        }
    }
    Ok(())
}

/// Checks sizes and values against `layout` and the (orthonormalized) `frame`.
fn validate(input: &GatherInput<'_>, layout: &Layout, frame: &Frame) -> Result<()> {
    let cells = layout.len();
    if input.channels == 0 {
        return Err(Error::InvalidArgument("channels must be >= 1".into()));
    }
    check_len("directions", input.directions.len(), Some(cells), "m*n")?;
    check_len("distance", input.distance.len(), Some(cells), "m*n")?;
    check_len(
        "radiance",
        input.radiance.len(),
        cells.checked_mul(input.channels),
        "m*n*channels",
    )?;
    ensure_finite(input.sigma_t, "sigma_t")?;
    if input.sigma_t < 0.0 {
        return Err(Error::InvalidArgument(format!(
            "sigma_t must be >= 0 (got {})",
            input.sigma_t
        )));
    }
    for (i, &d) in input.distance.iter().enumerate() {
        if d.is_nan() || d <= 0.0 {
            return Err(Error::InvalidArgument(format!(
                "distance[{i}] = {d}: distances must be > 0, or INFINITY for a miss"
            )));
        }
    }
    check_all_finite(input.radiance, "radiance")?;
    if let Some(media) = &input.media {
        if media.steps == 0 {
            return Err(Error::InvalidArgument("media steps must be >= 1".into()));
        }
        ensure_finite(media.step, "media step")?;
        if media.step <= 0.0 || !(media.step * media.steps as f64).is_finite() {
            return Err(Error::InvalidArgument(format!(
                "media step must be > 0 with a finite march length (step = {}, steps = {})",
                media.step, media.steps
            )));
        }
        let samples = cells
            .checked_mul(media.steps)
            .and_then(|v| v.checked_mul(input.channels));
        check_len(
            "media_radiance",
            media.radiance.len(),
            samples,
            "m*n*steps*channels",
        )?;
        check_all_finite(media.radiance, "media_radiance")?;
        if let Some(g) = media.gradient {
            check_len(
                "media_radiance_gradient",
                g.len(),
                samples.and_then(|v| v.checked_mul(3)),
                "m*n*steps*3*channels",
            )?;
            check_all_finite(g, "media_radiance_gradient")?;
        }
    }
    check_directions(layout, frame, input.directions)
}

/// The direction check shared with the current implementation: the reference is the baseline of
/// the evaluation, not of the validation (the messages of both must match).
fn check_directions(layout: &Layout, frame: &Frame, directions: &[DVec3]) -> Result<()> {
    super::strata::check_directions(layout, frame, directions)
}
