//! The irradiance layer against hand-computed radii, against the gather functions it calls, and
//! the one-call path against its own pieces.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{DMat3, DVec3};

use super::*;
use crate::cache::{Cache, Extent, LeakGuard};
use crate::gather::hessian::{occlusion_derivatives, HemisphereGather, Topology};
use crate::gather::radii::{surface_radii_floored, tangent_basis, CurvatureFloor, ErrorMode};
use crate::gather::{evaluate, Frame, Layout, LayoutKind, Wanted};
use crate::{Error, Order};

/// A ceiling at height 1 above the plane z = 0 of the point traced from, radiance `(2, 1, 0.5)`
/// where y > 0 and black elsewhere: a penumbra along the x axis.
fn half_ceiling(origin: DVec3, directions: &[DVec3], distance: &mut [f64], radiance: &mut [f32]) {
    for (i, w) in directions.iter().enumerate() {
        let t = (1.0 - origin.z) / w.z.max(1e-12);
        distance[i] = t;
        let lit = origin.y + t * w.y > 0.0;
        let l = if lit { [2.0, 1.0, 0.5] } else { [0.0; 3] };
        radiance[3 * i..3 * i + 3].copy_from_slice(&l);
    }
}

fn traced_at(x: DVec3, seed: u64) -> (Layout, Frame, Vec<DVec3>, Vec<f64>, Vec<f32>) {
    let layout = Layout::new(LayoutKind::CosinePolar, 8, 24, seed).unwrap();
    let frame = Frame::new(x, DVec3::Z, DVec3::X).unwrap();
    let directions = layout.directions(&frame).unwrap();
    let mut distance = vec![0.0; directions.len()];
    let mut radiance = vec![0.0f32; 3 * directions.len()];
    half_ceiling(x, &directions, &mut distance, &mut radiance);
    (layout, frame, directions, distance, radiance)
}

fn small_settings() -> IrradianceSettings {
    let mut s = IrradianceSettings::new(3);
    s.gather_m = 8;
    s.gather_n = 24;
    s.radius_bounds = RadiusBounds::world(0.01, 2.0);
    s
}

/// An evaluation with the given scalar summary (one channel), for the metrics' formulas.
fn summary(scalar: f64, gradient: DVec3, distance: f64, hessian: DMat3) -> GatherEvaluation {
    GatherEvaluation {
        position: DVec3::new(1.0, 2.0, 3.0),
        normal: DVec3::Z,
        irradiance: vec![scalar],
        gradient: vec![gradient],
        rotation_gradient: vec![DVec3::ZERO],
        scalar,
        scalar_gradient: gradient,
        harmonic_mean_distance: distance,
        occlusion_hessian: Some(hessian),
        unaware_hessian: Some(hessian),
        geometric_hessian: None,
        weights: vec![1.0],
        smoothing: crate::gather::StrataSmoothing::OFF,
    }
}

fn settings_for(metric: Metric, accuracy: f64) -> IrradianceSettings {
    IrradianceSettings {
        metric,
        accuracy,
        ..IrradianceSettings::new(1)
    }
}

#[test]
fn split_sphere_family_and_gradient_radii_by_hand() {
    // E = 2, |∇E| = 5 (E/|∇E| = 0.4), D = 3
    let e = summary(2.0, DVec3::new(3.0, 4.0, 0.0), 3.0, DMat3::ZERO);
    let radius = |metric| settings_for(metric, 0.5).extent(&e).unwrap().radii;
    assert_eq!(radius(Metric::SplitSphere), [1.5; 3]);
    assert_eq!(radius(Metric::BoundedSplitSphere), [0.5 * 0.4; 3]);
    assert_eq!(radius(Metric::Gradient), [0.5 * 2.0 / 5.0; 3]);
    // a gradient too weak to bound the split sphere
    let weak = summary(2.0, DVec3::new(0.0, 0.1, 0.0), 3.0, DMat3::ZERO);
    let r = settings_for(Metric::BoundedSplitSphere, 0.5)
        .extent(&weak)
        .unwrap();
    assert_eq!(r.radii, [1.5; 3]);
    // unbounded: every ray missed (split-sphere family), a zero gradient (gradient metric)
    let blind = summary(2.0, DVec3::X, f64::INFINITY, DMat3::ZERO);
    for metric in [Metric::SplitSphere, Metric::BoundedSplitSphere] {
        let r = settings_for(metric, 0.5).extent(&blind).unwrap();
        assert_eq!(r.radii, [f64::INFINITY; 3], "{metric:?}");
    }
    let flat = summary(2.0, DVec3::ZERO, 3.0, DMat3::ZERO);
    let r = settings_for(Metric::Gradient, 0.5).extent(&flat).unwrap();
    assert_eq!(r.radii, [f64::INFINITY; 3]);
    // a black gather divides by the floor, not by zero
    let black = summary(0.0, DVec3::new(0.0, 1e-3, 0.0), 3.0, DMat3::ZERO);
    let r = settings_for(Metric::Gradient, 0.5).extent(&black).unwrap();
    assert_eq!(r.radii, [0.5 * 1e-12 / 1e-3; 3]);
}

