//! The gather evaluation as it was before the single-pass rewrite (validation included), kept as
//! the reference `tests/gather_equivalence.rs` compares `raddiff::gather::evaluate` against and as
//! the baseline of `benches/gather.rs` (which includes this file by path). It uses the crate's
//! public API only; the wall vectors of the Ward-Heckbert gradient (`src/gather/walls.rs`, private
//! to the crate) are computed here from the same formulas, so that the comparison covers the
//! evaluation's passes, and the walls have their own unit tests against numerical wall integrals.

use std::f64::consts::{PI, TAU};
use std::sync::{Arc, Mutex};

use glam::{DVec2, DVec3};
use raddiff::gather::{
    Frame, GatherInput, GatherValues, Layout, LayoutKind, MediaRadiance, Wanted,
};
use raddiff::{kernels, Error, Order, Result};

/// A gather whose layout, frame and input passed validation; evaluate it once or several times
/// (a Hessian pass can reuse it without validating again).
#[derive(Debug, Clone, Copy)]
struct ReferenceGather<'a> {
    layout: Layout,
    frame: Frame,
    input: GatherInput<'a>,
}

impl<'a> ReferenceGather<'a> {
    /// Validates `layout`, `frame` (re-orthonormalized) and `input` (sizes, finite values, unit
    /// directions inside their strata, distances > 0 or `INFINITY`). `InvalidArgument` with a
    /// message naming the first problem.
    fn new(layout: &Layout, frame: &Frame, input: &GatherInput<'a>) -> Result<Self> {
        layout.validate()?;
        let given = *frame;
        let frame = frame.orthonormalized()?;
        validate(input, layout, &given)?;
        Ok(ReferenceGather {
            layout: *layout,
            frame,
            input: *input,
        })
    }

    /// Monte-Carlo weight of one stratum: `π/(MN)` (cosine-weighted hemisphere) or `4π/(MN)`.
    fn stratum_weight(&self) -> f64 {
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
    fn evaluate(&self, wanted: Wanted) -> Result<GatherValues> {
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

/// The previous implementation of `raddiff::gather::evaluate`: validates, then evaluates.
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

/// Checks sizes and values against `layout` and `frame` (as given: the direction check
/// orthonormalizes it).
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
    // The direction check is the library's own: the reference is the baseline of the evaluation,
    // not of the validation (the messages of both must match).
    layout.check_directions(frame, input.directions)
}

/// `InvalidArgument` naming `what` unless `v` is finite (the library's message).
fn ensure_finite(v: f64, what: &str) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!(
            "{what} is not finite ({v})"
        )))
    }
}

// The wall vectors of the Ward-Heckbert gradient (the model and its formulas:
// `src/gather/walls.rs`).

/// Per-ring and per-column wall data of a polar or sphere layout (local frame).
struct Walls {
    /// Per column k: `(cos φ_k, sin φ_k)` of its lower azimuth wall.
    phi_wall: Vec<(f64, f64)>,
    /// Per column k: `(sinφ_{k+1} − sinφ_k, cosφ_k − cosφ_{k+1})` = `∫ (cosφ, sinφ) dφ` over the column.
    column: Vec<(f64, f64)>,
    /// Per ring wall j (index j, used for j ≥ 1): `(w sinθ cosθ, −w sin²θ Δφ)` at `θ_j`.
    ring_wall: Vec<(f64, f64)>,
    /// Per ring j: `∫_{θ_j}^{θ_{j+1}} w(θ) dθ`.
    ring_span: Vec<f64>,
    /// Per ring j: `∫_{θ_j}^{θ_{j+1}} sin²θ dθ` (rotational gradient of the cosine-polar layout).
    ring_sin2: Vec<f64>,
}

