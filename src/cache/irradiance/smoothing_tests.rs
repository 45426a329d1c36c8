//! Evaluations with smoothed strata: values from the strata as traced, derivatives from the
//! smoothed ones, and derivatives of a noisy gather closer to the exact ones than without.

use std::f64::consts::PI;

use glam::DVec3;

use super::*;
use crate::gather::{Frame, Layout, LayoutKind, StrataSmoothing};

/// A ceiling at height 1 above the plane z = 0, radiance `radiance` where y > 0 and black
/// elsewhere (a penumbra along the x axis); each lit stratum's radiance times `noise(i)`.
fn half_ceiling(
    x: DVec3,
    layout: Layout,
    noise: impl Fn(usize) -> f32,
) -> (Frame, Vec<DVec3>, Vec<f64>, Vec<f32>) {
    let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
    let directions = layout.directions(&frame).unwrap();
    let distance: Vec<f64> = directions.iter().map(|w| 1.0 / w.z.max(1e-12)).collect();
    let radiance = directions
        .iter()
        .zip(&distance)
        .enumerate()
        .map(|(i, (w, t))| {
            if x.y + t * w.y > 0.0 {
                2.0 * noise(i)
            } else {
                0.0
            }
        })
        .collect();
    (frame, directions, distance, radiance)
}

