#!/usr/bin/env python3
"""The real-scene benchmark's report: reads the files `raddiff_embree --bench` wrote under a
folder (one run per `<run>-summary.csv`) and the denoised path-tracing snapshots bench.sh made,
and writes report.md, report.csv and the figures (error against CPU time, error maps, record
plots, radius distributions) into the same folder.

usage: report.py OUT_DIR
"""

import csv
import math
import os
import sys

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Ellipse  # noqa: E402
from PIL import Image  # noqa: E402  (pillow: a dependency of matplotlib)

LUMA = np.array([0.2126, 0.7152, 0.0722])
METRICS = [
    "split-sphere",
    "bounded-split-sphere",
    "gradient",
    "hessian-unaware",
    "hessian-geometric",
    "hessian-isotropic",
    "hessian-anisotropic",
]
STYLE = {
    "split-sphere": ("tab:blue", "o"),
    "bounded-split-sphere": ("tab:cyan", "s"),
    "gradient": ("tab:olive", "^"),
    "hessian-unaware": ("tab:purple", "v"),
    "hessian-geometric": ("tab:brown", "D"),
    "hessian-isotropic": ("tab:orange", "P"),
    "hessian-anisotropic": ("tab:red", "*"),
    "path-tracing": ("0.5", "x"),
    "path-tracing+oidn": ("black", "+"),
}


