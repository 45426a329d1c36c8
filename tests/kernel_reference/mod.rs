//! Independent high-precision references for the tests of the solid angle, the segment and the
//! transmittance: each value formula evaluated in astro-float at 320 bits from the exact f64
//! inputs, and its derivatives by central differences at that precision with a tiny step
//! (truncation ~ (h/ρ)², rounding ~ 2^-320/h²: both far below f64).
#![allow(dead_code, clippy::needless_range_loop)]

use astro_float::{BigFloat, Consts, RoundingMode};
use glam::{DMat2, DMat3, DVec2, DVec3};

pub const P: usize = 320;
const RM: RoundingMode = RoundingMode::ToEven;

pub struct Hp {
    cc: Consts,
}

pub type B = BigFloat;

impl Hp {
    pub fn new() -> Self {
        Hp {
            cc: Consts::new().expect("astro-float constants"),
        }
    }
    pub fn f(&self, v: f64) -> B {
        B::from_f64(v, P)
    }
    pub fn add(&self, a: &B, b: &B) -> B {
        a.add(b, P, RM)
    }
    pub fn sub(&self, a: &B, b: &B) -> B {
        a.sub(b, P, RM)
    }
    pub fn mul(&self, a: &B, b: &B) -> B {
        a.mul(b, P, RM)
    }
    pub fn div(&self, a: &B, b: &B) -> B {
        a.div(b, P, RM)
    }
    pub fn sqrt(&self, a: &B) -> B {
        a.sqrt(P, RM)
    }
    pub fn exp(&mut self, a: &B) -> B {
        a.exp(P, RM, &mut self.cc)
    }
    pub fn pi(&mut self) -> B {
        self.cc.pi(P, RM)
    }
    /// atan2(y, x) ∈ (−π, π].
    pub fn atan2(&mut self, y: &B, x: &B) -> B {
        let pi = self.pi();
        if x.is_zero() {
            let half = self.div(&pi, &self.f(2.0));
            return if y.is_negative() { half.neg() } else { half };
        }
        let t = self.div(y, x).atan(P, RM, &mut self.cc);
        if !x.is_negative() {
            t
        } else if y.is_negative() {
            self.sub(&t, &pi)
        } else {
            self.add(&t, &pi)
        }
    }
}

/// Round a BigFloat to the nearest f64 (from its top 128 mantissa bits: ample for error measurement).
pub fn to_f64(v: &B) -> f64 {
    if v.is_zero() {
        return 0.0;
    }
    let digits = v.mantissa_digits().expect("finite reference");
    let e = v.exponent().expect("finite reference");
    let n = digits.len();
    // Mantissa is 0.d_{n-1} d_{n-2} ... in base 2^64, times 2^e.
    let hi = digits[n - 1] as f64;
    let lo = if n >= 2 { digits[n - 2] as f64 } else { 0.0 };
    let m = hi * 2f64.powi(-64) + lo * 2f64.powi(-128);
    let mag = m
        * 2f64.powi(e.clamp(-1000, 1000))
        * 2f64.powi((e - e.clamp(-1000, 1000)).clamp(-1000, 1000));
    if v.is_negative() {
        -mag
    } else {
        mag
    }
}

#[derive(Clone)]
pub struct V3(pub [B; 3]);

impl V3 {
    pub fn from(hp: &Hp, v: DVec3) -> V3 {
        V3([hp.f(v.x), hp.f(v.y), hp.f(v.z)])
    }
    pub fn sub(&self, hp: &Hp, o: &V3) -> V3 {
        V3([0, 1, 2].map(|i| hp.sub(&self.0[i], &o.0[i])))
    }
    pub fn dot(&self, hp: &Hp, o: &V3) -> B {
        let s = hp.add(&hp.mul(&self.0[0], &o.0[0]), &hp.mul(&self.0[1], &o.0[1]));
        hp.add(&s, &hp.mul(&self.0[2], &o.0[2]))
    }
    pub fn cross(&self, hp: &Hp, o: &V3) -> V3 {
        let (a, b) = (&self.0, &o.0);
        V3([
            hp.sub(&hp.mul(&a[1], &b[2]), &hp.mul(&a[2], &b[1])),
            hp.sub(&hp.mul(&a[2], &b[0]), &hp.mul(&a[0], &b[2])),
            hp.sub(&hp.mul(&a[0], &b[1]), &hp.mul(&a[1], &b[0])),
        ])
    }
    pub fn norm(&self, hp: &Hp) -> B {
        hp.sqrt(&self.dot(hp, self))
    }
    /// self + h·e_i + k·e_j
    pub fn shifted(&self, hp: &Hp, i: usize, h: &B, j: usize, k: &B) -> V3 {
        let mut v = self.clone();
        v.0[i] = hp.add(&v.0[i], h);
        v.0[j] = hp.add(&v.0[j], k);
        v
    }
}

