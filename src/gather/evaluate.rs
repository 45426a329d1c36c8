//! Irradiance (or fluence) and its first derivatives from what a gather's rays found.
//!
//! * Value: stratified Monte Carlo with weight `A_{j,k}·cosθ = π/(MN)` per stratum for the
//!   cosine-weighted hemisphere layouts and `4π/(MN)` for the sphere (fluence) — Jarosz et al. 2008
//!   Table 2: the cell area is `(MN)⁻¹ pdf⁻¹` (the thesis' Table 3.1 misprints it as `(MN)⁻¹ pdf`).
//! * Translational gradient: Ward-Heckbert wall motion (see [`super::walls`]) on the radiance
//!   reaching x through each stratum, plus the cell-radiance term `∇T·L` through a homogeneous
//!   medium (Jarosz 2008 eq. 14-18), plus, with media radiance, the gradient of each stratum's
//!   marched segment with its hit point fixed. Media radiance enters the wall terms with the surface
//!   radiance, so the visibility gradient of surfaces occluding the medium (eq. 22-26) arises at
//!   silhouettes, where the shells between the occluder and the farther hit move with the occluder.
//!   Applying eq. 24 at every depth difference instead (Algorithm 1 taken literally) also moves the
//!   iso-distance contours of smooth surfaces as if they were silhouettes, which biased the gradient
//!   by 18-50% in the reference tests; the segment model converges (README, "Gathers").
//! * Rotational gradient (thesis eq. 3.23-3.24): `∫ L (n × ω) dω`, integrated exactly over each
//!   polar stratum (no `tanθ` blow-up at the horizon); Monte Carlo for the concentric layout.

use glam::DVec3;

use super::input::GatherInput;
use super::layout::{Frame, Layout, LayoutKind};
use super::smoothing::{SmoothedRadiance, StrataSmoothing};
use super::walls::{ConcentricWalls, LayoutTables, Walls};
use crate::error::{Error, Result};
use media::{March, MediaTerms};

/// Which results [`ValidGather::evaluate`] computes; work for the others is skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Wanted {
    /// Irradiance (hemisphere layouts) or fluence (sphere layout) per channel.
    pub irradiance: bool,
    /// Translational gradient per channel (with the media terms when a medium is given).
    pub gradient: bool,
    /// Rotational gradient per channel.
    pub rotation_gradient: bool,
    /// Harmonic-mean and minimum hit distance.
    pub distances: bool,
}

impl Wanted {
    /// Everything.
    pub const ALL: Wanted = Wanted {
        irradiance: true,
        gradient: true,
        rotation_gradient: true,
        distances: true,
    };
    /// The irradiance only.
    pub const IRRADIANCE: Wanted = Wanted {
        irradiance: true,
        gradient: false,
        rotation_gradient: false,
        distances: false,
    };
}

/// Results of a gather evaluation. Vectors are empty when not [`Wanted`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GatherValues {
    /// Irradiance `∫ L (n·ω) dω` (hemisphere layouts) or fluence `∫ L dω` (sphere), per channel:
    /// radiance units × sr. With `L` the largest |radiance| and no medium: at most `πL` (`4πL`).
    pub irradiance: Vec<f64>,
    /// Translational gradient (world axes, per L), per channel. All three components: the tangent
    /// ones are Ward-Heckbert's; the normal one follows from the same wall motion. Without a medium
    /// its length is at most `2π(2M + N) L / min_distance` (`docs/robustness.md`).
    pub gradient: Vec<DVec3>,
    /// Rotational gradient (world axes, per radian), per channel: rotating the normal by the small
    /// rotation vector ρ changes the irradiance by `ρ·∇_r E`. Zero for the sphere layout (fluence does
    /// not depend on the normal). Its length is at most `(π²/2) L`.
    pub rotation_gradient: Vec<DVec3>,
    /// Harmonic mean of the hit distances, `MN / Σ 1/r` (thesis eq. 3.9; misses count as 1/r = 0):
    /// `INFINITY` if every ray missed.
    pub harmonic_mean_distance: Option<f64>,
    /// Smallest hit distance, `INFINITY` if every ray missed.
    pub min_distance: Option<f64>,
}

/// A gather whose layout, frame and input passed validation; evaluate it once or several times
/// (a Hessian pass can reuse it without validating again).
#[derive(Debug, Clone, Copy)]
pub struct ValidGather<'a> {
    layout: Layout,
    frame: Frame,
    input: GatherInput<'a>,
}

