#!/usr/bin/env python3
"""Denoises every path-tracing snapshot of one benchmark run with Open Image Denoise.

The colour is the irradiance; the guides are a white albedo (irradiance is what the surface's
reflectance multiplies, so its albedo is 1) and the primary hits' normals, both noise-free
(--clean_aux). Of the variants tried (colour only, Kd as albedo, demodulated radiance), this one
and colour-only gave the smallest errors. Writes <run>-pt-sppN-oidn.pfm and <run>-pt-oidn.csv
with the denoiser's CPU seconds (user + system of its process), which the report adds to the path
tracer's.

usage: denoise.py RUN_PREFIX OIDN_DENOISE_BINARY
"""

import csv
import resource
import subprocess
import sys

import numpy as np


def main():
    prefix, oidn = sys.argv[1], sys.argv[2]
    with open(prefix + "-normal.pfm", "rb") as f:
        f.readline()
        w, h = map(int, f.readline().split())
        f.readline()
        normal = np.fromfile(f, "<f4").reshape(h, w, 3)
    white = np.repeat((np.abs(normal).sum(2, keepdims=True) > 0).astype("<f4"), 3, axis=2)
    with open(prefix + "-white.pfm", "wb") as f:
        f.write(b"PF\n%d %d\n-1\n" % (w, h))
        f.write(white.tobytes())
    with open(prefix + "-pt.csv") as f:
        snapshots = list(csv.DictReader(f))
    out = [["spp", "oidn_cpu_s", "file"]]
    for s in snapshots:
        denoised = s["file"][: -len(".pfm")] + "-oidn.pfm"
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([oidn, "--hdr", s["file"], "--alb", prefix + "-white.pfm", "--nrm", prefix + "-normal.pfm",
                        "--clean_aux", "-o", denoised], check=True, capture_output=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        out.append([s["spp"], f"{cpu:.4f}", denoised])
    with open(prefix + "-pt-oidn.csv", "w", newline="") as f:
        csv.writer(f).writerows(out)


if __name__ == "__main__":
    main()
