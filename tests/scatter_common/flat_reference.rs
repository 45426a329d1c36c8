//! First-principles reference for a flat interface z = 0 (outside z > 0) with a point light: the
//! refraction point from a 1-D bisection of Snell's law in the plane of incidence, the beam's
//! cross-section from its widths in and across that plane, unpolarized Fresnel, Henyey-Greenstein,
//! and a recursively bisected 20-point Gauss-Legendre integral along the eye segment. Written
//! independently of the library's Newton solves, D factors and quadrature.

use glam::{DVec2, DVec3};
use raddiff::scatter::Medium;

/// The refraction point for V below the plane (bisection of the monotone Snell residual along the
/// horizontal line from the light's foot to V's foot).
pub fn snell_point(light: DVec3, eta: f64, v: DVec3) -> DVec3 {
    let (hl, hv) = (light.z, -v.z);
    let foot = DVec2::new(v.x - light.x, v.y - light.y);
    let r = foot.length();
    let residual = |p: f64| {
        p / (p * p + hl * hl).sqrt() - eta * (r - p) / ((r - p) * (r - p) + hv * hv).sqrt()
    };
    let (mut lo, mut hi) = (0.0, r);
    for _ in 0..1100 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if residual(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let rho = 0.5 * (lo + hi);
    let dir = if r > 0.0 { foot / r } else { DVec2::ZERO };
    DVec3::new(light.x + rho * dir.x, light.y + rho * dir.y, 0.0)
}

/// Radiance per unit length at V(x) = origin + x dir, carried back to the origin (intensity 1).
pub fn contribution(m: &Medium, light: DVec3, origin: DVec3, dir: DVec3, x: f64) -> f64 {
    let eta = m.eta;
    let v = origin + x * dir;
    let p = snell_point(light, eta, v);
    let (d_l, d_v) = ((light - p).length(), (v - p).length());
    let (cos_l, cos_v) = (light.z / d_l, -v.z / d_v);
    // Beam width across the plane of incidence per radian at the light: (η d_L + d_V)/η; in the
    // plane: d_L cos_V/cos_L + d_V cos_L/(η cos_V).
    let sagittal = (eta * d_l + d_v) / eta;
    let tangential = d_l * cos_v / cos_l + d_v * cos_l / (eta * cos_v);
    let d = sagittal * tangential;
    let rs = (cos_l - eta * cos_v) / (cos_l + eta * cos_v);
    let rp = (eta * cos_l - cos_v) / (eta * cos_l + cos_v);
    let t = 1.0 - 0.5 * (rs * rs + rp * rp);
    let mu = -((v - p) / d_v).dot(dir);
    let g = m.g;
    let phase =
        (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * mu).powf(1.5));
    m.sigma_s * phase * t * (-m.sigma_t * (x + d_v)).exp() / d
}

/// ∫ f over [a, b]: a 20-point Gauss-Legendre rule on each interval, the interval whose halves
/// disagree most with it bisected until the summed disagreement is at most `tol` (absolute) or
/// 20 000 intervals (rounding noise of the integrand bounds the reachable accuracy).
pub fn adaptive(f: &dyn Fn(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    let (nodes, weights) = raddiff::scatter::integrate::gauss_legendre(20);
    let rule = |a: f64, b: f64| -> f64 {
        let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
        nodes
            .iter()
            .zip(&weights)
            .map(|(z, w)| h * w * f(c + h * z))
            .sum()
    };
    // (a, b, value of the halves, disagreement with the whole)
    let part = |a: f64, b: f64, whole: f64| {
        let m = 0.5 * (a + b);
        let halves = rule(a, m) + rule(m, b);
        (a, b, halves, (halves - whole).abs())
    };
    let mut parts = vec![part(a, b, rule(a, b))];
    while parts.iter().map(|p| p.3).sum::<f64>() > tol && parts.len() < 20_000 {
        let worst = (0..parts.len())
            .max_by(|&i, &j| parts[i].3.total_cmp(&parts[j].3))
            .unwrap();
        let (lo, hi, _, _) = parts[worst];
        let m = 0.5 * (lo + hi);
        let (l, r) = (rule(lo, m), rule(m, hi));
        parts[worst] = part(lo, m, l);
        parts.push(part(m, hi, r));
    }
    parts.iter().map(|p| p.2).sum()
}

/// The single-scattered radiance of the segment entry → exit below the plane z = 0.
pub fn radiance(m: &Medium, light: DVec3, entry: DVec3, exit: DVec3, rel_tol: f64) -> f64 {
    let len = (exit - entry).length();
    let dir = (exit - entry) / len;
    let f = |x: f64| contribution(m, light, entry, dir, x);
    let rough = adaptive(&f, 0.0, len, 1e-6 * f(0.5 * len).abs().max(1e-300) * len);
    // 20-point rules on halves agree to far better than their disagreement with the whole.
    adaptive(&f, 0.0, len, rel_tol * rough.abs())
}
