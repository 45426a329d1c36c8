//! Error metrics compared at equal record counts on a closed-form irradiance field.
//!
//! Scene: the floor z = 0 under an infinite uniform emitting ceiling at z = H (radiance 1) and a
//! black half-plane occluder {x < 2, z = h}, plus a smooth ambient term A. The floor irradiance is
//!   E(x, y) = (1 − sin α)/2 + A(x, y),  sin α = u/√(u² + h²), u = 2 − x
//! (the cosine-weighted fraction of the hemisphere behind an infinite edge parallel to y at
//! elevation angle α is (1 + sin α)/2), with A = 0.3 + 0.1 sin(1.3x) cos(0.9y): a sharp
//! penumbra of width ~h at x = 2 on a smooth field. Value, gradient and Hessian are analytic
//! (checked against central differences below). The split sphere's harmonic-mean distance comes
//! from a 16×32 cosine-weighted gather of that scene.
//!
//! Each metric fills a cache greedily (a record wherever a grid point is not covered yet, in a
//! fixed pseudo-random order); its tolerance is bisected until the record count is within a few
//! percent of the same target for all metrics; the RMS error of the interpolated field over the
//! grid is then compared. The Hessian radii come from `cache::metric::hessian_surface` (i.e.
//! `gather::radii::surface_radii`, relative error, anisotropy at most 2, thesis eq. 6.7-6.9).
//!
//! Run with `--nocapture` to print the README table.

use glam::{DMat2, DMat3, DVec2, DVec3};
use raddiff::cache::{metric, Cache, CacheConfig, Extent, Interpolation, Record};

const H_OCC: f64 = 0.1;
const H_CEIL: f64 = 1.0;
const SIDE: f64 = 4.0;
const GRID: usize = 72;
const R_MIN: f64 = 0.01;
const R_MAX: f64 = 2.0;

/// Value, gradient and Hessian of the floor irradiance.
fn field(p: DVec2) -> (f64, DVec2, DMat2) {
    let (x, y) = (p.x, p.y);
    let u = 2.0 - x;
    let q = u * u + H_OCC * H_OCC;
    let s = u / q.sqrt();
    let h2 = H_OCC * H_OCC;
    let e_pen = 0.5 * (1.0 - s);
    let d_pen = h2 / (2.0 * q.powf(1.5));
    let dd_pen = 3.0 * h2 * u / (2.0 * q.powf(2.5));
    let (sx, cx) = (1.3 * x).sin_cos();
    let (sy, cy) = (0.9 * y).sin_cos();
    let a = 0.3 + 0.1 * sx * cy;
    let g = DVec2::new(d_pen + 0.13 * cx * cy, -0.09 * sx * sy);
    let hxx = dd_pen - 0.169 * sx * cy;
    let hxy = -0.117 * cx * sy;
    let hyy = -0.081 * sx * cy;
    (
        e_pen + a,
        g,
        DMat2::from_cols(DVec2::new(hxx, hxy), DVec2::new(hxy, hyy)),
    )
}

/// Harmonic mean distance of a cosine-weighted 16×32 gather at floor point p.
fn harmonic_mean_distance(p: DVec2) -> f64 {
    let (m, n) = (16, 32);
    let mut d = Vec::with_capacity(m * n);
    for j in 0..m {
        let sin_t = ((j as f64 + 0.5) / m as f64).sqrt();
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        for k in 0..n {
            let phi = std::f64::consts::TAU * (k as f64 + 0.5) / n as f64;
            let t_occ = H_OCC / cos_t;
            let hit_x = p.x + t_occ * sin_t * phi.cos();
            d.push(if hit_x < 2.0 { t_occ } else { H_CEIL / cos_t });
        }
    }
    metric::harmonic_mean_distance(&d).unwrap()
}

#[derive(Clone, Copy, Debug)]
enum Metric {
    SplitSphere,
    Bounded,
    Gradient,
    Hessian,
}

fn extent(metric: Metric, param: f64, p: DVec2) -> Extent {
    let (e, g, h) = field(p);
    let g3 = DVec3::new(g.x, g.y, 0.0);
    let clamp = metric::RadiusLimits::new(R_MIN, R_MAX).unwrap();
    match metric {
        Metric::SplitSphere => Extent::isotropic(
            clamp.clamp(metric::split_sphere(param, harmonic_mean_distance(p)).unwrap()),
        ),
        Metric::Bounded => {
            Extent::isotropic(clamp.clamp(
                metric::split_sphere_bounded(param, harmonic_mean_distance(p), e, g3).unwrap(),
            ))
        }
        Metric::Gradient => {
            let r = metric::gradient_metric(param, &[e], &[g3]).unwrap_or(R_MAX);
            Extent::isotropic(clamp.clamp(r))
        }
        Metric::Hessian => {
            let h3 = DMat3::from_cols(
                DVec3::new(h.x_axis.x, h.x_axis.y, 0.0),
                DVec3::new(h.y_axis.x, h.y_axis.y, 0.0),
                DVec3::ZERO,
            );
            let e =
                metric::hessian_surface(h3, DVec3::Z, e, param, metric::ErrorMode::Relative, 2.0)
                    .unwrap();
            clamp.apply(&e)
        }
    }
}

