//! Saving, loading and validating cache files: round trips, atomic replacement, and rejection of
//! every kind of damage (a proptest over mutated and truncated files shows `from_bytes` never
//! panics and never accepts a damaged file).

use glam::DVec3;
use proptest::prelude::*;
use raddiff::cache::{
    Cache, CacheConfig, Extent, FarFieldReach, LeakGuard, OpenFractionTest, Record,
};
use raddiff::Error;

fn sample(n: usize) -> Cache<[f32; 3]> {
    let c: Cache<[f32; 3]> = Cache::new(CacheConfig::surface(3)).unwrap();
    for i in 0..n {
        let x = i as f64 * 0.37;
        c.insert(&Record {
            position: DVec3::new(x, (i % 5) as f64, 0.0),
            normal: DVec3::new(0.1, 0.0, 1.0),
            value: [i as f32, 1.0, 0.5],
            gradient: Some([[0.5, 0.0, 0.1], [0.0; 3], [0.25; 3]]),
            rotation_gradient: Some([[0.0; 3], [0.3, 0.2, 0.1], [0.0; 3]]),
            extent: Extent {
                radii: [0.5, 1.0, 0.0],
                axes: [DVec3::X, DVec3::ZERO, DVec3::ZERO],
            },
            open_fraction: None,
        })
        .unwrap();
    }
    c
}

fn tmp_dir(name: &str) -> std::path::PathBuf {
    let d = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Rewrites the trailing checksum so that only the deeper validation can catch a change.
fn reseal(bytes: &mut [u8]) {
    let body = bytes.len() - 8;
    let sum = fnv(&bytes[..body]);
    bytes[body..].copy_from_slice(&sum.to_le_bytes());
}

/// Size of the version 9 header (records start here).
const HEADER: usize = 112;
/// Size of the version 8 and 7 headers: no coverage tolerance (offsets 104..112).
const HEADER_V8: usize = 104;
/// Size of the version 6 header: no lookup radius scale (offsets 96..104).
const HEADER_V6: usize = 96;
/// Size of the version 5 header: no open-fraction field (offsets 88..96).
const HEADER_V5: usize = 88;
/// Size of the version 4 header: no far-field fields (offsets 72..88).
const HEADER_V4: usize = 72;
/// Size of the version 3 header: no leak-guard fields either (offsets 56..72).
const HEADER_V3: usize = 56;

fn corrupt_reason(bytes: &[u8]) -> String {
    match Cache::<[f32; 3]>::from_bytes(bytes) {
        Err(Error::Corrupt(m)) => m,
        other => panic!("expected Corrupt, got {other:?}"),
    }
}

#[test]
fn save_load_round_trip_is_exact_and_atomic() {
    let dir = tmp_dir("cache_round_trip");
    let path = dir.join("irradiance.rdfcache");
    let c = sample(50);
    c.save(&path).unwrap();
    // overwrite in place: still exactly one file, no temporary left behind
    c.save(&path).unwrap();
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "{names:?}");
    let back = Cache::<[f32; 3]>::load(&path).unwrap();
    assert_eq!(back.len(), 50);
    assert_eq!(back.keys(), c.keys());
    assert_eq!(back.config(), c.config());
    assert_eq!(back.to_bytes(), std::fs::read(&path).unwrap());
    for i in 0..200 {
        let p = DVec3::new(i as f64 * 0.1, (i % 7) as f64 * 0.5, 0.0);
        let (a, b) = (c.lookup(p, DVec3::Z), back.lookup(p, DVec3::Z));
        assert_eq!(a.ok().map(|l| l.value), b.ok().map(|l| l.value));
    }
    // runtime channels read the same file
    let dynamic = Cache::<Vec<f32>>::load(&path).unwrap();
    assert_eq!(dynamic.config().channels, 3);
    // failures: I/O and wrong channel count
    assert!(matches!(
        c.save(dir.join("missing/dir/x.rdfcache")),
        Err(Error::Io(_))
    ));
    assert!(matches!(
        Cache::<f32>::load(dir.join("nope")),
        Err(Error::Io(_))
    ));
    match Cache::<f32>::load(&path) {
        Err(Error::Corrupt(m)) => assert!(m.contains("3-channel"), "{m}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn every_truncation_is_rejected() {
    let bytes = sample(3).to_bytes();
    for len in 0..bytes.len() {
        let m = corrupt_reason(&bytes[..len]);
        assert!(
            m.contains("truncated") || m.contains("length"),
            "{len}: {m}"
        );
    }
    let mut longer = bytes.clone();
    longer.push(0);
    corrupt_reason(&longer);
}

#[test]
fn header_and_record_damage_is_named() {
    let good = sample(4).to_bytes();
    let mut b = good.clone();
    b[0] = b'X';
    assert!(corrupt_reason(&b).contains("magic"));
    let mut b = good.clone();
    b[8] = 10;
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("version"));
    let mut b = good.clone();
    b[100] ^= 1;
    assert!(corrupt_reason(&b).contains("checksum"));
    // a header flag this version does not know (bit 0 is the non-negative flag, bit 1 the
    // gradient limit, bit 2 the leak guard, bit 3 the far field, bit 4 the open-fraction test;
    // bit 5, version 8's keeping coverage, is unknown too)
    let mut b = good.clone();
    b[44] = 64;
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("flags"));
    // a resealed file with a NaN radius (record 0 radii start at HEADER + 40)
    let mut b = good.clone();
    b[HEADER + 40..HEADER + 44].copy_from_slice(&f32::NAN.to_le_bytes());
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("radius"));
    // a frame quaternion that is not a rotation (record 0 quaternion at HEADER + 24)
    let mut b = good.clone();
    b[HEADER + 24..HEADER + 28].copy_from_slice(&2.0f32.to_le_bytes());
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("quaternion"));
    // a record's open fraction beyond 1 (its code at HEADER + 60: 0 none, else 1 + V·2³⁰)
    let mut b = good.clone();
    b[HEADER + 60..HEADER + 64].copy_from_slice(&((1u32 << 30) + 2).to_le_bytes());
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("open fraction"));
    // records swapped: no longer in content order
    let stride = 64 + 16 * 3;
    let mut b = good.clone();
    let (r0, r1) = (
        HEADER..HEADER + stride,
        HEADER + stride..HEADER + 2 * stride,
    );
    let first: Vec<u8> = b[r0.clone()].to_vec();
    b.copy_within(r1.clone(), r0.start);
    b[r1].copy_from_slice(&first);
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("increasing"));
    // a duplicated record is not increasing either
    let mut b = good.clone();
    b.copy_within(HEADER..HEADER + stride, HEADER + stride);
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("increasing"));
    // version 1 files are named as such
    let mut b = good.clone();
    b[8] = 1;
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("version 1"));
    // domain out of range
    let mut b = good.clone();
    b[16] = 9;
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("domain"));
}