def read_pfm(path):
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            raise ValueError(f"{path}: not an RGB PFM")
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.fromfile(f, "<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return data[::-1]


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def num(s):
    try:
        return float(s)
    except ValueError:
        return s


class Run:
    def __init__(self, folder, name):
        self.folder, self.name = folder, name
        p = os.path.join(folder, name)
        self.summary = {r["key"]: num(r["value"]) for r in rows(p + "-summary.csv")}
        self.fills = [{k: num(v) for k, v in r.items()} for r in rows(p + "-fills.csv")]
        self.floor = {r["metric"]: float(r["floor_rel_rms"]) for r in rows(p + "-floor.csv")}
        self.measured = rows(p + "-measured.csv")
        self.width, self.height = int(self.summary["width"]), int(self.summary["height"])
        self.pt = [{k: num(v) for k, v in r.items()} for r in rows(p + "-pt.csv")] if os.path.exists(p + "-pt.csv") else []
        self.oidn = []
        oidn_csv = p + "-pt-oidn.csv"
        if os.path.exists(oidn_csv):
            for r in rows(oidn_csv):
                spp = int(r["spp"])
                base = next((q for q in self.pt if int(q["spp"]) == spp), None)
                if base is None:
                    continue
                err, worst = self.score(read_pfm(r["file"]))
                self.oidn.append(
                    {"spp": spp, "cpu_s": base["cpu_s"] + float(r["oidn_cpu_s"]), "oidn_cpu_s": float(r["oidn_cpu_s"]),
                     "rel_rms": err, "worst1_share": worst, "file": r["file"]})
        self.metrics = [m for m in METRICS if any(f["metric"] == m for f in self.fills)]

    def path(self, suffix):
        return os.path.join(self.folder, self.name + suffix)

    def score(self, image):
        lum = image @ LUMA
        e = np.array([lum[int(r["y"]), int(r["x"])] - float(r["reference"]) for r in self.measured])
        ref = np.array([float(r["reference"]) for r in self.measured])
        sq = np.sort(e * e)[::-1]
        worst = max(1, len(sq) // 100)
        return math.sqrt((e * e).sum() / (ref * ref).sum()), sq[:worst].sum() / max(sq.sum(), 1e-300)

    def equal(self, metric):
        return next((f for f in self.fills if f["metric"] == metric and int(f["equal_records"]) == 1), None)

    def curve(self, metric):
        return sorted((f for f in self.fills if f["metric"] == metric), key=lambda f: f["total_s"])


def interpolate_loglog(points, x):
    """Error of a (time, error) curve at time x, log-log interpolation (None outside it)."""
    pts = sorted(points)
    for (x0, y0), (x1, y1) in zip(pts, pts[1:]):
        if x0 <= x <= x1 and x1 > x0:
            t = (math.log(x) - math.log(x0)) / (math.log(x1) - math.log(x0))
            return math.exp(math.log(y0) + t * (math.log(y1) - math.log(y0)))
    return None


def time_to_reach(points, target):
    """The first time a (time, error) curve reaches `target` error (log-log between its points),
    or None when it never does."""
    pts = sorted(points)
    if pts and pts[0][1] <= target:
        return pts[0][0]
    for (x0, y0), (x1, y1) in zip(pts, pts[1:]):
        if y0 > target >= y1:
            t = (math.log(target) - math.log(y0)) / (math.log(y1) - math.log(y0))
            return math.exp(math.log(x0) + t * (math.log(x1) - math.log(x0)))
    return None


def records_to_reach(run, target):
    """The anisotropic Hessian's records at `target` error, log-log between the points of its
    error-against-records curve: (records, False), or (its fewest records, True) when already its
    cheapest point is at or below the target, or None when it never reaches it (or did not run)."""
    pts = [(g["records"], g["rel_rms"]) for g in run.curve("hessian-anisotropic")]
    if not pts:
        return None
    fewest = min(pts)
    if fewest[1] <= target:
        return fewest[0], True
    n = time_to_reach(pts, target)
    return None if n is None else (n, False)


def trimmed_error(run, metric):
    """Relative RMS error without the worst 1% of the measured pixels (the bulk of the image)."""
    pixels = rows(run.path(f"-{metric}-pixels.csv"))
    sq = sorted((float(r["error"]) ** 2 for r in pixels), reverse=True)
    ref2 = sum(float(r["reference"]) ** 2 for r in pixels)
    return math.sqrt(sum(sq[len(sq) // 100:]) / ref2) if ref2 > 0 else 0.0


EDGE_ANGLE = 0.2  # radians: the cache's own maximum normal deviation


def edge_pixels(run):
    """The measured pixels within one pixel of a geometric edge (a crease, a silhouette or the
    rim of the background): a 4-neighbour pair whose primary-hit normals differ by more than
    EDGE_ANGLE marks both pixels, then the mark grows by one pixel. None without a normal buffer."""
    path = run.path("-normal.pfm")
    if not os.path.exists(path):
        return None
    n = read_pfm(path)
    n = n / np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-12)
    edge = np.zeros(n.shape[:2], dtype=bool)
    for dy, dx in ((0, 1), (1, 0)):
        h, w = n.shape[0] - dy, n.shape[1] - dx
        apart = (n[:h, :w] * n[dy:, dx:]).sum(axis=2) < math.cos(EDGE_ANGLE)
        edge[:h, :w] |= apart
        edge[dy:, dx:] |= apart
    near = edge.copy()
    near[1:, :] |= edge[:-1, :]
    near[:-1, :] |= edge[1:, :]
    near[:, 1:] |= edge[:, :-1]
    near[:, :-1] |= edge[:, 1:]
    return np.array([near[int(r["y"]), int(r["x"])] for r in run.measured])


def edge_split(run, metric, at_edge):
    """A metric's relative RMS error split into the part at edge pixels and the part away from
    them (each over the same total reference, so the squares add up to the error's square)."""
    if at_edge is None:
        return None, None
    pixels = rows(run.path(f"-{metric}-pixels.csv"))
    e2 = np.array([float(r["error"]) ** 2 for r in pixels])
    ref2 = sum(float(r["reference"]) ** 2 for r in pixels)
    if ref2 <= 0 or len(e2) != len(at_edge):
        return None, None
    return math.sqrt(e2[at_edge].sum() / ref2), math.sqrt(e2[~at_edge].sum() / ref2)


def shared_split(run, metrics):
    """Every metric's error split into the part all of `metrics` share and its own part: at each
    measured pixel the shared part is the mean of the metrics' errors, a metric's own part its
    error minus that mean. Returns (shared relative RMS, {metric: own relative RMS}), or None
    with fewer than two metrics. The shared part holds what every metric gets wrong alike (the
    near field's and the reference's noise, the noise of the gathers they all interpolate, the
    near/far decomposition's bias) besides the mean of their interpolation errors; a metric's own
    part is where its records make it depart from the others."""
    if len(metrics) < 2:
        return None
    pixels = {m: {(int(r["x"]), int(r["y"])): r for r in rows(run.path(f"-{m}-pixels.csv"))} for m in metrics}
    keys = sorted(set.intersection(*(set(p) for p in pixels.values())))
    if not keys:
        return None
    e = np.array([[float(pixels[m][k]["error"]) for k in keys] for m in metrics])
    ref2 = sum(float(pixels[metrics[0]][k]["reference"]) ** 2 for k in keys)
    if ref2 <= 0:
        return None
    shared = e.mean(axis=0)
    own = {m: math.sqrt(((e[i] - shared) ** 2).sum() / ref2) for i, m in enumerate(metrics)}
    return math.sqrt((shared**2).sum() / ref2), own


def mosaic(run, values):
    """Each measured pixel's value over its stratum (the grid of the stratified selection)."""
    g = int(run.summary["reference_grid"])
    out = np.full((run.height, run.width), np.nan)
    for r, v in zip(run.measured, values):
        x, y = int(r["x"]), int(r["y"])
        gx, gy = x * g // run.width, y * g // run.height
        out[gy * run.height // g:(gy + 1) * run.height // g, gx * run.width // g:(gx + 1) * run.width // g] = v
    return out


def tonemap(lum, exposure):
    v = np.clip(lum * exposure, 0, 1)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def plot_error_time(run):
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for m in run.metrics + ["path-tracing", "path-tracing+oidn"]:
        if m == "path-tracing":
            pts = [(p["cpu_s"], p["rel_rms"]) for p in run.pt]
        elif m == "path-tracing+oidn":
            pts = [(p["cpu_s"], p["rel_rms"]) for p in run.oidn]
        else:
            pts = [(f["total_s"], f["rel_rms"]) for f in run.curve(m)]
        if not pts:
            continue
        pts.sort()
        colour, marker = STYLE[m]
        ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=marker, color=colour, label=m,
                linestyle="--" if m.startswith("path") else "-")
    floors = [v for v in run.floor.values()]
    if floors:
        ax.axhline(float(np.median(floors)), color="0.3", linestyle=":", linewidth=1,
                   label="gathers' own error (floor)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("CPU seconds (tracing + raddiff + cache; path tracing + denoising)")
    ax.set_ylabel("relative RMS error of the indirect irradiance")
    ax.set_title(f"{run.name}: error against CPU time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(run.path("-error-time.png"), dpi=90)
    plt.close(fig)


def plot_error_map(run, metric, scale):
    rows_ = rows(run.path(f"-{metric}-pixels.csv"))
    err = [abs(float(r["error"])) / scale for r in rows_]
    fig, ax = plt.subplots(figsize=(5.2, 4.4))
    cmap = matplotlib.colormaps["inferno"].copy()
    cmap.set_bad("0.5")  # strata with no measured pixel (sky, emitters, black surfaces)
    im = ax.imshow(mosaic(run, err), cmap=cmap, vmin=0, vmax=0.25, interpolation="nearest")
    ax.set_title(f"{metric}: |error| / mean reference", fontsize=9)
    ax.axis("off")
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
    fig.tight_layout()
    fig.savefig(run.path(f"-{metric}-error.png"), dpi=80)
    plt.close(fig)


def plot_records(run, metric):
    image = read_pfm(run.path(f"-{metric}.pfm")) @ LUMA
    recs = rows(run.path(f"-{metric}-records.csv"))
    fig, ax = plt.subplots(figsize=(5.2, 5.2))
    ax.imshow(0.6 * tonemap(image, float(run.summary["exposure"])), cmap="gray", vmin=0, vmax=1)
    for r in recs:
        cx, cy = float(r["px"]), float(r["py"])
        u = np.array([float(r["ux"]), float(r["uy"])])
        v = np.array([float(r["vx"]), float(r["vy"])])
        t = np.linspace(0, 2 * np.pi, 25)
        pts = np.array([cx, cy])[:, None] + np.outer(u, np.cos(t)) + np.outer(v, np.sin(t))
        ax.plot(pts[0], pts[1], color="orange", linewidth=0.3, alpha=0.6)
    ax.scatter([float(r["px"]) for r in recs], [float(r["py"]) for r in recs], s=0.3, color="yellow")
    ax.set_xlim(0, run.width)
    ax.set_ylim(run.height, 0)
    ax.set_title(f"{metric}: {len(recs)} records", fontsize=9)
    ax.axis("off")
    fig.tight_layout()
    fig.savefig(run.path(f"-{metric}-records.png"), dpi=90)
    plt.close(fig)


def plot_radii(run):
    fig, ax = plt.subplots(figsize=(7, 4))
    for m in run.metrics:
        r = [float(x["radius_px"]) for x in rows(run.path(f"-{m}-records.csv"))]
        if not r:
            continue
        r = np.sort(r)
        ax.plot(r, np.linspace(0, 1, len(r)), color=STYLE[m][0], label=m)
    ax.set_xscale("log")
    ax.set_xlabel("record's smallest radius (pixels)")
    ax.set_ylabel("fraction of records")
    ax.set_title(f"{run.name}: record radii at equal records")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(run.path("-radii.png"), dpi=90)
    plt.close(fig)


def plot_reference(run):
    ref = [float(r["reference"]) for r in run.measured]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.6))
    reference = np.ma.masked_invalid(tonemap(mosaic(run, ref), float(run.summary["exposure"])))
    grey = matplotlib.colormaps["gray"].copy()
    grey.set_bad("tab:blue")  # strata with no measured pixel (sky, emitters, black surfaces)
    axes[0].imshow(reference, cmap=grey, vmin=0, vmax=1, interpolation="nearest")
    axes[0].set_title(f"converged reference at {len(ref)} stratified pixels", fontsize=9)
    if run.pt:
        best = max(run.pt, key=lambda p: p["spp"])
        axes[1].imshow(tonemap(read_pfm(best["file"]) @ LUMA, float(run.summary["exposure"])), cmap="gray", vmin=0,
                       vmax=1)
        axes[1].set_title(f"path traced, {int(best['spp'])} spp per pixel (for viewing)", fontsize=9)
    for a in axes:
        a.axis("off")
    fig.tight_layout()
    fig.savefig(run.path("-reference.png"), dpi=90)
    plt.close(fig)


def plot_panel(run, metrics, scale):
    """One figure for the guides: per metric (one row each) its cache image, error map and records."""
    metrics = [m for m in metrics if m in run.metrics]
    if not metrics:
        return
    exposure = float(run.summary["exposure"])
    cmap = matplotlib.colormaps["inferno"].copy()
    cmap.set_bad("0.5")
    fig, axes = plt.subplots(len(metrics), 3, figsize=(12, 4 * len(metrics)), squeeze=False)
    for row, m in zip(axes, metrics):
        image = read_pfm(run.path(f"-{m}.pfm")) @ LUMA
        f = run.equal(m)
        row[0].imshow(tonemap(image, exposure), cmap="gray", vmin=0, vmax=1)
        row[0].set_title(f"{m}: {int(f['records'])} records, error {f['rel_rms']:.4f}", fontsize=9)
        err = [abs(float(r["error"])) / scale for r in rows(run.path(f"-{m}-pixels.csv"))]
        im = row[1].imshow(mosaic(run, err), cmap=cmap, vmin=0, vmax=0.25, interpolation="nearest")
        row[1].set_title("|error| / mean reference at the measured pixels", fontsize=9)
        fig.colorbar(im, ax=row[1], fraction=0.046, pad=0.04)
        row[2].imshow(0.6 * tonemap(image, exposure), cmap="gray", vmin=0, vmax=1)
        for r in rows(run.path(f"-{m}-records.csv")):
            u = np.array([float(r["ux"]), float(r["uy"])])
            v = np.array([float(r["vx"]), float(r["vy"])])
            t = np.linspace(0, 2 * np.pi, 25)
            pts = np.array([float(r["px"]), float(r["py"])])[:, None] + np.outer(u, np.cos(t)) + np.outer(v, np.sin(t))
            row[2].plot(pts[0], pts[1], color="orange", linewidth=0.25, alpha=0.6)
        row[2].set_xlim(0, run.width)
        row[2].set_ylim(run.height, 0)
        row[2].set_title("records (centres and extents)", fontsize=9)
        for a in row:
            a.axis("off")
    fig.tight_layout()
    fig.savefig(run.path("-panel.png"), dpi=60)
    plt.close(fig)
    # A 256-colour palette keeps the guides' copies small (a quarter of the RGBA file's size).
    with Image.open(run.path("-panel.png")) as im:
        im.convert("RGB").quantize(256).save(run.path("-panel.png"), optimize=True)


def fmt(x, digits=4):
    return "" if x is None else f"{x:.{digits}f}"


def report_run(run, md, table):
    s = run.summary
    scale = float(s["reference_mean"])
    plot_error_time(run)
    plot_radii(run)
    plot_reference(run)
    for m in run.metrics:
        plot_error_map(run, m, scale)
        plot_records(run, m)
    plot_panel(run, METRICS, scale)

    md.append(f"## {run.name}\n")
    md.append(
        f"{int(s['width'])} x {int(s['height'])} px, {int(s['triangles'])} triangles, scene size "
        f"{float(s['scene_size']):.3g}; gathers {s['gather']}, hit radiance: {s['hit_radiance']}; "
        f"records tuned to {int(s['target_records'])} (within 5%); reference: {int(s['measured_pixels'])} "
        f"stratified pixels x {int(s['reference_rays'])} rays, relative noise "
        f"{float(s['reference_relative_noise']):.4f}; {int(s['gathers_computed'])} gathers computed "
        f"(shared by every metric and threshold); max RSS {int(s['max_rss_mib'])} MiB; "
        f"{float(s['process_cpu_s']):.0f} CPU s in all.\n")
    split = run.equal("split-sphere")
    anis = run.equal("hessian-anisotropic")
    at_edge = edge_pixels(run)
    if at_edge is not None:
        md.append(
            f"Edge pixels (within one pixel of a crease or silhouette, normals {EDGE_ANGLE} rad apart): "
            f"{int(at_edge.sum())} of {len(at_edge)} measured pixels; the error is split into its part at "
            f"them and away from them (the squares add up to the error's square).\n")
    shared = shared_split(run, [m for m in run.metrics if run.equal(m) is not None])
    if shared is not None:
        md.append(
            f"Shared by every metric: {shared[0]:.4f} (at each measured pixel the mean of the metrics' errors "
            f"at equal records); \"own part\" is a metric's error minus that mean, where its records make it "
            f"depart from the others.\n")
    own_gathers = float(s.get("pixel_gathers_rel_rms", -1))
    if own_gathers >= 0:
        md.append(
            f"Every measured pixel from its own gather, with no cache (`--pixel-gathers`): {own_gathers:.4f}, "
            f"what a record at every pixel would give (the gathers' and near field's noise, the near/far "
            f"decomposition's bias, the reference's noise); a cache can fall a little below it where its "
            f"lookups average neighbouring records' noise.\n")
        table.append([run.name, "pixel-gathers", "", "", "", "", "", "", own_gathers, "", "", "", "", "", "", 0])
    md.append("| metric | records | CPU s (trace / raddiff / cache) | raddiff share | error | vs split sphere "
              "| gathers' floor | interpolation | own part | worst 1% share | without the worst 1% "
              "| at edges / away | CPU s to the Hessian's error | the Hessian's records at this error "
              "| radius px (min / 5% / median) |")
    md.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    errors = []
    for m in run.metrics:
        f = run.equal(m)
        if f is None:
            continue
        floor = run.floor.get(m)
        interp = math.sqrt(max(0.0, f["rel_rms"] ** 2 - floor ** 2)) if floor is not None else None
        ratio = f["rel_rms"] / split["rel_rms"] if split else None
        share = f["raddiff_s"] / f["total_s"] if f["total_s"] > 0 else 0
        errors.append(f["rel_rms"])
        trimmed = trimmed_error(run, m)
        edge_part, away_part = edge_split(run, m, at_edge)
        edges_text = "" if edge_part is None else f"{edge_part:.4f} / {away_part:.4f}"
        own = shared[1][m] if shared is not None else None
        reach = time_to_reach([(g["total_s"], g["rel_rms"]) for g in run.curve(m)], anis["rel_rms"]) if anis else None
        reach_text = "not reached" if reach is None else f"{reach:.1f}"
        need = None if m == "hessian-anisotropic" else records_to_reach(run, f["rel_rms"])
        need_text = ("" if m == "hessian-anisotropic" else "not reached" if need is None else
                     f"{'at most ' if need[1] else ''}{need[0]:.0f} ({need[0] / f['records']:.2f}x)")
        md.append(
            f"| {m} | {int(f['records'])} | {f['total_s']:.1f} ({f['trace_s']:.1f} / {f['raddiff_s']:.2f} / "
            f"{f['cache_s']:.2f}) | {100 * share:.1f}% | {fmt(f['rel_rms'])} | {fmt(ratio, 2)} | {fmt(floor)} | "
            f"{fmt(interp)} | {fmt(own)} | {f['worst1_share']:.2f} | {fmt(trimmed)} | {edges_text} | {reach_text} | "
            f"{need_text} | "
            f"{f['radius_px_min']:.1f} / {f['radius_px_p5']:.1f} / {f['radius_px_median']:.1f} |")
        table.append([run.name, m, f["parameter"], int(f["records"]), f["trace_s"], f["raddiff_s"], f["cache_s"],
                      f["total_s"], f["rel_rms"], floor, f["worst1_share"], trimmed, fmt(edge_part),
                      fmt(away_part), fmt(own), 1])
        for g in run.curve(m):
            if int(g["equal_records"]) == 0:
                table.append([run.name, m, g["parameter"], int(g["records"]), g["trace_s"], g["raddiff_s"],
                              g["cache_s"], g["total_s"], g["rel_rms"], "", g["worst1_share"], "", "", "", "", 0])
    for kind, pts in (("path-tracing", run.pt), ("path-tracing+oidn", run.oidn)):
        for p in pts:
            table.append([run.name, kind, p["spp"], "", "", "", "", p["cpu_s"], p["rel_rms"], "", p["worst1_share"],
                          "", "", "", "", 0])
        if anis and pts:
            e = interpolate_loglog([(p["cpu_s"], p["rel_rms"]) for p in pts], anis["total_s"])
            reach = time_to_reach([(p["cpu_s"], p["rel_rms"]) for p in pts], anis["rel_rms"])
            reach_text = "not reached" if reach is None else f"{reach:.1f}"
            if e is not None:
                errors.append(e)
                md.append(f"| {kind} at the anisotropic Hessian's {anis['total_s']:.1f} CPU s | | | | {fmt(e)} | "
                          f"{fmt(e / split['rel_rms'] if split else None, 2)} | | | | | | | {reach_text} | | |")
    md.append("")
    noise = float(s["reference_relative_noise"])
    smallest = min(errors) if errors else 0
    md.append(
        f"Reference noise {noise:.4f} against the smallest error in this table {smallest:.4f}: "
        f"{'within' if noise <= smallest / 5 else 'NOT within'} the 1/5 the measurement needs.\n")
    md.append(f"![error against time]({run.name}-error-time.png)\n")
    md.append(f"![reference]({run.name}-reference.png) ![radii]({run.name}-radii.png)\n")
    md.append("| metric | cache | error map | records |")
    md.append("|---|---|---|---|")
    for m in run.metrics:
        md.append(f"| {m} | ![]({run.name}-{m}.png) | ![]({run.name}-{m}-error.png) | ![]({run.name}-{m}-records.png) |")
    md.append("")


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    folder = sys.argv[1]
    runs = sorted(f[: -len("-summary.csv")] for f in os.listdir(folder) if f.endswith("-summary.csv"))
    if not runs:
        sys.exit(f"no runs (*-summary.csv) in {folder}")
    md = ["# Real-scene benchmark report\n",
          "Relative RMS error of the indirect irradiance's luminance at the measured pixels against the "
          "converged reference; CPU seconds summed over threads. Written by examples/embree/report.py.\n"]
    table = [["run", "metric", "parameter", "records", "trace_s", "raddiff_s", "cache_s", "total_s", "rel_rms",
              "gather_floor", "worst1_share", "rel_rms_without_worst1", "rel_rms_at_edges", "rel_rms_away_from_edges",
              "rel_rms_own_part", "equal_records"]]
    for name in runs:
        report_run(Run(folder, name), md, table)
    with open(os.path.join(folder, "report.md"), "w") as f:
        f.write("\n".join(md) + "\n")
    with open(os.path.join(folder, "report.csv"), "w", newline="") as f:
        csv.writer(f).writerows(table)
    print(f"report: {os.path.join(folder, 'report.md')}, {os.path.join(folder, 'report.csv')}")


if __name__ == "__main__":
    main()
