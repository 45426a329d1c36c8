//! The open-fraction test of far-field caches: lookups with the query's open fraction refuse
//! exactly the records beyond the tolerance (on the index path and on both cursor paths, bit for
//! bit), change nothing with the test off, uncover no query beyond what the coverage tolerance
//! allows when the test keeps coverage, and
//! the one-call near/far query under a ledge makes a record of its own where the records nearby
//! see another part of the sky.

#[path = "common/plane_records.rs"]
mod plane_records;
#[path = "common/splitmix.rs"]
mod splitmix;

use std::cell::Cell;

use glam::DVec3;
use raddiff::cache::irradiance::{IrradianceSettings, NearFieldSettings, RadiusBounds};
use raddiff::cache::{
    Cache, CacheConfig, Cursor, FarFieldReach, Interpolation, OpenFractionTest, Record,
};
use raddiff::Error;

/// A stream of numbers in [0, 1) from `seed`.
fn stream(mut state: u64) -> impl FnMut() -> f64 {
    move || splitmix::uniform(&mut state)
}

/// The shared plane records with largest radii in [0.2, 0.8).
fn records(count: usize, seed: u64) -> Vec<Record<[f32; 3]>> {
    plane_records::plane_records(count, seed, (0.2, 0.6))
}

fn far_cache(test: OpenFractionTest, interpolation: Interpolation) -> Cache<[f32; 3]> {
    let config = CacheConfig::surface(3)
        .with_interpolation(interpolation)
        .with_far_field(FarFieldReach::world(1.0))
        .with_open_fraction_test(test);
    Cache::new(config).unwrap()
}

/// What the test must admit at a query of open fraction `open`: every record covering the query
/// whose open fraction is within the tolerance, or that has none. The lookup's record count and
/// weight sum must be those of the plain lookup in a cache holding only these records.
#[test]
fn lookups_refuse_exactly_the_records_beyond_the_tolerance() {
    let all = records(300, 7);
    for interpolation in [Interpolation::Ward, Interpolation::Tent, Interpolation::Log] {
        let tolerance = 0.1875;
        let cache = far_cache(OpenFractionTest::new(tolerance), interpolation);
        for r in &all {
            cache.insert(r).unwrap();
        }
        let mut u = stream(11);
        let mut refusals = 0;
        for _ in 0..400 {
            let x = DVec3::new(4.0 * u(), 4.0 * u(), 0.0);
            let open = (16.0 * u()).floor() / 16.0 + 1.0 / 32.0;
            // the reference: a cache (test off) of the admitted records only
            let admitted = far_cache(OpenFractionTest::OFF, interpolation);
            for r in &all {
                if r.open_fraction
                    .is_none_or(|v| (v - open).abs() <= tolerance)
                {
                    admitted.insert(r).unwrap();
                }
            }
            let got = cache.lookup_open(x, DVec3::Z, open);
            let want = admitted.lookup_indexed(x, DVec3::Z);
            match (&got, &want) {
                (Ok(a), Ok(b)) => assert_eq!(a, b, "{interpolation:?} at {x} open {open}"),
                (Err(Error::NotFound(_)), Err(Error::NotFound(_))) => {}
                _ => panic!("{interpolation:?} at {x} open {open}: {got:?} vs {want:?}"),
            }
            let plain = cache.lookup(x, DVec3::Z);
            if let Ok(p) = &plain {
                refusals += got.as_ref().map_or(p.records, |g| p.records - g.records);
            }
        }
        assert!(
            refusals > 100,
            "{interpolation:?}: only {refusals} refusals"
        );
    }
}