#[test]
fn hessian_radii_by_hand() {
    // isotropic tangent curvature λ = 3 at E = 2: R = (4 τ / (π λ))^¼ with τ = a E (thesis eq.
    // 4.19), without the floor
    let h = DMat3::from_diagonal(DVec3::new(3.0, 3.0, -7.0));
    let e = summary(2.0, DVec3::ZERO, 3.0, h);
    let mut s = settings_for(Metric::HessianIsotropic, 0.01);
    s.curvature_floor = 0.0;
    let r = s.extent(&e).unwrap();
    let expected = (4.0 * 0.01 * 2.0 / (std::f64::consts::PI * 3.0)).powf(0.25);
    for radius in r.radii {
        assert!(
            (radius - expected).abs() < 1e-12 * expected,
            "{radius} vs {expected}"
        );
    }
    // a vanishing Hessian: the floor κE/D² alone, R = (4 a D² / (π κ))^¼
    let zero = summary(2.0, DVec3::ZERO, 3.0, DMat3::ZERO);
    let s = settings_for(Metric::HessianAnisotropic, 0.01);
    let r = s.extent(&zero).unwrap();
    let expected = (4.0 * 0.01 * 9.0 / (std::f64::consts::PI * s.curvature_floor)).powf(0.25);
    assert!((r.radii[0] - expected).abs() < 1e-12 * expected, "{r:?}");
    // anisotropic: the demo's call, and the ratio capped at max_anisotropy
    let h = DMat3::from_diagonal(DVec3::new(16.0, 1.0, 0.0));
    let e = summary(2.0, DVec3::ZERO, 3.0, h);
    let s = settings_for(Metric::HessianAnisotropic, 0.01);
    let r = s.extent(&e).unwrap();
    let floor = CurvatureFloor::new(3.0);
    let direct =
        surface_radii_floored(h, DVec3::Z, 2.0, 0.01, ErrorMode::Relative, 2.0, floor).unwrap();
    assert_eq!(r.radii, [direct.radii[0], direct.radii[1], direct.radii[0]]);
    assert_eq!(r.axes[..2], direct.axes);
    assert!((r.radii[1] / r.radii[0] - 2.0).abs() < 1e-12);
    // the isotropic metric ignores max_anisotropy
    let r = settings_for(Metric::HessianIsotropic, 0.01)
        .extent(&e)
        .unwrap();
    assert_eq!(r.radii[0], r.radii[1]);
    // a metric whose Hessian was not computed
    let missing = settings_for(Metric::HessianGeometric, 0.01).extent(&e);
    assert!(matches!(missing, Err(Error::InvalidArgument(m)) if m.contains("Geometric")));
}

#[test]
fn radius_bounds_in_world_units_and_pixels() {
    let bounds = RadiusBounds {
        world_min: 0.01,
        world_max: 5.0,
        pixel_min: 1.0,
        pixel_max: 150.0,
    };
    // unknown footprint: world bounds only
    assert_eq!(bounds.resolve(0.0).unwrap(), (0.01, 5.0));
    // 0.002 per pixel: [max(0.01, 0.002), min(5, 0.3)]
    assert_eq!(bounds.resolve(0.002).unwrap(), (0.01, 150.0 * 0.002));
    // 0.1 per pixel: the one-pixel minimum and the world maximum bind
    assert_eq!(bounds.resolve(0.1).unwrap(), (0.1, 5.0));
    // crossing bounds: the maximum wins
    assert_eq!(bounds.resolve(10.0).unwrap(), (5.0, 5.0));
    // pixel bounds alone need a footprint for a finite maximum
    let pixels = RadiusBounds::default();
    assert!(matches!(pixels.resolve(0.0), Err(Error::InvalidArgument(m)) if m.contains("maximum")));
    assert_eq!(pixels.resolve(0.5).unwrap(), (0.5, 75.0));
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        assert!(bounds.resolve(bad).is_err(), "{bad}");
    }
    let e = Extent {
        radii: [0.001, f64::INFINITY, 2.0],
        axes: [DVec3::X, DVec3::Y, DVec3::ZERO],
    };
    assert_eq!(RadiusBounds::apply(&e, (0.01, 1.0)).radii, [0.01, 1.0, 1.0]);
    assert!(RadiusBounds::world(2.0, 1.0).validate().is_err());
    assert!(RadiusBounds::world(f64::NAN, 1.0).validate().is_err());
}

