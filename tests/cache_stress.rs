//! 8 threads insert and look up at once; the result must equal a single-threaded replay.
//!
//! `RADDIFF_CACHE_STRESS=<records per thread>` runs a bigger instance (default 800).

use std::sync::Barrier;

use glam::DVec3;
use raddiff::cache::{Cache, CacheConfig, Extent, Interpolation, Record};

const THREADS: usize = 8;

fn per_thread() -> usize {
    std::env::var("RADDIFF_CACHE_STRESS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(800)
}

fn hash(mut x: u64) -> u64 {
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d049bb133111eb);
    x ^ (x >> 31)
}

fn unit(seed: u64) -> f64 {
    (hash(seed) >> 11) as f64 / (1u64 << 53) as f64
}

/// Record `i` of thread `t`; every 7th repeats another thread's record (a duplicate insert race).
fn record(t: usize, i: usize) -> Record<[f32; 3]> {
    let (t, i) = if i % 7 == 3 {
        ((t + 1) % THREADS, i - 1)
    } else {
        (t, i)
    };
    let s = (t * 1_000_003 + i) as u64 * 16;
    let p = DVec3::new(unit(s) * 20.0, unit(s + 1) * 20.0, unit(s + 2) * 0.2);
    let n = DVec3::new(unit(s + 3) - 0.5, unit(s + 4) - 0.5, 4.0);
    let v = [
        unit(s + 5) as f32,
        unit(s + 6) as f32,
        1.0 + unit(s + 7) as f32,
    ];
    let g = [unit(s + 8) as f32 - 0.5, unit(s + 9) as f32 - 0.5, 0.0];
    let r0 = 0.3 + unit(s + 10);
    Record {
        position: p,
        normal: n,
        value: v,
        gradient: Some([[g[0]; 3], [g[1]; 3], [g[2]; 3]]),
        rotation_gradient: Some([[0.2, 0.1, 0.0], [0.0; 3], [0.1; 3]]),
        extent: Extent {
            radii: [r0, r0 * (1.0 + unit(s + 11)), 0.0],
            axes: [
                DVec3::new(unit(s + 12) - 0.5, 1.0, 0.0),
                DVec3::ZERO,
                DVec3::ZERO,
            ],
        },
        open_fraction: None,
    }
}

fn query(k: usize) -> (DVec3, DVec3) {
    let s = 0xdead_beef + k as u64 * 4;
    (
        DVec3::new(unit(s) * 20.0, unit(s + 1) * 20.0, 0.1),
        DVec3::new(0.0, 0.0, 1.0),
    )
}

#[test]
fn concurrent_inserts_and_lookups_match_a_single_threaded_replay() {
    let n = per_thread();
    let config = CacheConfig::surface(3).with_interpolation(Interpolation::Tent);
    let shared: Cache<[f32; 3]> = Cache::new(config).unwrap();
    let barrier = Barrier::new(THREADS);
    std::thread::scope(|scope| {
        for t in 0..THREADS {
            let (shared, barrier) = (&shared, &barrier);
            scope.spawn(move || {
                barrier.wait();
                for i in 0..n {
                    let r = record(t, i);
                    shared.insert(&r).unwrap();
                    // the record just inserted is visible to this thread at once
                    let own = shared.lookup(r.position, r.normal).unwrap();
                    assert!(own.value.iter().all(|v| v.is_finite()));
                    for k in 0..4 {
                        let (p, nq) = query(t * n * 4 + i * 4 + k);
                        if let Ok(l) = shared.lookup(p, nq) {
                            assert!(l.weight_sum > 0.0 && l.value.iter().all(|v| v.is_finite()));
                        }
                    }
                }
            });
        }
    });
    // the replay: one thread, a different order (thread-major, reversed)
    let replay: Cache<[f32; 3]> = Cache::new(config).unwrap();
    for t in (0..THREADS).rev() {
        for i in (0..n).rev() {
            replay.insert(&record(t, i)).unwrap();
        }
    }
    assert_eq!(shared.len(), replay.len());
    assert!(shared.len() < THREADS * n, "duplicates were detected");
    assert_eq!(shared.keys(), replay.keys());
    assert_eq!(shared.to_bytes(), replay.to_bytes());
    let mut hits = 0;
    for k in 0..20_000 {
        let (p, nq) = query(k);
        match (shared.lookup(p, nq), replay.lookup(p, nq)) {
            (Ok(a), Ok(b)) => {
                hits += 1;
                assert_eq!(a.value.map(f32::to_bits), b.value.map(f32::to_bits));
                assert_eq!(a.weight_sum.to_bits(), b.weight_sum.to_bits());
                assert_eq!(a.records, b.records);
            }
            (Err(_), Err(_)) => {}
            (a, b) => panic!("query {k}: {a:?} vs {b:?}"),
        }
    }
    assert!(hits > 10_000, "{hits}");
}
