use super::*;

fn brute(balls: &[(DVec3, f64)], p: DVec3) -> Vec<u32> {
    (0..balls.len() as u32)
        .filter(|&i| (p - balls[i as usize].0).length() <= balls[i as usize].1)
        .collect()
}

fn lcg(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || crate::test_rng::lcg(&mut s)
}

#[test]
fn levels_hold_their_spheres() {
    for k in -190..190 {
        let r = 10f64.powf(k as f64 / 6.3);
        let l = level_for(r);
        assert!(cell_side(l) * (1.0 - SIDE_MARGIN) >= 2.0 * r, "{r}");
        assert!(cell_side(l - 1) * (1.0 - SIDE_MARGIN) < 2.0 * r, "{r}");
    }
}

/// Every covering sphere is reported once, at every scale and far from the origin.
fn check_against_brute_force(offset: DVec3, scale: f64, seed: u64) {
    let grid = Grid::new();
    let mut rnd = lcg(seed);
    let mut balls = Vec::new();
    for i in 0..3000u32 {
        let s = scale * 10f64.powf(rnd() * 3.0 - 1.0);
        let c = offset + DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * scale * 20.0;
        let r = s * (0.05 + rnd());
        grid.insert(i, c, r);
        balls.push((c, r));
    }
    for k in 0..3000 {
        // half the queries right at sphere boundaries, where rounding matters
        let p = if k % 2 == 0 {
            offset + DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * scale * 24.0
        } else {
            let (c, r) = balls[(rnd() * balls.len() as f64) as usize];
            let d = DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize();
            c + d * r * (1.0 - 1e-9)
        };
        let mut got = Vec::new();
        grid.query(p, |id| got.push(id));
        got.sort_unstable();
        let mut dedup = got.clone();
        dedup.dedup();
        assert_eq!(dedup.len(), got.len(), "an id reported twice");
        for w in brute(&balls, p) {
            assert!(got.binary_search(&w).is_ok(), "missed {w} at {p}");
        }
        for g in &got {
            let (c, r) = balls[*g as usize];
            assert!((p - c).length() <= r * (1.0 + 1e-5), "far report {g}");
        }
    }
    assert_eq!(grid.entries(), balls.len());
}

#[test]
fn query_finds_every_covering_sphere() {
    check_against_brute_force(DVec3::ZERO, 1.0, 1);
    check_against_brute_force(DVec3::new(1e6, -3e6, 2e6), 1.0, 2);
    check_against_brute_force(DVec3::new(-1e-20, 0.0, 0.0), 1e-22, 3);
    check_against_brute_force(DVec3::new(0.0, 1e25, 0.0), 1e20, 4);
}

#[test]
fn compaction_keeps_results_and_frees_memory() {
    let mut grid = Grid::new();
    let mut rnd = lcg(9);
    for i in 0..5000u32 {
        let c = DVec3::new(rnd(), rnd(), 0.0) * 50.0;
        grid.insert(i, c, 0.5 + rnd());
    }
    let probes: Vec<DVec3> = (0..200)
        .map(|_| DVec3::new(rnd(), rnd(), 0.0) * 50.0)
        .collect();
    let before: Vec<Vec<u32>> = probes
        .iter()
        .map(|&p| {
            let mut v = Vec::new();
            grid.query(p, |id| v.push(id));
            v
        })
        .collect();
    let bytes = grid.bytes();
    let identity: Vec<u32> = (0..5000).collect();
    grid.compact(&identity);
    assert!(grid.bytes() < bytes);
    for (p, b) in probes.iter().zip(&before) {
        let mut v = Vec::new();
        grid.query(*p, |id| v.push(id));
        assert_eq!(&v, b);
    }
    grid.insert(99_999, probes[0], 0.7);
    let mut v = Vec::new();
    grid.query(probes[0], |id| v.push(id));
    assert!(v.contains(&99_999));
}

#[test]
#[ignore]
fn print_scan_stats() {
    let grid = Grid::new();
    let n = 100_000u32;
    let side = (n as f64).sqrt();
    let mut rnd = lcg(1);
    let r = (8.0 / std::f64::consts::PI).sqrt();
    for i in 0..n {
        grid.insert(
            i,
            DVec3::new(rnd() * side, rnd() * side, 0.0),
            r * (0.8 + 0.4 * rnd()),
        );
    }
    let mut found = 0usize;
    for _ in 0..1000 {
        let p = DVec3::new(rnd() * side, rnd() * side, 0.0);
        grid.query(p, |_| found += 1);
    }
    println!(
        "cells {}, found/query {:.2}, index bytes/record {:.1}",
        grid.cells.load(Ordering::Relaxed),
        found as f64 / 1000.0,
        grid.bytes() as f64 / n as f64
    );
}
