//! The gather API: sphere (fluence) convergence, the concentric layout, output selection, channels,
//! and every rejected input (status + message, no panic, nothing computed).

#[path = "gather_support/mod.rs"]
mod support;

use glam::DVec3;
use raddiff::gather::{
    evaluate, Frame, GatherInput, Layout, LayoutKind, MediaRadiance, ValidGather, Wanted,
};
use raddiff::Error;
use support::*;

#[test]
fn sphere_fluence_in_an_absorbing_emissive_medium_converges() {
    let mut scene = Scene::new(vec![emitter(), occluder_a()]);
    scene.sigma = 0.4;
    scene.media = Media::Constant(0.3);
    scene.steps = 120;
    scene.step = 0.05;
    let frame = Frame::new(DVec3::new(0.05, -0.1, 0.2), DVec3::Z, DVec3::X).unwrap();
    let x = frame.position;
    let f_ref = scene.fluence(x);
    let g_ref = scene.fluence_gradient(x);
    println!("fluence {f_ref:.9}, gradient {g_ref:.6}");
    let ms = [8, 16, 32, 64];
    let mut errs = Vec::new();
    for &m in &ms {
        let layout = Layout::new(LayoutKind::Sphere, m, 2 * m, 0).unwrap();
        let v = scene.gather(&layout, &frame, true);
        let fe = (v.irradiance[0] - f_ref).abs() / f_ref;
        let ge = (v.gradient[0] - g_ref).length() / g_ref.length();
        println!(
            "  M={m:3}: fluence error {fe:.2e}, gradient error {ge:.2e} ({:.5})",
            v.gradient[0]
        );
        assert_eq!(v.rotation_gradient[0], DVec3::ZERO);
        errs.push((fe, ge));
    }
    println!(
        "  gradient rate {:.2}",
        rate(&ms, &errs.iter().map(|e| e.1).collect::<Vec<_>>())
    );
    assert!(errs[3].0 < 1e-2 && errs[3].1 < 3e-2, "{errs:?}");
    assert!(errs[3].1 < errs[0].1 / 3.0);
}

#[test]
fn concentric_layout_gradients_converge() {
    let mut scene = Scene::new(vec![emitter(), occluder_a(), occluder_b()]);
    scene.env = 0.05;
    let frame = plane_frame(0.05, -0.1);
    let x = frame.position;
    let e_ref = scene.irradiance(x, DVec3::Z);
    let g_ref = scene.irradiance_gradient(x, DVec3::Z);
    let polar_v = scene.gather(&polar(64, 0), &frame, true);
    let ms = [12, 24, 48, 96];
    let mut errs = Vec::new();
    for &m in &ms {
        let layout = Layout::new(LayoutKind::Concentric, m, m, 0).unwrap();
        let v = scene.gather(&layout, &frame, true);
        let e_err = (v.irradiance[0] - e_ref).abs() / e_ref;
        let g_err = (v.gradient[0] - g_ref).length() / g_ref.length();
        let r_err = (v.rotation_gradient[0] - polar_v.rotation_gradient[0]).length()
            / polar_v.rotation_gradient[0].length();
        println!(
            "concentric {m}x{m}: irradiance {e_err:.2e}, gradient {g_err:.2e} ({:.5}), rotation vs polar 64x128 {r_err:.2e}",
            v.gradient[0]
        );
        errs.push((e_err, g_err, r_err));
    }
    let g: Vec<f64> = errs.iter().map(|e| e.1).collect();
    println!("  gradient rate {:.2}", rate(&ms, &g));
    assert!(
        errs[3].0 < 1e-2 && errs[3].1 < 3e-2 && errs[3].2 < 5e-2,
        "{errs:?}"
    );
    assert!(g[3] < g[0] / 3.0);
}

/// A small valid gather over a uniform sky with one hit, for the API tests.
struct Small {
    layout: Layout,
    frame: Frame,
    dirs: Vec<DVec3>,
    dist: Vec<f64>,
    rad: Vec<f32>,
    media: Vec<f32>,
    media_grad: Vec<f32>,
}

const CH: usize = 3;
const STEPS: usize = 4;

impl Small {
    fn new(kind: LayoutKind) -> Small {
        let layout = Layout::new(kind, 4, 6, 17).unwrap();
        let n = DVec3::new(0.2, 0.3, 0.9).normalize();
        let frame = Frame::new(DVec3::new(1.0, 2.0, 3.0), n, n.any_orthonormal_vector()).unwrap();
        let dirs = layout.directions(&frame).unwrap();
        let cells = layout.len();
        let dist = (0..cells)
            .map(|i| {
                if i % 5 == 0 {
                    f64::INFINITY
                } else {
                    0.5 + (i % 7) as f64 * 0.3
                }
            })
            .collect();
        let rad = (0..cells * CH)
            .map(|i| ((i * 37) % 11) as f32 * 0.1)
            .collect();
        let media = (0..cells * STEPS * CH)
            .map(|i| ((i * 13) % 5) as f32 * 0.05)
            .collect();
        let media_grad = (0..cells * STEPS * CH * 3)
            .map(|i| ((i * 7) % 9) as f32 * 0.01 - 0.04)
            .collect();
        Small {
            layout,
            frame,
            dirs,
            dist,
            rad,
            media,
            media_grad,
        }
    }