/// The version 2 file of a cache without a gradient limit, leak guard, far field or open-fraction
/// test: the current file without the fields at offsets 48..112, version 2, resealed.
fn as_version_2(current: &[u8]) -> Vec<u8> {
    as_version(current, 48, 2)
}

/// The version 3 file of a cache without a leak guard or later fields: the current file without
/// the fields at offsets 56..112, version 3, resealed.
fn as_version_3(current: &[u8]) -> Vec<u8> {
    as_version(current, HEADER_V3, 3)
}

/// The version 4 file of a cache without a far field or open-fraction test: the current file
/// without the fields at offsets 72..112, version 4, resealed.
fn as_version_4(current: &[u8]) -> Vec<u8> {
    as_version(current, HEADER_V4, 4)
}

/// The version 5 file of a cache without an open-fraction test: the current file without the
/// tolerance, the scale and the coverage tolerance (offsets 88..112), version 5, resealed.
fn as_version_5(current: &[u8]) -> Vec<u8> {
    as_version(current, HEADER_V5, 5)
}

/// The version 6 file of a cache read over its records' own radii: the current file without the
/// lookup radius scale and the coverage tolerance (offsets 96..112), version 6, resealed.
fn as_version_6(current: &[u8]) -> Vec<u8> {
    as_version(current, HEADER_V6, 6)
}

/// The current file with its header cut to `header` bytes and its version set to `version`.
fn as_version(current: &[u8], header: usize, version: u32) -> Vec<u8> {
    let mut b = current[..header].to_vec();
    b.extend_from_slice(&current[HEADER..]);
    b[8..12].copy_from_slice(&version.to_le_bytes());
    reseal(&mut b);
    b
}

