//! Value accuracy of the form factors where the certified fast paths now reach: small triangles
//! and convex polygons seen from 3 to 1e4 sizes away (mesh lights, occluders), against the
//! 320-bit reference (`form_factor_support`), through the public entry points (whichever path they
//! take; `src/kernels/lambert*.rs` unit tests check which one). The generic contract is 1e-12.

mod form_factor_support;

use form_factor_support::*;
use glam::DVec3;
use raddiff::{kernels, Order};

/// A random convex polygon with `m` vertices: points on an ellipse at sorted random angles, in a
/// random plane through `c`, of size `s`.
fn convex(rng: &mut Rng, m: usize, c: DVec3, s: f64) -> Vec<DVec3> {
    let normal = rng.unit();
    let a = normal.any_orthonormal_vector();
    let b = normal.cross(a);
    let (ra, rb) = (s * rng.range(0.5, 1.0), s * rng.range(0.5, 1.0));
    let mut phi: Vec<f64> = (0..m)
        .map(|k| std::f64::consts::TAU * (k as f64 + rng.range(0.1, 0.9)) / m as f64)
        .collect();
    phi.sort_by(f64::total_cmp);
    phi.iter()
        .map(|p| c + a * (ra * p.cos()) + b * (rb * p.sin()))
        .collect()
}

#[test]
fn small_polygons_far_away_against_320_bits() {
    let mut big = Big::new();
    let mut rng = Rng(18);
    let mut worst = [0.0f64; 3];
    let mut count = [0usize; 3];
    for case in 0..24 {
        let m = 3 + case % 3;
        let s = 10f64.powf(rng.range(-3.0, 1.0));
        let c = rng.vec(10.0 * s);
        let v = convex(&mut rng, m, c, s);
        let dir = rng.unit();
        for &t in &[3.0, 10.0, 30.0, 100.0, 300.0, 1e3, 1e4] {
            let x = c + dir * (t * s);
            // The receiver faces the polygon within ~50°, nothing clipped.
            let n = (c - x).normalize() + rng.vec(0.6);
            let n = n.normalize();
            if v.iter().any(|p| n.dot(*p - x) <= 0.0) {
                continue;
            }
            let reference = big.polygon_reference(x, n, &v, true).value;
            let got = if m == 3 {
                kernels::triangle_form_factor(x, n, v[0], v[1], v[2], Order::Value)
            } else {
                kernels::polygon_form_factor(x, n, &v, Order::Value)
            }
            .unwrap()
            .value;
            let e = rel_scalar(got, reference, 1e-300);
            assert!(
                e < 1e-12,
                "m={m} t={t:e}: {got} vs {reference} ({e:e})\n x={x:?} n={n:?} v={v:?}"
            );
            worst[m - 3] = worst[m - 3].max(e);
            count[m - 3] += 1;
        }
    }
    println!("worst value error, 3 to 1e4 sizes away: triangle {:.1e} (n={}), quad {:.1e} (n={}), pentagon {:.1e} (n={})",
        worst[0], count[0], worst[1], count[1], worst[2], count[2]);
    assert!(count.iter().all(|&k| k > 20), "{count:?}");
}