    fn input(&self) -> GatherInput<'_> {
        GatherInput {
            directions: &self.dirs,
            distance: &self.dist,
            radiance: &self.rad,
            channels: CH,
            sigma_t: 0.3,
            media: Some(MediaRadiance {
                radiance: &self.media,
                gradient: Some(&self.media_grad),
                steps: STEPS,
                step: 0.4,
            }),
        }
    }
}

#[test]
fn requested_outputs_match_the_full_evaluation_and_skipped_ones_are_empty() {
    for kind in [LayoutKind::CosinePolar, LayoutKind::Sphere] {
        let s = Small::new(kind);
        let all = evaluate(&s.layout, &s.frame, &s.input(), Wanted::ALL).unwrap();
        assert_eq!(all.irradiance.len(), CH);
        let only_e = evaluate(&s.layout, &s.frame, &s.input(), Wanted::IRRADIANCE).unwrap();
        assert_eq!(only_e.irradiance, all.irradiance);
        assert!(only_e.gradient.is_empty() && only_e.rotation_gradient.is_empty());
        assert!(only_e.harmonic_mean_distance.is_none());
        let valid = ValidGather::new(&s.layout, &s.frame, &s.input()).unwrap();
        let g = valid
            .evaluate(Wanted {
                gradient: true,
                ..Wanted::default()
            })
            .unwrap();
        assert_eq!(g.gradient, all.gradient);
        assert!(g.irradiance.is_empty());
        let r = valid
            .evaluate(Wanted {
                rotation_gradient: true,
                ..Wanted::default()
            })
            .unwrap();
        assert_eq!(r.rotation_gradient, all.rotation_gradient);
        let finite: Vec<f64> = s.dist.iter().copied().filter(|d| d.is_finite()).collect();
        let harmonic = s.layout.len() as f64 / finite.iter().map(|d| 1.0 / d).sum::<f64>();
        assert!((all.harmonic_mean_distance.unwrap() - harmonic).abs() < 1e-12);
        assert_eq!(all.min_distance, Some(0.5));
    }
}

#[test]
fn channels_are_independent() {
    let s = Small::new(LayoutKind::CosinePolar);
    let all = evaluate(&s.layout, &s.frame, &s.input(), Wanted::ALL).unwrap();
    for c in 0..CH {
        let rad: Vec<f32> = s.rad.iter().skip(c).step_by(CH).copied().collect();
        let media: Vec<f32> = s.media.iter().skip(c).step_by(CH).copied().collect();
        let grad: Vec<f32> = s
            .media_grad
            .chunks(3)
            .skip(c)
            .step_by(CH)
            .flatten()
            .copied()
            .collect();
        let mut input = s.input();
        input.channels = 1;
        input.radiance = &rad;
        input.media = Some(MediaRadiance {
            radiance: &media,
            gradient: Some(&grad),
            steps: STEPS,
            step: 0.4,
        });
        let one = evaluate(&s.layout, &s.frame, &input, Wanted::ALL).unwrap();
        assert!((one.irradiance[0] - all.irradiance[c]).abs() < 1e-12);
        assert!((one.gradient[0] - all.gradient[c]).length() < 1e-12);
        assert!((one.rotation_gradient[0] - all.rotation_gradient[c]).length() < 1e-12);
    }
}

#[test]
fn uniform_environment_has_zero_gradients_and_infinite_distances() {
    for kind in [LayoutKind::CosinePolar, LayoutKind::Sphere] {
        let layout = Layout::new(kind, 6, 9, 3).unwrap();
        let frame = plane_frame(0.0, 0.0);
        let dirs = layout.directions(&frame).unwrap();
        let dist = vec![f64::INFINITY; layout.len()];
        let rad = vec![2.0f32; layout.len()];
        let input = GatherInput {
            directions: &dirs,
            distance: &dist,
            radiance: &rad,
            channels: 1,
            sigma_t: 0.0,
            media: None,
        };
        let v = evaluate(&layout, &frame, &input, Wanted::ALL).unwrap();
        let sr = if kind == LayoutKind::Sphere { 4.0 } else { 1.0 } * std::f64::consts::PI;
        assert!((v.irradiance[0] - 2.0 * sr).abs() < 1e-12);
        assert_eq!(v.gradient[0], DVec3::ZERO);
        assert!(v.rotation_gradient[0].length() < 1e-12);
        assert_eq!(v.harmonic_mean_distance, Some(f64::INFINITY));
        assert_eq!(v.min_distance, Some(f64::INFINITY));
    }
}

fn expect_invalid(s: &Small, input: &GatherInput<'_>, fragment: &str) {
    match evaluate(&s.layout, &s.frame, input, Wanted::ALL) {
        Err(Error::InvalidArgument(m)) => assert!(m.contains(fragment), "{m:?} lacks {fragment:?}"),
        other => panic!("expected InvalidArgument({fragment}), got {other:?}"),
    }
}

