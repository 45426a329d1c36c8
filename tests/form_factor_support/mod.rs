//! Shared helpers for the form factor's tests: an arbitrary-precision (astro-float, 320 bits) reference
//! for the point-to-polygon form factor and its edge terms, with derivatives by central differences,
//! and error metrics.
#![allow(dead_code)]

use astro_float::{BigFloat, Consts, RoundingMode, Sign};
use glam::{DMat3, DVec3};

pub const P: usize = 320;
const RM: RoundingMode = RoundingMode::ToEven;

pub struct Big {
    cc: Consts,
    pi: BigFloat,
}

type B3 = [BigFloat; 3];

fn bf(v: f64) -> BigFloat {
    BigFloat::from_f64(v, 64)
}

pub fn to_f64(b: &BigFloat) -> f64 {
    if b.is_zero() {
        return 0.0;
    }
    let (m, _n, s, e, _) = b.as_raw_parts().expect("reference is not a number");
    let top = *m.last().unwrap();
    // value = 0.top... * 2^e
    let mut v = top as f64;
    let mut ex = e as i64 - 64;
    while ex > 500 {
        v *= 2f64.powi(500);
        ex -= 500;
    }
    while ex < -500 {
        v *= 2f64.powi(-500);
        ex += 500;
    }
    v *= 2f64.powi(ex as i32);
    if s == Sign::Neg {
        -v
    } else {
        v
    }
}

/// Reference derivatives in f64.
#[derive(Debug, Clone, Copy)]
pub struct Reference {
    pub value: f64,
    pub gradient: DVec3,
    pub hessian: DMat3,
}

impl Big {
    pub fn new() -> Self {
        let mut cc = Consts::new().unwrap();
        let pi = cc.pi(P, RM);
        Big { cc, pi }
    }

    fn add(&self, a: &BigFloat, b: &BigFloat) -> BigFloat {
        a.add(b, P, RM)
    }
    fn sub(&self, a: &BigFloat, b: &BigFloat) -> BigFloat {
        a.sub(b, P, RM)
    }
    fn mul(&self, a: &BigFloat, b: &BigFloat) -> BigFloat {
        a.mul(b, P, RM)
    }
    fn div(&self, a: &BigFloat, b: &BigFloat) -> BigFloat {
        a.div(b, P, RM)
    }
    fn dot(&self, a: &B3, b: &B3) -> BigFloat {
        let t = self.add(&self.mul(&a[0], &b[0]), &self.mul(&a[1], &b[1]));
        self.add(&t, &self.mul(&a[2], &b[2]))
    }
    fn cross(&self, a: &B3, b: &B3) -> B3 {
        [
            self.sub(&self.mul(&a[1], &b[2]), &self.mul(&a[2], &b[1])),
            self.sub(&self.mul(&a[2], &b[0]), &self.mul(&a[0], &b[2])),
            self.sub(&self.mul(&a[0], &b[1]), &self.mul(&a[1], &b[0])),
        ]
    }
    fn vsub(&self, a: &B3, b: &B3) -> B3 {
        [
            self.sub(&a[0], &b[0]),
            self.sub(&a[1], &b[1]),
            self.sub(&a[2], &b[2]),
        ]
    }
    fn vadd_scaled(&self, a: &B3, t: &BigFloat, e: &B3) -> B3 {
        [
            self.add(&a[0], &self.mul(t, &e[0])),
            self.add(&a[1], &self.mul(t, &e[1])),
            self.add(&a[2], &self.mul(t, &e[2])),
        ]
    }

    /// atan2(y, x) for y ≥ 0.
    fn atan2(&mut self, y: &BigFloat, x: &BigFloat) -> BigFloat {
        if x.is_zero() {
            return self.pi.div(&bf(2.0), P, RM);
        }
        let t = self.div(y, x).abs();
        let a = t.atan(P, RM, &mut self.cc);
        if x.is_negative() {
            self.sub(&self.pi, &a)
        } else {
            a
        }
    }

    /// Signed edge term β n·w/|w| / 2π for r_a, r_b.
    fn edge(&mut self, ra: &B3, rb: &B3, n: &B3) -> BigFloat {
        let w = self.cross(ra, rb);
        let w2 = self.dot(&w, &w);
        if w2.is_zero() {
            return bf(0.0);
        }
        let wl = w2.sqrt(P, RM);
        let beta = self.atan2(&wl, &self.dot(ra, rb));
        let nw = self.dot(n, &w);
        let two_pi = self.mul(&self.pi, &bf(2.0));
        self.div(&self.mul(&beta, &nw), &self.mul(&wl, &two_pi))
    }

