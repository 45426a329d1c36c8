use super::super::walls::tests::WallVectors;
use super::*;

/// The march's weights over any interval, as the tests check them.
trait Visit {
    /// Calls `f(s, ∫ exp(−σt) dt, ∫ t exp(−σt) dt)` over `[lo, hi) ∩ step s` for every step
    /// overlapping `[lo, hi)`.
    fn visit(&self, lo: f64, hi: f64, f: impl FnMut(usize, f64, f64));
}

impl Visit for March {
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

/// The AVX2 builds (used when the CPU has it) give bitwise the results of the portable build:
/// the same operations in the same order, no FMA.
#[test]
fn avx2_builds_match_the_portable_build_bitwise() {
    for kind in [
        LayoutKind::CosinePolar,
        LayoutKind::Sphere,
        LayoutKind::Concentric,
    ] {
        for (m, n, ch) in [(1, 1, 1), (3, 7, 3), (9, 16, 2), (6, 33, 5)] {
            let layout = Layout::new(kind, m, n, 9).unwrap();
            let frame = Frame::new(DVec3::ZERO, DVec3::new(0.0, 0.6, 0.8), DVec3::X).unwrap();
            let dirs = layout.directions(&frame).unwrap();
            let cells = layout.len();
            let dist: Vec<f64> = (0..cells)
                .map(|i| {
                    if i % 5 == 0 {
                        f64::INFINITY
                    } else {
                        0.3 + (i * 7 % 11) as f64 * 0.37
                    }
                })
                .collect();
            let rad: Vec<f32> = (0..cells * ch)
                .map(|i| ((i * 29) % 13) as f32 * 0.1 - 0.2)
                .collect();
            let input = GatherInput {
                directions: &dirs,
                distance: &dist,
                radiance: &rad,
                channels: ch,
                sigma_t: 0.0,
                media: None,
            };
            let v = ValidGather::new(&layout, &frame, &input).unwrap();
            let bits = |g: &[DVec3]| -> Vec<[u64; 3]> {
                g.iter().map(|g| g.to_array().map(f64::to_bits)).collect()
            };
            if kind == LayoutKind::Concentric {
                let walls = ConcentricWalls::cached(&layout);
                let (g0, r0) = v.concentric_pass(&walls, &rad, Wanted::ALL);
                let (g1, r1) = v.concentric_pass_any(&walls, &rad, Wanted::ALL);
                assert_eq!(bits(&g0), bits(&g1));
                assert_eq!(bits(&r0), bits(&r1));
            } else {
                let walls = Walls::new(&layout);
                let a = v.polar_pass(&walls, &rad, Wanted::ALL);
                let b = v.polar_pass_any(&walls, &rad, Wanted::ALL);
                assert_eq!(bits(&a.gradient), bits(&b.gradient));
                assert_eq!(bits(&a.rotation), bits(&b.rotation));
                assert_eq!(a.inv_sum.to_bits(), b.inv_sum.to_bits());
                assert_eq!(a.min.to_bits(), b.min.to_bits());
            }
        }
    }
}

/// The factored wall loop equals the plain sum over walls of `(L_a − L_b)/min(r) · W`, and the
/// factored rotation sum the plain sum of `L ∫_cell sinθ e_φ dω`.
#[test]
fn factored_sums_match_plain_wall_sums() {
    for kind in [LayoutKind::CosinePolar, LayoutKind::Sphere] {
        let layout = Layout::new(kind, 5, 7, 3).unwrap();
        let frame = Frame::new(DVec3::ZERO, DVec3::Z, DVec3::X).unwrap();
        let dirs = layout.directions(&frame).unwrap();
        let ch = 2;
        let dist: Vec<f64> = (0..35)
            .map(|i| {
                if i % 4 == 0 {
                    f64::INFINITY
                } else {
                    1.0 + (i % 5) as f64
                }
            })
            .collect();
        let rad: Vec<f32> = (0..70).map(|i| ((i * 29) % 13) as f32 * 0.1).collect();
        let input = GatherInput {
            directions: &dirs,
            distance: &dist,
            radiance: &rad,
            channels: ch,
            sigma_t: 0.0,
            media: None,
        };
        let v = ValidGather::new(&layout, &frame, &input).unwrap();
        let walls = Walls::new(&layout);
        let r64: Vec<f64> = rad.iter().map(|&l| l as f64).collect();
        let sums = v.polar_pass(&walls, &r64, Wanted::ALL);
        let (got, rot) = (sums.gradient, sums.rotation);
        let (m, n) = (5, 7);
        for c in 0..ch {
            let mut want = DVec3::ZERO;
            let mut want_rot = DVec3::ZERO;
            let mut wall = |a: usize, b: usize, w: DVec3| {
                let r = dist[a].min(dist[b]);
                if r.is_finite() {
                    want += w * ((r64[a * ch + c] - r64[b * ch + c]) / r);
                }
            };
            for j in 0..m {
                for k in 0..n {
                    let i = j * n + k;
                    wall(i, j * n + (k + n - 1) % n, walls.azimuth_wall_vector(j, k));
                    if j >= 1 {
                        wall(i, i - n, walls.ring_wall_vector(j, k));
                    }
                    want_rot += walls.rotation_vector(j, k) * r64[i * ch + c];
                }
            }
            assert!(
                (got[c] - want).length() < 1e-13,
                "{kind:?} {} {want}",
                got[c]
            );
            if kind == LayoutKind::CosinePolar {
                assert!((rot[c] - want_rot).length() < 1e-13);
            }
        }
    }
}

#[test]
fn march_weights_integrate_the_exponential_exactly() {
    // references: fine midpoint sums of e^{-σt} and t e^{-σt}
    let reference = |sigma: f64, lo: f64, hi: f64| {
        let q = 200_000;
        let h = (hi - lo) / q as f64;
        (0..q).fold((0.0, 0.0), |(a, b), i| {
            let t = lo + (i as f64 + 0.5) * h;
            let e = (-sigma * t).exp() * h;
            (a + e, b + t * e)
        })
    };
    for sigma in [0.7, 1e-5] {
        let m = March::new(sigma, 0.3, 10);
        for (lo, hi) in [(0.45, 2.05), (1.0, f64::INFINITY)] {
            let (mut t0, mut t1) = (0.0, 0.0);
            m.visit(lo, hi, |_, a, b| {
                t0 += a;
                t1 += b;
            });
            let (e0, e1) = reference(sigma, lo, hi.min(3.0));
            assert!((t0 - e0).abs() < 1e-10, "{sigma} {t0} {e0}");
            assert!((t1 - e1).abs() < 1e-10, "{sigma} {t1} {e1}");
        }
    }
    // weights() is visit() from 0, step by step
    for sigma in [0.0, 1e-5, 0.7, 3.0] {
        let m = March::new(sigma, 0.3, 10);
        for r in [1e-3, 0.3, 0.45, 0.6, 2.05, 2.999, 3.0, 7.0, f64::INFINITY] {
            let i0_full: Vec<f64> = m.full.iter().map(|w| w.0).collect();
            let i1_full: Vec<f64> = m.full.iter().map(|w| w.1).collect();
            let (mut i0, mut i1) = (i0_full.clone(), i1_full.clone());
            let used = m.weights(r, &mut i0, &mut i1);
            let count = used.0;
            let mut want = Vec::new();
            m.visit(0.0, r, |s, a, b| want.push((s, a, b)));
            assert_eq!(count, want.len());
            for (k, &(s, a, b)) in want.iter().enumerate() {
                assert_eq!((k, i0[k], i1[k]), (s, a, b), "{sigma} {r}");
            }
            m.restore(&mut i0, &mut i1, used);
            assert_eq!((i0, i1), (i0_full, i1_full));
        }
    }
    let m = March::new(0.0, 0.25, 4);
    let (mut t0, mut t1) = (0.0, 0.0);
    m.visit(0.1, 0.6, |_, a, b| {
        t0 += a;
        t1 += b;
    });
    assert!((t0 - 0.5).abs() < 1e-15);
    assert!((t1 - (0.36 - 0.01) / 2.0).abs() < 1e-15);
}
