//! The lookup radius scale: a scaled cache blends what a cache of records with scaled radii
//! blends, misses exactly where the unscaled cache misses (so the one-call queries make the same
//! records), gives the same bits on every lookup path, and is the unscaled cache bit for bit at 1.

#[path = "common/plane_records.rs"]
mod plane_records;
#[path = "common/splitmix.rs"]
mod splitmix;

use glam::DVec3;
use raddiff::cache::irradiance::{IrradianceSettings, NearFieldSettings, RadiusBounds};
use raddiff::cache::{
    Cache, CacheConfig, Cursor, Extent, FarFieldReach, Interpolation, LeakGuard, OpenFractionTest,
    Record, LOOKUP_RADIUS_SCALE_MAX, RADIUS_MAX,
};
use raddiff::Error;

/// The shared plane records with largest radii in [0.1, 0.4).
fn records(count: usize, seed: u64) -> Vec<Record<[f32; 3]>> {
    plane_records::plane_records(count, seed, (0.1, 0.3))
}

fn filled(config: CacheConfig, all: &[Record<[f32; 3]>]) -> Cache<[f32; 3]> {
    let cache = Cache::new(config).unwrap();
    for r in all {
        cache.insert(r).unwrap();
    }
    cache
}

/// At a covered query, a cache read over k times the radii gives what a cache of the same
/// records with radii k times larger gives (the reference: radii scaled before they are
/// stored as f32, so agreement to f32 rounding, not bits).
#[test]
fn a_scaled_lookup_blends_the_records_of_scaled_radii() {
    let all = records(300, 7);
    for k in [1.5, 2.0, 3.25] {
        let wide: Vec<_> = all
            .iter()
            .map(|r| {
                let mut w = r.clone();
                w.extent.radii = r.extent.radii.map(|x| x * k);
                w
            })
            .collect();
        for interpolation in [Interpolation::Ward, Interpolation::Tent, Interpolation::Log] {
            let config = CacheConfig::surface(3).with_interpolation(interpolation);
            let scaled = filled(config.with_lookup_radius_scale(k), &all);
            let reference = filled(config, &wide);
            let mut state = 11;
            let mut compared = 0;
            for _ in 0..500 {
                let x = DVec3::new(
                    4.0 * splitmix::uniform(&mut state),
                    4.0 * splitmix::uniform(&mut state),
                    0.0,
                );
                let n = DVec3::new(0.02 * splitmix::uniform(&mut state), 0.0, 1.0);
                let Ok(got) = scaled.lookup(x, n) else {
                    continue;
                };
                let want = reference.lookup(x, n).unwrap();
                for c in 0..3 {
                    let (a, b) = (got.value[c] as f64, want.value[c] as f64);
                    assert!(
                        (a - b).abs() <= 1e-5 * b.abs().max(1.0),
                        "{interpolation:?} k {k} at {x}: channel {c} {a} vs {b}"
                    );
                }
                let (a, b) = (got.weight_sum, want.weight_sum);
                assert!(
                    (a - b).abs() <= 1e-5 * b.abs(),
                    "{interpolation:?} k {k}: {a} vs {b}"
                );
                compared += 1;
            }
            assert!(compared > 300, "{interpolation:?} k {k}: {compared}");
        }
    }
}