    /// Two-sided, clipped form factor of the loop `r` (vertices relative to x).
    fn polygon(&mut self, r: &[B3], n: &B3, clip: bool) -> BigFloat {
        let count = r.len();
        let mut newell = [bf(0.0), bf(0.0), bf(0.0)];
        for i in 0..count {
            let c = self.cross(&r[i], &r[(i + 1) % count]);
            newell = [
                self.add(&newell[0], &c[0]),
                self.add(&newell[1], &c[1]),
                self.add(&newell[2], &c[2]),
            ];
        }
        // sign of N·r_0 (Newell of r equals Newell of v: translation invariant)
        let hp = self.dot(&newell, &r[0]);
        let mut loopv: Vec<B3> = Vec::new();
        if clip {
            let d: Vec<BigFloat> = r.iter().map(|v| self.dot(n, v)).collect();
            for i in 0..count {
                let j = (i + 1) % count;
                if !d[i].is_negative() {
                    loopv.push(r[i].clone());
                }
                let cross = (d[i].is_positive() && d[j].is_negative())
                    || (d[i].is_negative() && d[j].is_positive());
                if cross {
                    let t = self.div(&d[i], &self.sub(&d[i], &d[j]));
                    let e = self.vsub(&r[j], &r[i]);
                    loopv.push(self.vadd_scaled(&r[i], &t, &e));
                }
            }
        } else {
            loopv = r.to_vec();
        }
        let mut sum = bf(0.0);
        for i in 0..loopv.len() {
            let t = self.edge(&loopv[i], &loopv[(i + 1) % loopv.len()], n);
            sum = self.add(&sum, &t);
        }
        if hp.is_negative() {
            sum.neg()
        } else {
            sum
        }
    }

    /// Exact r_i = v_i − x (any magnitudes), rounded to P bits.
    fn rel(&self, x: DVec3, v: DVec3) -> B3 {
        let d = |a: f64, b: f64| {
            BigFloat::from_f64(a, 64)
                .sub(&BigFloat::from_f64(b, 64), 2300, RoundingMode::None)
                .add(&bf(0.0), P, RM)
        };
        [d(v.x, x.x), d(v.y, x.y), d(v.z, x.z)]
    }

    /// Value, gradient (central differences) and Hessian (second differences) of `f(r - δ)` at δ = 0,
    /// where the step is `step` (in the units of r).
    fn derivatives(
        &mut self,
        r: &[B3],
        step: f64,
        f: &mut dyn FnMut(&mut Self, &[B3]) -> BigFloat,
    ) -> Reference {
        let shift = |s: &Self, r: &[B3], d: [f64; 3]| -> Vec<B3> {
            r.iter()
                .map(|v| {
                    [
                        s.sub(&v[0], &bf(d[0])),
                        s.sub(&v[1], &bf(d[1])),
                        s.sub(&v[2], &bf(d[2])),
                    ]
                })
                .collect()
        };
        let f0 = f(self, r);
        let mut grad = [0.0; 3];
        let mut hess = [[0.0; 3]; 3];
        let hb = bf(step);
        for i in 0..3 {
            let mut d = [0.0; 3];
            d[i] = step;
            let fp = f(self, &shift(self, r, d));
            d[i] = -step;
            let fm = f(self, &shift(self, r, d));
            grad[i] = to_f64(&self.div(&self.sub(&fp, &fm), &self.mul(&hb, &bf(2.0))));
            // diagonal: (f(+2h) − 2f + f(−2h)) / 4h²
            d[i] = 2.0 * step;
            let fpp = f(self, &shift(self, r, d));
            d[i] = -2.0 * step;
            let fmm = f(self, &shift(self, r, d));
            let num = self.add(&self.sub(&fpp, &self.mul(&f0, &bf(2.0))), &fmm);
            hess[i][i] = to_f64(&self.div(&num, &self.mul(&self.mul(&hb, &hb), &bf(4.0))));
            for j in 0..i {
                let mut eval = |si: f64, sj: f64, s: &mut Self| {
                    let mut d = [0.0; 3];
                    d[i] = si * step;
                    d[j] = sj * step;
                    let rr = shift(s, r, d);
                    f(s, &rr)
                };
                let a = eval(1.0, 1.0, self);
                let b = eval(1.0, -1.0, self);
                let c = eval(-1.0, 1.0, self);
                let dd = eval(-1.0, -1.0, self);
                let num = self.add(&self.sub(&self.sub(&a, &b), &c), &dd);
                let v = to_f64(&self.div(&num, &self.mul(&self.mul(&hb, &hb), &bf(4.0))));
                hess[i][j] = v;
                hess[j][i] = v;
            }
        }
        Reference {
            value: to_f64(&f0),
            gradient: DVec3::from_array(grad),
            hessian: DMat3::from_cols_array_2d(&hess),
        }
    }