/// Value, gradient and Hessian of a scalar function of a 3D point by 320-bit central differences.
pub struct Ref3 {
    pub value: f64,
    pub gradient: DVec3,
    pub hessian: DMat3,
}

pub fn central3(hp: &mut Hp, x: DVec3, step: f64, f: &mut dyn FnMut(&mut Hp, &V3) -> B) -> Ref3 {
    let x0 = V3::from(hp, x);
    let h = hp.f(step);
    let zero = hp.f(0.0);
    let mh = h.neg();
    let f0 = f(hp, &x0);
    let mut g = [0.0; 3];
    let mut fp = Vec::new();
    let mut fm = Vec::new();
    for i in 0..3 {
        let p = f(hp, &x0.shifted(hp, i, &h, i, &zero));
        let m = f(hp, &x0.shifted(hp, i, &mh, i, &zero));
        g[i] = to_f64(&hp.div(&hp.sub(&p, &m), &hp.mul(&hp.f(2.0), &h)));
        fp.push(p);
        fm.push(m);
    }
    let h2 = hp.mul(&h, &h);
    let mut hess = [[0.0; 3]; 3];
    for i in 0..3 {
        let num = hp.add(&hp.sub(&fp[i], &hp.mul(&hp.f(2.0), &f0)), &fm[i]);
        hess[i][i] = to_f64(&hp.div(&num, &h2));
        for j in (i + 1)..3 {
            let pp = f(hp, &x0.shifted(hp, i, &h, j, &h));
            let pm = f(hp, &x0.shifted(hp, i, &h, j, &mh));
            let mp = f(hp, &x0.shifted(hp, i, &mh, j, &h));
            let mm = f(hp, &x0.shifted(hp, i, &mh, j, &mh));
            let num = hp.add(&hp.sub(&hp.sub(&pp, &pm), &mp), &mm);
            let v = to_f64(&hp.div(&num, &hp.mul(&hp.f(4.0), &h2)));
            hess[i][j] = v;
            hess[j][i] = v;
        }
    }
    Ref3 {
        value: to_f64(&f0),
        gradient: DVec3::from_array(g),
        hessian: DMat3::from_cols_array_2d(&hess),
    }
}

pub struct Ref2 {
    pub value: f64,
    pub gradient: DVec2,
    pub hessian: DMat2,
}

pub fn central2(hp: &mut Hp, x: DVec2, step: f64, f: &mut dyn FnMut(&mut Hp, &B, &B) -> B) -> Ref2 {
    let (x0, y0) = (hp.f(x.x), hp.f(x.y));
    let h = hp.f(step);
    let two = hp.f(2.0);
    let at = |hp: &mut Hp, f: &mut dyn FnMut(&mut Hp, &B, &B) -> B, dx: f64, dy: f64| {
        let xs = hp.add(&x0, &hp.mul(&hp.f(dx), &h));
        let ys = hp.add(&y0, &hp.mul(&hp.f(dy), &h));
        f(hp, &xs, &ys)
    };
    let f0 = at(hp, f, 0.0, 0.0);
    let fxp = at(hp, f, 1.0, 0.0);
    let fxm = at(hp, f, -1.0, 0.0);
    let fyp = at(hp, f, 0.0, 1.0);
    let fym = at(hp, f, 0.0, -1.0);
    let fpp = at(hp, f, 1.0, 1.0);
    let fpm = at(hp, f, 1.0, -1.0);
    let fmp = at(hp, f, -1.0, 1.0);
    let fmm = at(hp, f, -1.0, -1.0);
    let h2 = hp.mul(&h, &h);
    let d1 = |hp: &Hp, p: &B, m: &B| to_f64(&hp.div(&hp.sub(p, m), &hp.mul(&two, &h)));
    let d2 =
        |hp: &Hp, p: &B, m: &B| to_f64(&hp.div(&hp.add(&hp.sub(p, &hp.mul(&two, &f0)), m), &h2));
    let gx = d1(hp, &fxp, &fxm);
    let gy = d1(hp, &fyp, &fym);
    let hxx = d2(hp, &fxp, &fxm);
    let hyy = d2(hp, &fyp, &fym);
    let num = hp.add(&hp.sub(&hp.sub(&fpp, &fpm), &fmp), &fmm);
    let hxy = to_f64(&hp.div(&num, &hp.mul(&hp.f(4.0), &h2)));
    Ref2 {
        value: to_f64(&f0),
        gradient: DVec2::new(gx, gy),
        hessian: DMat2::from_cols(DVec2::new(hxx, hxy), DVec2::new(hxy, hyy)),
    }
}

