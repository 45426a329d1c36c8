//! Irradiance in one call per shading point with the near/far decomposition
//! (`Cache::irradiance_near_far`): against the closed form of a point under a ceiling, against
//! the plain one-call query on the same gather (the identity E = E_near + V·F), what the callback
//! is asked for, the far-field marker as cache state, and every refusal.

use std::cell::Cell;
use std::f64::consts::PI;

use glam::DVec3;
use raddiff::cache::irradiance::{IrradianceSettings, NearFieldSettings, RadiusBounds};
use raddiff::cache::{Cache, FarFieldReach};
use raddiff::Error;

/// A tracing callback of `Cache::irradiance_near_far`.
type Trace = Box<dyn Fn(DVec3, &[DVec3], f64, &mut [f64], &mut [f32]) -> Result<(), String>>;

/// A ceiling at height `height` above the plane z = 0, radiance `radiance(direction)` per
/// channel (3 channels); rays longer than `max_distance` report a miss and leave their radiance.
fn ceiling(height: f64, radiance: impl Fn(DVec3) -> [f32; 3] + 'static) -> Trace {
    Box::new(move |origin, directions, max_distance, distance, out| {
        for (i, w) in directions.iter().enumerate() {
            let t = (height - origin.z) / w.z.max(1e-12);
            if t >= max_distance {
                distance[i] = f64::INFINITY;
            } else {
                distance[i] = t;
                out[3 * i..3 * i + 3].copy_from_slice(&radiance(*w));
            }
        }
        Ok(())
    })
}