#[test]
fn records_carry_the_gather_in_f32_within_the_bounds() {
    let mut e = summary(2.0, DVec3::new(3.0, 4.0, 0.0), 3.0, DMat3::ZERO);
    e.irradiance = vec![0.1, 0.2, 0.3];
    e.gradient = vec![
        DVec3::new(1.0, 2.0, 3.0),
        DVec3::new(4.0, 5.0, 6.0),
        DVec3::ZERO,
    ];
    e.rotation_gradient = vec![DVec3::X, DVec3::Y, DVec3::Z];
    let mut s = settings_for(Metric::SplitSphere, 0.5);
    s.channels = 3;
    s.radius_bounds = RadiusBounds {
        world_min: 0.0,
        world_max: f64::INFINITY,
        pixel_min: 1.0,
        pixel_max: 100.0,
    };
    // a·D = 1.5 within [0.01, 1.0] pixels of 0.01: clamped to 1.0
    let r: crate::cache::Record<[f32; 3]> = s.record(&e, 0.01).unwrap();
    assert_eq!(r.value, [0.1f32, 0.2, 0.3]);
    assert_eq!(
        r.gradient,
        Some([[1.0, 4.0, 0.0], [2.0, 5.0, 0.0], [3.0, 6.0, 0.0]])
    );
    assert_eq!(r.rotation_gradient.unwrap()[1], [0.0, 1.0, 0.0]);
    assert_eq!(r.extent.radii, [1.0; 3]);
    assert_eq!((r.position, r.normal), (e.position, e.normal));
    // the channel count must match the settings and the value type
    assert!(s.record::<[f32; 2]>(&e, 0.01).is_err());
    assert!(settings_for(Metric::SplitSphere, 0.5)
        .record::<Vec<f32>>(&e, 0.01)
        .is_err());
    // a radius far below the index's resolution at the record's position is raised to it
    let mut far = e.clone();
    far.position = DVec3::new(1e12, 0.0, 0.0);
    s.radius_bounds = RadiusBounds::world(0.0, 1e-3);
    let r: crate::cache::Record<[f32; 3]> = s.record(&far, 0.0).unwrap();
    assert_eq!(r.extent.radii, [1e12 / (1u64 << 39) as f64; 3]);
    let cache: Cache<[f32; 3]> = Cache::new(s.cache_config()).unwrap();
    assert!(cache.insert(&r).unwrap());
}

/// The evaluation's numbers are those of the gather functions it calls, on the luminance of the
/// channels (rounded to f32, as the renderer's channels are).
#[test]
fn evaluation_matches_the_gather_functions() {
    let x = DVec3::new(0.1, -0.05, 0.0);
    let (layout, frame, directions, distance, radiance) = traced_at(x, 3);
    let traced = TracedGather::new(layout, frame, &directions, &distance, &radiance, 3);
    let weights = LUMINANCE_WEIGHTS;
    let e =
        GatherEvaluation::new(&traced, &weights, Hessians::for_metrics(&Metric::ALL[5..])).unwrap();
    let values = evaluate(&layout, &frame, &traced.input, Wanted::ALL).unwrap();
    assert_eq!(e.irradiance, values.irradiance);
    assert_eq!(e.gradient, values.gradient);
    assert_eq!(e.rotation_gradient, values.rotation_gradient);
    let lum = |v: [f64; 3]| 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
    let irr = &values.irradiance;
    assert_eq!(e.scalar, lum([irr[0], irr[1], irr[2]]));
    let g = &values.gradient;
    assert_eq!(e.scalar_gradient.y, lum([g[0].y, g[1].y, g[2].y]));
    assert!(e.scalar_gradient.y > 0.0, "brighter towards the lit side");
    assert_eq!(
        Some(e.harmonic_mean_distance),
        values.harmonic_mean_distance
    );
    let luminance: Vec<f32> = radiance
        .chunks(3)
        .map(|l| lum([l[0] as f64, l[1] as f64, l[2] as f64]) as f32)
        .collect();
    let topology = Topology::new(LayoutKind::CosinePolar, 8, 24).unwrap();
    let gather = HemisphereGather {
        normal: frame.normal,
        directions: &directions,
        distance: &distance,
        radiance: &luminance,
        channels: 1,
        sigma_t: 0.0,
    };
    let direct = occlusion_derivatives(&topology, &gather, Order::Hessian).unwrap();
    assert_eq!(e.occlusion_hessian, Some(direct.robust_hessian(0)));
    assert_eq!((e.unaware_hessian, e.geometric_hessian), (None, None));
    // a renderer's own scalar radiance replaces the weighted channels
    let halved: Vec<f32> = luminance.iter().map(|l| l * 0.5).collect();
    let mut own = traced;
    own.scalar_radiance = Some(&halved);
    let e2 = GatherEvaluation::new(
        &own,
        &weights,
        Hessians::for_metrics(&[Metric::HessianIsotropic]),
    )
    .unwrap();
    let h = e2.occlusion_hessian.unwrap().to_cols_array();
    let expected = (direct.robust_hessian(0) * 0.5).to_cols_array();
    let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.0);
    for (a, b) in h.iter().zip(expected) {
        assert!((a - b).abs() < 1e-12 * scale, "{a} vs {b}");
    }
}