    /// Reference for `polygon_form_factor` (clip = true) or the unclipped two-sided form factor.
    pub fn polygon_reference(
        &mut self,
        x: DVec3,
        n: DVec3,
        verts: &[DVec3],
        clip: bool,
    ) -> Reference {
        let r: Vec<B3> = verts.iter().map(|v| self.rel(x, *v)).collect();
        let nb = [bf(n.x), bf(n.y), bf(n.z)];
        let step = step_for(x, verts);
        self.derivatives(&r, step, &mut |s, r| s.polygon(r, &nb, clip))
    }

    /// Reference for `edge_form_factor`.
    pub fn edge_reference(&mut self, x: DVec3, n: DVec3, a: DVec3, b: DVec3) -> Reference {
        let r = vec![self.rel(x, a), self.rel(x, b)];
        let nb = [bf(n.x), bf(n.y), bf(n.z)];
        let step = step_for(x, &[a, b]);
        self.derivatives(&r, step, &mut |s, r| s.edge(&r[0], &r[1], &nb))
    }
}

impl Default for Big {
    fn default() -> Self {
        Self::new()
    }
}

/// A finite-difference step far below every geometric length scale of the configuration.
fn step_for(x: DVec3, verts: &[DVec3]) -> f64 {
    let mut d = f64::INFINITY;
    for v in verts {
        d = d.min((*v - x).length());
    }
    d * 1e-24
}

/// Relative error of a scalar, normalized by max(|reference|, floor).
pub fn rel_scalar(got: f64, want: f64, floor: f64) -> f64 {
    (got - want).abs() / want.abs().max(floor)
}

/// Max-norm error of a vector normalized by the largest reference entry (and `floor`).
pub fn rel_vec(got: DVec3, want: DVec3, floor: f64) -> f64 {
    (got - want).abs().max_element() / want.abs().max_element().max(floor)
}

/// Max-norm error of a matrix normalized by the largest reference entry (and `floor`).
pub fn rel_mat(got: DMat3, want: DMat3, floor: f64) -> f64 {
    let g = got.to_cols_array();
    let w = want.to_cols_array();
    let mut err: f64 = 0.0;
    let mut big: f64 = floor;
    for k in 0..9 {
        err = err.max((g[k] - w[k]).abs());
        big = big.max(w[k].abs());
    }
    err / big
}

// `examples/kernels.rs` includes both support modules, each of which loads the generator.
#[allow(clippy::duplicate_mod)]
#[path = "../common/splitmix.rs"]
mod splitmix;

/// A tiny deterministic generator (SplitMix64) so accuracy runs are reproducible.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        splitmix::next_u64(&mut self.0)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    pub fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                self.range(-1., 1.),
                self.range(-1., 1.),
                self.range(-1., 1.),
            );
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
    pub fn vec(&mut self, scale: f64) -> DVec3 {
        DVec3::new(
            self.range(-1., 1.),
            self.range(-1., 1.),
            self.range(-1., 1.),
        ) * scale
    }
    /// A random triangle in the cube of half-side `scale`, redrawn until twice its area exceeds
    /// `0.05 scale²` (no slivers).
    pub fn fat_triangle(&mut self, scale: f64) -> [DVec3; 3] {
        loop {
            let t = [self.vec(scale), self.vec(scale), self.vec(scale)];
            if (t[1] - t[0]).cross(t[2] - t[0]).length() > 0.05 * scale * scale {
                return t;
            }
        }
    }
}

/// The hard-regime contract of issue 18: relative value, gradient, Hessian errors, each part
/// normalized by its largest entry.
pub const HARD: [f64; 3] = [1e-10, 1e-9, 1e-8];

/// The errors of `d` against the reference `r`, per part (value, gradient, Hessian), each relative
/// to the reference's largest entry.
pub fn errors(d: &raddiff::Deriv3, r: &Reference) -> [f64; 3] {
    [
        rel_scalar(d.value, r.value, 1e-300),
        rel_vec(d.gradient, r.gradient, 1e-300),
        rel_mat(d.hessian, r.hessian, 1e-300),
    ]
}

/// `a = max(a, b)` per part.
pub fn max3(a: &mut [f64; 3], b: [f64; 3]) {
    for k in 0..3 {
        a[k] = a[k].max(b[k]);
    }
}

/// Every part of `e` within its `bound`.
pub fn within(e: [f64; 3], bound: [f64; 3]) -> bool {
    e.iter().zip(bound).all(|(e, b)| *e <= b)
}
