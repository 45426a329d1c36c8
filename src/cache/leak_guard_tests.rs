//! The leak guard in lookups: a step and a concave crease, every interpolation scheme, and the
//! cursor, vector and index paths agreeing bit for bit with it on.

use glam::DVec3;

use super::tests::lcg;
use super::*;

/// A one-channel surface record of value `value`, radius `r`, no gradients.
fn disc(position: DVec3, normal: DVec3, value: f32, r: f64) -> Record<f32> {
    Record::new(position, normal, value, Extent::isotropic(r))
}

fn guarded_cache(interpolation: Interpolation, guard: LeakGuard) -> Cache<f32> {
    let config = CacheConfig::surface(1)
        .with_interpolation(interpolation)
        .with_leak_guard(guard);
    Cache::new(config).unwrap()
}

/// A step of height 0.2 at x = 0: the upper floor (x > 0) at z = 0.2, the lower one at z = 0, both
/// facing +z. A record on the upper floor 0.05 from the edge must not be used on the lower floor
/// (the lower floor sees the step's riser, the record does not); a record on the lower floor is
/// still used on the upper floor (the query lies above it).
#[test]
fn a_step_refuses_the_upper_record_below_it() {
    let upper = disc(DVec3::new(0.05, 0.0, 0.2), DVec3::Z, 2.0, 0.5);
    let lower = disc(DVec3::new(-0.05, 0.0, 0.0), DVec3::Z, 1.0, 0.5);
    let below = DVec3::new(-0.1, 0.0, 0.0);
    let above = DVec3::new(0.1, 0.0, 0.2);
    for interpolation in [Interpolation::Ward, Interpolation::Tent] {
        let open = guarded_cache(interpolation, LeakGuard::OFF);
        // tolerance 0.1·0.5 = 0.05 < the step's 0.2
        let guarded = guarded_cache(interpolation, LeakGuard::relative(0.1));
        open.insert(&upper).unwrap();
        guarded.insert(&upper).unwrap();
        assert_eq!(open.lookup(below, DVec3::Z).unwrap().value, 2.0);
        assert!(matches!(
            guarded.lookup(below, DVec3::Z),
            Err(Error::NotFound(_))
        ));
        assert!(matches!(
            guarded.lookup_indexed(below, DVec3::Z),
            Err(Error::NotFound(_))
        ));
        // a tolerance above the step's height lets it through again
        let lenient = guarded_cache(interpolation, LeakGuard::relative(0.41));
        lenient.insert(&upper).unwrap();
        assert_eq!(lenient.lookup(below, DVec3::Z).unwrap().value, 2.0);
        let lenient = guarded_cache(
            interpolation,
            LeakGuard {
                relative: 0.0,
                absolute: 0.2,
            },
        );
        lenient.insert(&upper).unwrap();
        assert_eq!(lenient.lookup(below, DVec3::Z).unwrap().value, 2.0);
        // the lower record serves the upper floor in both caches
        guarded.insert(&lower).unwrap();
        let l = guarded.lookup(above, DVec3::Z).unwrap();
        assert_eq!(l.records, 2, "{interpolation:?}");
        let l = guarded.lookup(below, DVec3::Z).unwrap();
        assert_eq!((l.records, l.value), (1, 1.0), "{interpolation:?}");
    }
}