impl Walls {
    /// Wall data for a [`LayoutKind::CosinePolar`] or [`LayoutKind::Sphere`] layout.
    fn new(layout: &Layout) -> Walls {
        debug_assert!(layout.kind != LayoutKind::Concentric);
        let (m, n) = (layout.m as usize, layout.n as usize);
        let d_phi = TAU / n as f64;
        let phi_wall: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                let (s, c) = (d_phi * k as f64).sin_cos();
                (c, s)
            })
            .collect();
        let column = (0..n)
            .map(|k| {
                let (c0, s0) = phi_wall[k];
                let (c1, s1) = phi_wall[(k + 1) % n];
                (s1 - s0, c0 - c1)
            })
            .collect();
        // (sin θ_j, cos θ_j) at the ring boundaries j = 0..=M.
        let bound: Vec<(f64, f64)> = (0..=m)
            .map(|j| {
                let f = j as f64 / m as f64;
                match layout.kind {
                    LayoutKind::Sphere => {
                        let c = 1.0 - 2.0 * f;
                        (((1.0 - c) * (1.0 + c)).max(0.0).sqrt(), c)
                    }
                    _ => (f.sqrt(), (1.0 - f).max(0.0).sqrt()),
                }
            })
            .collect();
        let sphere = layout.kind == LayoutKind::Sphere;
        let weight = |c: f64| if sphere { 1.0 } else { c };
        let ring_wall = bound
            .iter()
            .map(|&(s, c)| (weight(c) * s * c, -weight(c) * s * s * d_phi))
            .collect();
        let theta = |(s, c): (f64, f64)| s.atan2(c);
        let ring_span = (0..m)
            .map(|j| {
                if sphere {
                    theta(bound[j + 1]) - theta(bound[j])
                } else {
                    bound[j + 1].0 - bound[j].0
                }
            })
            .collect();
        // ∫ sin²θ dθ = (θ − sinθ cosθ)/2
        let g = |b: (f64, f64)| 0.5 * (theta(b) - b.0 * b.1);
        let ring_sin2 = (0..m).map(|j| g(bound[j + 1]) - g(bound[j])).collect();
        Walls {
            phi_wall,
            column,
            ring_wall,
            ring_span,
            ring_sin2,
        }
    }
}

/// Wall vectors `∫_wall w ν dl` (w = cosθ) of the concentric layout, whose walls are the images of
/// the grid lines of `[−1, 1]²` under the Shirley-Chiu map, lifted to the hemisphere.
///
/// For a wall traced as `ω(t)` with `t ∈ [0, 1]` along its grid line, `ν dl = ∓(ω × ω') dt` (the
/// sign picks the side). With `ω = (d, z)`, `z = sqrt(1 − |d|²)` and `z' = −(d·d')/z`, the integrand
/// `z (ω × ω')` is `(−(d_y (d·d') + z² d_y'), z² d_x' + d_x (d·d'), z (d × d'))`: bounded up to the
/// horizon. The map is smooth inside each of its four wedges and only continuous across the
/// diagonals `|a| = |b|`, so each wall is split there and integrated by 4-point Gauss-Legendre
/// per piece.
struct ConcentricWalls {
    /// Walls between `(j−1, k)` and `(j, k)`, index `(j−1)·N + k`, pointing into `(j, k)`.
    first: Vec<DVec3>,
    /// Walls between `(j, k−1)` and `(j, k)`, index `j·(N−1) + k − 1`, pointing into `(j, k)`.
    second: Vec<DVec3>,
}

/// Recently used concentric wall sets, keyed by (M, N), as the library keeps them: they depend on
/// the grid only, so the baseline does not pay for them on every gather either.
static CONCENTRIC_CACHE: Mutex<Vec<(u32, u32, Arc<ConcentricWalls>)>> = Mutex::new(Vec::new());

impl ConcentricWalls {
    /// The wall set of an M×N concentric grid from [`CONCENTRIC_CACHE`] (computed on a miss).
    fn cached(layout: &Layout) -> Arc<ConcentricWalls> {
        let key = (layout.m, layout.n);
        let mut cache = CONCENTRIC_CACHE.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(hit) = cache.iter().find(|e| (e.0, e.1) == key) {
            return Arc::clone(&hit.2);
        }
        let walls = Arc::new(ConcentricWalls::new(layout));
        if cache.len() >= 4 {
            cache.remove(0);
        }
        cache.push((key.0, key.1, Arc::clone(&walls)));
        walls
    }

    fn new(layout: &Layout) -> ConcentricWalls {
        let (m, n) = (layout.m as usize, layout.n as usize);
        let sa = |j: usize| 2.0 * j as f64 / m as f64 - 1.0;
        let sb = |k: usize| 2.0 * k as f64 / n as f64 - 1.0;
        let mut first_axis = Vec::with_capacity((m - 1) * n);
        for j in 1..m {
            for k in 0..n {
                // Travelling towards +b, the cell with the larger a lies on the right.
                let s0 = DVec2::new(sa(j), sb(k));
                let s1 = DVec2::new(sa(j), sb(k + 1));
                first_axis.push(-grid_line_integral(s0, s1));
            }
        }
        let mut second_axis = Vec::with_capacity(m * (n - 1));
        for j in 0..m {
            for k in 1..n {
                // Travelling towards +a, the cell with the larger b lies on the left.
                let s0 = DVec2::new(sa(j), sb(k));
                let s1 = DVec2::new(sa(j + 1), sb(k));
                second_axis.push(grid_line_integral(s0, s1));
            }
        }
        ConcentricWalls {
            first: first_axis,
            second: second_axis,
        }
    }

