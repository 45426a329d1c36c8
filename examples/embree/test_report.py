#!/usr/bin/env python3
"""Checks of report.py's edge split, shared and own errors and equal-error records on synthetic
runs whose answers are known by construction.

usage: python3 examples/embree/test_report.py   (needs numpy and matplotlib, as report.py does)
"""

import math
import os
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import report  # noqa: E402


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


def main():
    tests = [v for k, v in sorted(globals().items()) if k.startswith("test_")]
    with tempfile.TemporaryDirectory() as folder:
        for t in tests:
            t(folder)
            print(f"ok {t.__name__}")
    print(f"{len(tests)} report checks passed")


if __name__ == "__main__":
    main()
