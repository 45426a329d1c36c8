//! Test-only analytic scenes for the gather tests: axis-aligned horizontal rectangles (emitters,
//! occluders) above the plane z = 0, a distant environment, and an optional homogeneous medium with
//! in-scattered radiance, together with a tiny ray caster and exact (or finely integrated) references.
//!
//! Reference irradiance: every rectangle is projected from x onto one plane z = H above them all; the
//! projections cut that plane into a grid of axis-aligned cells, each showing one front rectangle (or
//! the environment). Without a medium, a cell's contribution is the exact Lambert polygon form
//! factor; with one, a 16x16 Gauss-Legendre rule over the cell (smooth integrand) plus Gauss-Legendre
//! in depth for a varying medium. Gradients: 4th-order central differences of that reference.
#![allow(dead_code)]

use glam::DVec3;
use raddiff::gather::{
    evaluate, Frame, GatherInput, GatherValues, Layout, LayoutKind, MediaRadiance, Wanted,
};
use std::f64::consts::PI;

#[derive(Clone, Copy, Debug)]
pub struct Quad {
    pub h: f64,
    pub x: [f64; 2],
    pub y: [f64; 2],
    pub radiance: f64,
}

#[derive(Clone, Copy, Debug)]
pub enum Media {
    None,
    /// Constant in-scattered/emitted radiance per unit length.
    Constant(f64),
    /// q0 (1 + 0.5 sin(a.p)), a = (1.1, 0.7, 0.9): a spatially varying in-scattered radiance.
    Field(f64),
}

const FIELD_A: DVec3 = DVec3::new(1.1, 0.7, 0.9);

impl Media {
    pub fn q(&self, p: DVec3) -> f64 {
        match *self {
            Media::None => 0.0,
            Media::Constant(q) => q,
            Media::Field(q0) => q0 * (1.0 + 0.5 * FIELD_A.dot(p).sin()),
        }
    }
    pub fn grad(&self, p: DVec3) -> DVec3 {
        match *self {
            Media::Field(q0) => FIELD_A * (q0 * 0.5 * FIELD_A.dot(p).cos()),
            _ => DVec3::ZERO,
        }
    }
}

#[derive(Clone, Debug)]
pub struct Scene {
    pub quads: Vec<Quad>,
    pub env: f64,
    pub sigma: f64,
    pub media: Media,
    /// Media are marched over [0, steps*step] (the reference truncates there too).
    pub steps: usize,
    pub step: f64,
}

/// A unit square emitter of radiance 1 at height 1, off-centre so both tangent components matter.
pub fn emitter() -> Quad {
    Quad {
        h: 1.0,
        x: [-0.3, 0.7],
        y: [-0.2, 0.8],
        radiance: 1.0,
    }
}

/// One black occluder half-way up.
pub fn occluder_a() -> Quad {
    Quad {
        h: 0.5,
        x: [0.05, 0.45],
        y: [-0.1, 0.3],
        radiance: 0.0,
    }
}

/// A second, dim occluder whose projection overlaps the first and the emitter edge.
pub fn occluder_b() -> Quad {
    Quad {
        h: 0.7,
        x: [-0.25, 0.15],
        y: [0.2, 0.55],
        radiance: 0.1,
    }
}

impl Scene {
    pub fn new(quads: Vec<Quad>) -> Scene {
        Scene {
            quads,
            env: 0.0,
            sigma: 0.0,
            media: Media::None,
            steps: 0,
            step: 0.0,
        }
    }

    /// Nearest hit from x along w: (distance, radiance); a miss gives (INFINITY, env).
    pub fn trace(&self, x: DVec3, w: DVec3) -> (f64, f64) {
        let mut best = (f64::INFINITY, self.env);
        if w.z <= 0.0 {
            return best;
        }
        for q in &self.quads {
            let t = (q.h - x.z) / w.z;
            if t <= 0.0 || t >= best.0 {
                continue;
            }
            let p = x + w * t;
            if p.x >= q.x[0] && p.x <= q.x[1] && p.y >= q.y[0] && p.y <= q.y[1] {
                best = (t, q.radiance);
            }
        }
        best
    }