#[test]
fn gradient_limit_round_trips() {
    let config = CacheConfig::surface(3)
        .with_non_negative(true)
        .with_gradient_limit(0.75);
    let c: Cache<[f32; 3]> = Cache::new(config).unwrap();
    for r in sample(20).records() {
        c.insert(&r).unwrap();
    }
    let bytes = c.to_bytes();
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 9);
    assert_eq!(u32::from_le_bytes(bytes[44..48].try_into().unwrap()), 0b11);
    assert_eq!(f64::from_le_bytes(bytes[48..56].try_into().unwrap()), 0.75);
    let back = Cache::<[f32; 3]>::from_bytes(&bytes).unwrap();
    assert_eq!(back.config(), c.config());
    assert_eq!(back.keys(), c.keys());
    assert_eq!(back.to_bytes(), bytes);
    // the restored limit applies to the next insert as it did before saving
    let steep = Record {
        position: DVec3::new(100.0, 0.0, 0.0),
        normal: DVec3::Z,
        value: [1.0, 1.0, 1.0],
        gradient: Some([[500.0, 0.0, 0.0], [0.0; 3], [0.0; 3]]),
        rotation_gradient: None,
        extent: Extent::isotropic(1.0),
        open_fraction: None,
    };
    c.insert(&steep).unwrap();
    back.insert(&steep).unwrap();
    assert_eq!(back.keys(), c.keys());
    // no limit: flag clear and a zero field
    let plain = sample(3).to_bytes();
    assert_eq!(u32::from_le_bytes(plain[44..48].try_into().unwrap()), 0);
    assert_eq!(u64::from_le_bytes(plain[48..56].try_into().unwrap()), 0);
    assert_eq!(
        Cache::<[f32; 3]>::from_bytes(&plain)
            .unwrap()
            .config()
            .gradient_limit,
        f64::INFINITY
    );
    // invalid limit fields
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let mut b = bytes.clone();
        b[48..56].copy_from_slice(&f64::to_le_bytes(bad));
        reseal(&mut b);
        assert!(corrupt_reason(&b).contains("gradient limit"), "{bad}");
    }
    let mut b = plain.clone();
    b[48..56].copy_from_slice(&1.0f64.to_le_bytes());
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("flag is not set"));
}

#[test]
fn version_2_files_still_load() {
    let c = sample(30);
    let v5 = c.to_bytes();
    let v2 = as_version_2(&v5);
    assert_eq!(v2.len(), v5.len() - (HEADER - 48));
    let back = Cache::<[f32; 3]>::from_bytes(&v2).unwrap();
    assert_eq!(back.config(), c.config());
    assert_eq!(back.config().gradient_limit, f64::INFINITY);
    assert_eq!(back.keys(), c.keys());
    // saved again, it is the current file of the same cache
    assert_eq!(back.to_bytes(), v5);
    // the non-negative flag still reads from version 2
    let nn: Cache<[f32; 3]> = Cache::new(CacheConfig::surface(3).with_non_negative(true)).unwrap();
    let v2 = as_version_2(&nn.to_bytes());
    assert!(
        Cache::<[f32; 3]>::from_bytes(&v2)
            .unwrap()
            .config()
            .non_negative
    );
    // version 2 had no gradient-limit flag: bit 1 is unknown there
    let mut b = as_version_2(&v5);
    b[44] = 2;
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("flags"));
    // every truncation of a version 2 file is rejected
    let small = as_version_2(&sample(2).to_bytes());
    for len in 0..small.len() {
        let m = corrupt_reason(&small[..len]);
        assert!(
            m.contains("truncated") || m.contains("length"),
            "{len}: {m}"
        );
    }
}

/// Version 3 files (written before the leak guard existed) load with the guard off and keep
/// their gradient limit; version 3 knows no leak-guard flag.
#[test]
fn version_3_files_load_with_the_leak_guard_off() {
    let limited: Cache<[f32; 3]> =
        Cache::new(CacheConfig::surface(3).with_gradient_limit(2.0)).unwrap();
    for r in sample(12).records() {
        limited.insert(&r).unwrap();
    }
    let v5 = limited.to_bytes();
    let v3 = as_version_3(&v5);
    assert_eq!(v3.len(), v5.len() - (HEADER - HEADER_V3));
    let back = Cache::<[f32; 3]>::from_bytes(&v3).unwrap();
    assert_eq!(back.config(), limited.config());
    assert_eq!(back.config().leak_guard, LeakGuard::OFF);
    assert_eq!(back.config().gradient_limit, 2.0);
    assert_eq!(back.keys(), limited.keys());
    assert_eq!(back.to_bytes(), v5);
    let mut b = v3.clone();
    b[44] |= 4;
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("flags"));
    for len in 0..v3.len() {
        let m = corrupt_reason(&v3[..len]);
        assert!(
            m.contains("truncated") || m.contains("length"),
            "{len}: {m}"
        );
    }
}

