//! A surface point inside a medium: the hemisphere gather's marched media radiance enters the
//! occlusion-aware gradient through one hemisphere ring per march step (`gather::hessian::outputs`).
//! Reference: central differences of the gather's own Monte-Carlo irradiance (dense concentric
//! layout, re-traced at x ± h), which includes the media and the ceiling.

use glam::DVec3;
use raddiff::gather::hessian::occlusion_outputs;
use raddiff::gather::{
    evaluate, Frame, GatherInput, Layout, LayoutKind, MediaRadiance, ValidGather, Wanted,
};

const SIGMA_T: f64 = 0.2;
const STEPS: usize = 50;
const STEP: f64 = 0.05;

/// A closed room: ceiling z = 1 (radiance 1 for x < 0.2, 0.2 beyond: an edge to resolve), grey
/// walls at |x|, |y| = 1.5 (0.3), media radiance 0.2 + 0.1 x + 0.05 z (per unit length) inside. The
/// march (2.5) reaches every wall, so neither estimate truncates the medium.
fn trace(layout: &Layout, x: DVec3) -> (Vec<DVec3>, Vec<f64>, Vec<f32>, Vec<f32>) {
    let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
    let dirs = layout.directions(&frame).unwrap();
    let mut dist = Vec::new();
    let mut rad = Vec::new();
    let mut media = Vec::new();
    for w in &dirs {
        let mut d = if w.z > 0.0 {
            (1.0 - x.z) / w.z
        } else {
            f64::INFINITY
        };
        let mut wall = false;
        for (c, o) in [(w.x, x.x), (w.y, x.y)] {
            let t = if c > 0.0 {
                (1.5 - o) / c
            } else if c < 0.0 {
                (-1.5 - o) / c
            } else {
                f64::INFINITY
            };
            if t < d {
                d = t;
                wall = true;
            }
        }
        let p = x + *w * d;
        dist.push(d);
        rad.push(if wall {
            0.3
        } else if p.x < 0.2 {
            1.0
        } else {
            0.2
        });
        for s in 0..STEPS {
            let y = x + *w * ((s as f64 + 0.5) * STEP);
            media.push((0.2 + 0.1 * y.x + 0.05 * y.z) as f32);
        }
    }
    (dirs, dist, rad, media)
}

fn irradiance(layout: &Layout, x: DVec3) -> f64 {
    let (dirs, dist, rad, media) = trace(layout, x);
    let input = GatherInput {
        directions: &dirs,
        distance: &dist,
        radiance: &rad,
        channels: 1,
        sigma_t: SIGMA_T,
        media: Some(MediaRadiance {
            radiance: &media,
            gradient: None,
            steps: STEPS,
            step: STEP,
        }),
    };
    let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
    evaluate(layout, &frame, &input, Wanted::IRRADIANCE)
        .unwrap()
        .irradiance[0]
}

#[test]
fn media_rings_give_the_gradient_of_the_marched_irradiance() {
    let x = DVec3::new(0.1, -0.05, 0.0);
    let dense = Layout::new(LayoutKind::Concentric, 384, 384, 0).unwrap();
    let h = 0.05;
    let fd = |e: DVec3| (irradiance(&dense, x + e * h) - irradiance(&dense, x - e * h)) / (2.0 * h);
    let reference = DVec3::new(fd(DVec3::X), fd(DVec3::Y), 0.0);
    let mut errors = Vec::new();
    for side in [16u32, 32, 64, 128] {
        let layout = Layout::new(LayoutKind::Concentric, side, side, 0).unwrap();
        let (dirs, dist, rad, media) = trace(&layout, x);
        let input = GatherInput {
            directions: &dirs,
            distance: &dist,
            radiance: &rad,
            channels: 1,
            sigma_t: SIGMA_T,
            media: Some(MediaRadiance {
                radiance: &media,
                gradient: None,
                steps: STEPS,
                step: STEP,
            }),
        };
        let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
        let valid = ValidGather::new(&layout, &frame, &input).unwrap();
        let (g, h) = occlusion_outputs(&valid, true).unwrap();
        assert!(h[0].is_finite());
        let t = DVec3::new(g[0].x, g[0].y, 0.0);
        let err = (t - reference).length() / reference.length();
        println!("{side}x{side}: tangent gradient {t} reference {reference} error {err:.2e}");
        errors.push(err);
    }
    // 128²: surface part 1.2e-2, media part 1.8e-2 (measured separately), together 3.7e-2.
    assert!(
        errors[3] < 0.06 && errors[3] < errors[0] / 2.0,
        "{errors:?}"
    );
}
