//! Exact wall integrals of the polar and sphere layouts, for the Ward-Heckbert gradient.
//!
//! Model: each stratum shows one piece of the scene with constant radiance. Translating x by δ
//! moves a scene point at distance r in direction ω by `dω = −(δ − (δ·ω)ω)/r` on the unit sphere,
//! so a wall between strata a and b drifts, and a gains `∫_wall w(ω) (δ·ν_a)/r dl` of weighted solid
//! angle (ν_a: the wall's unit normal pointing into a; w = cosθ for irradiance, 1 for fluence).
//! Ward and Heckbert let the wall move with the closer of the two hits. The gradient is then
//! `Σ_walls (L_a − L_b)/min(r_a, r_b) · W`, with `W = ∫_wall w ν_a dl` a vector depending on the
//! layout only. For θ/φ walls it has a closed form:
//!
//! * ring wall at `θ_j` between rings j−1 and j, column k (a = ring j, ν_a = e_θ):
//!   `W = w(θ_j) sinθ_j (cosθ_j (sinφ_{k+1} − sinφ_k), cosθ_j (cosφ_k − cosφ_{k+1}), −sinθ_j Δφ)`;
//! * azimuth wall at `φ_k` between columns k−1 and k, ring j (a = column k, ν_a = e_φ):
//!   `W = (−sinφ_k, cosφ_k, 0) ∫_{θ_j}^{θ_{j+1}} w(θ) dθ`.
//!
//! These are the exact integrals of Jarosz et al. 2008 eq. (12)-(13) (which approximate them with
//! centre values; ERRATA 3 fixes the azimuthal wall's distance and sign) extended to all three
//! axes: the normal component follows from the same wall motion.

use std::f64::consts::TAU;

#[cfg(test)]
use glam::DVec3;

use super::layout::{Layout, LayoutKind};

/// Per-ring and per-column wall data of a polar or sphere layout (local frame).
pub(crate) struct Walls {
    /// Per column k: `(cos φ_k, sin φ_k)` of its lower azimuth wall.
    pub(crate) phi_wall: Vec<(f64, f64)>,
    /// Per column k: `(sinφ_{k+1} − sinφ_k, cosφ_k − cosφ_{k+1})` = `∫ (cosφ, sinφ) dφ` over the column.
    pub(crate) column: Vec<(f64, f64)>,
    /// Per ring wall j (index j, used for j ≥ 1): `(w sinθ cosθ, −w sin²θ Δφ)` at `θ_j`.
    pub(crate) ring_wall: Vec<(f64, f64)>,
    /// Per ring j: `∫_{θ_j}^{θ_{j+1}} w(θ) dθ`.
    pub(crate) ring_span: Vec<f64>,
    /// Per ring j: `∫_{θ_j}^{θ_{j+1}} sin²θ dθ` (rotational gradient of the cosine-polar layout).
    pub(crate) ring_sin2: Vec<f64>,
}

impl Walls {
    /// Wall data for a [`LayoutKind::CosinePolar`] or [`LayoutKind::Sphere`] layout.
    pub(crate) fn new(layout: &Layout) -> Walls {
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

    /// `∫ w ν dl` of the ring wall at the top of ring `j ≥ 1`, column `k` (local frame).
    #[cfg(test)]
    pub(crate) fn ring_wall_vector(&self, j: usize, k: usize) -> DVec3 {
        let (a, b) = self.ring_wall[j];
        let (c1, c2) = self.column[k];
        DVec3::new(a * c1, a * c2, b)
    }

    /// `∫ w ν dl` of the azimuth wall at the start of column `k`, ring `j` (local frame).
    #[cfg(test)]
    pub(crate) fn azimuth_wall_vector(&self, j: usize, k: usize) -> DVec3 {
        let (c, s) = self.phi_wall[k];
        let r = self.ring_span[j];
        DVec3::new(-s * r, c * r, 0.0)
    }

    /// `∫_cell sinθ e_φ dω` of stratum `(j, k)` (local frame): the rotational-gradient weight.
    #[cfg(test)]
    pub(crate) fn rotation_vector(&self, j: usize, k: usize) -> DVec3 {
        let (c1, c2) = self.column[k];
        DVec3::new(-c2, c1, 0.0) * self.ring_sin2[j]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Numerical ∫ w ν dl along the walls, by midpoint quadrature on θ and φ.
    #[test]
    fn wall_vectors_match_numerical_wall_integrals() {
        for kind in [LayoutKind::CosinePolar, LayoutKind::Sphere] {
            let layout = Layout::new(kind, 5, 6, 0).unwrap();
            let walls = Walls::new(&layout);
            let sphere = kind == LayoutKind::Sphere;
            let w = |t: f64| if sphere { 1.0 } else { t.cos() };
            let q = 20000;
            let (j, k) = (2, 4);
            let super::super::layout::StratumBounds::Polar { theta, phi } =
                layout.stratum_bounds(j, k)
            else {
                panic!()
            };
            // ring wall at theta.0: ∫ w(θ) e_θ sinθ dφ
            let mut ring = DVec3::ZERO;
            let mut rot = DVec3::ZERO;
            for i in 0..q {
                let p = phi.0 + (phi.1 - phi.0) * (i as f64 + 0.5) / q as f64;
                let t = theta.0;
                let e_theta = DVec3::new(t.cos() * p.cos(), t.cos() * p.sin(), -t.sin());
                ring += e_theta * w(t) * t.sin() * (phi.1 - phi.0) / q as f64;
                for l in 0..200 {
                    let tt = theta.0 + (theta.1 - theta.0) * (l as f64 + 0.5) / 200.0;
                    let e_phi = DVec3::new(-p.sin(), p.cos(), 0.0);
                    rot += e_phi * tt.sin() * tt.sin() * (phi.1 - phi.0) / q as f64
                        * (theta.1 - theta.0)
                        / 200.0;
                }
            }
            let got = walls.ring_wall_vector(j as usize, k as usize);
            assert!((got - ring).length() < 1e-8, "{kind:?} {got} {ring}");
            let got = walls.rotation_vector(j as usize, k as usize);
            assert!((got - rot).length() < 1e-6, "{kind:?} {got} {rot}");
            let mut az = 0.0;
            for i in 0..q {
                let t = theta.0 + (theta.1 - theta.0) * (i as f64 + 0.5) / q as f64;
                az += w(t) * (theta.1 - theta.0) / q as f64;
            }
            let e_phi = DVec3::new(-phi.0.sin(), phi.0.cos(), 0.0);
            let got = walls.azimuth_wall_vector(j as usize, k as usize);
            assert!((got - e_phi * az).length() < 1e-9, "{kind:?}");
        }
    }
}