#[test]
fn bad_inputs_are_rejected_with_a_message() {
    let s = Small::new(LayoutKind::CosinePolar);
    assert!(evaluate(&s.layout, &s.frame, &s.input(), Wanted::ALL).is_ok());
    let mut i = s.input();
    i.directions = &s.dirs[1..];
    expect_invalid(&s, &i, "directions holds");
    let mut i = s.input();
    i.distance = &s.dist[1..];
    expect_invalid(&s, &i, "distance holds");
    let mut i = s.input();
    i.radiance = &s.rad[1..];
    expect_invalid(&s, &i, "radiance holds");
    let mut i = s.input();
    i.channels = 0;
    expect_invalid(&s, &i, "channels");
    let mut i = s.input();
    i.sigma_t = -1.0;
    expect_invalid(&s, &i, "sigma_t");
    i.sigma_t = f64::NAN;
    expect_invalid(&s, &i, "sigma_t");

    let mut dist = s.dist.clone();
    for bad in [-1.0, 0.0, f64::NAN, f64::NEG_INFINITY] {
        dist[3] = bad;
        let mut i = s.input();
        i.distance = &dist;
        expect_invalid(&s, &i, "distance[3]");
    }
    let mut rad = s.rad.clone();
    rad[5] = f32::NAN;
    let mut i = s.input();
    i.radiance = &rad;
    expect_invalid(&s, &i, "radiance[5]");

    let mut dirs = s.dirs.clone();
    dirs[2] *= 1.01;
    let mut i = s.input();
    i.directions = &dirs;
    expect_invalid(&s, &i, "not unit");
    // swapped index order: a direction from another stratum
    let mut dirs = s.dirs.clone();
    dirs.swap(1, 6);
    let mut i = s.input();
    i.directions = &dirs;
    expect_invalid(&s, &i, "stratum");
    let mut dirs = s.dirs.clone();
    dirs.swap(0, 1);
    let mut i = s.input();
    i.directions = &dirs;
    expect_invalid(&s, &i, "azimuth");

    let media = s.media.clone();
    let mut i = s.input();
    i.media = Some(MediaRadiance {
        radiance: &media[1..],
        gradient: None,
        steps: STEPS,
        step: 0.4,
    });
    expect_invalid(&s, &i, "media_radiance holds");
    i.media = Some(MediaRadiance {
        radiance: &media,
        gradient: Some(&s.media_grad[1..]),
        steps: STEPS,
        step: 0.4,
    });
    expect_invalid(&s, &i, "media_radiance_gradient holds");
    for (steps, step) in [
        (0, 0.4),
        (STEPS, 0.0),
        (STEPS, -1.0),
        (STEPS, f64::INFINITY),
    ] {
        i.media = Some(MediaRadiance {
            radiance: &media,
            gradient: None,
            steps,
            step,
        });
        expect_invalid(&s, &i, "step");
    }
    let mut media = s.media.clone();
    media[9] = f32::INFINITY;
    i.media = Some(MediaRadiance {
        radiance: &media,
        gradient: None,
        steps: STEPS,
        step: 0.4,
    });
    expect_invalid(&s, &i, "media_radiance[9]");

    // frames and layouts
    let bad_frame = Frame {
        tangent: s.frame.normal,
        ..s.frame
    };
    assert!(
        matches!(evaluate(&s.layout, &bad_frame, &s.input(), Wanted::ALL), Err(Error::InvalidArgument(m)) if m.contains("perpendicular"))
    );
    let bad_layout = Layout { m: 0, ..s.layout };
    assert!(evaluate(&bad_layout, &s.frame, &s.input(), Wanted::ALL).is_err());
    let big = Layout {
        m: 70000,
        ..s.layout
    };
    assert!(evaluate(&big, &s.frame, &s.input(), Wanted::ALL).is_err());
}

#[test]
fn overflowing_results_are_degenerate_not_infinite() {
    let s = Small::new(LayoutKind::CosinePolar);
    let dist = vec![1e-310; s.layout.len()];
    let mut rad = s.rad.clone();
    rad[0] = 3.0e38;
    let mut i = s.input();
    i.distance = &dist;
    i.radiance = &rad;
    i.sigma_t = 0.0;
    i.media = None;
    // irradiance alone is fine; the 1/r wall terms overflow
    assert!(evaluate(&s.layout, &s.frame, &i, Wanted::IRRADIANCE).is_ok());
    assert!(matches!(
        evaluate(&s.layout, &s.frame, &i, Wanted::ALL),
        Err(Error::Degenerate(_))
    ));
}

#[test]
fn jittered_evaluation_is_deterministic() {
    let s = Small::new(LayoutKind::CosinePolar);
    let a = evaluate(&s.layout, &s.frame, &s.input(), Wanted::ALL).unwrap();
    let s2 = Small::new(LayoutKind::CosinePolar);
    let b = evaluate(&s2.layout, &s2.frame, &s2.input(), Wanted::ALL).unwrap();
    assert_eq!(a, b);
}
