#!/usr/bin/env python3
"""Splits each metric's error into the samples' noise and what stays when the noise averages out,
from K >= 2 benchmark runs that differ only in `--noise-seed` (every gather, near field and hit
radiance drawn from another random stream; the same reference).

With e_k = b + n_k + r at a pixel (b the error that does not depend on the samples, n_k run k's
noise, independent between the runs, r the reference's noise, the same in all), the runs'
sample variance s^2 estimates the noise's mean square, and their mean error m has b + r plus
1/K of it:

    noise^2      = sum s^2 / sum ref^2                     (s^2 with K - 1 in its denominator)
    systematic^2 = sum m^2 / sum ref^2 - noise^2 / K - reference_noise^2

(relative mean squares over the pixels every run measured; the reference's relative noise from
the first run's summary). Each run's error^2 is then about systematic^2 + noise^2 +
reference_noise^2: the noise part is what the gathers and near fields bring whatever the metric
does. With `--pixel-gathers` in the runs, the row `pixel-gathers` (every measured pixel shown from
its own gather, no cache) has the systematic part no record placement removes (the near/far
decomposition's bias); a metric's systematic part above it is its interpolation's. More runs
make the systematic part's estimate steadier (its worst pixels are heavy-tailed).

Under `--near-field` (the pixels' and records' CSVs carry open fractions) it also gives, per
metric, the share of the pixels next to a record of the first run (within 3 pixels) whose open
fraction differs from theirs by more than 0.1, and the share of the systematic square they hold;
and each metric's systematic part split by the pixels' own open fraction (bins 0-0.6, 0.6-0.8,
0.8-0.9, 0.9-0.97, 0.97-1), whose squares add up to the systematic square with the reference's
noise included (a bin whose estimates sum below 0 shows 0): which pixels a safeguard helps, and
which it costs.

usage: noise_split.py RUN RUN [RUN...]   (run prefixes: <prefix>-summary.csv, <prefix>-<metric>-pixels.csv)
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


def per_pixel(runs):
    """(keys, values, errors, references) over the pixels every run measured: values and errors
    as arrays of shape (runs, pixels)."""
    keys = sorted(set.intersection(*(set(r) for r in runs)))
    values = np.array([[r[k][0] for k in keys] for r in runs])
    errors = np.array([[r[k][2] for k in keys] for r in runs])
    references = np.array([runs[0][k][1] for k in keys])
    return keys, values, errors, references


def systematic_estimates(values, errors):
    """Each pixel's unbiased estimate of its systematic square (reference noise included): the
    runs' mean error squared less the sample variance of their values over K."""
    count = values.shape[0]
    return errors.mean(axis=0) ** 2 - values.var(axis=0, ddof=1) / count