impl<'a> ValidGather<'a> {
    /// Validates `layout`, `frame` (re-orthonormalized) and `input` (sizes, finite values, unit
    /// directions inside their strata, distances > 0 or `INFINITY`). `InvalidArgument` with a
    /// message naming the first problem.
    pub fn new(layout: &Layout, frame: &Frame, input: &GatherInput<'a>) -> Result<Self> {
        layout.validate()?;
        let frame = frame.orthonormalized()?;
        input.validate(layout, &frame)?;
        Ok(ValidGather {
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
        self.layout.kind.measure() / self.layout.len() as f64
    }

    /// Computes what `wanted` asks for.
    ///
    /// `Degenerate` if a result overflows (e.g. hits at ~1e-300 L).
    pub fn evaluate(&self, wanted: Wanted) -> Result<GatherValues> {
        let mut out = GatherValues::default();
        let plain = self.input.sigma_t == 0.0 && self.input.media.is_none();
        if plain {
            // Surface radiance as the renderer gave it: read in place, no per-stratum array.
            self.sums(self.input.radiance, wanted, &mut out);
        } else {
            // Radiance reaching x through each stratum: attenuated surface radiance plus media.
            let mut rad: Vec<f64> = self.input.radiance.iter().map(|&l| l as f64).collect();
            let terms = MediaTerms {
                input: &self.input,
                weight: self.stratum_weight(),
            };
            if self.input.sigma_t > 0.0 {
                terms.attenuate(&mut rad, wanted.gradient, &mut out.gradient)?;
            }
            if let Some(media) = &self.input.media {
                let march = March::new(self.input.sigma_t, media.step, media.steps);
                terms.add_media(&mut rad, media, &march, wanted.gradient, &mut out.gradient);
            }
            self.sums(&rad, wanted, &mut out);
        }
        let finite = out.irradiance.iter().all(|v| v.is_finite())
            && out.gradient.iter().all(|v| v.is_finite())
            && out.rotation_gradient.iter().all(|v| v.is_finite())
            // INFINITY only when every ray missed; a few hits at distances near f64::MAX overflow
            // MN / sum(1/r) (found by fuzzing, fuzz/regressions/gather_evaluate/).
            && out.harmonic_mean_distance.map_or(true, |v| {
                v.is_finite() || (v == f64::INFINITY && out.min_distance == Some(f64::INFINITY))
            });
        if !finite {
            return Err(Error::Degenerate(
                "gather result overflows (hit distances or radiance too extreme)".into(),
            ));
        }
        Ok(out)
    }

    /// [`ValidGather::evaluate`] with the radiance of every stratum (and the marched media
    /// radiance and its gradient, if any) first smoothed over its neighbours by `smoothing`
    /// ([`StrataSmoothing`]): the derivatives of a noisy gather, quieter. The layout, frame,
    /// directions and distances are this gather's; with [`StrataSmoothing::OFF`] this is
    /// `evaluate` itself. Errors as `evaluate` (the smoothed values stay finite).
    pub fn evaluate_smoothed(
        &self,
        smoothing: StrataSmoothing,
        wanted: Wanted,
    ) -> Result<GatherValues> {
        if !smoothing.is_on() {
            return self.evaluate(wanted);
        }
        let smoothed = SmoothedRadiance::of(&self.layout, &self.input, smoothing)?;
        ValidGather {
            input: smoothed.input(&self.input),
            ..*self
        }
        .evaluate(wanted)
    }

    /// Irradiance, wall and rotational gradients and distances from the radiance reaching x
    /// through each stratum (`rad`, index `i·channels + c`); the wall gradient is added to what
    /// `out.gradient` holds (the media terms).
    fn sums<T: Copy + Into<f64>>(&self, rad: &[T], wanted: Wanted, out: &mut GatherValues) {
        let ch = self.input.channels;
        let weight = self.stratum_weight();
        let gradients = wanted.gradient || wanted.rotation_gradient;
        let tables = gradients.then(|| LayoutTables::cached(&self.layout));
        let polar = tables.as_ref().and_then(|t| t.walls.as_ref());
        // The same summation whatever else is requested, so the irradiance does not depend on it.
        if wanted.irradiance {
            out.irradiance = channel_sums(rad, ch)
                .into_iter()
                .map(|e| e * weight)
                .collect();
        }
        let local = match polar {
            Some(walls) => {
                let s = self.polar_pass(walls, rad, wanted);
                if wanted.distances {
                    out.harmonic_mean_distance = Some(self.layout.len() as f64 / s.inv_sum);
                    out.min_distance = Some(s.min);
                }
                if wanted.rotation_gradient {
                    out.rotation_gradient =
                        s.rotation.iter().map(|&v| self.frame.to_world(v)).collect();
                }
                s.gradient
            }
            None => {
                if wanted.distances {
                    let (inv_sum, min) = inverse_sum_and_min(self.input.distance);
                    out.harmonic_mean_distance = Some(self.layout.len() as f64 / inv_sum);
                    out.min_distance = Some(min);
                }
                if wanted.gradient || wanted.rotation_gradient {
                    let walls = ConcentricWalls::cached(&self.layout);
                    let (gradient, rotation) = self.concentric_pass(&walls, rad, wanted);
                    if wanted.rotation_gradient {
                        out.rotation_gradient = rotation
                            .into_iter()
                            .map(|v| self.frame.to_world(v))
                            .collect();
                    }
                    gradient
                } else {
                    Vec::new()
                }
            }
        };
        if wanted.gradient {
            if out.gradient.is_empty() {
                out.gradient = vec![DVec3::ZERO; ch];
            }
            for (g, l) in out.gradient.iter_mut().zip(local) {
                *g += self.frame.to_world(l);
            }
        }
    }

    /// One pass over the rows of a polar or sphere layout: the Ward-Heckbert wall terms on the total
    /// (surface + media) radiance, the rotational gradient and the distances.
    ///
    /// Each wall contributes `(L_a − L_b)/min(r_a, r_b)` times its wall vector; the vectors factor
    /// into a per-ring scalar and a per-column vector, so the pass accumulates scalars per column
    /// and applies the column vectors once at the end (likewise `∫_cell sinθ e_φ dω` for the
    /// rotation). Each row is copied channel-major into f64, so every per-column accumulation is a
    /// contiguous loop the compiler vectorizes; the per-column wall scales `1/min(r_a, r_b)` are
    /// shared by the channels. The sums over a column run in the same order as a plain loop over
    /// the walls; only the normal component and the distance sum are
    /// reassociated (rounding-level differences).
    fn polar_pass<T: Copy + Into<f64>>(
        &self,
        walls: &Walls,
        rad: &[T],
        wanted: Wanted,
    ) -> PolarSums {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx2() {
            // SAFETY: the CPU has AVX2. (No FMA: results are bitwise those of the SSE2 build.)
            return unsafe { self.polar_pass_avx2(walls, rad, wanted) };
        }
        self.polar_pass_any(walls, rad, wanted)
    }

    /// [`ValidGather::polar_pass`] compiled for AVX2 (4 doubles per vector).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn polar_pass_avx2<T: Copy + Into<f64>>(
        &self,
        walls: &Walls,
        rad: &[T],
        wanted: Wanted,
    ) -> PolarSums {
        self.polar_pass_any(walls, rad, wanted)
    }

    #[inline(always)]
    fn polar_pass_any<T: Copy + Into<f64>>(
        &self,
        walls: &Walls,
        rad: &[T],
        wanted: Wanted,
    ) -> PolarSums {
        let (m, n) = (self.layout.m as usize, self.layout.n as usize);
        let ch = self.input.channels;
        let plane = ch * n;
        let grad = wanted.gradient;
        let rot = wanted.rotation_gradient && self.layout.kind == LayoutKind::CosinePolar;
        // All row buffers and column accumulators in one allocation.
        let planes = |on: bool, count: usize| if on { count * plane } else { 0 };
        let mut scratch = vec![0.0; 2 * plane + 4 * n + planes(grad, 3) + planes(rot, 1)];
        let (mut cur, rest) = scratch.split_at_mut(plane);
        let (mut prev, rest) = rest.split_at_mut(plane);
        let (mut inv, rest) = rest.split_at_mut(n);
        let (mut inv_prev, rest) = rest.split_at_mut(n);
        let (s_az, rest) = rest.split_at_mut(n);
        let (s_ring, rest) = rest.split_at_mut(n);
        let (azimuth, rest) = rest.split_at_mut(planes(grad, 1));
        let (ring, rest) = rest.split_at_mut(planes(grad, 1));
        let (normal, column) = rest.split_at_mut(planes(grad, 1));
        let mut dist = DistanceSums::new();
        for j in 0..m {
            channel_major(&rad[j * plane..(j + 1) * plane], ch, cur);
            let r = &self.input.distance[j * n..(j + 1) * n];
            if grad || wanted.distances {
                for (inv, &r) in inv.iter_mut().zip(r) {
                    // 1/r, 0 for a miss: 1/min(r_a, r_b) = max(1/r_a, 1/r_b).
                    *inv = 1.0 / r;
                }
            }
            if wanted.distances {
                dist.add(r, inv);
            }
            if grad {
                if n >= 2 {
                    let span = walls.ring_span[j];
                    s_az[0] = inv[0].max(inv[n - 1]) * span;
                    for ((s, &a), &b) in s_az[1..n].iter_mut().zip(&inv[1..]).zip(&inv[..n - 1]) {
                        *s = a.max(b) * span;
                    }
                }
                if j >= 1 {
                    for ((s, &a), &b) in s_ring.iter_mut().zip(inv.iter()).zip(inv_prev.iter()) {
                        *s = a.max(b);
                    }
                }
            }
            let (ring_a, ring_b) = walls.ring_wall[j];
            let sin2 = walls.ring_sin2[j];
            for c in 0..ch {
                let span = c * n..(c + 1) * n;
                let (l, lp) = (&cur[span.clone()], &prev[span.clone()]);
                if grad && rot && n >= 2 && j >= 1 {
                    // The common case in one loop: each element sees the same operations in the
                    // same order as in the separate loops below.
                    let az = &mut azimuth[span.clone()];
                    let (rg, nz) = (&mut ring[span.clone()], &mut normal[span.clone()]);
                    let col = &mut column[span];
                    az[0] += (l[0] - l[n - 1]) * s_az[0];
                    let d = (l[0] - lp[0]) * s_ring[0];
                    rg[0] += d * ring_a;
                    nz[0] += d * ring_b;
                    col[0] += sin2 * l[0];
                    let accumulators = az[1..]
                        .iter_mut()
                        .zip(rg[1..].iter_mut())
                        .zip(nz[1..].iter_mut().zip(col[1..].iter_mut()));
                    let inputs = l[1..]
                        .iter()
                        .zip(&l[..n - 1])
                        .zip(lp[1..].iter().zip(&s_az[1..]).zip(&s_ring[1..]));
                    for (((az, rg), (nz, col)), ((&l1, &l0), ((&lp1, &sa), &sr))) in
                        accumulators.zip(inputs)
                    {
                        *az += (l1 - l0) * sa;
                        let d = (l1 - lp1) * sr;
                        *rg += d * ring_a;
                        *nz += d * ring_b;
                        *col += sin2 * l1;
                    }
                    continue;
                }
                if grad {
                    let az = &mut azimuth[span.clone()];
                    if n >= 2 {
                        az[0] += (l[0] - l[n - 1]) * s_az[0];
                        for (((a, &l1), &l0), &s) in az[1..]
                            .iter_mut()
                            .zip(&l[1..])
                            .zip(&l[..n - 1])
                            .zip(&s_az[1..n])
                        {
                            *a += (l1 - l0) * s;
                        }
                    }
                    if j >= 1 {
                        let (rg, nz) = (&mut ring[span.clone()], &mut normal[span.clone()]);
                        for ((((rg, nz), &l1), &l0), &s) in
                            rg.iter_mut().zip(nz).zip(l).zip(lp).zip(&s_ring[..n])
                        {
                            let d = (l1 - l0) * s;
                            *rg += d * ring_a;
                            *nz += d * ring_b;
                        }
                    }
                }
                if rot {
                    for (acc, &l) in column[span].iter_mut().zip(l) {
                        *acc += sin2 * l;
                    }
                }
            }
            std::mem::swap(&mut cur, &mut prev);
            std::mem::swap(&mut inv, &mut inv_prev);
        }
        let mut out = PolarSums {
            gradient: Vec::new(),
            rotation: Vec::new(),
            inv_sum: 0.0,
            min: f64::INFINITY,
        };
        (out.inv_sum, out.min) = dist.finish();
        if grad {
            out.gradient = normal
                .chunks_exact(n)
                .map(|z| DVec3::new(0.0, 0.0, pairwise_sum(z)))
                .collect();
            for k in 0..n {
                let (cos_k, sin_k) = walls.phi_wall[k];
                let (c1, c2) = walls.column[k];
                for (c, g) in out.gradient.iter_mut().enumerate() {
                    let (az, rg) = (azimuth[c * n + k], ring[c * n + k]);
                    g.x += rg * c1 - az * sin_k;
                    g.y += rg * c2 + az * cos_k;
                }
            }
        }
        if wanted.rotation_gradient {
            out.rotation = vec![DVec3::ZERO; ch];
            if rot {
                // ∫_cell sinθ e_φ dω = (∫ sin²θ dθ)(∫ e_φ dφ): per-column sums, then the vectors.
                for k in 0..n {
                    let (c1, c2) = walls.column[k];
                    for (c, g) in out.rotation.iter_mut().enumerate() {
                        *g += DVec3::new(-c2, c1, 0.0) * column[c * n + k];
                    }
                }
            }
        }
        out
    }

    /// The same wall terms for the concentric layout, whose wall vectors are computed by quadrature
    /// along the images of the grid lines (see [`ConcentricWalls`]), and its rotational gradient
    /// `∫ L (n × ω) dω`; both local frame, per channel, empty when not wanted.
    fn concentric_pass<T: Copy + Into<f64>>(
        &self,
        walls: &ConcentricWalls,
        rad: &[T],
        wanted: Wanted,
    ) -> (Vec<DVec3>, Vec<DVec3>) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx2() {
            // SAFETY: the CPU has AVX2. (No FMA: results are bitwise those of the SSE2 build.)
            return unsafe { self.concentric_pass_avx2(walls, rad, wanted) };
        }
        self.concentric_pass_any(walls, rad, wanted)
    }