    pub fn march_end(&self) -> f64 {
        self.steps as f64 * self.step
    }

    /// The gather input for a layout at `frame`, and the evaluation.
    pub fn gather(&self, layout: &Layout, frame: &Frame, with_media_terms: bool) -> GatherValues {
        let dirs = layout.directions(frame).unwrap();
        let x = frame.position;
        let mut dist = Vec::with_capacity(dirs.len());
        let mut rad = Vec::with_capacity(dirs.len());
        let has_media = !matches!(self.media, Media::None);
        let mut mrad = Vec::new();
        let mut mgrad = Vec::new();
        for &w in &dirs {
            let (r, l) = self.trace(x, w);
            dist.push(r);
            let mut cell = l;
            if has_media {
                let mut lm = 0.0;
                for s in 0..self.steps {
                    let t = (s as f64 + 0.5) * self.step;
                    let p = x + w * t;
                    mrad.push(self.media.q(p) as f32);
                    let g = self.media.grad(p);
                    mgrad.extend([g.x as f32, g.y as f32, g.z as f32]);
                    // what a renderer would fold into the cell without the media terms
                    let (a, b) = (s as f64 * self.step, (s as f64 + 1.0) * self.step);
                    let b = b.min(r);
                    if b > a {
                        lm += self.media.q(p) * ((-self.sigma * a).exp() - (-self.sigma * b).exp())
                            / self.sigma;
                    }
                }
                cell = l * (-self.sigma * r).exp() + lm;
            } else if self.sigma > 0.0 {
                cell = l * (-self.sigma * r).exp();
            }
            rad.push(if with_media_terms {
                l as f32
            } else {
                cell as f32
            });
        }
        let media = (has_media && with_media_terms).then(|| MediaRadiance {
            radiance: &mrad,
            gradient: Some(&mgrad),
            steps: self.steps,
            step: self.step,
        });
        let input = GatherInput {
            directions: &dirs,
            distance: &dist,
            radiance: &rad,
            channels: 1,
            sigma_t: if with_media_terms { self.sigma } else { 0.0 },
            media,
        };
        evaluate(layout, frame, &input, Wanted::ALL).unwrap()
    }

    /// ∫_a^b exp(−σt) Q(x + tω) dt.
    fn media_segment(&self, x: DVec3, w: DVec3, a: f64, b: f64) -> f64 {
        if b <= a {
            return 0.0;
        }
        match self.media {
            Media::None => 0.0,
            Media::Constant(q) => {
                if self.sigma == 0.0 {
                    q * (b - a)
                } else {
                    q * ((-self.sigma * a).exp() - (-self.sigma * b).exp()) / self.sigma
                }
            }
            Media::Field(_) => {
                let chunks = (b - a).ceil().max(1.0) as usize;
                let len = (b - a) / chunks as f64;
                let mut sum = 0.0;
                for c in 0..chunks {
                    let lo = a + c as f64 * len;
                    for (t, wt) in gauss16(lo, lo + len) {
                        sum += wt * (-self.sigma * t).exp() * self.media.q(x + w * t);
                    }
                }
                sum
            }
        }
    }

    /// Reference irradiance at x with normal n (x below every quad).
    pub fn irradiance(&self, x: DVec3, n: DVec3) -> f64 {
        self.integrate(x, n, false)
    }

    /// Reference fluence at x (whole sphere; needs sigma > 0 or env = 0 below the horizon).
    pub fn fluence(&self, x: DVec3) -> f64 {
        self.integrate(x, DVec3::Z, true)
    }