/// With the leak guard and the open-fraction test on, a query is found by the scaled cache
/// exactly when the unscaled cache finds it, and then with at least as many records.
#[test]
fn misses_are_those_of_the_unscaled_cache() {
    let all = records(200, 3);
    let config = CacheConfig::surface(3)
        .with_interpolation(Interpolation::Tent)
        .with_leak_guard(LeakGuard {
            relative: 0.1,
            absolute: 0.01,
        })
        .with_far_field(FarFieldReach::world(1.0))
        .with_open_fraction_test(OpenFractionTest::new(0.125));
    let one = filled(config, &all);
    let two = filled(config.with_lookup_radius_scale(2.0), &all);
    let mut state = 5;
    let (mut misses, mut wider) = (0, 0);
    for _ in 0..4000 {
        let x = DVec3::new(
            4.4 * splitmix::uniform(&mut state) - 0.2,
            4.4 * splitmix::uniform(&mut state) - 0.2,
            0.02 * (splitmix::uniform(&mut state) - 0.5),
        );
        let n = DVec3::new(0.1 * (splitmix::uniform(&mut state) - 0.5), 0.0, 1.0);
        let open = splitmix::uniform(&mut state);
        match (one.lookup_open(x, n, open), two.lookup_open(x, n, open)) {
            (Err(Error::NotFound(_)), Err(Error::NotFound(_))) => misses += 1,
            (Ok(a), Ok(b)) => {
                assert!(b.records >= a.records, "{x}: {} < {}", b.records, a.records);
                wider += (b.records > a.records) as usize;
            }
            (a, b) => panic!("{x} open {open}: {a:?} at 1, {b:?} at 2"),
        }
    }
    assert!(
        misses > 200 && wider > 1000,
        "{misses} misses, {wider} wider"
    );
}

/// The index, this thread's cursor and an explicit cursor agree bit for bit on a scaled cache,
/// over coherent walks that make the cursors anchor and serve from memory.
#[test]
fn every_path_gives_the_same_bits() {
    let all = records(500, 9);
    for interpolation in [Interpolation::Ward, Interpolation::Tent, Interpolation::Log] {
        let config = CacheConfig::surface(3)
            .with_interpolation(interpolation)
            .with_leak_guard(LeakGuard {
                relative: 0.1,
                absolute: 0.01,
            })
            .with_lookup_radius_scale(1.5);
        let cache = filled(config, &all);
        let mut cursor = Cursor::new();
        let mut state = 13;
        let mut found = 0;
        for walk in 0..40 {
            let start = DVec3::new(
                4.0 * splitmix::uniform(&mut state),
                4.0 * splitmix::uniform(&mut state),
                0.0,
            );
            for step in 0..30 {
                let x = start + DVec3::new(0.01 * step as f64, 0.004 * step as f64, 0.0);
                let n = DVec3::new(0.01 * splitmix::uniform(&mut state), 0.0, 1.0);
                let (mut indexed, mut threaded, mut explicit) = ([0.0f32; 3], [0.0; 3], [0.0; 3]);
                let a = cache.lookup_into_indexed(x, n, &mut indexed);
                let b = cache.lookup_into(x, n, &mut threaded);
                let c = cache.lookup_into_with(&mut cursor, x, n, &mut explicit);
                let at = format!("{interpolation:?} walk {walk} step {step}");
                assert_eq!(a.is_ok(), b.is_ok(), "{at}");
                assert_eq!(a.is_ok(), c.is_ok(), "{at}");
                if let (Ok(a), Ok(b), Ok(c)) = (a, b, c) {
                    assert_eq!((a, indexed), (b, threaded), "{at}");
                    assert_eq!((a, indexed), (c, explicit), "{at}");
                    found += 1;
                }
            }
        }
        assert!(
            found > 600,
            "{interpolation:?}: only {found} covered queries"
        );
    }
}

