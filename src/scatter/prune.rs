//! Conservative pruning tests (report sec. 3.2.4): the spindle test on bounding spheres of nodes and
//! triangles, and the shading-normal cone test on triangles. Both only ever discard configurations
//! with no refracted path, so they change the running time, never the result.
//!
//! Shared construction: for a bounding sphere (C, r), an eye sub-segment [x0, x1] and the light L,
//! * ω_L (from any P in the sphere to L) lies in the cone of axis u_L = CL/|CL| and half-angle
//!   θ_L = asin(r/|CL|);
//! * ω_V (from P to V(x)) lies within θ_V = asin(r/d_min) of u_V(x) = (V(x) − C)/|V(x) − C|, d_min the
//!   distance from C to the sub-segment. The axes u_V(x) sweep a great-circle arc, parameterized here
//!   by its angle ψ in [0, Ψ]: u_V(ψ) = cos ψ e1 + sin ψ e2.
//!
//! If the sphere contains the light or touches the sub-segment the cones are undefined and nothing
//! is pruned.

use glam::DVec3;

use super::bvh::BoundingSphere;
use super::constraint::EyeSegment;

/// A cone containing the (normalized, interpolated) shading normals of a triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalCone {
    /// Unit axis.
    pub axis: DVec3,
    /// Half-angle (radians); π when no useful cone exists.
    pub angle: f64,
}

impl NormalCone {
    /// The cone around normalize(n0 + n1 + n2) through the farthest vertex normal. Normalized convex
    /// combinations of the normals stay in their spherical triangle, which a cap of half-angle below
    /// π/2 containing the three vertices contains; wider spreads give the trivial cone (angle π).
    pub fn of_normals(n: &[DVec3; 3]) -> Self {
        let Some(axis) = (n[0] + n[1] + n[2]).try_normalize() else {
            return NormalCone {
                axis: DVec3::Z,
                angle: std::f64::consts::PI,
            };
        };
        let angle = n
            .iter()
            .map(|v| angle_between(axis, *v))
            .fold(0.0, f64::max);
        let angle = if angle < std::f64::consts::FRAC_PI_2 {
            angle * (1.0 + 1e-12) + 1e-15
        } else {
            std::f64::consts::PI
        };
        NormalCone { axis, angle }
    }
}

