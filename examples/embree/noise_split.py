#!/usr/bin/env python3
"""Splits each metric's error into the samples' noise and what stays when the noise averages out,
from two benchmark runs that differ only in `--noise-seed` (every gather, near field and hit
radiance drawn from another random stream; the same reference).

With e_k = b + n_k + r at a pixel (b the error that does not depend on the samples, n_k run k's
noise, independent between the runs, r the reference's noise, the same in both), the runs'
difference has twice the noise's mean square, and their mean error has b + r plus half of it:

    noise^2      = sum (v_a - v_b)^2 / 2 / sum ref^2
    systematic^2 = sum ((e_a + e_b) / 2)^2 / sum ref^2 - noise^2 / 2 - reference_noise^2

(relative mean squares over the pixels both runs measured; the reference's relative noise from
the run's summary). Each run's error^2 is then about systematic^2 + noise^2 + reference_noise^2:
the noise part is what the gathers and near fields bring whatever the metric does. With
`--pixel-gathers` in both runs, the row `pixel-gathers` (every measured pixel shown from its own
gather, no cache) has the systematic part no record placement removes (the near/far
decomposition's bias); a metric's systematic part above it is its interpolation's.

Under `--near-field` (the pixels' and records' CSVs carry open fractions) it also gives, per
metric, the share of the pixels next to a record of RUN_A (within 3 pixels) whose open fraction
differs from theirs by more than 0.1, and the share of the systematic square they hold.

usage: noise_split.py RUN_A RUN_B   (run prefixes: <prefix>-summary.csv, <prefix>-<metric>-pixels.csv)
"""

import math
import os
import sys

import numpy as np

from report import METRICS, rows


def read_pixels(prefix, metric):
    """{(x, y): (value, reference, error)} of a run's measured pixels for `metric`."""
    return {(int(r["x"]), int(r["y"])): (float(r["value"]), float(r["reference"]), float(r["error"]))
            for r in rows(f"{prefix}-{metric}-pixels.csv")}


def relative_rms(pixels):
    """A run's relative RMS error over its measured pixels (as report.py gives it)."""
    ref2 = sum(v[1] ** 2 for v in pixels.values())
    return math.sqrt(sum(v[2] ** 2 for v in pixels.values()) / ref2) if ref2 > 0 else 0.0


def noise_split(a, b, reference_noise):
    """(noise, systematic, worst1_share) of one metric from its pixels in two runs (as read_pixels
    returns them), over the pixels both measured: the noise and systematic relative RMS parts
    (the systematic square clamped at 0: the reference's noise or the estimate's own noise can
    exceed it), and the share of the systematic square (reference noise included) that the worst
    1% of the pixels hold, each pixel's share estimated without bias as its mean error squared
    minus its half-difference squared. None when the runs share no pixel or their references
    are all 0."""
    keys = sorted(set(a) & set(b))
    ref2 = sum(a[k][1] ** 2 for k in keys)
    if not keys or ref2 <= 0:
        return None
    noise2 = sum((a[k][0] - b[k][0]) ** 2 for k in keys) / 2 / ref2
    mean2 = sum(((a[k][2] + b[k][2]) / 2) ** 2 for k in keys) / ref2
    per_pixel = sorted((((a[k][2] + b[k][2]) / 2) ** 2 - ((a[k][0] - b[k][0]) / 2) ** 2 for k in keys), reverse=True)
    total = sum(per_pixel)
    worst = sum(per_pixel[: len(per_pixel) // 100]) / total if total > 0 else 0.0
    return math.sqrt(noise2), math.sqrt(max(0.0, mean2 - noise2 / 2 - reference_noise**2)), worst


def read_records(prefix, metric):
    """[(px, py, open_fraction)] of a run's records for `metric`, or None when its records' CSV
    has no open fraction (runs before the column, or without one)."""
    records = rows(f"{prefix}-{metric}-records.csv")
    if not records or "open_fraction" not in records[0]:
        return None
    return [(float(r["px"]), float(r["py"]), float(r["open_fraction"])) for r in records]


def read_open_fractions(prefix, metric):
    """{(x, y): open fraction} of a run's measured pixels, or None without the column."""
    pixels = rows(f"{prefix}-{metric}-pixels.csv")
    if not pixels or "open_fraction" not in pixels[0]:
        return None
    return {(int(r["x"]), int(r["y"])): float(r["open_fraction"]) for r in pixels}


def open_fraction_mismatch(a, b, open_fractions, records, within_px=3.0, tolerance=0.1):
    """(pixel share, systematic share): the pixels (both runs measured) with a record within
    `within_px` pixels whose open fraction differs from the pixel's by more than `tolerance`,
    as a share of the pixels and of the sum of the per-pixel systematic estimates (as in
    noise_split). None when no pixel has an open fraction or the estimates sum to 0 or less."""
    keys = [k for k in sorted(set(a) & set(b)) if k in open_fractions]
    if not keys or not records:
        return None
    rec = np.array(records)
    estimate = np.array([((a[k][2] + b[k][2]) / 2) ** 2 - ((a[k][0] - b[k][0]) / 2) ** 2 for k in keys])
    mismatched = np.zeros(len(keys), dtype=bool)
    for i, (x, y) in enumerate(keys):
        near = np.hypot(rec[:, 0] - x, rec[:, 1] - y) < within_px
        mismatched[i] = near.any() and np.abs(rec[near, 2] - open_fractions[(x, y)]).max() > tolerance
    total = estimate.sum()
    if total <= 0:
        return None
    return mismatched.mean(), estimate[mismatched].sum() / total


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    run_a, run_b = sys.argv[1:]
    summary = {r["key"]: r["value"] for r in rows(f"{run_a}-summary.csv")}
    reference_noise = float(summary["reference_relative_noise"])
    print(f"reference noise {reference_noise:.4f}")
    print("| metric | error A | error B | noise | systematic | worst 1% share of the systematic |")
    print("|---|---|---|---|---|---|")
    found = {}
    for m in METRICS + ["pixel-gathers"]:
        if not (os.path.exists(f"{run_a}-{m}-pixels.csv") and os.path.exists(f"{run_b}-{m}-pixels.csv")):
            continue
        a, b = read_pixels(run_a, m), read_pixels(run_b, m)
        parts = noise_split(a, b, reference_noise)
        if parts is None:
            continue
        found[m] = parts
        print(f"| {m} | {relative_rms(a):.4f} | {relative_rms(b):.4f} | {parts[0]:.4f} | {parts[1]:.4f} | "
              f"{parts[2]:.2f} |")
    if not found:
        sys.exit(f"no metric measured in both {run_a} and {run_b}")
    for m in found:
        if m == "pixel-gathers":
            continue
        open_fractions, records = read_open_fractions(run_a, m), read_records(run_a, m)
        if open_fractions is None or records is None:
            continue
        shares = open_fraction_mismatch(read_pixels(run_a, m), read_pixels(run_b, m), open_fractions, records)
        if shares is not None:
            print(f"{m}: pixels with a record of RUN_A within 3 px whose open fraction differs from theirs by "
                  f"more than 0.1 are {100 * shares[0]:.1f}% of the pixels and hold {100 * shares[1]:.0f}% of the "
                  f"systematic square")


if __name__ == "__main__":
    main()