    /// [`ValidGather::concentric_pass`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn concentric_pass_avx2<T: Copy + Into<f64>>(
        &self,
        walls: &ConcentricWalls,
        rad: &[T],
        wanted: Wanted,
    ) -> (Vec<DVec3>, Vec<DVec3>) {
        self.concentric_pass_any(walls, rad, wanted)
    }

    /// Row by row like [`ValidGather::polar_pass`]: each wall's `(L_a − L_b)/min(r_a, r_b)` times
    /// its vector, accumulated per column and axis (contiguous loops), summed over the columns
    /// at the end. Concentric strata are not θ/φ boxes, so the rotational gradient is the Monte
    /// Carlo estimate with the cosine pdf: `(n × ω)/cosθ` per sample, cosθ clamped where a
    /// jittered sample touches the horizon.
    #[inline(always)]
    fn concentric_pass_any<T: Copy + Into<f64>>(
        &self,
        walls: &ConcentricWalls,
        rad: &[T],
        wanted: Wanted,
    ) -> (Vec<DVec3>, Vec<DVec3>) {
        let (grad, rot) = (wanted.gradient, wanted.rotation_gradient);
        let (m, n) = (self.layout.m as usize, self.layout.n as usize);
        let ch = self.input.channels;
        let plane = ch * n;
        let planes = |on: bool, count: usize| if on { count * plane } else { 0 };
        let mut scratch = vec![0.0; 2 * plane + 6 * n + planes(grad, 3) + planes(rot, 2)];
        let (mut cur, rest) = scratch.split_at_mut(plane);
        let (mut prev, rest) = rest.split_at_mut(plane);
        let (mut inv, rest) = rest.split_at_mut(n);
        let (mut inv_prev, rest) = rest.split_at_mut(n);
        let (s1, rest) = rest.split_at_mut(n);
        let (s2, rest) = rest.split_at_mut(n);
        let (rot_x, rest) = rest.split_at_mut(n);
        let (rot_y, rest) = rest.split_at_mut(n);
        let (acc_x, rest) = rest.split_at_mut(planes(grad, 1));
        let (acc_y, rest) = rest.split_at_mut(planes(grad, 1));
        let (acc_z, rest) = rest.split_at_mut(planes(grad, 1));
        let (racc_x, racc_y) = rest.split_at_mut(planes(rot, 1));
        let weight = self.stratum_weight();
        let (t, b, nrm) = (
            self.frame.tangent,
            self.frame.bitangent(),
            self.frame.normal,
        );
        let [f_x, f_y, f_z] = &walls.first_by_axis;
        let [s_x, s_y, s_z] = &walls.second_by_axis;
        for j in 0..m {
            channel_major(&rad[j * plane..(j + 1) * plane], ch, cur);
            if rot {
                let dirs = &self.input.directions[j * n..(j + 1) * n];
                for ((&w, vx), vy) in dirs.iter().zip(rot_x.iter_mut()).zip(rot_y.iter_mut()) {
                    let scale = weight / w.dot(nrm).max(1e-6);
                    (*vx, *vy) = (-w.dot(b) * scale, w.dot(t) * scale);
                }
                for c in 0..ch {
                    let span = c * n..(c + 1) * n;
                    let l = &cur[span.clone()];
                    let (ax, ay) = (&mut racc_x[span.clone()], &mut racc_y[span]);
                    for ((((ax, ay), &l), &vx), &vy) in ax
                        .iter_mut()
                        .zip(ay.iter_mut())
                        .zip(l)
                        .zip(rot_x.iter())
                        .zip(rot_y.iter())
                    {
                        *ax += vx * l;
                        *ay += vy * l;
                    }
                }
            }
            if !grad {
                continue;
            }
            for (inv, &r) in inv.iter_mut().zip(&self.input.distance[j * n..(j + 1) * n]) {
                *inv = 1.0 / r;
            }
            if j >= 1 {
                for ((s, &a), &b) in s1.iter_mut().zip(inv.iter()).zip(inv_prev.iter()) {
                    *s = a.max(b);
                }
            }
            for ((s, &a), &b) in s2[1..].iter_mut().zip(&inv[1..]).zip(&inv[..n - 1]) {
                *s = a.max(b);
            }
            // Wall vectors of the walls below row j (first axis) and inside row j (second axis).
            let below = if j >= 1 { (j - 1) * n..j * n } else { 0..0 };
            let (fx, fy, fz) = (&f_x[below.clone()], &f_y[below.clone()], &f_z[below]);
            let inside = j * (n - 1)..(j + 1) * (n - 1);
            let (sx, sy, sz) = (&s_x[inside.clone()], &s_y[inside.clone()], &s_z[inside]);
            for c in 0..ch {
                let span = c * n..(c + 1) * n;
                let (l, lp) = (&cur[span.clone()], &prev[span.clone()]);
                let ax = &mut acc_x[span.clone()];
                let ay = &mut acc_y[span.clone()];
                let az = &mut acc_z[span];
                if j >= 1 {
                    let diff = l
                        .iter()
                        .zip(lp)
                        .zip(s1.iter())
                        .map(|((&a, &b), &s)| (a - b) * s);
                    let vectors = fx.iter().zip(fy).zip(fz);
                    for (((d, ((wx, wy), wz)), ax), (ay, az)) in diff
                        .zip(vectors)
                        .zip(ax.iter_mut())
                        .zip(ay.iter_mut().zip(az.iter_mut()))
                    {
                        *ax += wx * d;
                        *ay += wy * d;
                        *az += wz * d;
                    }
                }
                let diff = l[1..]
                    .iter()
                    .zip(&l[..n - 1])
                    .zip(&s2[1..])
                    .map(|((&a, &b), &s)| (a - b) * s);
                let vectors = sx.iter().zip(sy).zip(sz);
                for (((d, ((wx, wy), wz)), ax), (ay, az)) in diff
                    .zip(vectors)
                    .zip(ax[1..].iter_mut())
                    .zip(ay[1..].iter_mut().zip(az[1..].iter_mut()))
                {
                    *ax += wx * d;
                    *ay += wy * d;
                    *az += wz * d;
                }
            }
            std::mem::swap(&mut cur, &mut prev);
            std::mem::swap(&mut inv, &mut inv_prev);
        }
        let sums = |on: bool, x: &[f64], y: &[f64], z: Option<&[f64]>| -> Vec<DVec3> {
            if !on {
                return Vec::new();
            }
            (0..ch)
                .map(|c| {
                    let span = c * n..(c + 1) * n;
                    DVec3::new(
                        pairwise_sum(&x[span.clone()]),
                        pairwise_sum(&y[span.clone()]),
                        z.map_or(0.0, |z| pairwise_sum(&z[span])),
                    )
                })
                .collect()
        };
        (
            sums(grad, acc_x, acc_y, Some(acc_z)),
            sums(rot, racc_x, racc_y, None),
        )
    }
}

