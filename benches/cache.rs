//! Radiance-cache benchmarks: lookups at 10k / 100k / 1M records with ~8 covering records per
//! query, against a brute-force scan; inserts; 1 vs 2 threads; bytes per record.
//!
//! `cargo bench --bench cache -- --warm-up-time 1 --measurement-time 3`

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, Criterion, Throughput};
use glam::DVec3;
use raddiff::cache::{Cache, CacheConfig, Cursor, Extent, Record};

const OVERLAP: f64 = 8.0;

fn hash(mut x: u64) -> u64 {
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d049bb133111eb);
    x ^ (x >> 31)
}

fn unit(seed: u64) -> f64 {
    (hash(seed) >> 11) as f64 / (1u64 << 53) as f64
}

/// Side of the square floor holding `n` records (density 1 record per unit area).
fn side(n: usize) -> f64 {
    (n as f64).sqrt()
}

/// Records uniformly on the floor z = 0, radii such that a point is covered by ~8 on average.
fn record(i: usize, n: usize) -> Record<[f32; 3]> {
    let s = side(n);
    let r = (OVERLAP / std::f64::consts::PI).sqrt();
    let k = i as u64 * 8;
    Record {
        position: DVec3::new(unit(k) * s, unit(k + 1) * s, 0.0),
        normal: DVec3::new(unit(k + 2) * 0.01, unit(k + 3) * 0.01, 1.0),
        value: [unit(k + 4) as f32, 0.5, 0.25],
        gradient: Some([[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0; 3]]),
        rotation_gradient: Some([[0.0; 3], [0.05; 3], [0.0; 3]]),
        extent: Extent::isotropic(r * (0.8 + 0.4 * unit(k + 5))),
        open_fraction: None,
    }
}

fn build(n: usize) -> Cache<[f32; 3]> {
    let mut cache = Cache::new(CacheConfig::surface(3)).unwrap();
    let t = Instant::now();
    for i in 0..n {
        cache.insert(&record(i, n)).unwrap();
    }
    let m = cache.memory();
    let elapsed = t.elapsed();
    cache.compact();
    eprintln!(
        "cache of {n} records built in {elapsed:.2?}: {} B/record stored, {:.0} B/record allocated, \
         index {:.0} B/record ({:.0} after compact), {:.2} index entries/record",
        m.bytes_per_record,
        m.record_bytes as f64 / n as f64,
        m.index_bytes as f64 / n as f64,
        cache.memory().index_bytes as f64 / n as f64,
        m.index_entries as f64 / n as f64
    );
    cache
}

fn queries(n: usize, count: usize) -> Vec<DVec3> {
    let s = side(n);
    (0..count as u64)
        .map(|i| {
            DVec3::new(
                unit((1 << 40) | (i * 2)) * s,
                unit((1 << 40) | (i * 2 + 1)) * s,
                0.0,
            )
        })
        .collect()
}

/// Scanline-like coherence: successive queries 0.05 apart along rows.
fn scanline_queries(n: usize) -> Vec<DVec3> {
    let s = side(n);
    (0..1 << 16)
        .map(|k| {
            DVec3::new(
                (k % 4096) as f64 * 0.05 % s,
                100.0 + (k / 4096) as f64 * 0.05,
                0.0,
            )
        })
        .collect()
}

fn mean_covering(cache: &Cache<[f32; 3]>, qs: &[DVec3]) -> f64 {
    let total: usize = qs
        .iter()
        .filter_map(|&q| cache.lookup(q, DVec3::Z).ok())
        .map(|l| l.records)
        .sum();
    total as f64 / qs.len() as f64
}

