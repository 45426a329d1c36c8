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

usage: noise_split.py RUN_A RUN_B   (run prefixes: <prefix>-summary.csv, <prefix>-<metric>-pixels.csv)
"""

import math
import os
import sys

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


if __name__ == "__main__":
    main()