/// Keeping coverage: a query that some record passes reads exactly what the default test gives;
/// a query whose covering records the test all refuses reads those within the coverage tolerance
/// as a test at that tolerance does (bit for bit, on the three paths of a lookup), so a query is
/// covered exactly where it is at the coverage tolerance: everywhere the test off covers it when
/// the coverage tolerance is infinite, not where only records beyond it cover the query when it
/// is finite. With records read over twice their radii too, where coverage is decided at their
/// own.
#[test]
fn keeping_coverage_reads_the_refused_records_only_where_none_passes() {
    let all = records(120, 13);
    for scale in [1.0, 2.0] {
        for coverage in [f64::INFINITY, 0.25] {
            let test = OpenFractionTest::new(0.0625);
            let cache_of = |test: OpenFractionTest| {
                let config = CacheConfig::surface(3)
                    .with_interpolation(Interpolation::Tent)
                    .with_far_field(FarFieldReach::world(1.0))
                    .with_open_fraction_test(test)
                    .with_lookup_radius_scale(scale);
                let cache = Cache::<[f32; 3]>::new(config).unwrap();
                for r in &all {
                    cache.insert(r).unwrap();
                }
                cache
            };
            // the reference of the second read: the test at the coverage tolerance (infinite: off)
            let (keeping, uncovering, wider, off) = (
                cache_of(test.with_coverage_tolerance(coverage)),
                cache_of(test),
                cache_of(OpenFractionTest::new(coverage)),
                cache_of(OpenFractionTest::OFF),
            );
            let mut cursor = Cursor::new();
            let mut u = stream(17);
            let (mut chosen, mut kept, mut uncovered) = (0, 0, 0);
            for _ in 0..600 {
                let x = DVec3::new(4.0 * u(), 4.0 * u(), 0.0);
                let open = u();
                let got = keeping.lookup_open(x, DVec3::Z, open);
                let want = match uncovering.lookup_open(x, DVec3::Z, open) {
                    Err(Error::NotFound(_)) => {
                        let second = wider.lookup_open(x, DVec3::Z, open);
                        kept += usize::from(second.is_ok());
                        uncovered +=
                            usize::from(second.is_err() && off.lookup(x, DVec3::Z).is_ok());
                        second
                    }
                    passed => {
                        chosen += usize::from(passed.is_ok());
                        passed
                    }
                };
                let at = format!("scale {scale}, coverage {coverage} at {x} open {open}");
                match (&got, &want) {
                    (Ok(a), Ok(b)) => assert_eq!(a, b, "{at}"),
                    (Err(Error::NotFound(_)), Err(Error::NotFound(_))) => {}
                    _ => panic!("{at}: {got:?} vs {want:?}"),
                }
                assert_eq!(
                    got.is_ok(),
                    wider.lookup_open(x, DVec3::Z, open).is_ok(),
                    "coverage {at}"
                );
                let mut indexed = [0.0f32; 3];
                let mut explicit = [0.0f32; 3];
                let a = keeping.lookup_into_indexed_open(x, DVec3::Z, open, &mut indexed);
                let c =
                    keeping.lookup_into_with_open(&mut cursor, x, DVec3::Z, open, &mut explicit);
                assert_eq!(a.is_ok(), got.is_ok());
                assert_eq!(c.is_ok(), got.is_ok());
                if let (Ok(a), Ok(c)) = (a, c) {
                    assert_eq!((a, indexed), (c, explicit), "{at}");
                }
            }
            assert!(
                chosen > 100 && kept > 30,
                "scale {scale}, coverage {coverage}: {chosen} chosen, {kept} kept"
            );
            // a finite coverage tolerance still uncovers the queries that only records beyond it
            // cover; an infinite one none
            assert_eq!(
                uncovered > 10,
                coverage.is_finite(),
                "scale {scale}, coverage {coverage}: {uncovered} uncovered"
            );
        }
    }
}

/// The coverage tolerance keeps nothing unless it is above the tolerance, and is validated with
/// it.
#[test]
fn a_coverage_tolerance_not_above_the_tolerance_keeps_nothing() {
    let test = OpenFractionTest::new(0.125);
    assert!(!test.keeps_coverage());
    assert!(!test.with_coverage_tolerance(0.125).keeps_coverage());
    assert!(test.with_coverage_tolerance(0.126).keeps_coverage());
    assert!(test.keeping_coverage().keeps_coverage());
    assert!(!OpenFractionTest::OFF.keeping_coverage().keeps_coverage());
    for bad in [-0.5, f64::NAN] {
        let config = CacheConfig::surface(3)
            .with_far_field(FarFieldReach::world(1.0))
            .with_open_fraction_test(test.with_coverage_tolerance(bad));
        assert!(
            matches!(
                Cache::<[f32; 3]>::new(config),
                Err(Error::InvalidArgument(_))
            ),
            "{bad}"
        );
    }
}