/// Angle between two unit vectors, accurate at all angles.
#[inline]
pub(crate) fn angle_between(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// The arc of eye directions seen from a sphere's centre, with the cone half-angles.
struct Sweep {
    e1: DVec3,
    e2: DVec3,
    span: f64,
    /// V(x0) − C.
    p0: DVec3,
    x0: f64,
    x1: f64,
    u_l: DVec3,
    theta_l: f64,
    theta_v: f64,
}

fn sweep(
    sphere: &BoundingSphere,
    eye: &EyeSegment,
    (x0, x1): (f64, f64),
    light: DVec3,
) -> Option<Sweep> {
    let c = sphere.center;
    let r = sphere.radius;
    let cl = light - c;
    let dcl = cl.length();
    if !(dcl > r) {
        return None;
    }
    let p0 = eye.at(x0) - c;
    let p1 = eye.at(x1) - c;
    let tc = (-p0.dot(eye.dir)).clamp(0.0, (x1 - x0).max(0.0));
    let d_min = (p0 + tc * eye.dir).length();
    if !(d_min > r) {
        return None;
    }
    let e1 = p0.normalize();
    let q1 = p1.normalize();
    let m = e1.cross(q1);
    let (e2, span) = match m.try_normalize() {
        Some(mn) => (mn.cross(e1), angle_between(e1, q1)),
        None => (e1.any_orthogonal_vector(), 0.0),
    };
    Some(Sweep {
        e1,
        e2,
        span,
        p0,
        x0,
        x1,
        u_l: cl / dcl,
        theta_l: (r / dcl).asin(),
        theta_v: (r / d_min).asin(),
    })
}

impl Sweep {
    fn axis(&self, psi: f64) -> DVec3 {
        psi.cos() * self.e1 + psi.sin() * self.e2
    }

    /// Smallest angle between the unit vector `a` and the arc of axes.
    fn min_angle_to_arc(&self, a: DVec3) -> f64 {
        let (ax, ay) = (a.dot(self.e1), a.dot(self.e2));
        let psi = ay.atan2(ax);
        if psi >= 0.0 && psi <= self.span {
            let az = a.dot(self.e1.cross(self.e2));
            return az.abs().atan2(ax.hypot(ay));
        }
        angle_between(a, self.e1).min(angle_between(a, self.axis(self.span)))
    }

    /// The eye parameter x whose direction from C is u_V(ψ).
    fn x_at(&self, psi: f64, dir: DVec3) -> f64 {
        if self.span == 0.0 {
            return if psi <= 0.0 { self.x0 } else { self.x1 };
        }
        let d = self.axis(psi);
        let m = self.e1.cross(self.e2);
        let denom = dir.cross(d).dot(m);
        if denom == 0.0 {
            return self.x1;
        }
        (self.x0 - self.p0.cross(d).dot(m) / denom).clamp(self.x0, self.x1)
    }
}

/// Spindle test: whether a refracted path from `light` through some point of `sphere` can reach the
/// eye sub-segment `x_range` (false means: prune).
///
/// At a refraction into index η the angle between ω_V and −ω_L is at most π/2 − asin(1/η) (the
/// deviation at grazing incidence). The test fails when the arc of u_V is farther than that plus
/// θ_V + θ_L from −u_L.
pub fn spindle_test(
    sphere: &BoundingSphere,
    eye: &EyeSegment,
    x_range: (f64, f64),
    light: DVec3,
    eta: f64,
) -> bool {
    let Some(s) = sweep(sphere, eye, x_range, light) else {
        return true;
    };
    let limit = std::f64::consts::FRAC_PI_2 - (1.0 / eta).asin() + s.theta_v + s.theta_l;
    if limit >= std::f64::consts::PI {
        return true;
    }
    s.min_angle_to_arc(-s.u_l) <= limit * (1.0 + 1e-12) + 1e-12
}

/// Sidedness agreement (Walter et al. 2009), exact and cheap: a physical path through a triangle
/// needs the light strictly on the outer side of its plane and V strictly on the inner side. Returns
/// the part of `x_range` where V is on the inner side, or `None` (prune) if the light is not outside
/// or no such part exists.
pub fn sidedness_test(
    triangle: &super::constraint::TriangleGeometry,
    eye: &EyeSegment,
    (x0, x1): (f64, f64),
    light: DVec3,
) -> Option<(f64, f64)> {
    let n = triangle.geometric_normal;
    if !((light - triangle.p0).dot(n) > 0.0) {
        return None;
    }
    // Signed height of V(x) above the plane: h0 + x dh.
    let h0 = (eye.origin - triangle.p0).dot(n);
    let dh = eye.dir.dot(n);
    let (h_lo, h_hi) = (h0 + x0 * dh, h0 + x1 * dh);
    if h_lo >= 0.0 && h_hi >= 0.0 {
        return None;
    }
    if h_lo < 0.0 && h_hi < 0.0 {
        return Some((x0, x1));
    }
    // The crossing, padded outwards by a relative 1e-9 so rounding cannot cut a contribution.
    let xc = -h0 / dh;
    let pad = 1e-9 * (x1 - x0);
    if h_lo < 0.0 {
        Some((x0, (xc + pad).min(x1)))
    } else {
        Some(((xc - pad).max(x0), x1))
    }
}

/// Maximum number of sub-arcs the normal-cone test examines before giving up (keeping the rest).
pub const NORMAL_CONE_BUDGET: usize = 12;

/// Shading-normal cone test: `None` if no refracted path through a triangle with bounding sphere
/// `sphere` and shading normals in `cone` can reach the eye sub-segment `x_range` (prune); otherwise
/// the sub-range of x where one may (the validity interval of the report).
///
/// A path needs n_s = −ĥ with ĥ = normalize(η ω_V + ω_L). The tip of η ω_V + ω_L lies within
/// ρ = η r_V + r_L (r = 2 sin(θ/2), the chord of each cone) of a(ψ) = η u_V(ψ) + u_L, so ĥ lies within
/// asin(ρ/|a(ψ)|) of â(ψ), and a path at ψ requires angle(−â(ψ), u_n) ≤ θ_n + asin(ρ/|a(ψ)|).
/// Central projection onto the plane M·u_n = 1 maps the directions −a(ψ) onto a branch of a
/// hyperbola (an ellipse arc for some configurations) and the cone of half-angle θ onto a disc of
/// radius tan θ around u_n: the test is the report's point-to-hyperbola distance. It is evaluated
/// in the conic's angular parameter ψ by a certified branch-and-bound: on a sub-arc of half-width
/// w, the angle moves by at most w η / min|a| (|dâ/dψ| ≤ η/|a|), and min|a| is exact, so a sub-arc is
/// discarded only when its certified lower bound exceeds the allowance. This replaces the report's
/// dichotomy and cannot discard a contributing x.
pub fn normal_cone_test(
    sphere: &BoundingSphere,
    cone: &NormalCone,
    eye: &EyeSegment,
    x_range: (f64, f64),
    light: DVec3,
    eta: f64,
) -> Option<(f64, f64)> {
    let Some(s) = sweep(sphere, eye, x_range, light) else {
        return Some(x_range);
    };
    if cone.angle >= std::f64::consts::PI {
        return Some(x_range);
    }
    let chord = |t: f64| 2.0 * (0.5 * t).sin();
    let rho = eta * chord(s.theta_v) + chord(s.theta_l);
    let (cx, cy) = (s.u_l.dot(s.e1), s.u_l.dot(s.e2));
    let phi = cy.atan2(cx);
    let rr = cx.hypot(cy);
    // min over [a, b] of |a(ψ)| from the exact minimum of cos(ψ − φ).
    let min_norm = |a: f64, b: f64| {
        let mut c = (a - phi).cos().min((b - phi).cos());
        let mut opposite = phi + std::f64::consts::PI;
        while opposite > a {
            opposite -= std::f64::consts::TAU;
        }
        while opposite < a {
            opposite += std::f64::consts::TAU;
        }
        if opposite <= b {
            c = -1.0;
        }
        (eta * eta + 1.0 + 2.0 * eta * rr * c).max(0.0).sqrt()
    };
    let angle_at = |psi: f64| {
        let a = eta * s.axis(psi) + s.u_l;
        angle_between(-a.normalize_or_zero(), cone.axis)
    };
    let mut stack: smallvec::SmallVec<[(f64, f64); 16]> = smallvec::smallvec![(0.0, s.span)];
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut evaluations = 0;
    while let Some((a, b)) = stack.pop() {
        let keep = |lo: &mut f64, hi: &mut f64| {
            *lo = lo.min(a);
            *hi = hi.max(b);
        };
        // Once a kept range covers this sub-arc, examining it cannot shrink the hull.
        if a >= lo && b <= hi {
            continue;
        }
        let amin = min_norm(a, b);
        if !(rho < amin) {
            keep(&mut lo, &mut hi);
            continue;
        }
        let allowance = cone.angle + (rho / amin).asin();
        let c = 0.5 * (a + b);
        let center = angle_at(c);
        evaluations += 1;
        let lower = center - 0.5 * (b - a) * eta / amin;
        if lower > allowance * (1.0 + 1e-12) + 1e-12 {
            continue;
        }
        if center <= allowance || evaluations >= NORMAL_CONE_BUDGET || b - a < 1e-9 {
            keep(&mut lo, &mut hi);
            continue;
        }
        // Examine the outer halves last so the hull grows from the inside out.
        stack.push((c, b));
        stack.push((a, c));
    }
    if lo > hi {
        return None;
    }
    let xa = s.x_at(lo, eye.dir);
    let xb = s.x_at(hi, eye.dir);
    let pad = 1e-9 * (s.x1 - s.x0);
    Some(((xa - pad).max(s.x0), (xb + pad).min(s.x1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_maps_angles_back_to_eye_parameters() {
        let sphere = BoundingSphere {
            center: DVec3::new(0.2, 1.0, 0.3),
            radius: 0.1,
        };
        let eye = EyeSegment::new(DVec3::new(-1.0, 0.0, 0.0), DVec3::new(2.0, 0.1, -0.2)).unwrap();
        let s = sweep(&sphere, &eye, (0.5, 2.5), DVec3::new(0.0, 5.0, 0.0)).unwrap();
        for &x in &[0.5, 1.0, 1.7, 2.5] {
            let d = (eye.at(x) - sphere.center).normalize();
            let psi = d.dot(s.e2).atan2(d.dot(s.e1));
            assert!((s.x_at(psi, eye.dir) - x).abs() < 1e-12, "{x}");
        }
        // Min angle to the arc vs dense sampling.
        for a in [
            DVec3::X,
            DVec3::new(0.3, -0.8, 0.5).normalize(),
            DVec3::NEG_Y,
        ] {
            let m = s.min_angle_to_arc(a);
            let brute = (0..=10_000)
                .map(|k| angle_between(a, s.axis(s.span * k as f64 / 10_000.0)))
                .fold(f64::INFINITY, f64::min);
            assert!(m <= brute + 1e-12 && brute - m < 1e-6, "{m} vs {brute}");
        }
    }
}
