use std::f64::consts::TAU;

use super::*;

fn layout(kind: LayoutKind, m: u32, n: u32) -> Layout {
    Layout::new(kind, m, n, 0).unwrap()
}

const KINDS: [LayoutKind; 3] = [
    LayoutKind::CosinePolar,
    LayoutKind::Concentric,
    LayoutKind::Sphere,
];

/// Deterministic values in [0, 1) (a multiplicative hash), like a noisy gather's.
fn noisy(len: usize) -> Vec<f32> {
    (0..len)
        .map(|i| {
            ((i as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect()
}

#[test]
fn constant_values_stay_bit_identical() {
    for kind in KINDS {
        let l = layout(kind, 5, 7);
        let mut v = vec![0.3f32; l.len() * 2];
        StrataSmoothing::new(3, 2).apply(&l, &mut v, 2).unwrap();
        assert!(v.iter().all(|&x| x == 0.3f32), "{kind:?}");
    }
}

#[test]
fn off_leaves_the_values_as_they_were() {
    let l = layout(LayoutKind::CosinePolar, 4, 8);
    let original = noisy(l.len());
    let mut v = original.clone();
    StrataSmoothing::OFF.apply(&l, &mut v, 1).unwrap();
    assert_eq!(v, original);
}

#[test]
fn azimuthal_passes_keep_every_rings_sum_on_polar_layouts() {
    for kind in [LayoutKind::CosinePolar, LayoutKind::Sphere] {
        let l = layout(kind, 6, 12);
        let original = noisy(l.len());
        let mut v = original.clone();
        StrataSmoothing::new(3, 0).apply(&l, &mut v, 1).unwrap();
        assert_ne!(v, original);
        for j in 0..6 {
            let ring = |x: &[f32]| {
                x[j * 12..(j + 1) * 12]
                    .iter()
                    .map(|&a| a as f64)
                    .sum::<f64>()
            };
            assert!(
                (ring(&v) - ring(&original)).abs() < 1e-6,
                "{kind:?} ring {j}"
            );
        }
    }
}

#[test]
fn every_pass_keeps_the_total_on_every_layout() {
    for kind in KINDS {
        let l = layout(kind, 7, 9);
        let original = noisy(l.len() * 3);
        let mut v = original.clone();
        StrataSmoothing::new(2, 3).apply(&l, &mut v, 3).unwrap();
        for c in 0..3 {
            let total = |x: &[f32]| x.iter().skip(c).step_by(3).map(|&a| a as f64).sum::<f64>();
            assert!(
                (total(&v) - total(&original)).abs() < 1e-5,
                "{kind:?} channel {c}: {} against {}",
                total(&v),
                total(&original)
            );
        }
    }
}

#[test]
fn one_azimuthal_pass_scales_a_rings_harmonic_by_cos_squared() {
    let n = 16;
    let l = layout(LayoutKind::CosinePolar, 2, n);
    for p in 1..=4u32 {
        let phase = |k: usize| TAU * p as f64 * k as f64 / n as f64;
        let mut v: Vec<f32> = (0..2 * n as usize)
            .map(|i| (1.0 + 0.5 * phase(i % n as usize).cos()) as f32)
            .collect();
        StrataSmoothing::new(1, 0).apply(&l, &mut v, 1).unwrap();
        let gain = (std::f64::consts::PI * p as f64 / n as f64).cos().powi(2);
        for (i, &x) in v.iter().enumerate() {
            let want = 1.0 + 0.5 * gain * phase(i % n as usize).cos();
            assert!(
                (x as f64 - want).abs() < 1e-6,
                "p {p}, stratum {i}: {x} against {want}"
            );
        }
    }
}

#[test]
fn rings_wrap_on_polar_layouts_and_not_on_the_concentric_square() {
    for kind in KINDS {
        let (m, n) = (3usize, 8usize);
        let l = layout(kind, m as u32, n as u32);
        let mut v = vec![0.0f32; m * n];
        v[n] = 1.0; // (j, k) = (1, 0)
        StrataSmoothing::new(1, 0).apply(&l, &mut v, 1).unwrap();
        let wraps = kind != LayoutKind::Concentric;
        assert_eq!(v[n + 1], 0.25, "{kind:?}");
        assert_eq!(v[n + n - 1], if wraps { 0.25 } else { 0.0 }, "{kind:?}");
        assert_eq!(v[n], if wraps { 0.5 } else { 0.75 }, "{kind:?}");
        assert!(v[..n].iter().chain(&v[2 * n..]).all(|&x| x == 0.0));
    }
}

#[test]
fn polar_passes_repeat_the_first_and_last_rings() {
    let (m, n) = (4usize, 5usize);
    let l = layout(LayoutKind::CosinePolar, m as u32, n as u32);
    let mut v = vec![0.0f32; m * n];
    v[2] = 1.0; // (0, 2)
    v[(m - 1) * n + 4] = 2.0; // (3, 4)
    StrataSmoothing::new(0, 1).apply(&l, &mut v, 1).unwrap();
    assert_eq!((v[2], v[n + 2]), (0.75, 0.25));
    assert_eq!((v[(m - 1) * n + 4], v[(m - 2) * n + 4]), (1.5, 0.5));
    assert_eq!(v.iter().filter(|&&x| x != 0.0).count(), 4);
}

#[test]
fn channels_are_filtered_apart() {
    let l = layout(LayoutKind::Concentric, 3, 3);
    let mut v = vec![0.0f32; 9 * 2];
    for s in 0..9 {
        v[2 * s + 1] = 4.0;
    }
    v[2 * 4] = 1.0; // the centre cell, channel 0
    StrataSmoothing::new(1, 1).apply(&l, &mut v, 2).unwrap();
    assert!(v.iter().skip(1).step_by(2).all(|&x| x == 4.0));
    // [1 2 1] / 4 along each axis: the outer product
    let want = [1.0, 2.0, 1.0, 2.0, 4.0, 2.0, 1.0, 2.0, 1.0].map(|w: f32| w / 16.0);
    for s in 0..9 {
        assert_eq!(v[2 * s], want[s], "cell {s}");
    }
}

#[test]
fn extreme_values_stay_finite_and_within_the_inputs_range() {
    let l = layout(LayoutKind::CosinePolar, 3, 6);
    let mut v: Vec<f32> = (0..18)
        .map(|i| if i % 2 == 0 { f32::MAX } else { -f32::MAX })
        .collect();
    v[5] = f32::MIN_POSITIVE;
    StrataSmoothing::new(5, 5).apply(&l, &mut v, 1).unwrap();
    assert!(v.iter().all(|x| x.is_finite() && x.abs() <= f32::MAX));
    let mut tiny = vec![f32::from_bits(1); 18];
    tiny[0] = 0.0;
    StrataSmoothing::new(2, 2).apply(&l, &mut tiny, 1).unwrap();
    assert!(tiny.iter().all(|&x| (0.0..=f32::from_bits(1)).contains(&x)));
}

#[test]
fn bad_counts_and_sizes_are_refused() {
    let l = layout(LayoutKind::CosinePolar, 2, 6);
    let mut v = vec![0.0f32; 12];
    let too_many = StrataSmoothing::MAX_PASSES + 1;
    assert!(StrataSmoothing::new(too_many, 0)
        .apply(&l, &mut v, 1)
        .is_err());
    assert!(StrataSmoothing::new(0, too_many).validate().is_err());
    assert!(StrataSmoothing::new(64, 64).validate().is_ok());
    assert!(StrataSmoothing::new(1, 0).apply(&l, &mut v, 0).is_err());
    assert!(StrataSmoothing::new(1, 0).apply(&l, &mut v, 2).is_err());
    assert!(StrataSmoothing::new(1, 0)
        .apply(&l, &mut v[..11], 1)
        .is_err());
}

#[test]
fn lines_of_one_and_two_strata() {
    for kind in KINDS {
        let l = layout(kind, 1, 1);
        let mut v = vec![3.0f32, 5.0];
        StrataSmoothing::new(2, 2).apply(&l, &mut v, 2).unwrap();
        assert_eq!(v, [3.0, 5.0], "{kind:?}");
        let l = layout(kind, 2, 2);
        let mut v = vec![1.0f32, 0.0, 0.0, 0.0];
        StrataSmoothing::new(1, 0).apply(&l, &mut v, 1).unwrap();
        let want = if kind == LayoutKind::Concentric {
            [0.75, 0.25, 0.0, 0.0]
        } else {
            [0.5, 0.5, 0.0, 0.0]
        };
        assert_eq!(v, want, "{kind:?}");
        StrataSmoothing::new(0, 1).apply(&l, &mut v, 1).unwrap();
        assert_eq!(v[..2], want.map(|x| 0.75 * x)[..2], "{kind:?}");
        assert_eq!(v[2..], want.map(|x| 0.25 * x)[..2], "{kind:?}");
    }
}