/// What [`ValidGather::polar_pass`] sums (local frame, before the stratum weight).
struct PolarSums {
    gradient: Vec<DVec3>,
    rotation: Vec<DVec3>,
    inv_sum: f64,
    min: f64,
}

/// Copies one row `[k·ch + c]` into `out[c·n + k]` as f64.
#[inline(always)]
fn channel_major<T: Copy + Into<f64>>(row: &[T], ch: usize, out: &mut [f64]) {
    let n = row.len() / ch;
    match ch {
        1 => {
            for (o, &l) in out.iter_mut().zip(row) {
                *o = l.into();
            }
        }
        3 => {
            let (o0, rest) = out.split_at_mut(n);
            let (o1, o2) = rest.split_at_mut(n);
            for (((cell, a), b), c) in row.chunks_exact(3).zip(o0).zip(o1).zip(o2) {
                (*a, *b, *c) = (cell[0].into(), cell[1].into(), cell[2].into());
            }
        }
        _ => {
            for (k, cell) in row.chunks_exact(ch).enumerate() {
                for (c, &l) in cell.iter().enumerate() {
                    out[c * n + k] = l.into();
                }
            }
        }
    }
}

/// Sum with a short dependency chain (and an error bound of `log2(len)` ulps of the absolute sum).
fn pairwise_sum(v: &[f64]) -> f64 {
    if v.len() <= 8 {
        return v.iter().sum();
    }
    let (a, b) = v.split_at(v.len() / 2);
    pairwise_sum(a) + pairwise_sum(b)
}