/// Setting the scale on a filled cache is creating the cache with it; setting it back to 1 is
/// the unscaled cache bit for bit; an invalid scale changes nothing.
#[test]
fn the_scale_set_later_is_the_scale_set_first() {
    let all = records(300, 17);
    let config = CacheConfig::surface(3).with_interpolation(Interpolation::Tent);
    let never = filled(config, &all);
    let first = filled(config.with_lookup_radius_scale(2.5), &all);
    let mut later = filled(config, &all);
    let mut cursor = Cursor::new();
    // a cursor that anchored before the change must not serve the old candidates after it
    let _ = later.lookup_with(&mut cursor, DVec3::new(2.0, 2.0, 0.0), DVec3::Z);
    later.set_lookup_radius_scale(2.5).unwrap();
    assert_eq!(later.config().lookup_radius_scale, 2.5);
    for bad in [0.5, 0.999, 8.001, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            later.set_lookup_radius_scale(bad),
            Err(Error::InvalidArgument(_))
        ));
        assert_eq!(later.config().lookup_radius_scale, 2.5);
    }
    let mut state = 19;
    let queries: Vec<DVec3> = (0..600)
        .map(|_| {
            DVec3::new(
                4.0 * splitmix::uniform(&mut state),
                4.0 * splitmix::uniform(&mut state),
                0.0,
            )
        })
        .collect();
    let same = |a: &Cache<[f32; 3]>, b: &Cache<[f32; 3]>, cursor: &mut Cursor| {
        for &x in &queries {
            assert_eq!(
                a.lookup(x, DVec3::Z).ok(),
                b.lookup_with(cursor, x, DVec3::Z).ok(),
                "{x}"
            );
        }
    };
    same(&first, &later, &mut cursor);
    later.set_lookup_radius_scale(1.0).unwrap();
    same(&never, &later, &mut cursor);
    let differs = queries
        .iter()
        .filter(|&&x| first.lookup(x, DVec3::Z).ok() != never.lookup(x, DVec3::Z).ok())
        .count();
    assert!(differs > 300, "the scale changed only {differs} lookups");
}

#[test]
fn invalid_scales_are_refused() {
    for good in [1.0, 1.5, LOOKUP_RADIUS_SCALE_MAX] {
        let config = CacheConfig::surface(3).with_lookup_radius_scale(good);
        assert!(Cache::<[f32; 3]>::new(config).is_ok(), "{good}");
    }
    for bad in [0.0, 0.999, -2.0, 8.001, f64::NAN, f64::INFINITY] {
        let config = CacheConfig::surface(3).with_lookup_radius_scale(bad);
        assert!(
            matches!(
                Cache::<[f32; 3]>::new(config),
                Err(Error::InvalidArgument(ref m)) if m.contains("lookup radius scale")
            ),
            "{bad}"
        );
        let mut settings = IrradianceSettings::new(3);
        settings.lookup_radius_scale = bad;
        assert!(settings.validate().is_err(), "{bad}");
    }
}

/// A ceiling of radiance 1 at height 0.5 over x < 0, the sky (radiance 0.25) beyond; rays
/// longer than `max_distance` report a miss.
fn ledge(
    origin: DVec3,
    directions: &[DVec3],
    max_distance: f64,
    distance: &mut [f64],
    radiance: &mut [f32],
) -> Result<(), String> {
    for (i, w) in directions.iter().enumerate() {
        let t = (0.5 - origin.z) / w.z.max(1e-12);
        let (d, l) = if (origin + t * *w).x < 0.0 {
            (t, 1.0)
        } else {
            (f64::INFINITY, 0.25)
        };
        distance[i] = if d < max_distance { d } else { f64::INFINITY };
        radiance[3 * i..3 * i + 3].fill(l);
    }
    Ok(())
}