/// Around a concave crease (a floor meeting a 25° ramp) with records on both sides, every lookup
/// with the guard equals the lookup without it over the records that pass the test computed here
/// from its definition, and the vector, cursor and index paths agree bit for bit.
#[test]
fn a_crease_matches_the_definition_on_every_path() {
    let ramp_normal = DVec3::new(-(25f64.to_radians().sin()), 0.0, 25f64.to_radians().cos());
    let on_floor = |x: f64, y: f64| (DVec3::new(x, y, 0.0), DVec3::Z);
    let on_ramp = |x: f64, y: f64| (DVec3::new(x, y, x * 25f64.to_radians().tan()), ramp_normal);
    let mut rand = lcg(17);
    let mut records = Vec::new();
    for i in 0..40 {
        let (x, y) = (rand() * 2.0 - 1.0, rand() * 2.0 - 1.0);
        let (p, n) = if x < 0.0 {
            on_floor(x, y)
        } else {
            on_ramp(x, y)
        };
        // values differ per record so that any difference in the set used shows
        records.push(disc(p, n, 1.0 + i as f32, 0.2 + 0.4 * rand()));
    }
    let guard = LeakGuard {
        relative: 0.05,
        absolute: 0.002,
    };
    for interpolation in [Interpolation::Ward, Interpolation::Tent, Interpolation::Log] {
        // the deviation limit must let the two planes see each other for the guard to matter
        let config = CacheConfig::surface(1).with_interpolation(interpolation);
        let config = CacheConfig {
            max_normal_deviation: 0.6,
            ..config
        };
        let guarded: Cache<f32> = Cache::new(config.with_leak_guard(guard)).unwrap();
        for r in &records {
            guarded.insert(r).unwrap();
        }
        // the normals and radii as stored (the guard reads those)
        let stored: Vec<(DVec3, f64)> = records
            .iter()
            .map(|r| {
                let s = guarded
                    .records()
                    .into_iter()
                    .find(|s| s.position == r.position);
                let s = s.expect("every record is stored");
                (s.normal, s.extent.radii[2])
            })
            .collect();
        let (mut refused, mut compared) = (0, 0);
        let mut cursor = Cursor::new();
        for k in 0..600 {
            let (x, y) = (k as f64 / 300.0 - 1.0, 0.3 * ((k % 7) as f64 - 3.0) / 3.0);
            let (q, n) = if x < 0.0 {
                on_floor(x, y)
            } else {
                on_ramp(x, y)
            };
            // the records the guard admits, by its definition
            let reference: Cache<f32> = Cache::new(config).unwrap();
            let unit = n / n.length();
            for (r, &(rn, rr)) in records.iter().zip(&stored) {
                let height = (q - r.position).dot(unit + rn) * 0.5;
                if height >= -(guard.relative * rr + guard.absolute) {
                    reference.insert(r).unwrap();
                } else if (q - r.position).length() < r.extent.radii[0] {
                    refused += 1;
                }
            }
            let expected = reference
                .lookup_indexed(q, n)
                .ok()
                .map(|l| l.value.to_bits());
            let indexed = guarded.lookup_indexed(q, n).ok().map(|l| l.value.to_bits());
            let through_thread_cursor = guarded.lookup(q, n).ok().map(|l| l.value.to_bits());
            let through_cursor = guarded
                .lookup_with(&mut cursor, q, n)
                .ok()
                .map(|l| l.value.to_bits());
            assert_eq!(indexed, expected, "{interpolation:?} at {q}");
            assert_eq!(through_thread_cursor, expected, "{interpolation:?} at {q}");
            assert_eq!(through_cursor, expected, "{interpolation:?} at {q}");
            compared += expected.is_some() as usize;
        }
        assert!(refused > 50, "{interpolation:?}: only {refused} refusals");
        assert!(
            compared > 300,
            "{interpolation:?}: only {compared} covered queries"
        );
    }
}

/// Volume records have no normal: the guard changes nothing there.
#[test]
fn volumes_ignore_the_guard() {
    let config = CacheConfig::volume(1).with_leak_guard(LeakGuard::relative(0.0));
    let c: Cache<f32> = Cache::new(config).unwrap();
    c.insert(&disc(DVec3::ZERO, DVec3::ZERO, 3.0, 1.0)).unwrap();
    assert_eq!(
        c.lookup(DVec3::new(0.0, 0.0, -0.5), DVec3::Z)
            .unwrap()
            .value,
        3.0
    );
}

#[test]
fn set_leak_guard_validates_and_applies() {
    let mut c = guarded_cache(Interpolation::Ward, LeakGuard::OFF);
    c.insert(&disc(DVec3::new(0.0, 0.0, 0.2), DVec3::Z, 2.0, 0.5))
        .unwrap();
    let below = DVec3::new(0.1, 0.0, 0.0);
    assert!(c.lookup(below, DVec3::Z).is_ok());
    c.set_leak_guard(LeakGuard::relative(0.1)).unwrap();
    assert_eq!(c.config().leak_guard, LeakGuard::relative(0.1));
    assert!(c.lookup(below, DVec3::Z).is_err());
    assert!(c.set_leak_guard(LeakGuard::relative(f64::NAN)).is_err());
    assert!(c.set_leak_guard(LeakGuard::relative(-0.1)).is_err());
    assert_eq!(c.config().leak_guard, LeakGuard::relative(0.1));
    c.set_leak_guard(LeakGuard::OFF).unwrap();
    assert!(c.lookup(below, DVec3::Z).is_ok());
    assert!(
        Cache::<f32>::new(CacheConfig::surface(1).with_leak_guard(LeakGuard {
            relative: 0.1,
            absolute: -1.0
        }))
        .is_err()
    );
}
