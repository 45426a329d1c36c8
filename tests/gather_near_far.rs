//! The near/far decomposition at a reach: the open fraction and the near field against closed forms
//! (a point under a ceiling, a point between two planes), the identity `E = E_near + V·F` of one
//! gather split with itself against a direct sum, the limits (nothing open, everything open, a hit
//! exactly at the reach) and every rejected input (nothing written).

#[path = "common/splitmix.rs"]
mod splitmix;

use glam::DVec3;
use raddiff::gather::{
    evaluate, far_field_gather, far_field_radiance, near_field, Frame, GatherInput, Layout,
    LayoutKind, NearField, Wanted,
};
use raddiff::Error;
use splitmix::uniform;

fn frame() -> Frame {
    Frame::new(DVec3::ZERO, DVec3::Z, DVec3::X).unwrap()
}

/// Distances to the planes z = ±h from the origin along each of the layout's directions (a
/// direction parallel to them misses).
fn distances_to_planes(layout: &Layout, h: f64) -> Vec<f64> {
    let dirs = layout.directions(&frame()).unwrap();
    dirs.iter()
        .map(|d| {
            if d.z.abs() > 0.0 {
                h / d.z.abs()
            } else {
                f64::INFINITY
            }
        })
        .collect()
}

/// A point on a floor under a ceiling of radiance `l` at height h: rays closer than the reach ρ
/// are those with cos θ > c = h/ρ, whose cosine-weighted share is 1 − c². So V = c² and
/// E_near = π l (1 − c²); a layout with m rings misses them by at most the one ring that
/// straddles cos θ = c (1/m of the measure).
#[test]
fn under_a_ceiling_the_open_fraction_is_the_closed_form() {
    let (h, l) = (1.0, 2.5f32);
    for kind in [LayoutKind::CosinePolar, LayoutKind::Concentric] {
        for reach in [1.25, 2.0, 4.0, 10.0] {
            let c: f64 = h / reach;
            for m in [16u32, 64] {
                let layout = Layout::new(kind, m, m, 7).unwrap();
                let distance = distances_to_planes(&layout, h);
                let radiance = vec![l; layout.len()];
                let near = near_field(&layout, &distance, &radiance, 1, reach).unwrap();
                let tol = if kind == LayoutKind::CosinePolar {
                    1.0 / m as f64
                } else {
                    // A concentric stratum is not a ring: the boundary circle crosses about 2πr·m/2
                    // of the m² cells, each 1/m² of the measure.
                    4.0 / m as f64
                };
                let v = c * c;
                assert!(
                    (near.open_fraction - v).abs() <= tol,
                    "{kind:?} m={m} reach={reach}: V {} against {v}",
                    near.open_fraction
                );
                let e = std::f64::consts::PI * f64::from(l) * (1.0 - v);
                assert!(
                    (near.irradiance[0] - e).abs() <= std::f64::consts::PI * f64::from(l) * tol,
                    "{kind:?} m={m} reach={reach}: E_near {} against {e}",
                    near.irradiance[0]
                );
            }
        }
    }
}

/// A point in a medium between the planes z = ±h, each of radiance `l`: rays closer than ρ are
/// those with |cos θ| > c = h/ρ, whose solid-angle share is 1 − c. So V = c and the near fluence
/// is 4π l (1 − c); the sphere layout's m rings in cos θ miss by at most the two that straddle.
#[test]
fn between_two_planes_the_sphere_layouts_open_fraction_is_the_closed_form() {
    let (h, l) = (0.5, 1.5f32);
    for reach in [0.6, 1.0, 3.0] {
        let c: f64 = h / reach;
        let m = 64;
        let layout = Layout::new(LayoutKind::Sphere, m, 2 * m, 3).unwrap();
        let distance = distances_to_planes(&layout, h);
        let radiance = vec![l; layout.len()];
        let near = near_field(&layout, &distance, &radiance, 1, reach).unwrap();
        let tol = 2.0 / m as f64;
        assert!(
            (near.open_fraction - c).abs() <= tol,
            "reach={reach}: V {} against {c}",
            near.open_fraction
        );
        let e = 4.0 * std::f64::consts::PI * f64::from(l) * (1.0 - c);
        assert!(
            (near.irradiance[0] - e).abs() <= 4.0 * std::f64::consts::PI * f64::from(l) * tol,
            "reach={reach}: near fluence {} against {e}",
            near.irradiance[0]
        );
    }
}