/// The three paths of a lookup (the index, this thread's cursor, an explicit cursor) agree bit
/// for bit with the test on, over coherent query walks that make the cursors re-anchor and
/// serve from memory; with the test off, a lookup with an open fraction is the plain lookup.
#[test]
fn every_path_gives_the_same_bits() {
    let all = records(500, 3);
    let on = far_cache(OpenFractionTest::new(0.125), Interpolation::Tent);
    let off = far_cache(OpenFractionTest::OFF, Interpolation::Tent);
    for r in &all {
        on.insert(r).unwrap();
        off.insert(r).unwrap();
    }
    let mut cursor = Cursor::new();
    let mut u = stream(5);
    let mut found = 0;
    for walk in 0..40 {
        let start = DVec3::new(4.0 * u(), 4.0 * u(), 0.0);
        let open = u();
        for step in 0..30 {
            let x = start + DVec3::new(0.01 * step as f64, 0.004 * step as f64, 0.0);
            let n = DVec3::new(0.01 * u(), 0.0, 1.0);
            let mut indexed = [0.0f32; 3];
            let mut threaded = [0.0f32; 3];
            let mut explicit = [0.0f32; 3];
            let a = on.lookup_into_indexed_open(x, n, open, &mut indexed);
            let b = on.lookup_into_open(x, n, open, &mut threaded);
            let c = on.lookup_into_with_open(&mut cursor, x, n, open, &mut explicit);
            assert_eq!(a.is_ok(), b.is_ok(), "walk {walk} step {step}");
            assert_eq!(a.is_ok(), c.is_ok(), "walk {walk} step {step}");
            if let (Ok(a), Ok(b), Ok(c)) = (a, b, c) {
                assert_eq!((a, indexed), (b, threaded), "walk {walk} step {step}");
                assert_eq!((a, indexed), (c, explicit), "walk {walk} step {step}");
                found += 1;
            }
            let plain = off.lookup(x, n).ok();
            assert_eq!(off.lookup_open(x, n, open).ok(), plain, "the test off");
        }
    }
    assert!(found > 300, "only {found} covered queries");
}

#[test]
fn invalid_open_fractions_are_refused() {
    let cache = far_cache(OpenFractionTest::new(0.1), Interpolation::Ward);
    let mut record = records(1, 1).remove(0);
    for bad in [-0.01, 1.01, f64::NAN, f64::INFINITY] {
        record.open_fraction = Some(bad);
        assert!(matches!(
            cache.insert(&record),
            Err(Error::InvalidArgument(_))
        ));
        let x = record.position;
        assert!(matches!(
            cache.lookup_open(x, DVec3::Z, bad),
            Err(Error::InvalidArgument(_))
        ));
    }
    assert!(cache.is_empty());
    let mut cache = cache;
    for bad in [-0.1, f64::NAN] {
        assert!(cache
            .set_open_fraction_test(OpenFractionTest::new(bad))
            .is_err());
    }
    assert_eq!(cache.config().open_fraction_test.tolerance, 0.1);
    cache.set_open_fraction_test(OpenFractionTest::OFF).unwrap();
    assert!(!cache.config().open_fraction_test.is_on());
}

/// A ledge: a ceiling of radiance 1 at height 0.5 over x < 0, the sky (radiance 0.25) beyond;
/// rays longer than `max_distance` report a miss.
fn ledge(
    origin: DVec3,
    directions: &[DVec3],
    max_distance: f64,
    distance: &mut [f64],
    radiance: &mut [f32],
) -> Result<(), String> {
    for (i, w) in directions.iter().enumerate() {
        let t = (0.5 - origin.z) / w.z.max(1e-12);
        let under = (origin + t * *w).x < 0.0;
        let (d, l) = if under {
            (t, 1.0)
        } else {
            (f64::INFINITY, 0.25)
        };
        distance[i] = if d < max_distance { d } else { f64::INFINITY };
        radiance[3 * i..3 * i + 3].fill(l);
    }
    Ok(())
}