/// The leak guard is cache state: saved (flag bit 2, tolerances at offsets 56 and 64), restored,
/// and the restored cache answers every lookup as the saved one did.
#[test]
fn leak_guard_round_trips() {
    let guard = LeakGuard {
        relative: 0.25,
        absolute: 0.01,
    };
    let c: Cache<[f32; 3]> = Cache::new(CacheConfig::surface(3).with_leak_guard(guard)).unwrap();
    for r in sample(20).records() {
        c.insert(&r).unwrap();
    }
    let bytes = c.to_bytes();
    assert_eq!(u32::from_le_bytes(bytes[44..48].try_into().unwrap()), 0b100);
    assert_eq!(f64::from_le_bytes(bytes[56..64].try_into().unwrap()), 0.25);
    assert_eq!(f64::from_le_bytes(bytes[64..72].try_into().unwrap()), 0.01);
    let back = Cache::<[f32; 3]>::from_bytes(&bytes).unwrap();
    assert_eq!(back.config().leak_guard, guard);
    assert_eq!(back.to_bytes(), bytes);
    let mut refused = 0;
    for i in 0..400 {
        // queries above and below the records' plane (their normal is (0.1, 0, 1))
        let p = DVec3::new(
            i as f64 * 0.02,
            (i % 9) as f64 * 0.5,
            (i % 5) as f64 * 0.1 - 0.2,
        );
        let (a, b) = (c.lookup(p, DVec3::Z), back.lookup(p, DVec3::Z));
        assert_eq!(a.ok().map(|l| l.value), b.ok().map(|l| l.value));
        refused += c.lookup(p, DVec3::Z).is_err() as usize;
    }
    assert!(
        refused > 0,
        "the guard never refused a query below the records"
    );
    // no guard: flag clear and zero fields; fields without the flag are damage
    let plain = sample(3).to_bytes();
    assert_eq!(u32::from_le_bytes(plain[44..48].try_into().unwrap()), 0);
    assert_eq!(u128::from_le_bytes(plain[56..72].try_into().unwrap()), 0);
    let mut b = plain.clone();
    b[56..64].copy_from_slice(&0.5f64.to_le_bytes());
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("leak guard"));
    for (relative, absolute) in [(-1.0, 0.0), (f64::NAN, 0.0), (0.1, f64::INFINITY)] {
        let mut b = bytes.clone();
        b[56..64].copy_from_slice(&relative.to_le_bytes());
        b[64..72].copy_from_slice(&f64::to_le_bytes(absolute));
        reseal(&mut b);
        assert!(
            corrupt_reason(&b).contains("leak guard"),
            "{relative} {absolute}"
        );
    }
}

/// Version 4 files (written before the far-field marker existed) load with it off and keep their
/// leak guard; version 4 knows no far-field flag.
#[test]
fn version_4_files_load_without_far_fields() {
    let guard = LeakGuard::relative(0.5);
    let guarded: Cache<[f32; 3]> =
        Cache::new(CacheConfig::surface(3).with_leak_guard(guard)).unwrap();
    for r in sample(12).records() {
        guarded.insert(&r).unwrap();
    }
    let v5 = guarded.to_bytes();
    let v4 = as_version_4(&v5);
    assert_eq!(v4.len(), v5.len() - (HEADER - HEADER_V4));
    let back = Cache::<[f32; 3]>::from_bytes(&v4).unwrap();
    assert_eq!(back.config(), guarded.config());
    assert_eq!(back.config().far_field, FarFieldReach::OFF);
    assert_eq!(back.config().leak_guard, guard);
    assert_eq!(back.keys(), guarded.keys());
    assert_eq!(back.to_bytes(), v5);
    let mut b = v4.clone();
    b[44] |= 8;
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("flags"));
    for len in 0..v4.len() {
        let m = corrupt_reason(&v4[..len]);
        assert!(
            m.contains("truncated") || m.contains("length"),
            "{len}: {m}"
        );
    }
}