/// A random gather: hits at distances spread around the reach, some misses, three channels.
fn random_gather(layout: &Layout, reach: f64, seed: u64) -> (Vec<f64>, Vec<f32>) {
    let mut s = seed;
    let distance = (0..layout.len())
        .map(|_| {
            let u = uniform(&mut s);
            if u < 0.15 {
                f64::INFINITY
            } else {
                reach * 4.0 * uniform(&mut s) + 1e-3
            }
        })
        .collect();
    let radiance = (0..3 * layout.len())
        .map(|_| (10.0 * uniform(&mut s)) as f32)
        .collect();
    (distance, radiance)
}

/// The split written out: near sum, open count and far mean per channel, from the definitions.
fn direct_split(distance: &[f64], radiance: &[f32], reach: f64) -> ([f64; 3], usize, [f64; 3]) {
    let (mut near, mut far, mut open) = ([0.0; 3], [0.0; 3], 0);
    for (i, &d) in distance.iter().enumerate() {
        let l = &radiance[3 * i..3 * i + 3];
        if d < reach {
            for c in 0..3 {
                near[c] += f64::from(l[c]);
            }
        } else {
            open += 1;
            for c in 0..3 {
                far[c] += f64::from(l[c]);
            }
        }
    }
    (near, open, far)
}

#[test]
fn one_gather_split_with_itself_gives_back_its_irradiance() {
    let frame = frame();
    for (case, kind) in [
        LayoutKind::CosinePolar,
        LayoutKind::Concentric,
        LayoutKind::Sphere,
    ]
    .into_iter()
    .enumerate()
    {
        for seed in 0..20u64 {
            let layout = Layout::new(kind, 12, 20, seed + 1).unwrap();
            let reach = 0.5 + seed as f64;
            let (distance, radiance) = random_gather(&layout, reach, 100 * case as u64 + seed);
            let directions = layout.directions(&frame).unwrap();
            let input = |radiance: &[f32]| {
                let gather = GatherInput {
                    directions: &directions,
                    distance: &distance,
                    radiance,
                    channels: 3,
                    sigma_t: 0.0,
                    media: None,
                };
                evaluate(&layout, &frame, &gather, Wanted::ALL).unwrap()
            };
            let whole = input(&radiance).irradiance;

            let near = near_field(&layout, &distance, &radiance, 3, reach).unwrap();
            let mut far_radiance = radiance.clone();
            let open = far_field_radiance(&layout, &distance, &mut far_radiance, 3, reach).unwrap();
            let far = input(&far_radiance).irradiance;

            let (near_sum, open_count, far_sum) = direct_split(&distance, &radiance, reach);
            let n = layout.len() as f64;
            let w = kind.measure() / n;
            assert_eq!(open, open_count as f64 / n, "{kind:?} seed {seed}");
            assert_eq!(near.open_fraction, open);
            for c in 0..3 {
                assert!((near.irradiance[c] - w * near_sum[c]).abs() <= 1e-12 * w * near_sum[c]);
                // The far field is the mean far radiance times the measure (f32 mean).
                let f = kind.measure() * far_sum[c] / open_count as f64;
                assert!(
                    (far[c] - f).abs() <= 1e-6 * f,
                    "{kind:?} seed {seed}: {} {f}",
                    far[c]
                );
            }
            let composed = near.irradiance_with(&far).unwrap();
            for c in 0..3 {
                assert!(
                    (composed[c] - whole[c]).abs() <= 1e-6 * whole[c],
                    "{kind:?} seed {seed} channel {c}: {} against {}",
                    composed[c],
                    whole[c]
                );
            }
            // Open directions keep their radiance; near ones carry the far mean.
            for (i, &d) in distance.iter().enumerate() {
                for c in 0..3 {
                    let want = if d >= reach {
                        radiance[3 * i + c]
                    } else {
                        (far_sum[c] / open_count as f64) as f32
                    };
                    assert_eq!(far_radiance[3 * i + c], want);
                }
            }
        }
    }
}