fn ledge_settings(test: OpenFractionTest) -> IrradianceSettings {
    let mut s = IrradianceSettings::new(3);
    (s.gather_m, s.gather_n) = (16, 48);
    s.radius_bounds = RadiusBounds::world(4.0, 4.0);
    s.near_field = NearFieldSettings {
        reach: FarFieldReach::world(1.0),
        m: 8,
        n: 8,
        open_fraction_test: test,
    };
    s
}

/// Under the ledge (x = −1) the ceiling is within the reach where cos θ > 1/2: open fraction 1/4.
/// At x = +1 nothing is within the reach: open fraction 1. A record made under the ledge covers
/// x = +1 (radius 4). Without the test the query there takes that record's far field, the mean
/// over the directions open under the ledge; with it the query makes its own record, whose value
/// is what a cache holding only that record gives.
#[test]
fn under_a_ledge_the_records_stay_under_it() {
    let (under, open) = (DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0));
    let plain = ledge_settings(OpenFractionTest::OFF);
    let tested = ledge_settings(OpenFractionTest::new(0.1));
    let calls = Cell::new(0);
    let counting = |o: DVec3, d: &[DVec3], m: f64, t: &mut [f64], l: &mut [f32]| {
        calls.set(calls.get() + 1);
        ledge(o, d, m, t, l)
    };

    let leaky: Cache<[f32; 3]> = Cache::new(plain.cache_config()).unwrap();
    let first = leaky
        .irradiance_near_far(&plain, under, DVec3::Z, 0.0, counting)
        .unwrap();
    assert_eq!(first.near.open_fraction, 0.25);
    let leaked = leaky
        .irradiance_near_far(&plain, open, DVec3::Z, 0.0, counting)
        .unwrap();
    assert_eq!(
        leaky.len(),
        1,
        "without the test the ledge's record covers x = +1"
    );
    assert_eq!(leaked.near.open_fraction, 1.0);
    assert_eq!(leaky.records()[0].open_fraction, None);

    let cache: Cache<[f32; 3]> = Cache::new(tested.cache_config()).unwrap();
    calls.set(0);
    cache
        .irradiance_near_far(&tested, under, DVec3::Z, 0.0, counting)
        .unwrap();
    assert_eq!(
        calls.get(),
        2,
        "a miss traces the near rays, then the gather"
    );
    calls.set(0);
    let own = cache
        .irradiance_near_far(&tested, open, DVec3::Z, 0.0, counting)
        .unwrap();
    assert_eq!(
        (calls.get(), cache.len()),
        (2, 2),
        "x = +1 makes its own record"
    );
    let mut kept: Vec<_> = cache.records().iter().map(|r| r.open_fraction).collect();
    kept.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(kept, [Some(0.25), Some(1.0)]);
    // the value a cache of x = +1's record alone gives
    let alone: Cache<[f32; 3]> = Cache::new(tested.cache_config()).unwrap();
    let want = alone
        .irradiance_near_far(&tested, open, DVec3::Z, 0.0, ledge)
        .unwrap();
    assert_eq!(own.value, want.value);
    // the leaked value is the ledge record's far field, far from x = +1's own
    let truth = want.value[0];
    assert!(
        (leaked.value[0] - truth).abs() > 0.05 * truth,
        "{leaked:?} vs {truth}"
    );
    // a hit traces the near rays only
    calls.set(0);
    let again = cache
        .irradiance_near_far(
            &tested,
            open + DVec3::new(0.01, 0.0, 0.0),
            DVec3::Z,
            0.0,
            counting,
        )
        .unwrap();
    assert_eq!((calls.get(), cache.len()), (1, 2));
    assert!(
        (again.value[0] - truth).abs() < 1e-2 * truth,
        "{again:?} vs {truth}"
    );
    // the settings and the cache must agree on the test
    let refused = cache.irradiance_near_far(&plain, open, DVec3::Z, 0.0, ledge);
    assert!(matches!(refused, Err(Error::InvalidArgument(m)) if m.contains("open-fraction")));
}