/// Signed (A, D) of Van Oosterom-Strackee at 320 bits, textbook form (exact at this precision).
pub fn solid_angle_hp(hp: &mut Hp, x: &V3, tri: &[V3; 3], signed: bool) -> B {
    let r = [tri[0].sub(hp, x), tri[1].sub(hp, x), tri[2].sub(hp, x)];
    let s = [r[0].norm(hp), r[1].norm(hp), r[2].norm(hp)];
    let a = r[0].dot(hp, &r[1].cross(hp, &r[2]));
    let mut d = hp.mul(&hp.mul(&s[0], &s[1]), &s[2]);
    d = hp.add(&d, &hp.mul(&r[0].dot(hp, &r[1]), &s[2]));
    d = hp.add(&d, &hp.mul(&r[1].dot(hp, &r[2]), &s[0]));
    d = hp.add(&d, &hp.mul(&r[2].dot(hp, &r[0]), &s[1]));
    let a = if signed { a } else { a.abs() };
    let t = hp.atan2(&a, &d);
    hp.mul(&hp.f(2.0), &t)
}

/// θ/(2π) for the flatland segment at 320 bits.
pub fn segment_hp(hp: &mut Hp, x: &B, y: &B, a: DVec2, b: DVec2) -> B {
    let (ax, ay) = (hp.sub(&hp.f(a.x), x), hp.sub(&hp.f(a.y), y));
    let (bx, by) = (hp.sub(&hp.f(b.x), x), hp.sub(&hp.f(b.y), y));
    let c = hp.sub(&hp.mul(&ax, &by), &hp.mul(&ay, &bx)).abs();
    let d = hp.add(&hp.mul(&ax, &bx), &hp.mul(&ay, &by));
    let t = hp.atan2(&c, &d);
    let pi = hp.pi();
    hp.div(&t, &hp.mul(&hp.f(2.0), &pi))
}

/// Relative error of a value.
pub fn rel(value: f64, reference: f64) -> f64 {
    if reference == 0.0 {
        value.abs()
    } else {
        (value - reference).abs() / reference.abs()
    }
}

/// Error of a vector normalized by its largest reference entry.
pub fn rel3(v: DVec3, r: DVec3) -> f64 {
    let m = r.abs().max_element();
    if m == 0.0 {
        (v - r).abs().max_element()
    } else {
        (v - r).abs().max_element() / m
    }
}

pub fn rel33(v: DMat3, r: DMat3) -> f64 {
    let m = r.to_cols_array().iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let e = (v - r)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |a, b| a.max(b.abs()));
    if m == 0.0 {
        e
    } else {
        e / m
    }
}

pub fn rel2(v: DVec2, r: DVec2) -> f64 {
    let m = r.abs().max_element();
    (v - r).abs().max_element() / if m == 0.0 { 1.0 } else { m }
}

pub fn rel22(v: DMat2, r: DMat2) -> f64 {
    let m = r.to_cols_array().iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let e = (v - r)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |a, b| a.max(b.abs()));
    e / if m == 0.0 { 1.0 } else { m }
}

// `examples/kernels.rs` includes both support modules, each of which loads the generator.
#[allow(clippy::duplicate_mod)]
#[path = "../common/splitmix.rs"]
mod splitmix;

/// SplitMix64: a small deterministic generator so failures reproduce.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        splitmix::next_u64(&mut self.0)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    /// 10^U(lo, hi)
    pub fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        10f64.powf(self.range(lo, hi))
    }
    pub fn in_ball(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length_squared();
            if l <= 1.0 && l > 1e-4 {
                return v;
            }
        }
    }
    pub fn dir(&mut self) -> DVec3 {
        self.in_ball().normalize()
    }
}

/// Worst error per column, printed as a table by the tests (run with `--nocapture` to see it).
#[derive(Default, Clone, Copy, Debug)]
pub struct Worst {
    pub value: f64,
    pub gradient: f64,
    pub hessian: f64,
    pub count: usize,
}

impl Worst {
    pub fn add(&mut self, v: f64, g: f64, h: f64) {
        self.value = self.value.max(v);
        self.gradient = self.gradient.max(g);
        self.hessian = self.hessian.max(h);
        self.count += 1;
    }
    pub fn report(&self, name: &str) {
        println!(
            "{name:<44} n={:<4} value {:9.2e}  gradient {:9.2e}  hessian {:9.2e}",
            self.count, self.value, self.gradient, self.hessian
        );
    }
    pub fn check(&self, name: &str, tv: f64, tg: f64, th: f64) {
        self.report(name);
        assert!(
            self.value <= tv && self.gradient <= tg && self.hessian <= th,
            "{name}: worst errors {self:?} exceed targets value {tv:e} gradient {tg:e} hessian {th:e}"
        );
    }
}

/// The accuracy target of generic inputs: value, gradient, Hessian (relative to the largest entry).
pub const GENERIC: (f64, f64, f64) = (1e-12, 1e-12, 1e-10);
/// The accuracy target of hard inputs (near the singular sets, extreme scales).
pub const HARD: (f64, f64, f64) = (1e-10, 1e-9, 1e-8);

/// Random configurations per accuracy test (`RADDIFF_ACCURACY_SAMPLES`, default 200).
pub fn samples() -> usize {
    std::env::var("RADDIFF_ACCURACY_SAMPLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200)
}