    fn integrate(&self, x: DVec3, n: DVec3, fluence: bool) -> f64 {
        let weight = |w: DVec3| if fluence { 1.0 } else { n.dot(w) };
        let top = self.quads.iter().map(|q| q.h).fold(f64::MIN, f64::max);
        let scale = |h: f64| (top - x.z) / (h - x.z);
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for q in &self.quads {
            let s = scale(q.h);
            for e in q.x {
                xs.push(x.x + (e - x.x) * s);
            }
            for e in q.y {
                ys.push(x.y + (e - x.y) * s);
            }
        }
        xs.sort_by(f64::total_cmp);
        ys.sort_by(f64::total_cmp);
        xs.dedup();
        ys.dedup();
        // environment over the whole hemisphere, then each cell's difference to it
        let mut e = self.hemisphere_env(x, n, fluence);
        let simple = !fluence && self.sigma == 0.0 && matches!(self.media, Media::None);
        for a in 0..xs.len() - 1 {
            for b in 0..ys.len() - 1 {
                let c = DVec3::new(0.5 * (xs[a] + xs[a + 1]), 0.5 * (ys[b] + ys[b + 1]), top);
                // front quad: the lowest one whose projection covers the cell centre
                let mut front: Option<&Quad> = None;
                for q in &self.quads {
                    let s = scale(q.h);
                    let p = x + (c - x) / s;
                    if p.x > q.x[0]
                        && p.x < q.x[1]
                        && p.y > q.y[0]
                        && p.y < q.y[1]
                        && front.map_or(true, |f| q.h < f.h)
                    {
                        front = Some(q);
                    }
                }
                let Some(q) = front else { continue };
                if simple {
                    let poly = [
                        DVec3::new(xs[a], ys[b], top),
                        DVec3::new(xs[a + 1], ys[b], top),
                        DVec3::new(xs[a + 1], ys[b + 1], top),
                        DVec3::new(xs[a], ys[b + 1], top),
                    ];
                    e += (q.radiance - self.env) * PI * lambert_form_factor(x, n, &poly);
                    continue;
                }
                let sq = scale(q.h);
                for (px, wx) in gauss16(xs[a], xs[a + 1]) {
                    for (py, wy) in gauss16(ys[b], ys[b + 1]) {
                        let d = DVec3::new(px, py, top) - x;
                        let rho = d.length();
                        let w = d / rho;
                        let domega = (top - x.z) / (rho * rho * rho);
                        let r = rho / sq;
                        let env = if self.sigma == 0.0 { self.env } else { 0.0 };
                        let f = q.radiance * (-self.sigma * r).exp()
                            - env
                            - self.media_segment(x, w, r.min(self.march_end()), self.march_end());
                        e += wx * wy * domega * weight(w) * f;
                    }
                }
            }
        }
        e
    }

    /// ∫ over the hemisphere of n (or the sphere) of the environment's radiance times (n·ω) (or 1).
    fn hemisphere_env(&self, x: DVec3, n: DVec3, fluence: bool) -> f64 {
        let sr = if fluence { 4.0 * PI } else { PI };
        let surface = if self.sigma == 0.0 {
            self.env * sr
        } else {
            0.0
        };
        match self.media {
            Media::None => surface,
            Media::Constant(_) => {
                surface + sr * self.media_segment(x, DVec3::Z, 0.0, self.march_end())
            }
            Media::Field(_) => {
                let t = n.any_orthonormal_vector();
                let b = n.cross(t);
                let nphi = 96;
                let mut sum = 0.0;
                let top = if fluence { PI } else { PI / 2.0 };
                for (th, wt) in gauss_n(0.0, top, 4) {
                    for i in 0..nphi {
                        let ph = 2.0 * PI * i as f64 / nphi as f64;
                        let w = (t * ph.cos() + b * ph.sin()) * th.sin() + n * th.cos();
                        let m = self.media_segment(x, w, 0.0, self.march_end());
                        let c = if fluence { 1.0 } else { th.cos() };
                        sum += wt * (2.0 * PI / nphi as f64) * c * th.sin() * m;
                    }
                }
                surface + sum
            }
        }
    }

    /// 4th-order central-difference gradient of the reference irradiance (normal fixed).
    pub fn irradiance_gradient(&self, x: DVec3, n: DVec3) -> DVec3 {
        central_gradient(|p| self.irradiance(p, n), x)
    }