#[test]
fn limits_nothing_open_everything_open_and_a_hit_at_the_reach() {
    let layout = Layout::new(LayoutKind::CosinePolar, 4, 8, 0).unwrap();
    let radiance: Vec<f32> = (0..layout.len()).map(|i| i as f32).collect();

    // Every hit closer than the reach: the far field is zero, and so is V.
    let closed = vec![0.5; layout.len()];
    let mut far = radiance.clone();
    assert_eq!(
        far_field_radiance(&layout, &closed, &mut far, 1, 1.0).unwrap(),
        0.0
    );
    assert!(far.iter().all(|&v| v == 0.0));
    let near = near_field(&layout, &closed, &radiance, 1, 1.0).unwrap();
    let sum: f64 = radiance.iter().map(|&v| f64::from(v)).sum();
    assert_eq!(near.open_fraction, 0.0);
    assert!((near.irradiance[0] - std::f64::consts::PI * sum / 32.0).abs() < 1e-12);
    // With V = 0 the far field does not matter.
    assert_eq!(near.irradiance_with(&[1e300]).unwrap(), near.irradiance);

    // Every ray reaching (misses and far hits): nothing changes, V = 1, no near field.
    let open: Vec<f64> = (0..layout.len())
        .map(|i| if i % 2 == 0 { f64::INFINITY } else { 3.0 })
        .collect();
    let mut far = radiance.clone();
    assert_eq!(
        far_field_radiance(&layout, &open, &mut far, 1, 2.0).unwrap(),
        1.0
    );
    assert_eq!(far, radiance);
    let near = near_field(&layout, &open, &radiance, 1, 2.0).unwrap();
    assert_eq!(
        near,
        NearField {
            irradiance: vec![0.0],
            open_fraction: 1.0
        }
    );

    // A hit exactly at the reach counts as open; the smallest distance below it as near.
    let mut at = vec![f64::INFINITY; layout.len()];
    at[0] = 2.0;
    at[1] = 2.0f64.next_down();
    let near = near_field(&layout, &at, &radiance, 1, 2.0).unwrap();
    assert_eq!(near.open_fraction, 31.0 / 32.0);
    assert_eq!(near.irradiance[0], std::f64::consts::PI * 1.0 / 32.0);

    // Tiny and huge scales: only the ratio of distance to reach matters.
    for scale in [1e-200, 1e-8, 1e8, 1e200] {
        let d: Vec<f64> = open.iter().map(|&d| d * scale).collect();
        let mixed: Vec<f64> = d
            .iter()
            .enumerate()
            .map(|(i, &v)| if i % 3 == 0 { 0.5 * scale } else { v })
            .collect();
        let near = near_field(&layout, &mixed, &radiance, 1, 2.0 * scale).unwrap();
        let reference = near_field(
            &layout,
            &mixed.iter().map(|&v| v / scale).collect::<Vec<_>>(),
            &radiance,
            1,
            2.0,
        )
        .unwrap();
        assert_eq!(near, reference, "scale {scale}");
        assert!(near.irradiance[0].is_finite());
    }
}

#[test]
fn huge_radiance_stays_finite_and_an_overflowing_composition_is_degenerate() {
    let layout = Layout::new(LayoutKind::CosinePolar, 8, 8, 0).unwrap();
    let radiance = vec![f32::MAX; layout.len()];
    let distance: Vec<f64> = (0..layout.len())
        .map(|i| if i % 2 == 0 { 1.0 } else { f64::INFINITY })
        .collect();
    let near = near_field(&layout, &distance, &radiance, 1, 2.0).unwrap();
    assert!(near.irradiance[0].is_finite() && near.irradiance[0] > 0.0);
    let mut far = radiance.clone();
    far_field_radiance(&layout, &distance, &mut far, 1, 2.0).unwrap();
    assert!(far.iter().all(|&v| v == f32::MAX));
    // Measured near fields cannot overflow with any finite far field (V < 1 when a hit is near);
    // a near field built by hand can.
    assert!(near.irradiance_with(&[f64::MAX]).unwrap()[0].is_finite());
    let built = NearField {
        irradiance: vec![f64::MAX],
        open_fraction: 1.0,
    };
    assert!(matches!(
        built.irradiance_with(&[f64::MAX]),
        Err(Error::Degenerate(_))
    ));
}

