//! A point inside a medium (sphere layout) in a closed room with an area light and an occluder
//! (Marco et al. 2018 Fig. 3/5 setting, in 3D): the occlusion-aware fluence gradient from the media
//! rings converges to central differences of the gather's own marched Monte-Carlo fluence
//! (dense layout, re-traced at x ± h). Run with `--nocapture` for the table.

use glam::DVec3;
use raddiff::gather::hessian::occlusion_outputs;
use raddiff::gather::{
    evaluate, Frame, GatherInput, Layout, LayoutKind, MediaRadiance, ValidGather, Wanted,
};

const SIGMA_T: f64 = 0.25;
const STEPS: usize = 64;
const STEP: f64 = 0.05;

/// Room |x|, |y| < 1.5, -1 < z < 1 (grey 0.2), an emitter square |x|, |y| < 0.5 in the ceiling
/// (radiance 3), a black plate z = 0.45 over [-0.1, 0.5] x [-0.4, 0.4], and media radiance
/// 0.2 + 0.1 x + 0.05 z per unit length. The march (3.2) reaches every wall, also from the shifted points.
fn trace(layout: &Layout, x: DVec3) -> (Vec<DVec3>, Vec<f64>, Vec<f32>, Vec<f32>) {
    let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
    let dirs = layout.directions(&frame).unwrap();
    let (mut dist, mut rad, mut media) = (Vec::new(), Vec::new(), Vec::new());
    for w in &dirs {
        let mut d = f64::INFINITY;
        let mut l = 0.2f32;
        for (c, o, lo, hi) in [
            (w.x, x.x, -1.5, 1.5),
            (w.y, x.y, -1.5, 1.5),
            (w.z, x.z, -1.0, 1.0),
        ] {
            let t = if c > 0.0 {
                (hi - o) / c
            } else if c < 0.0 {
                (lo - o) / c
            } else {
                f64::INFINITY
            };
            if t < d {
                d = t;
                let p = x + *w * t;
                l = if c > 0.0 && hi == 1.0 && p.x.abs() < 0.5 && p.y.abs() < 0.5 {
                    3.0
                } else {
                    0.2
                };
            }
        }
        if w.z > 0.0 {
            let t = (0.45 - x.z) / w.z;
            let p = x + *w * t;
            if t < d && p.x > -0.1 && p.x < 0.5 && p.y.abs() < 0.4 {
                d = t;
                l = 0.0;
            }
        }
        dist.push(d);
        rad.push(l);
        for s in 0..STEPS {
            let y = x + *w * ((s as f64 + 0.5) * STEP);
            media.push((0.2 + 0.1 * y.x + 0.05 * y.z) as f32);
        }
    }
    (dirs, dist, rad, media)
}

fn input<'a>(t: &'a (Vec<DVec3>, Vec<f64>, Vec<f32>, Vec<f32>)) -> GatherInput<'a> {
    GatherInput {
        directions: &t.0,
        distance: &t.1,
        radiance: &t.2,
        channels: 1,
        sigma_t: SIGMA_T,
        media: Some(MediaRadiance {
            radiance: &t.3,
            gradient: None,
            steps: STEPS,
            step: STEP,
        }),
    }
}

fn fluence(layout: &Layout, x: DVec3) -> f64 {
    let t = trace(layout, x);
    let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
    evaluate(layout, &frame, &input(&t), Wanted::IRRADIANCE)
        .unwrap()
        .irradiance[0]
}

#[test]
fn media_ring_gradient_converges_to_the_marched_fluence_gradient() {
    // In the plate's shadow boundary towards the emitter.
    let x = DVec3::new(0.55, 0.1, 0.0);
    let dense = Layout::new(LayoutKind::Sphere, 256, 512, 0).unwrap();
    let h = 0.05;
    let fd = |e: DVec3| {
        (8.0 * (fluence(&dense, x + e * h) - fluence(&dense, x - e * h))
            - (fluence(&dense, x + e * 2.0 * h) - fluence(&dense, x - e * 2.0 * h)))
            / (12.0 * h)
    };
    let reference = DVec3::new(fd(DVec3::X), fd(DVec3::Y), fd(DVec3::Z));
    let mut errors = Vec::new();
    for m in [8u32, 16, 32, 64, 128] {
        let layout = Layout::new(LayoutKind::Sphere, m, 2 * m, 0).unwrap();
        let t = trace(&layout, x);
        let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
        let valid = ValidGather::new(&layout, &frame, &input(&t)).unwrap();
        let (g, h) = occlusion_outputs(&valid, true).unwrap();
        assert!(h[0].is_finite());
        let err = (g[0] - reference).length() / reference.length();
        println!(
            "| {:5} | {:.4} | {:.4} | {err:.2e} |",
            2 * m * m,
            g[0],
            reference
        );
        errors.push(err);
    }
    // Measured: 6.0e-1, 3.2e-1, 3.1e-1, 1.6e-1, 1.1e-1. Split up (same points): the media rings
    // alone reach 2.7e-2 at 32768 rays; the surface ring converges like the cell size (1.4e-1
    // alone): the farthest-vertex rule moves the emitter's edges and the plate's shadow edge by up
    // to a cell, and the plate 0.45 above x makes those cells' derivatives large.
    assert!(
        errors[4] < 0.15 && errors[4] < errors[0] / 4.0,
        "{errors:?}"
    );
}