/// Uniform in [0, 1) from a hash of `(seed, i)`.
fn uniform(seed: u64, i: usize) -> f64 {
    let h =
        (seed.wrapping_mul(0x2545_f491_4f6c_dd1d) ^ i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    (h >> 11) as f64 / (1u64 << 53) as f64
}

const BOTH: Hessians = Hessians {
    occlusion_aware: true,
    unaware: true,
    geometric: false,
};

#[test]
fn values_come_from_the_strata_as_traced_and_derivatives_from_the_smoothed_ones() {
    let layout = Layout::new(LayoutKind::CosinePolar, 8, 24, 5).unwrap();
    let x = DVec3::new(0.1, -0.2, 0.0);
    let (frame, directions, distance, radiance) =
        half_ceiling(x, layout, |i| 0.5 + uniform(1, i) as f32);
    let normals = vec![DVec3::NEG_Z; directions.len()];
    let mut traced = TracedGather::new(layout, frame, &directions, &distance, &radiance, 1);
    traced.hit_normals = Some(&normals);
    let smoothing = StrataSmoothing::new(2, 1);
    let smoothed = GatherEvaluation::with_smoothing(&traced, &[1.0], BOTH, smoothing).unwrap();
    let raw = GatherEvaluation::new(&traced, &[1.0], BOTH).unwrap();
    let mut by_hand = radiance.clone();
    smoothing.apply(&layout, &mut by_hand, 1).unwrap();
    let mut traced_by_hand = traced;
    traced_by_hand.input.radiance = &by_hand;
    let of_smoothed = GatherEvaluation::new(&traced_by_hand, &[1.0], BOTH).unwrap();

    assert_eq!(smoothed.smoothing(), smoothing);
    assert_eq!(smoothed.irradiance, raw.irradiance);
    assert_eq!(smoothed.scalar, raw.scalar);
    assert_eq!(smoothed.harmonic_mean_distance, raw.harmonic_mean_distance);
    assert_eq!(smoothed.gradient, of_smoothed.gradient);
    assert_eq!(smoothed.rotation_gradient, of_smoothed.rotation_gradient);
    assert_eq!(smoothed.scalar_gradient, of_smoothed.scalar_gradient);
    assert_eq!(smoothed.occlusion_hessian, of_smoothed.occlusion_hessian);
    assert_eq!(smoothed.unaware_hessian, of_smoothed.unaware_hessian);
    assert_ne!(
        smoothed.gradient, raw.gradient,
        "the smoothing changed nothing"
    );
    assert_ne!(smoothed.occlusion_hessian, raw.occlusion_hessian);
    // off is the plain evaluation, bit for bit
    let off = GatherEvaluation::with_smoothing(&traced, &[1.0], BOTH, StrataSmoothing::OFF);
    assert_eq!(off.unwrap(), raw);
    // and the record's value is the traced strata's
    let record: crate::cache::Record<Vec<f32>> = smoothed
        .record(crate::cache::Extent::isotropic(1.0))
        .unwrap();
    assert_eq!(record.value[0], raw.irradiance[0] as f32);
}

#[test]
fn a_renderers_scalar_radiance_is_smoothed_too() {
    let layout = Layout::new(LayoutKind::Concentric, 12, 12, 9).unwrap();
    let x = DVec3::new(0.0, 0.15, 0.0);
    let (frame, directions, distance, radiance) =
        half_ceiling(x, layout, |i| 0.5 + uniform(2, i) as f32);
    let rgb: Vec<f32> = radiance
        .iter()
        .flat_map(|&l| [l, 0.5 * l, 0.25 * l])
        .collect();
    let mut traced = TracedGather::new(layout, frame, &directions, &distance, &rgb, 3);
    traced.scalar_radiance = Some(&radiance);
    let smoothing = StrataSmoothing::new(1, 2);
    let hessians = Hessians::for_metrics(&[Metric::HessianAnisotropic]);
    let smoothed =
        GatherEvaluation::with_smoothing(&traced, &LUMINANCE_WEIGHTS, hessians, smoothing);
    let mut by_hand = radiance.clone();
    smoothing.apply(&layout, &mut by_hand, 1).unwrap();
    let mut traced_by_hand = traced;
    traced_by_hand.scalar_radiance = Some(&by_hand);
    let of_smoothed = GatherEvaluation::new(&traced_by_hand, &LUMINANCE_WEIGHTS, hessians);
    assert_eq!(
        smoothed.unwrap().occlusion_hessian,
        of_smoothed.unwrap().occlusion_hessian
    );
}

/// Irradiance under the half ceiling at `y` (radiance 2): π L (1 + y / √(1 + y²)) / 2, the
/// form factor of a half-plane; its derivatives along y.
fn exact_along_y(y: f64) -> [f64; 3] {
    let (l, s) = (2.0, (1.0 + y * y).sqrt());
    [
        PI * l * (1.0 + y / s) / 2.0,
        PI * l / (2.0 * s.powi(3)),
        -3.0 * PI * l * y / (2.0 * s.powi(5)),
    ]
}

#[test]
fn smoothed_strata_quiet_a_noisy_gathers_hessian_at_a_small_bias() {
    let y = 0.3;
    let x = DVec3::new(0.0, y, 0.0);
    let [_, de, d2e] = exact_along_y(y);
    let hessians = Hessians::for_metrics(&[Metric::HessianAnisotropic]);
    let smoothings = [StrataSmoothing::OFF, StrataSmoothing::new(2, 1)];
    // [gradient y, Hessian yy] of a gather
    let derivatives = |traced: &TracedGather, smoothing| {
        let ev = GatherEvaluation::with_smoothing(traced, &[1.0], hessians, smoothing).unwrap();
        [ev.gradient[0].y, ev.occlusion_hessian.unwrap().y_axis.y]
    };
    // one shadow ray per stratum towards a light half occluded: radiance 0 or twice its mean
    let shadow_ray = |seed: u64| move |i: usize| if uniform(seed, i) < 0.5 { 0.0 } else { 2.0 };
    let runs = 24;
    let mut noise = [[0.0; 2]; 2]; // [raw, smoothed] × [gradient, Hessian], squared
    let mut bias = [[0.0; 2]; 2];
    for seed in 1..=runs {
        let layout = Layout::new(LayoutKind::CosinePolar, 16, 48, seed).unwrap();
        let (frame, directions, distance, mean) = half_ceiling(x, layout, |_| 1.0);
        let (.., noisy) = half_ceiling(x, layout, shadow_ray(seed));
        let traced = TracedGather::new(layout, frame, &directions, &distance, &mean, 1);
        let mut traced_noisy = traced;
        traced_noisy.input.radiance = &noisy;
        for (k, &smoothing) in smoothings.iter().enumerate() {
            let expected = derivatives(&traced, smoothing);
            let got = derivatives(&traced_noisy, smoothing);
            for (d, exact) in [de, d2e].into_iter().enumerate() {
                noise[k][d] += ((got[d] - expected[d]) / exact).powi(2) / runs as f64;
                bias[k][d] += (expected[d] - exact).abs() / exact.abs() / runs as f64;
            }
        }
    }
    let [raw, smoothed] = noise.map(|n| n.map(f64::sqrt));
    let why = format!("noise: raw {raw:?}, smoothed {smoothed:?}; bias {bias:?}");
    // measured: the Hessian's noise 0.109 -> 0.060 of the exact value, its bias 0.120 -> 0.121
    // (the estimator's own, at 16 x 48 strata); the gradient's noise 0.024 either way (its
    // weights vary slowly from stratum to stratum on this flat ceiling), its bias 0.013 -> 0.004
    assert!(smoothed[1] < 0.7 * raw[1], "{why}");
    assert!(smoothed[0] < 1.01 * raw[0], "{why}");
    for (with, without) in bias[1].iter().zip(bias[0]) {
        assert!(*with < without + 0.01, "{why}");
    }
}