fn grid() -> Vec<DVec2> {
    let mut pts: Vec<DVec2> = (0..GRID * GRID)
        .map(|i| {
            let (ix, iy) = (i % GRID, i / GRID);
            DVec2::new(
                (ix as f64 + 0.5) * SIDE / GRID as f64,
                (iy as f64 + 0.5) * SIDE / GRID as f64,
            )
        })
        .collect();
    // fixed pseudo-random visiting order (a renderer's pixels arrive in no useful order)
    let key = |p: &DVec2| {
        let mut x = (p.x * 1e6) as u64 ^ ((p.y * 1e6) as u64).rotate_left(32);
        x = (x ^ (x >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
        x ^ (x >> 27)
    };
    pts.sort_by_key(key);
    pts
}

fn fill(metric: Metric, param: f64, interp: Interpolation, pts: &[DVec2]) -> Cache<f32> {
    let cache = Cache::new(CacheConfig::surface(1).with_interpolation(interp)).unwrap();
    for &p in pts {
        let x = DVec3::new(p.x, p.y, 0.0);
        if cache.lookup(x, DVec3::Z).is_ok() {
            continue;
        }
        let (e, g, _) = field(p);
        cache
            .insert(&Record {
                position: x,
                normal: DVec3::Z,
                value: e as f32,
                gradient: Some([g.x as f32, g.y as f32, 0.0]),
                rotation_gradient: None,
                extent: extent(metric, param, p),
                open_fraction: None,
            })
            .unwrap();
    }
    cache
}

fn rms(cache: &Cache<f32>, pts: &[DVec2]) -> f64 {
    let sum: f64 = pts
        .iter()
        .map(|&p| {
            let got = cache
                .lookup(DVec3::new(p.x, p.y, 0.0), DVec3::Z)
                .unwrap()
                .value as f64;
            (got - field(p).0).powi(2)
        })
        .sum();
    (sum / pts.len() as f64).sqrt()
}

/// Bisects the metric's tolerance (log scale; larger tolerance, fewer records) to `target`.
fn at_count(
    metric: Metric,
    interp: Interpolation,
    target: usize,
    pts: &[DVec2],
) -> (usize, f64, f64) {
    let (mut lo, mut hi) = (-12.0f64, 4.0f64);
    let mut best = (usize::MAX, f64::NAN, f64::NAN);
    for _ in 0..14 {
        let mid = 0.5 * (lo + hi);
        let param = mid.exp();
        let cache = fill(metric, param, interp, pts);
        let n = cache.len();
        if n.abs_diff(target) < best.0.abs_diff(target) {
            best = (n, param, rms(&cache, pts));
        }
        if n > target {
            lo = mid;
        } else {
            hi = mid;
        }
        if n.abs_diff(target) * 50 <= target {
            break;
        }
    }
    best
}

#[test]
fn analytic_field_derivatives_match_central_differences() {
    for &(x, y) in &[(1.9, 0.3), (2.05, 1.7), (0.4, 3.1), (2.0, 2.0), (3.3, 0.9)] {
        let p = DVec2::new(x, y);
        let (_, g, h) = field(p);
        let eps = 1e-5;
        for axis in 0..2 {
            let mut d = DVec2::ZERO;
            d[axis] = eps;
            let (ep, gp, _) = field(p + d);
            let (em, gm, _) = field(p - d);
            let fd = (ep - em) / (2.0 * eps);
            assert!(
                (fd - g[axis]).abs() < 1e-6 * (1.0 + g[axis].abs()),
                "{fd} {}",
                g[axis]
            );
            let fdh = (gp - gm) / (2.0 * eps);
            let col = h.col(axis);
            assert!((fdh - col).abs().max_element() < 1e-4 * (1.0 + col.abs().max_element()));
        }
    }
}

#[test]
fn hessian_metric_beats_split_sphere_at_equal_record_counts() {
    let pts = grid();
    let target = 300;
    println!("| metric | interpolation | records | tolerance | RMS error |");
    println!("|---|---|---|---|---|");
    for interp in [Interpolation::Tent, Interpolation::Ward] {
        let mut results = Vec::new();
        for metric in [
            Metric::SplitSphere,
            Metric::Bounded,
            Metric::Gradient,
            Metric::Hessian,
        ] {
            let (n, param, err) = at_count(metric, interp, target, &pts);
            println!("| {metric:?} | {interp:?} | {n} | {param:.3e} | {err:.2e} |");
            assert!(n.abs_diff(target) * 10 <= target, "{metric:?}: {n} records");
            results.push(err);
        }
        assert!(
            results[3] < results[0],
            "{interp:?}: Hessian RMS {} vs split sphere {}",
            results[3],
            results[0]
        );
    }
}
