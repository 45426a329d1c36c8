#!/usr/bin/env python3
"""Checks of report.py's edge split, shared and own errors and equal-error records, and of
noise_split.py's noise and systematic parts, and of strata_allocation.py's variances, on synthetic
runs whose answers are known by construction.

usage: python3 examples/embree/test_report.py   (needs numpy and matplotlib, as report.py does)
"""

import math
import os
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import noise_split  # noqa: E402
import report  # noqa: E402
import strata_allocation  # noqa: E402


def write_pfm(path, rgb):
    h, w, _ = rgb.shape
    with open(path, "wb") as f:
        f.write(f"PF\n{w} {h}\n-1\n".encode())
        f.write(np.ascontiguousarray(rgb[::-1], dtype="<f4").tobytes())


class SyntheticRun:
    """A run of `width` x `height` pixels, every pixel measured."""

    def __init__(self, folder, name, normals):
        self.folder, self.name = folder, name
        h, w, _ = normals.shape
        self.measured = [{"x": str(x), "y": str(y)} for y in range(h) for x in range(w)]
        write_pfm(self.path("-normal.pfm"), normals)

    def path(self, suffix):
        return os.path.join(self.folder, self.name + suffix)

    def write_pixels(self, metric, errors, references):
        with open(self.path(f"-{metric}-pixels.csv"), "w") as f:
            f.write("pixel,x,y,value,reference,error\n")
            for k, (r, e, ref) in enumerate(zip(self.measured, errors, references)):
                f.write(f"{k},{r['x']},{r['y']},{ref + e},{ref},{e}\n")


def crease(width, height, column, angle):
    """Normals +z left of `column`, tilted by `angle` about y from it on."""
    n = np.zeros((height, width, 3))
    n[:, :column] = (0.0, 0.0, 1.0)
    n[:, column:] = (math.sin(angle), 0.0, math.cos(angle))
    return n


def test_a_crease_marks_its_two_columns_and_their_neighbours(folder):
    run = SyntheticRun(folder, "crease", crease(10, 6, 5, 0.5))
    at = report.edge_pixels(run).reshape(6, 10)
    expected = np.zeros((6, 10), dtype=bool)
    expected[:, 3:7] = True  # the pair (4, 5), grown by one pixel
    assert (at == expected).all(), at.astype(int)


def test_the_angle_decides(folder):
    below = SyntheticRun(folder, "below", crease(10, 6, 5, 0.95 * report.EDGE_ANGLE))
    assert not report.edge_pixels(below).any()
    above = SyntheticRun(folder, "above", crease(10, 6, 5, 1.05 * report.EDGE_ANGLE))
    assert report.edge_pixels(above).sum() == 4 * 6


def test_the_background_rim_is_an_edge(folder):
    n = np.zeros((8, 8, 3))
    n[:, :, 2] = 1.0
    n[:, 6:] = 0.0  # no hit: zero normals
    run = SyntheticRun(folder, "rim", n)
    at = report.edge_pixels(run).reshape(8, 8)
    assert at[:, 4:].all() and not at[:, :4].any(), at.astype(int)


def test_the_split_adds_up_to_the_error(folder):
    run = SyntheticRun(folder, "split", crease(10, 6, 5, 0.5))
    at = report.edge_pixels(run)
    rng = np.random.default_rng(7)
    errors = rng.normal(0.0, 0.1, at.size)
    references = rng.uniform(1.0, 2.0, at.size)
    run.write_pixels("m", errors, references)
    edge_part, away_part = report.edge_split(run, "m", at)
    total = math.sqrt((errors**2).sum() / (references**2).sum())
    assert abs(edge_part**2 + away_part**2 - total**2) < 1e-12 * total**2
    expected_edge = math.sqrt((errors[at] ** 2).sum() / (references**2).sum())
    assert abs(edge_part - expected_edge) < 1e-12 * expected_edge


def test_no_normal_buffer_means_no_split(folder):
    run = SyntheticRun(folder, "none", crease(4, 4, 2, 0.5))
    os.remove(run.path("-normal.pfm"))
    assert report.edge_pixels(run) is None
    assert report.edge_split(run, "m", None) == (None, None)