/// The far-field marker is cache state: saved (flag bit 3, reaches at offsets 72 and 80) and
/// restored; fields without the flag, or a flag with no positive finite reach, are damage.
#[test]
fn far_field_marker_round_trips() {
    let reach = FarFieldReach {
        world: 0.05,
        pixels: 8.0,
    };
    let c: Cache<[f32; 3]> = Cache::new(CacheConfig::surface(3).with_far_field(reach)).unwrap();
    for r in sample(20).records() {
        c.insert(&r).unwrap();
    }
    let bytes = c.to_bytes();
    assert_eq!(
        u32::from_le_bytes(bytes[44..48].try_into().unwrap()),
        0b1000
    );
    assert_eq!(f64::from_le_bytes(bytes[72..80].try_into().unwrap()), 0.05);
    assert_eq!(f64::from_le_bytes(bytes[80..88].try_into().unwrap()), 8.0);
    let back = Cache::<[f32; 3]>::from_bytes(&bytes).unwrap();
    assert_eq!(back.config().far_field, reach);
    assert_eq!(back.config(), c.config());
    assert_eq!(back.keys(), c.keys());
    assert_eq!(back.to_bytes(), bytes);
    // no far field: flag clear and zero fields; fields without the flag are damage
    let plain = sample(3).to_bytes();
    assert_eq!(u32::from_le_bytes(plain[44..48].try_into().unwrap()), 0);
    assert_eq!(u128::from_le_bytes(plain[72..88].try_into().unwrap()), 0);
    let mut b = plain.clone();
    b[80..88].copy_from_slice(&4.0f64.to_le_bytes());
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("far-field"));
    for (world, pixels) in [
        (-1.0, 0.0),
        (f64::NAN, 1.0),
        (0.0, f64::INFINITY),
        (0.0, 0.0),
    ] {
        let mut b = bytes.clone();
        b[72..80].copy_from_slice(&f64::to_le_bytes(world));
        b[80..88].copy_from_slice(&f64::to_le_bytes(pixels));
        reseal(&mut b);
        assert!(corrupt_reason(&b).contains("far-field"), "{world} {pixels}");
    }
    // an invalid reach is refused when the cache is made
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let config = CacheConfig::surface(3).with_far_field(FarFieldReach::pixels(bad));
        assert!(matches!(
            Cache::<[f32; 3]>::new(config),
            Err(Error::InvalidArgument(_))
        ));
    }
}

/// Version 5 files (written before the open-fraction test existed) load with it off and keep
/// their far-field marker; version 5 knows no open-fraction flag, and its records' last head
/// field is reserved (0).
#[test]
fn version_5_files_load_without_open_fractions() {
    let reach = FarFieldReach::pixels(8.0);
    let far: Cache<[f32; 3]> = Cache::new(CacheConfig::surface(3).with_far_field(reach)).unwrap();
    for r in sample(12).records() {
        far.insert(&r).unwrap();
    }
    let current = far.to_bytes();
    let v5 = as_version_5(&current);
    assert_eq!(v5.len(), current.len() - (HEADER - HEADER_V5));
    let back = Cache::<[f32; 3]>::from_bytes(&v5).unwrap();
    assert_eq!(back.config(), far.config());
    assert_eq!(back.config().open_fraction_test, OpenFractionTest::OFF);
    assert_eq!(back.config().far_field, reach);
    assert_eq!(back.keys(), far.keys());
    assert_eq!(back.to_bytes(), current);
    let mut b = v5.clone();
    b[44] |= 16;
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("flags"));
    // a version 5 record whose reserved field holds what version 6 reads as an open fraction
    let mut b = v5.clone();
    b[HEADER_V5 + 60] = 1;
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("reserved"));
    for len in 0..v5.len() {
        let m = corrupt_reason(&v5[..len]);
        assert!(
            m.contains("truncated") || m.contains("length"),
            "{len}: {m}"
        );
    }
}

/// Looks up 400 queries over the sample's records with open fractions 0 to 1 in `c` and in
/// `back`, asserts the same answers, and counts the queries for which `mark` (the query's
/// position and open fraction, and whether `c` found records) holds.
fn same_open_answers(
    c: &Cache<[f32; 3]>,
    back: &Cache<[f32; 3]>,
    mut mark: impl FnMut(DVec3, f64, bool) -> bool,
) -> usize {
    let mut marked = 0;
    for i in 0..400 {
        let p = DVec3::new(i as f64 * 0.02, (i % 9) as f64 * 0.5, 0.0);
        let open = (i % 11) as f64 / 10.0;
        let (a, b) = (
            c.lookup_open(p, DVec3::Z, open),
            back.lookup_open(p, DVec3::Z, open),
        );
        assert_eq!(a.as_ref().ok().map(|l| l.value), b.ok().map(|l| l.value));
        marked += usize::from(mark(p, open, a.is_ok()));
    }
    marked
}