/// The one-call queries (plain and near/far) over a walk across the ledge make exactly the
/// records they make at scale 1, in the same calls, while the values they return blend more.
#[test]
fn one_call_queries_make_the_records_they_make_at_scale_one() {
    let mut plain = IrradianceSettings::new(3);
    (plain.gather_m, plain.gather_n) = (12, 36);
    plain.radius_bounds = RadiusBounds::world(0.05, 0.6);
    plain.accuracy = 1e-4;
    let mut near_far = plain.clone();
    near_far.near_field = NearFieldSettings {
        reach: FarFieldReach::world(0.3),
        m: 8,
        n: 8,
        open_fraction_test: OpenFractionTest::new(0.1),
    };
    let walk: Vec<DVec3> = (0..400)
        .map(|i| DVec3::new(-2.0 + 0.01 * i as f64, 0.05 * (i % 7) as f64, 0.0))
        .collect();
    for settings in [plain, near_far] {
        let near = settings.near_field.reach.is_on();
        let run = |scale: f64| {
            let mut s = settings.clone();
            s.lookup_radius_scale = scale;
            let cache: Cache<[f32; 3]> = Cache::new(s.cache_config()).unwrap();
            assert_eq!(cache.config().lookup_radius_scale, scale);
            let mut grew = Vec::new();
            let mut values = Vec::new();
            for &x in &walk {
                let before = cache.len();
                let value = if near {
                    cache
                        .irradiance_near_far(&s, x, DVec3::Z, 0.0, ledge)
                        .unwrap()
                        .value
                } else {
                    let trace = |o: DVec3, d: &[DVec3], t: &mut [f64], l: &mut [f32]| {
                        ledge(o, d, f64::INFINITY, t, l)
                    };
                    cache.irradiance(&s, x, DVec3::Z, 0.0, trace).unwrap().value
                };
                grew.push(cache.len() > before);
                values.push(value);
            }
            (cache.keys(), grew, values)
        };
        let (keys_one, grew_one, values_one) = run(1.0);
        let (keys_wide, grew_wide, values_wide) = run(1.5);
        assert!(
            keys_one.len() > 5,
            "near {near}: {} records",
            keys_one.len()
        );
        assert_eq!(grew_one, grew_wide, "near {near}: misses moved");
        assert_eq!(keys_one, keys_wide, "near {near}: other records");
        let changed = values_one
            .iter()
            .zip(&values_wide)
            .filter(|(a, b)| a != b)
            .count();
        assert!(changed > 50, "near {near}: only {changed} values changed");
    }
}

/// The largest scale at tiny, unit and huge radii: a record 4.5 radii away is blended in, a gap
/// between the records' own radii stays a miss, and every value is finite and between the
/// records'. A record of `RADIUS_MAX` (whose scaled sphere the index must still place) is found.
#[test]
fn the_largest_scale_holds_at_every_size() {
    let config = CacheConfig::surface(3)
        .with_interpolation(Interpolation::Tent)
        .with_lookup_radius_scale(LOOKUP_RADIUS_SCALE_MAX);
    let largest: Cache<[f32; 3]> = Cache::new(config).unwrap();
    let record = Record::new(
        DVec3::ZERO,
        DVec3::Z,
        [2.0; 3],
        Extent::isotropic(RADIUS_MAX),
    );
    largest.insert(&record).unwrap();
    for x in [0.0, 0.5, 0.99] {
        let hit = largest.lookup(DVec3::new(x * RADIUS_MAX, 0.0, 0.0), DVec3::Z);
        assert_eq!(hit.map(|h| h.value).ok(), Some([2.0; 3]), "{x} R");
    }
    for r in [1e-25, 1.0, 1e29] {
        let cache: Cache<[f32; 3]> = Cache::new(config).unwrap();
        let disc = |x: f64, v: f32| {
            Record::new(
                DVec3::new(x, 0.0, 0.0),
                DVec3::Z,
                [v; 3],
                Extent::isotropic(r),
            )
        };
        cache.insert(&disc(0.0, 1.0)).unwrap();
        cache.insert(&disc(5.0 * r, 3.0)).unwrap();
        let at = |x: f64| cache.lookup(DVec3::new(x * r, 0.0, 0.0), DVec3::Z);
        for x in [0.5, 4.5] {
            let hit = at(x).unwrap();
            assert_eq!(hit.records, 2, "r {r} at {x}");
            assert!(
                hit.value
                    .iter()
                    .all(|v| v.is_finite() && *v > 1.0 && *v < 3.0),
                "r {r}: {hit:?}"
            );
        }
        assert!(matches!(at(2.5), Err(Error::NotFound(_))), "r {r}");
    }
}