def test_the_shared_part_is_the_metrics_mean_and_the_own_parts_their_departures(folder):
    run = SyntheticRun(folder, "shared", crease(8, 5, 4, 0.5))
    rng = np.random.default_rng(11)
    n = len(run.measured)
    common = rng.normal(0.0, 0.1, n)
    departure = rng.normal(0.0, 0.03, n)
    references = rng.uniform(1.0, 2.0, n)
    ref = math.sqrt((references**2).sum())
    run.write_pixels("a", common + departure, references)
    run.write_pixels("b", common - 3 * departure, references)
    run.write_pixels("c", common + 2 * departure, references)
    shared, own = report.shared_split(run, ["a", "b", "c"])
    # the departures sum to zero over the metrics, so the mean is the common error exactly
    rms = lambda e: math.sqrt((e**2).sum()) / ref  # noqa: E731
    assert abs(shared - rms(common)) < 1e-6 * rms(common), (shared, rms(common))
    for m, k in (("a", 1), ("b", -3), ("c", 2)):
        assert abs(own[m] - abs(k) * rms(departure)) < 1e-5 * rms(departure), (m, own[m])
    # a metric identical to another leaves its own part, not the shared one, to the difference
    run.write_pixels("d", common + departure, references)
    shared2, own2 = report.shared_split(run, ["a", "d"])
    assert abs(shared2 - rms(common + departure)) < 1e-6 and own2["a"] < 1e-7 and own2["d"] < 1e-7
    assert report.shared_split(run, ["a"]) is None


class CurveRun:
    """A run whose anisotropic Hessian has the fills `points` (records, error)."""

    def __init__(self, points):
        self.fills = [{"metric": "hessian-anisotropic", "records": n, "rel_rms": e, "total_s": n / 100.0}
                      for n, e in points]

    def curve(self, metric):
        return sorted((f for f in self.fills if f["metric"] == metric), key=lambda f: f["total_s"])


def test_records_to_reach_an_error(folder):
    # error proportional to records^-1/2: 2,000 records give 0.04 / sqrt(2)
    run = CurveRun([(4000, 0.02), (1000, 0.04), (16000, 0.01)])
    n, at_most = report.records_to_reach(run, 0.04 / math.sqrt(2.0))
    assert abs(n - 2000) < 1e-9 and not at_most, n
    assert report.records_to_reach(run, 0.05) == (1000, True)  # its cheapest point is already below
    assert report.records_to_reach(run, 0.005) is None  # never reached
    assert report.records_to_reach(CurveRun([]), 0.03) is None