#[test]
fn rejected_inputs_write_nothing() {
    let layout = Layout::new(LayoutKind::CosinePolar, 4, 4, 0).unwrap();
    let good_d = vec![1.0; 16];
    let good_l = vec![1.0f32; 16];
    let invalid = |r: Result<f64, Error>| matches!(r, Err(Error::InvalidArgument(_)));
    // What is wrong, distances, radiance, channels, reach.
    type Case = (&'static str, Vec<f64>, Vec<f32>, usize, f64);
    let cases: Vec<Case> = vec![
        ("reach 0", good_d.clone(), good_l.clone(), 1, 0.0),
        ("negative reach", good_d.clone(), good_l.clone(), 1, -1.0),
        ("NaN reach", good_d.clone(), good_l.clone(), 1, f64::NAN),
        (
            "infinite reach",
            good_d.clone(),
            good_l.clone(),
            1,
            f64::INFINITY,
        ),
        ("no channels", good_d.clone(), vec![], 0, 1.0),
        ("short radiance", good_d.clone(), vec![1.0; 15], 1, 1.0),
        ("short distance", vec![1.0; 15], good_l.clone(), 1, 1.0),
        (
            "zero distance",
            [vec![0.0], vec![1.0; 15]].concat(),
            good_l.clone(),
            1,
            1.0,
        ),
        (
            "NaN distance",
            [vec![1.0; 15], vec![f64::NAN]].concat(),
            good_l.clone(),
            1,
            1.0,
        ),
        (
            "NaN radiance",
            good_d.clone(),
            [vec![1.0; 15], vec![f32::NAN]].concat(),
            1,
            1.0,
        ),
        (
            "infinite radiance",
            good_d.clone(),
            [vec![f32::INFINITY], vec![1.0; 15]].concat(),
            1,
            1.0,
        ),
    ];
    for (what, d, l, ch, reach) in cases {
        let mut changed = l.clone();
        assert!(
            invalid(far_field_radiance(&layout, &d, &mut changed, ch, reach)),
            "{what}"
        );
        assert!(
            changed
                .iter()
                .zip(&l)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{what}: radiance written on failure"
        );
        assert!(
            invalid(near_field(&layout, &d, &l, ch, reach).map(|n| n.open_fraction)),
            "{what}"
        );
    }
    let bad_layout = Layout { m: 0, ..layout };
    assert!(invalid(
        near_field(&bad_layout, &[], &[], 1, 1.0).map(|n| n.open_fraction)
    ));
    let near = near_field(&layout, &good_d, &good_l, 1, 2.0).unwrap();
    assert!(matches!(
        near.irradiance_with(&[1.0, 2.0]),
        Err(Error::InvalidArgument(_))
    ));
    assert!(matches!(
        near.irradiance_with(&[f64::NAN]),
        Err(Error::InvalidArgument(_))
    ));
}

/// The far-field gather with distances: the radiance as `far_field_radiance` gives it, near hits at
/// the reach, far hits and misses where they were; its evaluation is the same far field (no
/// medium); nothing changes on failure.
#[test]
fn the_far_field_gather_moves_near_hits_to_the_reach() {
    let frame = frame();
    let layout = Layout::new(LayoutKind::CosinePolar, 12, 20, 9).unwrap();
    let reach = 2.0;
    let (distance, radiance) = random_gather(&layout, reach, 77);
    let mut moved = distance.clone();
    let mut moved_radiance = radiance.clone();
    let open = far_field_gather(&layout, &mut moved, &mut moved_radiance, 3, reach).unwrap();
    let mut kept_radiance = radiance.clone();
    assert_eq!(
        open,
        far_field_radiance(&layout, &distance, &mut kept_radiance, 3, reach).unwrap()
    );
    assert_eq!(moved_radiance, kept_radiance);
    for (&before, &after) in distance.iter().zip(&moved) {
        if before < reach {
            assert_eq!(after, reach);
        } else {
            assert_eq!(after.to_bits(), before.to_bits());
        }
    }
    let directions = layout.directions(&frame).unwrap();
    let value = |distance: &[f64], radiance: &[f32]| {
        let input = GatherInput {
            directions: &directions,
            distance,
            radiance,
            channels: 3,
            sigma_t: 0.0,
            media: None,
        };
        evaluate(&layout, &frame, &input, Wanted::ALL).unwrap()
    };
    let (a, b) = (
        value(&moved, &moved_radiance),
        value(&distance, &kept_radiance),
    );
    assert_eq!(a.irradiance, b.irradiance);
    // Its smallest distance is the reach: the near geometry is gone from its derivatives.
    assert_eq!(a.min_distance, Some(reach));

    let mut bad = distance.clone();
    bad[5] = f64::NAN;
    let (before_d, before_l) = (bad.clone(), radiance.clone());
    let mut l = radiance.clone();
    assert!(far_field_gather(&layout, &mut bad, &mut l, 3, reach).is_err());
    assert!(bad
        .iter()
        .zip(&before_d)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    assert_eq!(l, before_l);
    let mut d = distance.clone();
    assert!(far_field_gather(&layout, &mut d, &mut l, 3, -1.0).is_err());
    assert_eq!(d, distance);
}