#[test]
fn unaware_hessians_need_normals_and_no_medium() {
    let (layout, frame, directions, distance, radiance) = traced_at(DVec3::ZERO, 1);
    let traced = TracedGather::new(layout, frame, &directions, &distance, &radiance, 3);
    let unaware = Hessians::for_metrics(&[Metric::HessianUnaware]);
    let e = GatherEvaluation::new(&traced, &LUMINANCE_WEIGHTS, unaware);
    assert!(matches!(e, Err(Error::InvalidArgument(m)) if m.contains("hit normals")));
    // the ceiling's normal faces down
    let normals = vec![-DVec3::Z; directions.len()];
    let mut with = traced;
    with.hit_normals = Some(&normals);
    let both = Hessians::for_metrics(&[Metric::HessianUnaware, Metric::HessianGeometric]);
    let e = GatherEvaluation::new(&with, &LUMINANCE_WEIGHTS, both).unwrap();
    assert!(e.unaware_hessian.is_some() && e.geometric_hessian.is_some());
    assert!(e.occlusion_hessian.is_none());
    let mut medium = with;
    medium.input.sigma_t = 0.1;
    let e = GatherEvaluation::new(&medium, &LUMINANCE_WEIGHTS, both);
    assert!(matches!(e, Err(Error::InvalidArgument(m)) if m.contains("medium")));
    // wrong sizes and bad weights
    let short = vec![-DVec3::Z; 3];
    let mut bad = traced;
    bad.hit_normals = Some(&short);
    assert!(GatherEvaluation::new(&bad, &LUMINANCE_WEIGHTS, Hessians::NONE).is_err());
    for weights in [
        &[1.0, 0.0][..],
        &[0.0; 3],
        &[1.0, f64::NAN, 0.0],
        &[1.0, -1.0, 1.0],
    ] {
        assert!(
            GatherEvaluation::new(&traced, weights, Hessians::NONE).is_err(),
            "{weights:?}"
        );
    }
}