/// The open-fraction test is cache state (flag bit 4, tolerance at offset 88) and each record's
/// open fraction is stored with it (the head's last field): the restored cache answers every
/// lookup as the saved one did, and damage to either is named.
#[test]
fn open_fraction_test_round_trips() {
    let test = OpenFractionTest::new(0.125);
    let config = CacheConfig::surface(3)
        .with_far_field(FarFieldReach::world(0.5))
        .with_open_fraction_test(test);
    let c: Cache<[f32; 3]> = Cache::new(config).unwrap();
    for (i, mut r) in sample(20).records().into_iter().enumerate() {
        // open fractions 0, 1/8, ..., 7/8 and one record without
        r.open_fraction = (i != 7).then_some((i % 8) as f64 / 8.0);
        c.insert(&r).unwrap();
    }
    let bytes = c.to_bytes();
    assert_eq!(
        u32::from_le_bytes(bytes[44..48].try_into().unwrap()),
        0b11000
    );
    assert_eq!(f64::from_le_bytes(bytes[88..96].try_into().unwrap()), 0.125);
    let back = Cache::<[f32; 3]>::from_bytes(&bytes).unwrap();
    assert_eq!(back.config(), c.config());
    assert_eq!(back.keys(), c.keys());
    assert_eq!(back.to_bytes(), bytes);
    let mut records = back.records();
    records.sort_by(|a, b| a.value[0].total_cmp(&b.value[0]));
    for (i, r) in records.iter().enumerate() {
        assert_eq!(r.open_fraction, (i != 7).then_some((i % 8) as f64 / 8.0));
    }
    let refused = same_open_answers(&c, &back, |p, _, found| {
        !found && c.lookup(p, DVec3::Z).is_ok()
    });
    assert!(refused > 0, "the test never refused a record");
    // no test: flag clear and a zero field; the field without the flag is damage
    let plain = sample(3).to_bytes();
    assert_eq!(u64::from_le_bytes(plain[88..96].try_into().unwrap()), 0);
    let mut b = plain.clone();
    b[88..96].copy_from_slice(&0.5f64.to_le_bytes());
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("open-fraction"));
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let mut b = bytes.clone();
        b[88..96].copy_from_slice(&f64::to_le_bytes(bad));
        reseal(&mut b);
        assert!(corrupt_reason(&b).contains("open-fraction"), "{bad}");
    }
    for bad in [-0.5, f64::NAN] {
        let config = CacheConfig::surface(3).with_open_fraction_test(OpenFractionTest::new(bad));
        assert!(matches!(
            Cache::<[f32; 3]>::new(config),
            Err(Error::InvalidArgument(_))
        ));
    }
}

/// The version 8 file of a cache whose open-fraction test keeps all coverage or none: the
/// current file without the coverage tolerance (offsets 104..112), flag bit 5 set for an
/// infinite one, version 8, resealed.
fn as_version_8(current: &[u8]) -> Vec<u8> {
    let coverage = f64::from_le_bytes(current[104..112].try_into().unwrap());
    let mut b = as_version(current, HEADER_V8, 8);
    if coverage == f64::INFINITY {
        b[44] |= 32;
        reseal(&mut b);
    }
    b
}