fn lookups(c: &mut Criterion) {
    let mut group = c.benchmark_group("cache_lookup");
    group.sample_size(20).throughput(Throughput::Elements(1));
    for n in [10_000usize, 100_000, 1_000_000] {
        let cache = build(n);
        let qs = queries(n, 1 << 16);
        eprintln!(
            "{n}: {:.2} covering records per query",
            mean_covering(&cache, &qs)
        );
        let mut i = 0;
        // `lookup` keeps per-thread cursors; `lookup_indexed` (the index alone) is its baseline
        group.bench_function(format!("random/{n}"), |b| {
            b.iter(|| {
                i = (i + 1) & (qs.len() - 1);
                black_box(cache.lookup(qs[i], DVec3::Z).ok())
            })
        });
        group.bench_function(format!("random_indexed/{n}"), |b| {
            b.iter(|| {
                i = (i + 1) & (qs.len() - 1);
                black_box(cache.lookup_indexed(qs[i], DVec3::Z).ok())
            })
        });
        if n == 1_000_000 {
            // incoherent queries through a cursor: it should fall back to about a plain lookup
            let mut cursor = Cursor::new();
            group.bench_function(format!("random_cursor/{n}"), |b| {
                b.iter(|| {
                    i = (i + 1) & (qs.len() - 1);
                    black_box(cache.lookup_with(&mut cursor, qs[i], DVec3::Z).ok())
                })
            });
        }
        if n == 1_000_000 {
            let row = scanline_queries(n);
            let mut j = 0;
            group.bench_function(format!("coherent/{n}"), |b| {
                b.iter(|| {
                    j = (j + 1) & (row.len() - 1);
                    black_box(cache.lookup(row[j], DVec3::Z).ok())
                })
            });
            group.bench_function(format!("coherent_indexed/{n}"), |b| {
                b.iter(|| {
                    j = (j + 1) & (row.len() - 1);
                    black_box(cache.lookup_indexed(row[j], DVec3::Z).ok())
                })
            });
            // the same queries through a per-thread cursor (identical results)
            let mut cursor = Cursor::new();
            let mut j = 0;
            group.bench_function(format!("coherent_cursor/{n}"), |b| {
                b.iter(|| {
                    j = (j + 1) & (row.len() - 1);
                    black_box(cache.lookup_with(&mut cursor, row[j], DVec3::Z).ok())
                })
            });
            // 1 vs 2 threads: wall time for `iters` lookups per thread
            for threads in [1usize, 2] {
                group.throughput(Throughput::Elements(threads as u64));
                group.bench_function(format!("threads/{threads}/{n}"), |b| {
                    b.iter_custom(|iters| {
                        let t = Instant::now();
                        std::thread::scope(|sc| {
                            for th in 0..threads {
                                let (cache, qs) = (&cache, &qs);
                                sc.spawn(move || {
                                    for k in 0..iters as usize {
                                        let q = qs[(k * 7 + th * 31) & (qs.len() - 1)];
                                        black_box(cache.lookup(q, DVec3::Z).ok());
                                    }
                                });
                            }
                        });
                        t.elapsed()
                    })
                });
            }
            group.throughput(Throughput::Elements(1));
        }
        if n == 100_000 {
            // the lookup radius scale's cost: the same records read over 1 and 1.5 times their
            // radii (about 2.25 times the records weighed and blended), random and coherent
            let row = scanline_queries(n);
            for scale in [1.0, 1.5] {
                let mut wide = build(n);
                wide.set_lookup_radius_scale(scale).unwrap();
                eprintln!(
                    "{n} at lookup radius scale {scale}: {:.2} records blended per query",
                    mean_covering(&wide, &qs)
                );
                let mut k = 0;
                group.bench_function(format!("scaled/{scale}/random/{n}"), |b| {
                    b.iter(|| {
                        k = (k + 1) & (qs.len() - 1);
                        black_box(wide.lookup(qs[k], DVec3::Z).ok())
                    })
                });
                group.bench_function(format!("scaled/{scale}/coherent/{n}"), |b| {
                    b.iter(|| {
                        k = (k + 1) & (row.len() - 1);
                        black_box(wide.lookup(row[k], DVec3::Z).ok())
                    })
                });
            }
        }
        if n == 10_000 {
            // baseline: test every record's bounding sphere (what a cache without an index does)
            let recs: Vec<(DVec3, f64)> = (0..n)
                .map(|i| {
                    let r = record(i, n);
                    (r.position, r.extent.max_radius())
                })
                .collect();
            let mut k = 0;
            group.bench_function(format!("brute_force_scan/{n}"), |b| {
                b.iter(|| {
                    k = (k + 1) & (qs.len() - 1);
                    let q = qs[k];
                    black_box(
                        recs.iter()
                            .filter(|(p, r)| (q - *p).length_squared() < r * r)
                            .count(),
                    )
                })
            });
        }
    }
    group.finish();
}

