//! Properties of the gather evaluation over random frames and data (proptest): a rigid motion of
//! the frame together with everything seen from it (and the media gradient vectors) leaves the
//! irradiance unchanged and rotates both gradients, for every layout, seed and medium; results are
//! linear in the radiance.

use glam::{DQuat, DVec3};
use proptest::prelude::*;
use raddiff::gather::{evaluate, Frame, GatherInput, Layout, LayoutKind, MediaRadiance, Wanted};

const STEPS: usize = 3;

struct Data {
    dist: Vec<f64>,
    rad: Vec<f32>,
    media: Vec<f32>,
    media_grad: Vec<f32>,
}

fn data(cells: usize, seed: u64) -> Data {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let dist = (0..cells)
        .map(|_| {
            let u = next();
            if u < 0.2 {
                f64::INFINITY
            } else {
                0.2 + 3.0 * u
            }
        })
        .collect();
    let rad = (0..cells).map(|_| next() as f32).collect();
    let media = (0..cells * STEPS).map(|_| 0.3 * next() as f32).collect();
    let media_grad = (0..cells * STEPS * 3)
        .map(|_| (next() - 0.5) as f32 * 0.1)
        .collect();
    Data {
        dist,
        rad,
        media,
        media_grad,
    }
}

fn run(
    layout: &Layout,
    frame: &Frame,
    d: &Data,
    grad: &[f32],
    sigma: f64,
) -> raddiff::gather::GatherValues {
    let dirs = layout.directions(frame).unwrap();
    let input = GatherInput {
        directions: &dirs,
        distance: &d.dist,
        radiance: &d.rad,
        channels: 1,
        sigma_t: sigma,
        media: Some(MediaRadiance {
            radiance: &d.media,
            gradient: Some(grad),
            steps: STEPS,
            step: 0.4,
        }),
    };
    evaluate(layout, frame, &input, Wanted::ALL).unwrap()
}

fn kind(k: u32) -> LayoutKind {
    LayoutKind::try_from(k).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn rigid_motion_rotates_the_gradients(
        k in 0u32..3, m in 1u32..7, n in 1u32..9, seed in 0u64..1000,
        axis in prop::array::uniform3(-1.0f64..1.0), angle in -3.0f64..3.0,
        shift in prop::array::uniform3(-50.0f64..50.0), sigma in prop::sample::select(vec![0.0, 0.7]),
    ) {
        let axis = DVec3::from(axis);
        prop_assume!(axis.length() > 0.1);
        let q = DQuat::from_axis_angle(axis.normalize(), angle);
        let layout = Layout::new(kind(k), m, n, seed).unwrap();
        let frame = Frame::new(DVec3::new(0.3, -0.2, 1.0), DVec3::Z, DVec3::X).unwrap();
        let moved = Frame::new(q * frame.position + DVec3::from(shift), q * DVec3::Z, q * DVec3::X).unwrap();
        let d = data(layout.len(), seed);
        let rotated_grad: Vec<f32> = d
            .media_grad
            .chunks(3)
            .flat_map(|g| {
                let v = q * DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64);
                [v.x as f32, v.y as f32, v.z as f32]
            })
            .collect();
        let a = run(&layout, &frame, &d, &d.media_grad, sigma);
        let b = run(&layout, &moved, &d, &rotated_grad, sigma);
        let scale = 1.0 + a.irradiance[0].abs();
        prop_assert!((a.irradiance[0] - b.irradiance[0]).abs() < 1e-12 * scale);
        let gs = 1.0 + a.gradient[0].length();
        // the media gradient went through f32: 1e-6 relative
        prop_assert!((q * a.gradient[0] - b.gradient[0]).length() < 1e-6 * gs, "{} vs {}", q * a.gradient[0], b.gradient[0]);
        let rs = 1.0 + a.rotation_gradient[0].length();
        prop_assert!((q * a.rotation_gradient[0] - b.rotation_gradient[0]).length() < 1e-12 * rs);
        prop_assert_eq!(a.harmonic_mean_distance, b.harmonic_mean_distance);
    }

    #[test]
    fn results_are_linear_in_radiance(k in 0u32..3, m in 1u32..6, n in 1u32..7, seed in 0u64..1000, s in 0.1f64..10.0) {
        let layout = Layout::new(kind(k), m, n, seed).unwrap();
        let frame = Frame::new(DVec3::ZERO, DVec3::Y, DVec3::Z).unwrap();
        let d = data(layout.len(), seed);
        let mut scaled = data(layout.len(), seed);
        // powers of two keep the f32 inputs exact
        let s = (s.log2().round()).exp2();
        scaled.rad.iter_mut().for_each(|v| *v *= s as f32);
        scaled.media.iter_mut().for_each(|v| *v *= s as f32);
        let grad: Vec<f32> = d.media_grad.iter().map(|v| v * s as f32).collect();
        let a = run(&layout, &frame, &d, &d.media_grad, 0.3);
        let b = run(&layout, &frame, &scaled, &grad, 0.3);
        prop_assert!((a.irradiance[0] * s - b.irradiance[0]).abs() <= 1e-12 * b.irradiance[0].abs().max(1.0));
        prop_assert!((a.gradient[0] * s - b.gradient[0]).length() <= 1e-12 * b.gradient[0].length().max(1.0));
    }
}