/// Per-channel sums of `rad` (index `i·ch + c`), accumulated column by column over blocks of
/// strata so the loop vectorizes.
fn channel_sums<T: Copy + Into<f64>>(rad: &[T], ch: usize) -> Vec<f64> {
    const BLOCK: usize = 64;
    let width = BLOCK * ch;
    let mut acc = vec![0.0; width];
    let mut chunks = rad.chunks_exact(width);
    for block in &mut chunks {
        for (a, &l) in acc.iter_mut().zip(block) {
            *a += l.into();
        }
    }
    for (a, &l) in acc.iter_mut().zip(chunks.remainder()) {
        *a += l.into();
    }
    (0..ch)
        .map(|c| acc.iter().skip(c).step_by(ch).sum())
        .collect()
}

/// `(Σ 1/r, min r)` over the hit distances (misses add 0), with four independent partial sums.
struct DistanceSums {
    sum: [f64; 4],
    min: [f64; 4],
}

impl DistanceSums {
    fn new() -> Self {
        DistanceSums {
            sum: [0.0; 4],
            min: [f64::INFINITY; 4],
        }
    }

    /// Adds distances `r` with their inverses `inv`.
    #[inline]
    fn add(&mut self, r: &[f64], inv: &[f64]) {
        let (rc, ic) = (r.chunks_exact(4), inv.chunks_exact(4));
        let (rr, ir) = (rc.remainder(), ic.remainder());
        for (r, inv) in rc.zip(ic) {
            for l in 0..4 {
                self.sum[l] += inv[l];
                self.min[l] = self.min[l].min(r[l]);
            }
        }
        for (l, (&r, &inv)) in rr.iter().zip(ir).enumerate() {
            self.sum[l] += inv;
            self.min[l] = self.min[l].min(r);
        }
    }

    fn finish(&self) -> (f64, f64) {
        let s = &self.sum;
        let m = &self.min;
        (
            (s[0] + s[1]) + (s[2] + s[3]),
            m[0].min(m[1]).min(m[2].min(m[3])),
        )
    }
}

/// `(Σ 1/r, min r)` over all distances.
fn inverse_sum_and_min(distance: &[f64]) -> (f64, f64) {
    let mut sums = DistanceSums::new();
    let mut inv = [0.0; 64];
    for r in distance.chunks(64) {
        for (i, &r) in inv.iter_mut().zip(r) {
            *i = 1.0 / r;
        }
        sums.add(r, &inv[..r.len()]);
    }
    sums.finish()
}

/// Irradiance and derivatives from a gather: validates, then [`ValidGather::evaluate`].
pub fn evaluate(
    layout: &Layout,
    frame: &Frame,
    input: &GatherInput<'_>,
    wanted: Wanted,
) -> Result<GatherValues> {
    ValidGather::new(layout, frame, input)?.evaluate(wanted)
}

mod media;
#[cfg(test)]
mod tests;
