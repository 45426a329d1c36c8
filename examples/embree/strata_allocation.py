#!/usr/bin/env python3
"""Would a second pass over a record's strata beat spending the same paths evenly?

A record's gather traces one path per stratum; the noise of its irradiance is the sum of the
strata's variances. An adaptive gather spends extra paths where a stratum's variance is largest.
With n_i paths in stratum i the variance of the gather's sum is sum_i var_i / n_i (fractional n_i:
the continuous ideal of any rounding). This script prints that variance, relative to one path per
stratum, for a budget of T paths per stratum on average (T = 2 and 4), for:

* even: every stratum T paths (1/T);
* oracle: Neyman's allocation, n_i proportional to the stratum's true standard deviation (at least
  one path), the most any allocation can gain; its deviations come from all traces in the file;
* rules a renderer can run, each taking traces 0-3 in turn as its first pass, averaged:
  * neighbours: n_i proportional to the mean of the first-pass luminance of the stratum's four grid
    neighbours (rows reflect at the pole and the horizon, columns wrap in azimuth) plus c times the
    gather's mean (c = 1, 2). Unbiased: a stratum's count does not depend on its own sample;
  * own sample: n_i proportional to the stratum's own first-pass luminance plus c times the mean (the
    rule of Radiance's super-samples; biased, as the first sample is kept in the average);
  * two-path pilot (T = 4 only): each stratum's deviation estimated from two traces,
    n_i proportional to it plus c times its mean, at least the pilot's two paths.

Only the strata a record reads count: with a near field, those whose hit is at least the reach away
(the record's far field); every stratum otherwise. The neighbour rules still see every stratum's
first pass, as a renderer would.

Input: the files of `raddiff_embree --bench --strata-variance DIR[,every[,paths]]`, one per sampled
record gather: m, n and the trace count P as little-endian uint32, the reach as float64 (0: no near
field), m*n*P float32 luminances (stratum-major: stratum i's traces together), m*n float64 hit
distances (inf for a miss).

usage: python3 examples/embree/strata_allocation.py DIR [DIR ...]
"""

import glob
import os
import sys

import numpy as np

BUDGETS = (2, 4)
DAMPING = (1.0, 2.0)
FIRST_PASSES = 4


def read_strata(path):
    """(luminance[m*n, P], distance[m*n], m, n, reach) of one file."""
    raw = open(path, "rb").read()
    m, n, paths = np.frombuffer(raw, "<u4", 3)
    reach = np.frombuffer(raw, "<f8", 1, 12)[0]
    count = int(m) * int(n)
    lum = np.frombuffer(raw, "<f4", count * int(paths), 20).astype(np.float64).reshape(count, int(paths))
    distance = np.frombuffer(raw, "<f8", count, 20 + 4 * count * int(paths))
    return lum, distance, int(m), int(n), float(reach)


def neighbour_mean(values, m, n):
    """The mean of each stratum's four grid neighbours (rows reflected, columns wrapped)."""
    g = values.reshape(m, n)
    if m > 1:
        up = np.vstack([g[1:2], g[:-1]])
        down = np.vstack([g[1:], g[-2:-1]])
    else:
        up = down = g
    return ((up + down + np.roll(g, 1, 1) + np.roll(g, -1, 1)) / 4).ravel()


def allocate(score, budget, floor=1.0):
    """Paths per stratum proportional to `score`, at least `floor`, `budget` per stratum on average."""
    s = np.maximum(score, 0.0)
    total = budget * len(s)
    fixed = np.zeros(len(s), dtype=bool)
    counts = np.full(len(s), float(budget))
    for _ in range(len(s)):
        free = ~fixed
        weight = s[free].sum()
        rest = total - floor * fixed.sum()
        counts[free] = rest * s[free] / weight if weight > 0 else rest / free.sum()
        low = free & (counts < floor)
        if not low.any():
            break
        fixed |= low
        counts[fixed] = floor
    return counts