def test_the_noise_and_systematic_parts_are_what_the_runs_were_built_from(folder):
    # two runs with a common error b, and noises s*u, s*w of patterns u, w that are orthogonal
    # to each other and to b's sign: the estimates are exact, not only expected
    count, s, b_level, ref_noise = 4000, 0.03, 0.02, 0.005
    u = np.array([1.0, 1.0, -1.0, -1.0] * (count // 4))
    w = np.array([1.0, -1.0, 1.0, -1.0] * (count // 4))
    b = np.full(count, b_level)
    references = np.full(count, 2.0)

    def pixels(noise):
        return {(k, 0): (ref + e, ref, e) for k, (ref, e) in enumerate(zip(references, b + noise))}

    ref = math.sqrt((references**2).sum())
    noise, systematic, worst = noise_split.noise_split([pixels(s * u), pixels(s * w)], ref_noise)
    true_noise = s * math.sqrt(count) / ref
    true_systematic = math.sqrt((b_level * math.sqrt(count) / ref) ** 2 - ref_noise**2)
    assert abs(noise - true_noise) < 1e-12, (noise, true_noise)
    assert abs(systematic - true_systematic) < 1e-12, (systematic, true_systematic)
    # each pixel's estimate is (b + s(u + w)/2)^2 - (s(u - w)/2)^2, which sum to count * b^2; the
    # worst 1% are pixels with u = w = 1, each (b + s)^2
    assert abs(worst - (b_level + s) ** 2 / (100 * b_level**2)) < 1e-12, worst
    # the squares add up to each run's error, reference noise included
    total = noise_split.relative_rms(pixels(s * u))
    assert abs(total**2 - (noise**2 + systematic**2 + ref_noise**2)) < 1e-12
    # identical runs: no noise, the whole error systematic; no shared pixel: no answer
    same = noise_split.noise_split([pixels(s * u), pixels(s * u)], 0.0)
    assert same[0] == 0.0 and abs(same[1] - total) < 1e-12
    # then each pixel's estimate is its error squared, (b + s)^2 on half the pixels, (b - s)^2 on the rest
    assert abs(same[2] - (b_level + s) ** 2 / (100 * (b_level**2 + s**2))) < 1e-12, same[2]
    assert noise_split.noise_split([pixels(s * u), {(-1, 0): (1.0, 1.0, 0.0)}], 0.0) is None


def test_more_runs_give_the_same_parts_when_their_noises_are_orthogonal(folder):
    # four runs whose noises are rows 1-4 of a Hadamard matrix of order 8 (each sums to 0, all
    # mutually orthogonal) times s, over a common error b: the sample variance and the mean
    # give the parts exactly
    h = np.array([[1.0]])
    for _ in range(3):
        h = np.block([[h, h], [h, -h]])
    count, s, b_level = 800, 0.04, 0.03
    references = np.full(count, 1.5)
    ref = math.sqrt((references**2).sum())

    def pixels(noise):
        return {(k, 0): (ref_k + b_level + e, ref_k, b_level + e) for k, (ref_k, e) in enumerate(zip(references, noise))}

    runs = [pixels(s * np.tile(h[row], count // 8)) for row in range(1, 5)]
    noise, systematic, _ = noise_split.noise_split(runs, 0.0)
    assert abs(noise - s * math.sqrt(count) / ref) < 1e-12, noise
    assert abs(systematic - b_level * math.sqrt(count) / ref) < 1e-12, systematic
    # two of them give the same answer too
    noise2, systematic2, _ = noise_split.noise_split(runs[:2], 0.0)
    assert abs(noise2 - noise) < 1e-12 and abs(systematic2 - systematic) < 1e-12


def test_the_open_fraction_mismatch_counts_pixels_next_to_records_of_another_openness(folder):
    # four pixels in a row, with the systematic estimates 4, 1, 1, 2 (identical runs: errors
    # 2, 1, 1, sqrt 2); open fractions 0.5, 0.5, 0.9, 0.9
    errors = [2.0, 1.0, 1.0, math.sqrt(2.0)]
    pixels = {(10 * k, 0): (1.0 + e, 1.0, e) for k, e in enumerate(errors)}
    open_fractions = {(0, 0): 0.5, (10, 0): 0.5, (20, 0): 0.9, (30, 0): 0.9}
    # a record of open fraction 0.9 beside pixel 0, one of 0.55 beside pixel 1 (within the
    # tolerance), one of 0.5 beside pixel 3 and one far from every pixel
    records = [(1.0, 1.0, 0.9), (11.0, 0.0, 0.55), (30.0, 2.0, 0.5), (100.0, 100.0, 0.0)]
    share = noise_split.open_fraction_mismatch([pixels, pixels], open_fractions, records)
    assert share == (0.5, 6.0 / 8.0), share  # pixels 0 and 3
    # a wider reach takes pixels 1 and 2 in too (the records 0.9 and 0.55 nine pixels away); a
    # looser tolerance none
    share = noise_split.open_fraction_mismatch([pixels, pixels], open_fractions, records, within_px=10.0)
    assert share == (1.0, 1.0), share
    assert noise_split.open_fraction_mismatch([pixels, pixels], open_fractions, records, tolerance=0.5) == (0.0, 0.0)
    assert noise_split.open_fraction_mismatch([pixels, pixels], {}, records) is None


def test_the_systematic_part_splits_by_the_pixels_open_fraction(folder):
    # identical runs (each pixel's estimate its error squared): errors 3, 4 at open fractions
    # 0.5 and 0.95, 12 at 1.0 (the last bin is closed), references 1; a pixel without an open
    # fraction is left out of every bin and of the sum of references
    pixels = {(0, 0): (4.0, 1.0, 3.0), (1, 0): (5.0, 1.0, 4.0), (2, 0): (13.0, 1.0, 12.0), (3, 0): (1.0, 1.0, 0.0)}
    opens = {(0, 0): 0.5, (1, 0): 0.95, (2, 0): 1.0}
    bins = noise_split.systematic_by_open_fraction([pixels, pixels], opens)
    assert [(lo, hi) for lo, hi, _, _ in bins] == [(0.0, 0.6), (0.6, 0.8), (0.8, 0.9), (0.9, 0.97), (0.97, 1.0)]
    expected = [(1 / 3, 3 / math.sqrt(3)), (0.0, 0.0), (0.0, 0.0), (1 / 3, 4 / math.sqrt(3)), (1 / 3, 12 / math.sqrt(3))]
    for (_, _, share, part), (want_share, want_part) in zip(bins, expected):
        assert abs(share - want_share) < 1e-12 and abs(part - want_part) < 1e-12, bins
    # the parts' squares add up to the whole's (13^2 / 3)
    assert abs(sum(p**2 for _, _, _, p in bins) - 169.0 / 3.0) < 1e-9
    assert noise_split.systematic_by_open_fraction([pixels, pixels], {}) is None


def write_strata(path, lum, distance, m, n, reach):
    """A file of `--strata-variance`: lum[m*n, P] luminances, m*n distances."""
    with open(path, "wb") as f:
        f.write(np.array([m, n, lum.shape[1]], dtype="<u4").tobytes())
        f.write(np.array([reach], dtype="<f8").tobytes())
        f.write(np.ascontiguousarray(lum, dtype="<f4").tobytes())
        f.write(np.ascontiguousarray(distance, dtype="<f8").tobytes())


def alternating(paths, means, spread):
    """Traces mean_i +- spread_i in turn: each stratum's sample variance is known exactly."""
    signs = np.where(np.arange(paths) % 2 == 0, 1.0, -1.0)
    return means[:, None] + spread[:, None] * signs[None, :]


def test_even_variances_leave_nothing_to_allocate(folder):
    m, n, paths = 4, 8, 8
    means = np.linspace(1.0, 2.0, m * n)
    lum = alternating(paths, means, np.full(m * n, 0.5))
    path = os.path.join(folder, "even.strata")
    write_strata(path, lum, np.ones(m * n), m, n, 0.0)
    got = strata_allocation.relative_variances(*strata_allocation.read_strata(path))
    for budget in strata_allocation.BUDGETS:
        assert abs(got["even"][budget] - 1 / budget) < 1e-12, got
        assert abs(got["oracle (true deviations)"][budget] - 1 / budget) < 1e-9, got
        # with equal variances no allocation beats the even one (convexity of 1/n)
        for rule, by_budget in got.items():
            assert by_budget.get(budget, 1.0) >= 1 / budget - 1e-9, (rule, by_budget)


def test_the_oracle_puts_every_extra_path_where_the_variance_is(folder):
    # a of the read strata have variance, the others none: Neyman gives the quiet ones one path and
    # the rest of T*N to the a, so the variance falls to a / (T*N - (N - a)). The first row is
    # closer than the reach and noisier than all: it must not count.
    m, n, paths, reach = 4, 8, 8, 2.0
    spread = np.zeros(m * n)
    noisy = [9, 14, 20, 27, 31]
    spread[noisy] = 1.0
    spread[:n] = 50.0
    distance = np.full(m * n, 3.0)
    distance[:n] = 1.0
    distance[12] = np.inf  # a miss is read
    lum = alternating(paths, np.full(m * n, 4.0), spread)
    path = os.path.join(folder, "oracle.strata")
    write_strata(path, lum, distance, m, n, reach)
    got = strata_allocation.relative_variances(*strata_allocation.read_strata(path))
    read, a = m * n - n, len(noisy)
    for budget in strata_allocation.BUDGETS:
        want = a / (budget * read - (read - a))
        assert abs(got["oracle (true deviations)"][budget] - want) < 1e-9, (budget, got)
    # without a near field every stratum is read: the quiet 19 get one path each, and so do the five
    # of deviation 1 (their share, below one path, is raised to it); the first row's eight share
    # the rest, 5 paths each for T = 2 and 13 for T = 4
    write_strata(path, lum, distance, m, n, 0.0)
    got = strata_allocation.relative_variances(*strata_allocation.read_strata(path))
    one_path = 8 * 50.0**2 + a
    for budget, first_row in ((2, 5.0), (4, 13.0)):
        want = (8 * 50.0**2 / first_row + a) / one_path
        assert abs(got["oracle (true deviations)"][budget] - want) < 1e-9, (budget, got)


def test_the_noisiest_strata_share(folder):
    # 38 read strata: two of variance 9 (deviation 3), 36 of variance 1; the noisiest 5% (round(1.9))
    # are the two, 18 of 54. Six near strata, three of them of variance 100, are not read.
    m, n = 4, 11
    spread = np.ones(m * n)
    spread[[3, 17]] = 3.0
    spread[:4] = 10.0
    spread[3] = 3.0
    distance = np.full(m * n, 5.0)
    distance[:3] = 1.0
    distance[[40, 41, 42]] = 1.0
    path = os.path.join(folder, "share.strata")
    write_strata(path, alternating(6, np.full(m * n, 2.0), spread), distance, m, n, 2.0)
    share = strata_allocation.noisiest_share(*strata_allocation.read_strata(path))
    assert abs(share - 18.0 / 54.0) < 1e-9, share
    gathers, mean_share, _ = strata_allocation.summarize(folder)
    assert gathers >= 1 and 0 < mean_share <= 1


def test_a_gather_without_variance_is_left_out(folder):
    m, n = 2, 4
    path = os.path.join(folder, "flat.strata")
    write_strata(path, np.ones((m * n, 4)), np.ones(m * n), m, n, 0.0)
    assert strata_allocation.relative_variances(*strata_allocation.read_strata(path)) is None


def main():
    tests = [v for k, v in sorted(globals().items()) if k.startswith("test_")]
    with tempfile.TemporaryDirectory() as folder:
        for t in tests:
            t(folder)
            print(f"ok {t.__name__}")
    print(f"{len(tests)} report checks passed")


if __name__ == "__main__":
    main()