fn inserts(c: &mut Criterion) {
    let mut group = c.benchmark_group("cache_insert");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(3));
    let n = 20_000;
    let recs: Vec<Record<[f32; 3]>> = (0..n).map(|i| record(i, n)).collect();
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function(format!("fill/{n}"), |b| {
        b.iter(|| {
            let cache: Cache<[f32; 3]> = Cache::new(CacheConfig::surface(3)).unwrap();
            for r in &recs {
                cache.insert(r).unwrap();
            }
            black_box(cache.len())
        })
    });
    // two threads inserting disjoint halves into one cache
    group.bench_function(format!("fill_2_threads/{n}"), |b| {
        b.iter(|| {
            let cache: Cache<[f32; 3]> = Cache::new(CacheConfig::surface(3)).unwrap();
            std::thread::scope(|sc| {
                for half in recs.chunks(n / 2) {
                    let cache = &cache;
                    sc.spawn(move || {
                        for r in half {
                            cache.insert(r).unwrap();
                        }
                    });
                }
            });
            black_box(cache.len())
        })
    });
    group.finish();
    for channels in [1usize, 3, 27] {
        let mut cache: Cache<Vec<f32>> = Cache::new(CacheConfig::surface(channels)).unwrap();
        let n = 100_000;
        for i in 0..n {
            let r = record(i, n);
            let rec = Record {
                position: r.position,
                normal: r.normal,
                value: vec![1.0; channels],
                gradient: None,
                rotation_gradient: None,
                extent: r.extent,
                open_fraction: None,
            };
            cache.insert(&rec).unwrap();
        }
        let filling = cache.memory();
        cache.compact();
        let m = cache.memory();
        eprintln!(
            "{channels} channels: {} B/record stored + index {:.1} B/record after compact = {:.1} \
             (budget {}); index while filling {:.1} B/record",
            m.bytes_per_record,
            m.index_bytes as f64 / n as f64,
            m.bytes_per_record as f64 + m.index_bytes as f64 / n as f64,
            96 + 16 * channels,
            filling.index_bytes as f64 / n as f64
        );
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(3));
    targets = lookups, inserts
}
/// `RADDIFF_CACHE_PROFILE=<queries>:<records>:<lookups>` builds a cache of `records` records and
/// makes `lookups` lookups and nothing else, for `valgrind --tool=callgrind`: the difference of two
/// runs' instruction counts over the difference of their lookup counts is the cost of one lookup,
/// whatever the machine's load. `queries` is `coherent` or `random` through `lookup`, or
/// `coherent_indexed` / `random_indexed` through the index alone (`lookup_indexed`).
fn profile(spec: &str) {
    let parts: Vec<&str> = spec.split(':').collect();
    let [kind, records, count] = parts[..] else {
        panic!("RADDIFF_CACHE_PROFILE=<queries>:<records>:<lookups>, got {spec}");
    };
    let n: usize = records.parse().expect("record count");
    let count: usize = count.parse().expect("lookup count");
    let cache = build(n);
    let (coherent, indexed) = match kind {
        "coherent" => (true, false),
        "coherent_indexed" => (true, true),
        "random" => (false, false),
        "random_indexed" => (false, true),
        other => panic!("unknown query kind {other}"),
    };
    let qs = if coherent {
        scanline_queries(n)
    } else {
        queries(n, 1 << 16)
    };
    for k in 0..count {
        let q = qs[k & (qs.len() - 1)];
        if indexed {
            black_box(cache.lookup_indexed(q, DVec3::Z).ok());
        } else {
            black_box(cache.lookup(q, DVec3::Z).ok());
        }
    }
}

fn main() {
    if let Ok(spec) = std::env::var("RADDIFF_CACHE_PROFILE") {
        profile(&spec);
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