fn settings(reach: FarFieldReach) -> IrradianceSettings {
    let mut s = IrradianceSettings::new(3);
    s.gather_m = 16;
    s.gather_n = 48;
    s.radius_bounds = RadiusBounds::world(0.01, 5.0);
    s.near_field = NearFieldSettings {
        reach,
        m: 8,
        n: 8,
        ..Default::default()
    };
    s
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

/// Under a ceiling at height h of constant radiance L, with reach ρ > h, the rays with
/// cos θ > h/ρ are near: the cosine-weighted open fraction is (h/ρ)² and the near field
/// πL(1 − (h/ρ)²). With h = 0.5 and ρ = 1 the boundary, sin²θ = 3/4, is a stratum boundary of every
/// cosine-polar layout with m divisible by 4, so the stratified estimate is exact for any jitter.
/// The far field is L everywhere (the near hits take the open directions' mean radiance), so the
/// value is πL at every query, on a miss and on a hit.
#[test]
fn under_a_ceiling_the_pieces_match_the_closed_form() {
    let s = settings(FarFieldReach::pixels(100.0));
    let cache: Cache<[f32; 3]> = Cache::new(s.cache_config()).unwrap();
    assert_eq!(cache.config().far_field, FarFieldReach::pixels(100.0));
    let trace = ceiling(0.5, |_| [2.0, 1.0, 0.5]);
    let footprint = 0.01;
    let calls = Cell::new(0);
    let miss = cache
        .irradiance_near_far(&s, DVec3::ZERO, DVec3::Z, footprint, |o, d, m, dist, r| {
            calls.set(calls.get() + 1);
            assert_eq!(d.len(), 16 * 48, "a miss traces the record's gather");
            assert_eq!(m, f64::INFINITY, "the gather's rays go all the way");
            trace(o, d, m, dist, r)
        })
        .unwrap();
    assert_eq!(calls.get(), 1);
    assert_eq!(cache.len(), 1);
    assert_eq!(miss.reach, 1.0);
    assert!((miss.near.open_fraction - 0.25).abs() < 1e-15);
    for (c, l) in [2.0, 1.0, 0.5].into_iter().enumerate() {
        assert!(rel(miss.near.irradiance[c], PI * l * 0.75) < 1e-6);
        assert!(rel(miss.far.value[c] as f64, PI * l) < 1e-6);
        assert!(rel(miss.value[c] as f64, PI * l) < 1e-6);
    }
    // a covered query traces only its near rays, no farther than the reach
    let x = DVec3::new(0.003, -0.002, 0.0);
    let hit = cache
        .irradiance_near_far(&s, x, DVec3::Z, footprint, |o, d, m, dist, r| {
            calls.set(calls.get() + 1);
            assert_eq!(d.len(), 64, "a hit traces the 8 x 8 near rays");
            assert_eq!(m, 1.0);
            assert_eq!(o, x);
            trace(o, d, m, dist, r)
        })
        .unwrap();
    assert_eq!(calls.get(), 2);
    assert_eq!(cache.len(), 1, "a hit inserts nothing");
    assert!(hit.far.records >= 1);
    assert!((hit.near.open_fraction - 0.25).abs() < 1e-15);
    for (c, l) in [2.0, 1.0, 0.5].into_iter().enumerate() {
        assert!(rel(hit.near.irradiance[c], PI * l * 0.75) < 1e-6);
        assert!(rel(hit.value[c] as f64, PI * l) < 1e-5, "{c}");
    }
}

/// On a miss the query's near field and the record both come from the same gather, so
/// E_near + V·F is the gather's irradiance: the plain query with the same settings (same seed,
/// same directions) gives the same value, up to the far field's f32 mean, under radiance that
/// varies with direction.
#[test]
fn on_a_miss_the_decomposition_adds_up_to_the_gather() {
    for (height, reach) in [(0.5, 1.0), (0.2, 3.0), (1.0, 0.5), (0.3, 0.31)] {
        let near_far = settings(FarFieldReach::world(reach));
        let plain = settings(FarFieldReach::OFF);
        let a: Cache<[f32; 3]> = Cache::new(near_far.cache_config()).unwrap();
        let b: Cache<[f32; 3]> = Cache::new(plain.cache_config()).unwrap();
        let shade = |w: DVec3| {
            let g = (1.0 + w.x + 0.5 * w.z) as f32;
            [g, 2.0 * g, 0.25]
        };
        let trace = ceiling(height, shade);
        let x = DVec3::new(0.1, 0.2, 0.0);
        let split = a
            .irradiance_near_far(&near_far, x, DVec3::Z, 0.0, &trace)
            .unwrap();
        let whole = b
            .irradiance(&plain, x, DVec3::Z, 0.0, |o, d, dist, r| {
                trace(o, d, f64::INFINITY, dist, r)
            })
            .unwrap();
        for c in 0..3 {
            let (got, want) = (split.value[c] as f64, whole.value[c] as f64);
            assert!(
                rel(got, want) < 1e-5,
                "h {height} reach {reach} channel {c}: {got} vs {want}"
            );
        }
        let open = split.near.open_fraction;
        assert!((0.0..=1.0).contains(&open));
        if height >= reach {
            assert_eq!(open, 1.0, "nothing is nearer than the reach");
        }
    }
}

/// The far-field marker travels with the cache: saved, loaded, and the loaded cache answers the
/// near/far query as the saved one did, and refuses the plain query.
#[test]
fn a_saved_cache_of_far_fields_stays_one() {
    let s = settings(FarFieldReach {
        world: 0.25,
        pixels: 50.0,
    });
    let cache: Cache<[f32; 3]> = Cache::new(s.cache_config()).unwrap();
    let trace = ceiling(0.5, |w| [1.0 + w.y as f32, 1.0, 1.0]);
    for i in 0..5 {
        let x = DVec3::new(i as f64 * 0.7, 0.0, 0.0);
        cache
            .irradiance_near_far(&s, x, DVec3::Z, 0.01, &trace)
            .unwrap();
    }
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("near_far_cache");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("far.rdfcache");
    cache.save(&path).unwrap();
    let back = Cache::<[f32; 3]>::load(&path).unwrap();
    assert_eq!(back.config(), cache.config());
    for i in 0..20 {
        let x = DVec3::new(i as f64 * 0.15, 0.05, 0.0);
        let (a, b) = (
            cache.irradiance_near_far(&s, x, DVec3::Z, 0.01, &trace),
            back.irradiance_near_far(&s, x, DVec3::Z, 0.01, &trace),
        );
        assert_eq!(a.unwrap().value, b.unwrap().value, "{i}");
    }
    let plain = settings(FarFieldReach::OFF);
    let refused = back.irradiance(&plain, DVec3::ZERO, DVec3::Z, 0.01, |_, _, _, _| {
        Ok::<(), String>(())
    });
    assert!(matches!(refused, Err(Error::InvalidArgument(m)) if m.contains("far fields")));
}

fn invalid(result: raddiff::Result<impl std::fmt::Debug>, needle: &str) {
    match result {
        Err(Error::InvalidArgument(m)) => assert!(m.contains(needle), "{m:?} lacks {needle:?}"),
        other => panic!("expected InvalidArgument naming {needle:?}, got {other:?}"),
    }
}

#[test]
fn refusals_insert_nothing() {
    let s = settings(FarFieldReach::pixels(8.0));
    let cache: Cache<[f32; 3]> = Cache::new(s.cache_config()).unwrap();
    let trace = ceiling(0.5, |_| [1.0; 3]);
    let (x, n) = (DVec3::ZERO, DVec3::Z);
    // settings without a reach, or with another reach than the cache's
    invalid(
        cache.irradiance_near_far(&settings(FarFieldReach::OFF), x, n, 0.1, &trace),
        "no near-field reach",
    );
    invalid(
        cache.irradiance_near_far(&settings(FarFieldReach::pixels(4.0)), x, n, 0.1, &trace),
        "far-field reach",
    );
    // a plain cache does not hold far fields
    let plain: Cache<[f32; 3]> = Cache::new(settings(FarFieldReach::OFF).cache_config()).unwrap();
    invalid(
        plain.irradiance_near_far(&s, x, n, 0.1, &trace),
        "far-field reach",
    );
    // the plain query refuses near-field settings
    invalid(
        plain.irradiance(&s, x, n, 0.1, |_, _, _, _| Ok::<(), String>(())),
        "irradiance_near_far",
    );
    // a reach in pixels needs a footprint
    invalid(
        cache.irradiance_near_far(&s, x, n, 0.0, &trace),
        "footprint",
    );
    // invalid queries
    invalid(
        cache.irradiance_near_far(&s, DVec3::new(f64::NAN, 0.0, 0.0), n, 0.1, &trace),
        "position",
    );
    invalid(
        cache.irradiance_near_far(&s, x, n, -1.0, &trace),
        "footprint",
    );
    // a failing callback
    let failed = cache.irradiance_near_far(&s, x, n, 0.1, |_, _, _, _, _| Err("no rays"));
    assert!(matches!(failed, Err(Error::Callback(m)) if m.contains("no rays")));
    // traced values the gather refuses
    invalid(
        cache.irradiance_near_far(&s, x, n, 0.1, |_, _, _, d: &mut [f64], _| {
            d.fill(f64::NAN);
            Ok::<(), String>(())
        }),
        "traced gather",
    );
    // a gather whose own sum overflows an f32 makes no record
    let huge = cache.irradiance_near_far(&s, x, n, 0.1, ceiling(0.5, |_| [2e38; 3]));
    assert!(matches!(huge, Err(Error::Degenerate(_))), "{huge:?}");
    assert_eq!(cache.len(), 0);
    // now a record covers x: the near rays are refused the same way, and a near-ray layout the
    // gather cannot make is named
    cache.irradiance_near_far(&s, x, n, 0.1, &trace).unwrap();
    assert_eq!(cache.len(), 1);
    invalid(
        cache.irradiance_near_far(&s, x, n, 0.1, |_, _, _, d: &mut [f64], _| {
            d.fill(-1.0);
            Ok::<(), String>(())
        }),
        "traced near-field rays",
    );
    let mut bad = s.clone();
    bad.near_field.m = 0;
    invalid(
        cache.irradiance_near_far(&bad, x, n, 0.1, &trace),
        "near-field rays",
    );
    invalid(bad.validate(), "near-field rays");
    // a sum beyond f32 is Degenerate, never infinite
    let huge = cache.irradiance_near_far(&s, x, n, 0.1, ceiling(0.5, |_| [f32::MAX; 3]));
    assert!(matches!(huge, Err(Error::Degenerate(_))), "{huge:?}");
    assert_eq!(cache.len(), 1);
    // negative or non-finite reaches are refused where the cache is made and in the settings
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let s = settings(FarFieldReach::world(bad));
        invalid(s.validate(), "reach");
        assert!(Cache::<[f32; 3]>::new(s.cache_config()).is_err());
    }
}
