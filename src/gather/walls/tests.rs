use super::*;

/// The polar layout's wall vectors one at a time, as the tests read them (the evaluation reads
/// the tables in bulk).
pub(crate) trait WallVectors {
    /// `∫ w ν dl` of the ring wall at the top of ring `j ≥ 1`, column `k` (local frame).
    fn ring_wall_vector(&self, j: usize, k: usize) -> DVec3;
    /// `∫ w ν dl` of the azimuth wall at the start of column `k`, ring `j` (local frame).
    fn azimuth_wall_vector(&self, j: usize, k: usize) -> DVec3;
    /// `∫_cell sinθ e_φ dω` of stratum `(j, k)` (local frame): the rotational-gradient weight.
    fn rotation_vector(&self, j: usize, k: usize) -> DVec3;
}

impl WallVectors for Walls {
    fn ring_wall_vector(&self, j: usize, k: usize) -> DVec3 {
        let (a, b) = self.ring_wall[j];
        let (c1, c2) = self.column[k];
        DVec3::new(a * c1, a * c2, b)
    }

    fn azimuth_wall_vector(&self, j: usize, k: usize) -> DVec3 {
        let (c, s) = self.phi_wall[k];
        let r = self.ring_span[j];
        DVec3::new(-s * r, c * r, 0.0)
    }

    fn rotation_vector(&self, j: usize, k: usize) -> DVec3 {
        let (c1, c2) = self.column[k];
        DVec3::new(-c2, c1, 0.0) * self.ring_sin2[j]
    }
}

/// Concentric wall vectors against a dense midpoint rule on the map itself, with tangents by
/// central differences and the sign fixed by the side of the cell it points into. (The midpoint
/// rule is first-order across the map's kinks at the diagonals: 1e-4 relative.)
#[test]
fn concentric_wall_vectors_match_dense_quadrature() {
    use super::super::layout::concentric_to_local;
    let layout = Layout::new(LayoutKind::Concentric, 5, 7, 0).unwrap();
    let walls = ConcentricWalls::new(&layout);
    let dense = |s0: DVec2, s1: DVec2| {
        let q = 20000;
        let mut sum = DVec3::ZERO;
        for i in 0..q {
            let t = (i as f64 + 0.5) / q as f64;
            let h = 1e-7;
            let w = concentric_to_local(s0 + (s1 - s0) * t);
            let dw = (concentric_to_local(s0 + (s1 - s0) * (t + h))
                - concentric_to_local(s0 + (s1 - s0) * (t - h)))
                / (2.0 * h);
            sum += w.cross(dw) * (w.z / q as f64);
        }
        sum
    };
    let sa = |j: usize| 2.0 * j as f64 / 5.0 - 1.0;
    let sb = |k: usize| 2.0 * k as f64 / 7.0 - 1.0;
    let at = |[x, y, z]: &[Vec<f64>; 3], i: usize| DVec3::new(x[i], y[i], z[i]);
    for (j, k) in [(1, 0), (2, 3), (3, 6), (4, 2)] {
        let want = -dense(DVec2::new(sa(j), sb(k)), DVec2::new(sa(j), sb(k + 1)));
        let got = at(&walls.first_by_axis, (j - 1) * 7 + k);
        assert!(
            (got - want).length() < 1e-4 * want.length().max(1e-3),
            "{got} {want}"
        );
        // it points from (j-1, k) into (j, k)
        let from = layout.grid_to_local(j as f64 - 0.5, k as f64 + 0.5);
        let into = layout.grid_to_local(j as f64 + 0.5, k as f64 + 0.5);
        assert!(got.dot(into - from) > 0.0);
    }
    for (j, k) in [(0, 1), (2, 3), (4, 6), (2, 4)] {
        let want = dense(DVec2::new(sa(j), sb(k)), DVec2::new(sa(j + 1), sb(k)));
        let got = at(&walls.second_by_axis, j * 6 + k - 1);
        assert!(
            (got - want).length() < 1e-4 * want.length().max(1e-3),
            "{got} {want}"
        );
        let from = layout.grid_to_local(j as f64 + 0.5, k as f64 - 0.5);
        let into = layout.grid_to_local(j as f64 + 0.5, k as f64 + 0.5);
        assert!(got.dot(into - from) > 0.0);
    }
}

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
        let super::super::layout::StratumBounds::Polar { theta, phi } = layout.stratum_bounds(j, k)
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