    /// Wall `i` between `(j−1, k)` and `(j, k)`.
    fn first(&self, i: usize) -> DVec3 {
        self.first[i]
    }

    /// Wall `i` between `(j, k−1)` and `(j, k)`.
    fn second(&self, i: usize) -> DVec3 {
        self.second[i]
    }
}

/// `∫ z (ω × ω') dt` along the image of the axis-aligned segment `s0 → s1` of the square.
fn grid_line_integral(s0: DVec2, s1: DVec2) -> DVec3 {
    let delta = s1 - s0;
    // Split where the segment crosses a diagonal |a| = |b| (a kink of the concentric map).
    let mut cuts: Vec<f64> = Vec::with_capacity(4);
    cuts.push(0.0);
    let (fixed, moving0, moving_len) = if delta.x == 0.0 {
        (s0.x, s0.y, delta.y)
    } else {
        (s0.y, s0.x, delta.x)
    };
    for target in [fixed.abs(), -fixed.abs()] {
        let t = (target - moving0) / moving_len;
        if t > 0.0 && t < 1.0 && !cuts.contains(&t) {
            cuts.push(t);
        }
    }
    cuts.push(1.0);
    cuts.sort_by(f64::total_cmp);
    const X: [f64; 2] = [0.339_981_043_584_856, 0.861_136_311_594_053];
    const W: [f64; 2] = [0.652_145_154_862_546, 0.347_854_845_137_454];
    let on_horizon = |t: f64| {
        let p = s0 + delta * t;
        p.x.abs().max(p.y.abs()) >= 1.0 - 1e-12
    };
    let mut sum = DVec3::ZERO;
    for piece in cuts.windows(2) {
        let (t0, t1) = (piece[0], piece[1]);
        // z ~ sqrt(distance to the horizon) at a horizon end: substitute t = end ∓ len·u² there,
        // which makes the integrand smooth again.
        let end = if on_horizon(t1) {
            Some((t1, -1.0))
        } else if on_horizon(t0) {
            Some((t0, 1.0))
        } else {
            None
        };
        for (x, w) in X.iter().zip(W) {
            for u in [0.5 - 0.5 * x, 0.5 + 0.5 * x] {
                let (t, jac) = match end {
                    Some((e, sign)) => {
                        let len = t1 - t0;
                        (e + sign * len * u * u, 2.0 * len * u)
                    }
                    None => (t0 + (t1 - t0) * u, t1 - t0),
                };
                sum += integrand(s0 + delta * t, delta) * (0.5 * w * jac);
            }
        }
    }
    sum
}

/// `z (ω × ω')` at square point `s` for the velocity `ds/dt = v`.
fn integrand(s: DVec2, v: DVec2) -> DVec3 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    let (a, b) = (s.x, s.y);
    // d and its derivatives ∂d/∂a, ∂d/∂b inside the wedge that contains s.
    let (d, da, db) = if a.abs() > b.abs() {
        let (sp, cp) = (FRAC_PI_4 * (b / a)).sin_cos();
        let radial = DVec2::new(cp, sp);
        let tangential = DVec2::new(-sp, cp);
        (
            radial * a,
            radial - tangential * (FRAC_PI_4 * b / a),
            tangential * FRAC_PI_4,
        )
    } else if b != 0.0 {
        let (sp, cp) = (FRAC_PI_2 - FRAC_PI_4 * (a / b)).sin_cos();
        let radial = DVec2::new(cp, sp);
        let tangential = DVec2::new(-sp, cp);
        (
            radial * b,
            -tangential * FRAC_PI_4,
            radial + tangential * (FRAC_PI_4 * a / b),
        )
    } else {
        // The centre: never a quadrature node (nodes are interior to each piece).
        return DVec3::ZERO;
    };
    let dd = da * v.x + db * v.y;
    let z2 = (1.0 - d.length_squared()).max(0.0);
    let dot = d.dot(dd);
    DVec3::new(
        -(d.y * dot + z2 * dd.y),
        z2 * dd.x + d.x * dot,
        z2.sqrt() * d.perp_dot(dd),
    )
}