/// One call per shading point makes exactly the record the pieces make for the same seed, and
/// returns the cache's interpolation there.
#[test]
fn one_call_equals_its_pieces() {
    let settings = small_settings();
    let x = DVec3::new(0.1, -0.05, 0.0);
    let cache: Cache<[f32; 3]> = Cache::new(settings.cache_config()).unwrap();
    let calls = AtomicUsize::new(0);
    let trace = |o: DVec3, d: &[DVec3], t: &mut [f64], l: &mut [f32]| {
        calls.fetch_add(1, Ordering::Relaxed);
        assert_eq!(o, x);
        half_ceiling(o, d, t, l);
        Ok::<(), String>(())
    };
    let found = cache
        .irradiance(&settings, x, DVec3::Z, 0.0, trace)
        .unwrap();
    assert_eq!((cache.len(), calls.load(Ordering::Relaxed)), (1, 1));
    // the pieces, with the seed the settings derive from the query
    let layout = settings.layout(settings.seed.seed(x, DVec3::Z)).unwrap();
    let frame = Frame::new(x, DVec3::Z, tangent_basis(DVec3::Z).0).unwrap();
    let directions = layout.directions(&frame).unwrap();
    let (mut distance, mut radiance) = (vec![0.0; 192], vec![0.0f32; 576]);
    half_ceiling(x, &directions, &mut distance, &mut radiance);
    let traced = TracedGather::new(layout, frame, &directions, &distance, &radiance, 3);
    let e = GatherEvaluation::new(&traced, &settings.weights(), settings.hessians()).unwrap();
    let record = settings.record::<[f32; 3]>(&e, 0.0).unwrap();
    let pieces: Cache<[f32; 3]> = Cache::new(settings.cache_config()).unwrap();
    pieces.insert(&record).unwrap();
    assert_eq!(cache.keys(), pieces.keys());
    assert_eq!(found.value, pieces.lookup(x, DVec3::Z).unwrap().value);
    // the record's own irradiance, at its own point
    for c in 0..3 {
        assert!((found.value[c] - e.irradiance[c] as f32).abs() <= 1e-6 * found.value[c].abs());
    }
    // a covered point does not trace
    let again = cache
        .irradiance(&settings, x, DVec3::Z, 0.0, |_, _, _, _| {
            Err("must not trace")
        })
        .unwrap();
    assert_eq!(again.value, found.value);
}

#[test]
fn failures_insert_nothing() {
    let settings = small_settings();
    let cache: Cache<[f32; 3]> = Cache::new(settings.cache_config()).unwrap();
    let x = DVec3::new(0.3, 0.2, 0.0);
    let failing = |_: DVec3, _: &[DVec3], _: &mut [f64], _: &mut [f32]| Err("out of rays");
    match cache.irradiance(&settings, x, DVec3::Z, 0.0, failing) {
        Err(Error::Callback(m)) => assert_eq!(m, "out of rays"),
        other => panic!("{other:?}"),
    }
    // what the gather refuses, as traced
    let nan = |o: DVec3, d: &[DVec3], t: &mut [f64], l: &mut [f32]| {
        half_ceiling(o, d, t, l);
        t[5] = f64::NAN;
        Ok::<(), String>(())
    };
    let e = cache.irradiance(&settings, x, DVec3::Z, 0.0, nan);
    assert!(matches!(e, Err(Error::InvalidArgument(m)) if m.contains("traced gather")));
    let inf = |o: DVec3, d: &[DVec3], t: &mut [f64], l: &mut [f32]| {
        half_ceiling(o, d, t, l);
        l[7] = f32::INFINITY;
        Ok::<(), String>(())
    };
    assert!(cache.irradiance(&settings, x, DVec3::Z, 0.0, inf).is_err());
    // bad queries and settings never reach the tracer
    let never = |_: DVec3, _: &[DVec3], _: &mut [f64], _: &mut [f32]| -> Result<(), String> {
        panic!("traced")
    };
    let bad_queries = [
        (DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Z, 0.0),
        (x, DVec3::ZERO, 0.0),
        (x, DVec3::new(0.0, f64::INFINITY, 1.0), 0.0),
        (x, DVec3::Z, -1.0),
        (x, DVec3::Z, f64::NAN),
    ];
    for (p, n, footprint) in bad_queries {
        let e = cache.irradiance(&settings, p, n, footprint, never);
        assert!(
            matches!(e, Err(Error::InvalidArgument(_))),
            "{p} {n} {footprint}: {e:?}"
        );
    }
    let mut unbounded = settings.clone();
    unbounded.radius_bounds = RadiusBounds::default();
    assert!(cache
        .irradiance(&unbounded, x, DVec3::Z, 0.0, never)
        .is_err());
    let mut other_limit = settings.clone();
    other_limit.gradient_limit = 1.0;
    assert!(cache
        .irradiance(&other_limit, x, DVec3::Z, 0.0, never)
        .is_err());
    let mut guarded = settings.clone();
    guarded.leak_guard = LeakGuard::relative(0.1);
    assert!(cache.irradiance(&guarded, x, DVec3::Z, 0.0, never).is_err());
    let mut unaware = settings.clone();
    unaware.metric = Metric::HessianUnaware;
    let e = cache.irradiance(&unaware, x, DVec3::Z, 0.0, never);
    assert!(matches!(e, Err(Error::InvalidArgument(m)) if m.contains("normals")));
    let mut zero = settings.clone();
    zero.accuracy = 0.0;
    assert!(cache.irradiance(&zero, x, DVec3::Z, 0.0, never).is_err());
    assert_eq!(cache.len(), 0);
}