/// The open-fraction test's coverage tolerance is cache state (offset 104, version 9): it
/// round-trips, the restored cache answers the queries that every record's open fraction refuses
/// as the saved one did, a NaN or negative one and the version 8 flag are damage, and it is
/// kept with the test off.
#[test]
fn coverage_tolerance_round_trips() {
    for coverage in [0.3, f64::INFINITY] {
        let test = OpenFractionTest::new(0.125).with_coverage_tolerance(coverage);
        let config = CacheConfig::surface(3)
            .with_far_field(FarFieldReach::world(0.5))
            .with_open_fraction_test(test);
        let c: Cache<[f32; 3]> = Cache::new(config).unwrap();
        for (i, mut r) in sample(20).records().into_iter().enumerate() {
            r.open_fraction = Some((i % 8) as f64 / 8.0);
            c.insert(&r).unwrap();
        }
        let bytes = c.to_bytes();
        assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 9);
        assert_eq!(
            u32::from_le_bytes(bytes[44..48].try_into().unwrap()),
            0b11000
        );
        assert_eq!(
            f64::from_le_bytes(bytes[104..112].try_into().unwrap()),
            coverage
        );
        let back = Cache::<[f32; 3]>::from_bytes(&bytes).unwrap();
        assert_eq!(back.config().open_fraction_test, test);
        assert_eq!(back.to_bytes(), bytes);
        let uncovering =
            Cache::<[f32; 3]>::new(config.with_open_fraction_test(OpenFractionTest::new(0.125)))
                .unwrap();
        for r in c.records() {
            uncovering.insert(&r).unwrap();
        }
        let kept = same_open_answers(&c, &back, |p, open, found| {
            found && uncovering.lookup_open(p, DVec3::Z, open).is_err()
        });
        assert!(kept > 0, "{coverage}: no query was kept covered");
        for bad in [-0.25, f64::NAN, f64::NEG_INFINITY] {
            let mut b = bytes.clone();
            b[104..112].copy_from_slice(&f64::to_le_bytes(bad));
            reseal(&mut b);
            assert!(corrupt_reason(&b).contains("coverage tolerance"), "{bad}");
        }
        // version 9 knows no keep-coverage flag
        let mut b = bytes.clone();
        b[44] |= 32;
        reseal(&mut b);
        assert!(corrupt_reason(&b).contains("flags"));
    }
    // kept with the test off, for a test turned on later
    let off = OpenFractionTest::OFF.with_coverage_tolerance(0.3);
    let c: Cache<[f32; 3]> =
        Cache::new(CacheConfig::surface(3).with_open_fraction_test(off)).unwrap();
    let back = Cache::<[f32; 3]>::from_bytes(&c.to_bytes()).unwrap();
    assert_eq!(back.config().open_fraction_test, off);
}

/// Version 8 files keep all coverage (flag bit 5) or none: they load with an infinite coverage
/// tolerance or 0, the flag without the test's is damage, and a version 7 file knows no such flag
/// (and loads with the test uncovering, every other field as saved).
#[test]
fn version_8_files_keep_all_coverage_or_none() {
    let config = CacheConfig::surface(3).with_far_field(FarFieldReach::world(0.5));
    let with = |test: OpenFractionTest| {
        let c: Cache<[f32; 3]> = Cache::new(config.with_open_fraction_test(test)).unwrap();
        for (i, mut r) in sample(20).records().into_iter().enumerate() {
            r.open_fraction = Some((i % 8) as f64 / 8.0);
            c.insert(&r).unwrap();
        }
        c
    };
    let keeping = with(OpenFractionTest::new(0.125).keeping_coverage());
    let v8 = as_version_8(&keeping.to_bytes());
    assert_eq!(u32::from_le_bytes(v8[44..48].try_into().unwrap()), 0b111000);
    let back = Cache::<[f32; 3]>::from_bytes(&v8).unwrap();
    assert_eq!(back.config(), keeping.config());
    assert_eq!(back.to_bytes(), keeping.to_bytes());
    let uncovering = with(OpenFractionTest::new(0.125));
    let back = Cache::<[f32; 3]>::from_bytes(&as_version_8(&uncovering.to_bytes())).unwrap();
    assert_eq!(back.config(), uncovering.config());
    // the flag without the test's
    let mut b = as_version_8(&sample(3).to_bytes());
    b[44] |= 32;
    reseal(&mut b);
    assert!(corrupt_reason(&b).contains("keep-coverage"));
    // version 7: the same header, flag bit 5 unknown
    let mut v7 = v8.clone();
    v7[8..12].copy_from_slice(&7u32.to_le_bytes());
    reseal(&mut v7);
    assert!(corrupt_reason(&v7).contains("flags"));
    v7[44] &= !32;
    reseal(&mut v7);
    let back = Cache::<[f32; 3]>::from_bytes(&v7).unwrap();
    assert_eq!(
        back.config().open_fraction_test,
        OpenFractionTest::new(0.125)
    );
    assert_eq!(back.config().far_field, keeping.config().far_field);
    assert_eq!(back.keys(), keeping.keys());
}