def noise_split(runs, reference_noise):
    """(noise, systematic, worst1_share) of one metric from its pixels in K >= 2 runs (as
    read_pixels returns them), over the pixels every run measured: the noise and systematic
    relative RMS parts (the systematic square clamped at 0: the reference's noise or the
    estimate's own noise can exceed it), and the share of the systematic square (reference
    noise included) that the worst 1% of the pixels hold, by each pixel's unbiased estimate.
    None when the runs share no pixel or their references are all 0."""
    keys, values, errors, references = per_pixel(runs)
    ref2 = (references**2).sum()
    if not keys or ref2 <= 0:
        return None
    noise2 = values.var(axis=0, ddof=1).sum() / ref2
    mean2 = (errors.mean(axis=0) ** 2).sum() / ref2
    estimates = np.sort(systematic_estimates(values, errors))[::-1]
    total = estimates.sum()
    worst = estimates[: len(estimates) // 100].sum() / total if total > 0 else 0.0
    systematic2 = mean2 - noise2 / len(runs) - reference_noise**2
    return math.sqrt(noise2), math.sqrt(max(0.0, systematic2)), float(worst)


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


def estimates_with_open_fraction(runs, open_fractions):
    """(keys, estimates, references) over the pixels every run measured that have an open
    fraction: their keys, their per-pixel systematic estimates (as in noise_split) and their
    references."""
    keys, values, errors, references = per_pixel(runs)
    kept = [i for i, k in enumerate(keys) if k in open_fractions]
    return [keys[i] for i in kept], systematic_estimates(values[:, kept], errors[:, kept]), references[kept]


def open_fraction_mismatch(runs, open_fractions, records, within_px=3.0, tolerance=0.1):
    """(pixel share, systematic share): the pixels (every run measured) with a record within
    `within_px` pixels whose open fraction differs from the pixel's by more than `tolerance`,
    as a share of the pixels and of the sum of the per-pixel systematic estimates (as in
    noise_split). None when no pixel has an open fraction, there are no records, or the
    estimates sum to 0 or less."""
    keys, estimate, _ = estimates_with_open_fraction(runs, open_fractions)
    if not keys or not records:
        return None
    rec = np.array(records)
    mismatched = np.zeros(len(keys), dtype=bool)
    for j, (x, y) in enumerate(keys):
        near = np.hypot(rec[:, 0] - x, rec[:, 1] - y) < within_px
        mismatched[j] = near.any() and np.abs(rec[near, 2] - open_fractions[(x, y)]).max() > tolerance
    total = estimate.sum()
    if total <= 0:
        return None
    return float(mismatched.mean()), float(estimate[mismatched].sum() / total)


OPEN_FRACTION_BINS = (0.0, 0.6, 0.8, 0.9, 0.97, 1.0)


def systematic_by_open_fraction(runs, open_fractions, edges=OPEN_FRACTION_BINS):
    """[(low, high, pixel share, part)]: for each bin [low, high) of the pixels' open fractions
    (the last bin closed), the share of the pixels (every run measured, with an open fraction)
    in it and its part of the systematic error, `sqrt(max(0, sum of the bin's per-pixel
    estimates) / sum ref^2)` over all those pixels, the reference's noise included (so that the
    parts' squares add up to the whole's, but for a bin whose sum is negative, shown as 0: the
    estimates' own noise). None when no pixel has an open fraction or the references are all 0."""
    keys, estimate, references = estimates_with_open_fraction(runs, open_fractions)
    ref2 = (references**2).sum()
    if not keys or ref2 <= 0:
        return None
    opens = np.array([open_fractions[k] for k in keys])
    parts = []
    for k, (low, high) in enumerate(zip(edges[:-1], edges[1:])):
        last = k == len(edges) - 2
        inside = (opens >= low) & ((opens <= high) if last else (opens < high))
        part = math.sqrt(max(0.0, float(estimate[inside].sum()) / ref2))
        parts.append((low, high, float(inside.mean()), part))
    return parts


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    prefixes = sys.argv[1:]
    summary = {r["key"]: r["value"] for r in rows(f"{prefixes[0]}-summary.csv")}
    reference_noise = float(summary["reference_relative_noise"])
    print(f"{len(prefixes)} runs; reference noise {reference_noise:.4f}")
    print("| metric | errors | noise | systematic | worst 1% share of the systematic |")
    print("|---|---|---|---|---|")
    found = {}
    for m in METRICS + ["pixel-gathers"]:
        if not all(os.path.exists(f"{p}-{m}-pixels.csv") for p in prefixes):
            continue
        runs = [read_pixels(p, m) for p in prefixes]
        parts = noise_split(runs, reference_noise)
        if parts is None:
            continue
        found[m] = runs
        errors = " / ".join(f"{relative_rms(r):.4f}" for r in runs)
        print(f"| {m} | {errors} | {parts[0]:.4f} | {parts[1]:.4f} | {parts[2]:.2f} |")
    if not found:
        sys.exit(f"no metric measured in every one of {', '.join(prefixes)}")
    for m, runs in found.items():
        if m == "pixel-gathers":
            continue
        open_fractions, records = read_open_fractions(prefixes[0], m), read_records(prefixes[0], m)
        if open_fractions is None or records is None:
            continue
        shares = open_fraction_mismatch(runs, open_fractions, records)
        if shares is not None:
            print(f"{m}: pixels with a record of the first run within 3 px whose open fraction differs from "
                  f"theirs by more than 0.1 are {100 * shares[0]:.1f}% of the pixels and hold "
                  f"{100 * shares[1]:.0f}% of the systematic square")
        bins = systematic_by_open_fraction(runs, open_fractions)
        if bins is not None:
            print(f"{m}: systematic part by the pixel's open fraction (share of the pixels), the "
                  "reference's noise included: "
                  + ", ".join(f"[{lo:g}, {hi:g}{']' if hi == 1.0 else ')'} {part:.4f} ({100 * share:.0f}%)"
                              for lo, hi, share, part in bins))


if __name__ == "__main__":
    main()