/// Threads racing over the same points insert each point's record once, and every record is the
/// one a single thread makes at its point: results depend on the queries, not on the threads.
#[test]
fn threads_make_the_records_one_thread_makes() {
    let settings = small_settings();
    let points: Vec<DVec3> = (0..24)
        .map(|i| DVec3::new(0.4 * (i % 6) as f64 - 1.0, 0.5 * (i / 6) as f64 - 0.75, 0.0))
        .collect();
    let trace = |o: DVec3, d: &[DVec3], t: &mut [f64], l: &mut [f32]| {
        half_ceiling(o, d, t, l);
        Ok::<(), String>(())
    };
    let shared: Cache<[f32; 3]> = Cache::new(settings.cache_config()).unwrap();
    std::thread::scope(|scope| {
        for thread in 0..4 {
            let (shared, points, settings) = (&shared, &points, &settings);
            scope.spawn(move || {
                for k in 0..points.len() {
                    let p = points[(k + 5 * thread) % points.len()];
                    shared
                        .irradiance(settings, p, DVec3::Z, 0.0, trace)
                        .unwrap();
                }
            });
        }
    });
    // every record is the one its own point makes alone
    let mut alone = Vec::new();
    for &p in &points {
        let single: Cache<[f32; 3]> = Cache::new(settings.cache_config()).unwrap();
        single
            .irradiance(&settings, p, DVec3::Z, 0.0, trace)
            .unwrap();
        alone.extend(single.keys());
    }
    for key in shared.keys() {
        assert!(
            alone.contains(&key),
            "record {key:x} is no point's own record"
        );
    }
    // racing on one point: one record
    let one: Cache<[f32; 3]> = Cache::new(settings.cache_config()).unwrap();
    let x = DVec3::new(0.05, 0.05, 0.0);
    let values: Vec<[f32; 3]> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..4)
            .map(|_| {
                scope.spawn(|| {
                    one.irradiance(&settings, x, DVec3::Z, 0.0, trace)
                        .unwrap()
                        .value
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(one.len(), 1);
    assert!(values.iter().all(|v| *v == values[0]));
}

#[test]
fn settings_validate_each_field() {
    assert!(IrradianceSettings::default().validate().is_ok());
    assert_eq!(
        IrradianceSettings::default().weights(),
        LUMINANCE_WEIGHTS.to_vec()
    );
    assert_eq!(IrradianceSettings::new(4).weights(), vec![0.25; 4]);
    let breakages: [fn(&mut IrradianceSettings); 12] = [
        |s| s.accuracy = -1.0,
        |s| s.accuracy = f64::INFINITY,
        |s| s.channels = 0,
        |s| s.channel_weights = Some(vec![1.0]),
        |s| s.gather_kind = LayoutKind::Sphere,
        |s| s.gather_m = 0,
        |s| s.radius_bounds.pixel_min = -1.0,
        |s| s.max_anisotropy = 0.5,
        |s| s.curvature_floor = f64::NAN,
        |s| s.gradient_limit = 0.0,
        |s| s.leak_guard = LeakGuard::relative(-1.0),
        |s| s.derivative_smoothing.polar_passes = 65,
    ];
    for (i, breaks) in breakages.iter().enumerate() {
        let mut s = IrradianceSettings::default();
        breaks(&mut s);
        assert!(
            matches!(s.validate(), Err(Error::InvalidArgument(_))),
            "breakage {i}"
        );
    }
    // the cache the settings describe
    let mut s = IrradianceSettings::new(2);
    s.metric = Metric::SplitSphere;
    s.leak_guard = LeakGuard::relative(0.2);
    let config = s.cache_config();
    assert_eq!(config.interpolation, crate::cache::Interpolation::Ward);
    assert_eq!(
        (config.channels, config.gradient_limit),
        (2, GRADIENT_LIMIT_DEFAULT)
    );
    assert!(config.non_negative && config.leak_guard == LeakGuard::relative(0.2));
    assert!(s.check_cache(&config).is_ok());
    assert!(s
        .check_cache(&crate::cache::CacheConfig::surface(2))
        .is_err());
    assert_eq!(
        Metric::parse("hessian-geometric"),
        Some(Metric::HessianGeometric)
    );
    assert_eq!(Metric::try_from(6).unwrap(), Metric::HessianAnisotropic);
    assert!(Metric::try_from(7).is_err());
}