/// The lookup radius scale is cache state (offset 96, version 7): the restored cache answers
/// every lookup as the saved one did, and a scale outside [1, 8] is damage.
#[test]
fn lookup_radius_scale_round_trips() {
    let config = CacheConfig::surface(3).with_lookup_radius_scale(1.75);
    let c: Cache<[f32; 3]> = Cache::new(config).unwrap();
    for r in sample(20).records() {
        c.insert(&r).unwrap();
    }
    let bytes = c.to_bytes();
    assert_eq!(f64::from_le_bytes(bytes[96..104].try_into().unwrap()), 1.75);
    let back = Cache::<[f32; 3]>::from_bytes(&bytes).unwrap();
    assert_eq!(back.config().lookup_radius_scale, 1.75);
    assert_eq!(back.config(), c.config());
    assert_eq!(back.to_bytes(), bytes);
    let unscaled = sample(20);
    let mut wider = 0;
    for i in 0..400 {
        let p = DVec3::new(i as f64 * 0.02, (i % 9) as f64 * 0.5, 0.0);
        let (a, b) = (c.lookup(p, DVec3::Z), back.lookup(p, DVec3::Z));
        assert_eq!(a.as_ref().ok().map(|l| l.value), b.ok().map(|l| l.value));
        let at_one = unscaled.lookup(p, DVec3::Z);
        assert_eq!(a.is_ok(), at_one.is_ok(), "misses must not move: {p}");
        if let (Ok(a), Ok(one)) = (a, at_one) {
            wider += (a.records > one.records) as usize;
        }
    }
    assert!(wider > 0, "the scale never blended a further record");
    // the unscaled cache writes 1.0
    assert_eq!(
        f64::from_le_bytes(sample(3).to_bytes()[96..104].try_into().unwrap()),
        1.0
    );
    for bad in [0.0, 0.5, 8.5, -1.0, f64::NAN, f64::INFINITY] {
        let mut b = bytes.clone();
        b[96..104].copy_from_slice(&f64::to_le_bytes(bad));
        reseal(&mut b);
        assert!(corrupt_reason(&b).contains("lookup radius scale"), "{bad}");
    }
}

/// Version 6 files (before the lookup radius scale) load with scale 1, their records and every
/// other field as saved.
#[test]
fn version_6_files_load_with_scale_one() {
    let test = OpenFractionTest::new(0.25);
    let config = CacheConfig::surface(3)
        .with_far_field(FarFieldReach::world(0.5))
        .with_open_fraction_test(test)
        .with_lookup_radius_scale(2.0);
    let c: Cache<[f32; 3]> = Cache::new(config).unwrap();
    for (i, mut r) in sample(12).records().into_iter().enumerate() {
        r.open_fraction = Some((i % 4) as f64 / 4.0);
        c.insert(&r).unwrap();
    }
    let v6 = as_version_6(&c.to_bytes());
    let back = Cache::<[f32; 3]>::from_bytes(&v6).unwrap();
    assert_eq!(back.config().lookup_radius_scale, 1.0);
    assert_eq!(back.config().open_fraction_test, test);
    assert_eq!(back.config().far_field, FarFieldReach::world(0.5));
    assert_eq!(back.keys(), c.keys());
    // every truncation of a version 6 file is rejected
    for len in 0..v6.len() {
        let m = corrupt_reason(&v6[..len]);
        assert!(
            m.contains("truncated") || m.contains("length"),
            "{len}: {m}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn mutated_files_never_panic_and_are_never_accepted(
        flips in proptest::collection::vec((any::<prop::sample::Index>(), 1u8..=255), 1..4),
        cut in any::<prop::sample::Index>(),
        mode in 0u8..4,
        reseal_after in any::<bool>(),
        junk in proptest::collection::vec(any::<u8>(), 1..16),
    ) {
        let good = sample(6).to_bytes();
        let mut b = good.clone();
        match mode {
            0 => for (i, x) in &flips { let i = i.index(b.len()); b[i] ^= x; },
            1 => b.truncate(cut.index(b.len())),
            2 => { let i = cut.index(b.len()); b.splice(i..i, junk.iter().copied()); }
            _ => { for (i, x) in &flips { let i = i.index(b.len()); b[i] ^= x; } b.truncate(cut.index(b.len()) + 1); }
        }
        if reseal_after && b.len() >= 8 {
            reseal(&mut b);
        }
        let result = std::panic::catch_unwind(|| Cache::<[f32; 3]>::from_bytes(&b));
        prop_assert!(result.is_ok(), "from_bytes panicked");
        if b != good {
            match result.unwrap() {
                Err(Error::Corrupt(_)) => {}
                // only a file whose checksum was recomputed after the damage can pass, and only if
                // every field is still valid: it is then exactly the file this library writes for
                // the cache it loaded (nothing out of range, out of order or non-canonical)
                Ok(c) => {
                    prop_assert!(reseal_after, "damaged file accepted ({} records)", c.len());
                    prop_assert_eq!(c.to_bytes(), b.clone());
                    for r in c.records() {
                        prop_assert!(c.lookup(r.position, r.normal).is_ok());
                    }
                }
                Err(e) => prop_assert!(false, "unexpected error {e}"),
            }
        }
    }
}