def read_strata_mask(distance, reach):
    """The strata a record reads: those at least the reach away (all without a near field)."""
    return distance >= reach if reach > 0 else np.ones(len(distance), dtype=bool)


def noisiest_share(lum, distance, m, n, reach, fraction=0.05):
    """The share of the gather's variance in its noisiest `fraction` of read strata (None: no variance)."""
    var = np.sort(lum[read_strata_mask(distance, reach)].var(axis=1, ddof=1))[::-1]
    total = var.sum()
    return float(var[: max(1, int(round(fraction * len(var))))].sum() / total) if total > 0 else None


def relative_variances(lum, distance, m, n, reach):
    """{rule: {budget: variance relative to one path per stratum}} for one gather, or None when its
    read strata have no variance."""
    read = read_strata_mask(distance, reach)
    var = lum[read].var(axis=1, ddof=1)
    one_path = var.sum()
    if not one_path > 0:
        return None
    out = {}

    def put(rule, budget, counts):
        out.setdefault(rule, {})[budget] = float((var / counts).sum() / one_path)

    passes = min(FIRST_PASSES, lum.shape[1] // 2)
    for budget in BUDGETS:
        put("even", budget, np.full(len(var), float(budget)))
        put("oracle (true deviations)", budget, allocate(np.sqrt(var), budget))
        for c in DAMPING:
            for rule, score_of in (
                (f"neighbours' mean + {c:g} x mean", lambda x: neighbour_mean(x, m, n)[read]),
                (f"own sample + {c:g} x mean (biased)", lambda x: x[read]),
            ):
                got = []
                for k in range(passes):
                    first = lum[:, k]
                    got.append((var / allocate(score_of(first) + c * first[read].mean(), budget)).sum())
                out.setdefault(rule, {})[budget] = float(np.mean(got) / one_path)
        if budget >= 4:
            for c in (0.0,) + DAMPING:
                got = []
                for k in range(passes):
                    pair = lum[read][:, [k, k + passes]]
                    deviation = np.abs(pair[:, 0] - pair[:, 1]) / np.sqrt(2)
                    counts = allocate(deviation + c * deviation.mean(), budget, floor=2.0)
                    got.append((var / counts).sum())
                out.setdefault(f"two-path pilot + {c:g} x mean (biased)", {})[budget] = float(np.mean(got) / one_path)
    return out


def summarize(folder):
    """(gathers, mean share of the variance in the noisiest 5% of the strata,
    {rule: {budget: (mean, median)}}) over the files of one folder."""
    per_rule = {}
    shares = []
    for path in sorted(glob.glob(os.path.join(folder, "*.strata"))):
        strata = read_strata(path)
        got = relative_variances(*strata)
        if got is None:
            continue
        shares.append(noisiest_share(*strata))
        for rule, by_budget in got.items():
            for budget, v in by_budget.items():
                per_rule.setdefault(rule, {}).setdefault(budget, []).append(v)
    return len(shares), float(np.mean(shares)) if shares else 0.0, {
        rule: {b: (float(np.mean(v)), float(np.median(v))) for b, v in by_budget.items()}
        for rule, by_budget in per_rule.items()
    }


def main():
    if len(sys.argv) < 2:
        print(__doc__)
        sys.exit(2)
    for folder in sys.argv[1:]:
        gathers, share, table = summarize(folder)
        print(f"{folder}: {gathers} gathers; their noisiest 5% of strata hold {100 * share:.0f}% of the "
              "variance on average.\nThe gather's variance relative to one path per stratum, mean (median):")
        print("| allocation | " + " | ".join(f"{b} paths per stratum" for b in BUDGETS) + " |")
        print("|---|" + "---|" * len(BUDGETS))
        for rule, by_budget in table.items():
            cells = [f"{by_budget[b][0]:.3f} ({by_budget[b][1]:.3f})" if b in by_budget else "" for b in BUDGETS]
            print(f"| {rule} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