    /// 4th-order central-difference gradient of the reference fluence.
    pub fn fluence_gradient(&self, x: DVec3) -> DVec3 {
        central_gradient(|p| self.fluence(p), x)
    }
}

/// 4th-order central differences, step 1e-3 (the references are smooth in x and accurate to ~1e-13).
pub fn central_gradient(f: impl Fn(DVec3) -> f64, x: DVec3) -> DVec3 {
    let h = 1e-3;
    let mut g = DVec3::ZERO;
    for axis in 0..3 {
        let mut e = DVec3::ZERO;
        e[axis] = h;
        let f = |s: f64| f(x + e * s);
        g[axis] = (f(-2.0) - 8.0 * f(-1.0) + 8.0 * f(1.0) - f(2.0)) / (12.0 * h);
    }
    g
}

/// Form factor of a convex planar polygon fully above the tangent plane of (x, n): Lambert's formula.
pub fn lambert_form_factor(x: DVec3, n: DVec3, poly: &[DVec3]) -> f64 {
    let mut sum = 0.0;
    for i in 0..poly.len() {
        let a = poly[i] - x;
        let b = poly[(i + 1) % poly.len()] - x;
        let c = a.cross(b);
        let len = c.length();
        if len == 0.0 {
            continue;
        }
        let beta = len.atan2(a.dot(b));
        sum += beta * n.dot(c) / len;
    }
    (sum / (2.0 * PI)).abs()
}

/// 16-point Gauss-Legendre nodes and weights on [a, b].
pub fn gauss16(a: f64, b: f64) -> impl Iterator<Item = (f64, f64)> {
    const X: [f64; 8] = [
        0.0950125098376374,
        0.2816035507792589,
        0.4580167776572274,
        0.6178762444026438,
        0.755404408355003,
        0.8656312023878318,
        0.9445750230732326,
        0.9894009349916499,
    ];
    const W: [f64; 8] = [
        0.1894506104550685,
        0.1826034150449236,
        0.1691565193950025,
        0.1495959888165767,
        0.1246289712555339,
        0.0951585116824928,
        0.0622535239386479,
        0.0271524594117541,
    ];
    let (m, r) = (0.5 * (a + b), 0.5 * (b - a));
    (0..16).map(move |i| {
        let (x, w) = (X[i % 8], W[i % 8]);
        let x = if i < 8 { -x } else { x };
        (m + r * x, r * w)
    })
}

/// `pieces` consecutive 16-point rules on [a, b].
pub fn gauss_n(a: f64, b: f64, pieces: usize) -> Vec<(f64, f64)> {
    let len = (b - a) / pieces as f64;
    (0..pieces)
        .flat_map(|p| gauss16(a + p as f64 * len, a + (p + 1) as f64 * len))
        .collect()
}

/// Frame on the plane z = 0 at (px, py) with normal +z.
pub fn plane_frame(px: f64, py: f64) -> Frame {
    Frame::new(DVec3::new(px, py, 0.0), DVec3::Z, DVec3::X).unwrap()
}

pub fn polar(m: u32, seed: u64) -> Layout {
    Layout::new(LayoutKind::CosinePolar, m, 2 * m, seed).unwrap()
}

/// Relative error of the tangent (x, y) components and of the full 3D vector.
pub fn rel_err(got: DVec3, want: DVec3) -> (f64, f64) {
    let t = (got.truncate() - want.truncate()).length() / want.truncate().length();
    let f = (got - want).length() / want.length();
    (t, f)
}

/// Least-squares slope of log(err) against log(m).
pub fn rate(ms: &[u32], errs: &[f64]) -> f64 {
    let n = ms.len() as f64;
    let lx: Vec<f64> = ms.iter().map(|&m| (m as f64).ln()).collect();
    let ly: Vec<f64> = errs.iter().map(|e| e.ln()).collect();
    let mx = lx.iter().sum::<f64>() / n;
    let my = ly.iter().sum::<f64>() / n;
    let num: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let den: f64 = lx.iter().map(|x| (x - mx) * (x - mx)).sum();
    num / den
}
