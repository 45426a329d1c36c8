//! The report: records, time and RMS error against the reference per metric (markdown and CSV),
//! and the series of the error-against-time plot.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use glam::DVec3;

use crate::caching::{rms_error, Baseline, GatherStore, Run};
use crate::cli::Options;
use crate::image::luminance;
use crate::plot::Series;
use crate::render::GBuffer;

/// Error maps show |error| / mean reference luminance from 0 to this value.
pub const ERROR_MAP_SCALE: f64 = 0.1;

/// One cache run's figures.
#[derive(Clone, Debug)]
pub struct Row {
    pub metric: &'static str,
    pub parameter: f64,
    pub records: usize,
    pub trace_seconds: f64,
    pub raddiff_seconds: f64,
    pub cache_seconds: f64,
    pub rms: f64,
    pub relative_rms: f64,
    pub uncovered: usize,
    /// Minimum, 5th percentile and median of the records' smallest radii (scene units); `None`
    /// without records.
    pub radii: Option<RadiusStats>,
    /// Share of the squared luminance error held by the worst 1% of the measured pixels; `None`
    /// without error.
    pub worst_share: Option<f64>,
}

/// The distribution of the records' smallest radii.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiusStats {
    pub min: f64,
    pub p5: f64,
    pub median: f64,
}

impl RadiusStats {
    /// Nearest-rank minimum, 5th percentile and median of `radii`; `None` if empty.
    pub fn of(mut radii: Vec<f64>) -> Option<RadiusStats> {
        if radii.is_empty() {
            return None;
        }
        radii.sort_by(f64::total_cmp);
        let rank =
            |q: f64| radii[((q * radii.len() as f64).ceil() as usize).clamp(1, radii.len()) - 1];
        Some(RadiusStats {
            min: radii[0],
            p5: rank(0.05),
            median: rank(0.5),
        })
    }
}

/// The share of the total of `squared_errors` held by its largest ceil(1%) entries: 0.01 for an
/// error spread evenly, 1 for an error in a single pixel (of 100 or fewer). `None` if the total is 0.
pub fn worst_percent_share(mut squared_errors: Vec<f64>) -> Option<f64> {
    let total: f64 = squared_errors.iter().sum();
    if squared_errors.is_empty() || total <= 0.0 {
        return None;
    }
    let k = squared_errors.len().div_ceil(100);
    squared_errors.sort_by(|a, b| b.total_cmp(a));
    Some(squared_errors[..k].iter().sum::<f64>() / total)
}

/// Squared luminance errors at the pixels the cache serves (`gbuffer.pixels[i].shaded()`).
fn shaded_squared_errors(image: &[DVec3], reference: &[DVec3], gbuffer: &GBuffer) -> Vec<f64> {
    image
        .iter()
        .zip(reference)
        .zip(&gbuffer.pixels)
        .filter(|(_, p)| p.shaded().is_some())
        .map(|((v, r), _)| (luminance(*v) - luminance(*r)).powi(2))
        .collect()
}

impl Row {
    pub fn new(run: &Run, reference: &[DVec3], gbuffer: &GBuffer) -> Row {
        let (rms, relative_rms) = rms_error(&run.image, reference, gbuffer);
        Row {
            metric: run.metric.name(),
            parameter: run.parameter,
            records: run.records.len(),
            trace_seconds: run.trace_seconds,
            raddiff_seconds: run.raddiff_seconds,
            cache_seconds: run.cache_seconds,
            rms,
            relative_rms,
            uncovered: run.uncovered,
            radii: RadiusStats::of(
                run.records
                    .iter()
                    .map(|r| r.extent.radii[0].min(r.extent.radii[1]))
                    .collect(),
            ),
            worst_share: worst_percent_share(shaded_squared_errors(&run.image, reference, gbuffer)),
        }
    }

    fn total(&self) -> f64 {
        self.trace_seconds + self.raddiff_seconds + self.cache_seconds
    }
}

pub struct SceneReport {
    scene: String,
    settings: String,
    tuned: Vec<Row>,
    sweeps: Vec<Vec<Row>>,
    overhead: String,
    /// The volume (media) caches' tuned rows, sweeps and settings (room only).
    media: Vec<Row>,
    media_sweeps: Vec<Vec<Row>>,
    media_settings: String,
}

impl SceneReport {
    pub fn new(scene: &str, o: &Options, reference_seconds: f64, baseline: Baseline) -> Self {
        SceneReport {
            scene: scene.to_string(),
            settings: format!(
                "{} baselines ({}). {}x{} pixels, gathers of {}x{} = {} rays, target {} records, \
                 reference {} rays per pixel ({reference_seconds:.1} s wall), {} threads",
                baseline.name(),
                baseline.summary(o.safeguards),
                o.width,
                o.height,
                o.gather_m,
                o.gather_n,
                o.gather_m * o.gather_n,
                o.records,
                o.reference_samples,
                rayon::current_num_threads()
            ),
            tuned: Vec::new(),
            sweeps: Vec::new(),
            overhead: String::new(),
            media: Vec::new(),
            media_sweeps: Vec::new(),
            media_settings: String::new(),
        }
    }

    pub fn add(&mut self, tuned: Row, sweep: Vec<Row>) {
        self.tuned.push(tuned);
        self.sweeps.push(sweep);
    }

    pub fn add_media(&mut self, tuned: Row, sweep: Vec<Row>) {
        self.media.push(tuned);
        self.media_sweeps.push(sweep);
    }

    pub fn media_settings(&mut self, text: String) {
        self.media_settings = text;
    }

    /// raddiff's derivative work against the ray casting of the same gathers.
    pub fn overhead(&mut self, store: &GatherStore, reference: &[DVec3]) {
        let (mut trace, mut gradient, mut hessian, mut count) = (0.0, 0.0, 0.0, 0usize);
        for g in store.computed() {
            trace += g.trace_seconds;
            gradient += g.gradient_seconds;
            hessian += g.hessian_seconds;
            count += 1;
        }
        if count == 0 || trace <= 0.0 {
            return;
        }
        let per = |s: f64| s / count as f64 * 1e6;
        let mut text = format!(
            "Per gather of {} rays, over {count} gathers: ray casting (with the hit radiance) \
             {:.0} µs; raddiff irradiance + Ward-Heckbert gradients {:.0} µs ({:.1}% of ray casting)",
            store.rays_per_gather(),
            per(trace),
            per(gradient),
            100.0 * gradient / trace,
        );
        if hessian > 0.0 {
            let _ = write!(
                text,
                "; raddiff occlusion-aware gradient + Hessian {:.0} µs ({:.1}%); together {:.1}%",
                per(hessian),
                100.0 * hessian / trace,
                100.0 * (gradient + hessian) / trace,
            );
        }
        let _ = writeln!(
            text,
            ". The gathers' own irradiance differs from the reference at their pixels by {:.4} \
             (relative RMS): the noise floor of every cache here.",
            store.gather_noise(reference)
        );
        self.overhead = text;
    }

    pub fn markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "## Scene `{}`\n\n{}\n", self.scene, self.settings);
        table(&mut s, &self.tuned);
        let _ = writeln!(
            s,
            "\nCPU time is the sum of the measured per-record costs (ray casting, raddiff's evaluation) \
             and the cache's placement and rendering lookups; RMS error is over the luminance of the \
             indirect irradiance at every pixel, relative RMS error divides it by the reference's RMS.\n"
        );
        let _ = writeln!(
            s,
            "Where the error lives: min, 5% and median radius are the minimum, 5th percentile and \
             median over the records of each record's smallest radius, in scene units (radii are \
             clamped to {} … {} × the scene size: a value at the lower clamp means the metric asked \
             for records at least that small); small radii mark where a metric saw fast change. \
             Worst 1% share is the fraction of the summed squared luminance error held by the worst \
             1% of the shaded pixels (0.01 if the error is spread evenly, near 1 if a few pixels \
             hold all of it).\n",
            crate::placement::RADIUS_MIN,
            crate::placement::RADIUS_MAX
        );
        if !self.overhead.is_empty() {
            let _ = writeln!(s, "{}", self.overhead);
        }
        if !self.media.is_empty() {
            let _ = writeln!(s, "### Media caches\n\n{}\n", self.media_settings);
            table(&mut s, &self.media);
            let _ = writeln!(
                s,
                "\nErrors are over the luminance of the cached term integrated along every camera ray \
                 (all pixels cross the medium), against the same integral of the reference. The radii are \
                 the smallest of each record's three ellipsoid radii, the worst 1% share is over \
                 the pixels whose ray crosses the medium.\n"
            );
        }
        s
    }

    pub fn series(&self) -> Vec<Series> {
        series(&self.sweeps)
    }

    /// The media caches' error-against-time lines (named without the `media-` prefix of the CSV).
    pub fn media_series(&self) -> Vec<Series> {
        let mut lines = series(&self.media_sweeps);
        for line in &mut lines {
            if let Some(name) = line.name.strip_prefix("media-") {
                line.name = name.to_string();
            }
        }
        lines
    }

    /// Writes `<scene>-report.md` and `<scene>-report.csv` (every run of every sweep).
    pub fn write(&self, out: &Path) -> std::io::Result<()> {
        std::fs::write(
            out.join(format!("{}-report.md", self.scene)),
            self.markdown(),
        )?;
        let mut csv = std::fs::File::create(out.join(format!("{}-report.csv", self.scene)))?;
        writeln!(
            csv,
            "scene,metric,tuned,parameter,records,cpu_seconds,trace_seconds,raddiff_seconds,cache_seconds,rms,relative_rms,uncovered_pixels,radius_min,radius_p5,radius_median,worst1pct_error_share"
        )?;
        let tuned = self.tuned.iter().chain(&self.media).map(|r| (true, r));
        let swept = self
            .sweeps
            .iter()
            .chain(&self.media_sweeps)
            .flatten()
            .map(|r| (false, r));
        for (is_tuned, r) in tuned.chain(swept) {
            writeln!(
                csv,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                self.scene,
                r.metric,
                is_tuned,
                r.parameter,
                r.records,
                r.total(),
                r.trace_seconds,
                r.raddiff_seconds,
                r.cache_seconds,
                r.rms,
                r.relative_rms,
                r.uncovered,
                opt(r.radii.map(|d| d.min)),
                opt(r.radii.map(|d| d.p5)),
                opt(r.radii.map(|d| d.median)),
                opt(r.worst_share)
            )?;
        }
        Ok(())
    }
}

/// A CSV field: the value, or empty.
fn opt(v: Option<f64>) -> String {
    v.map_or(String::new(), |v| v.to_string())
}

/// A table cell: the value with three significant digits, or "-".
fn cell(v: Option<f64>) -> String {
    match v {
        Some(v) if v != 0.0 && v.abs() < 0.01 => format!("{v:.2e}"),
        Some(v) => format!("{v:.3}"),
        None => "-".to_string(),
    }
}

/// One line per sweep: (CPU seconds, relative RMS error) of each run.
fn series(sweeps: &[Vec<Row>]) -> Vec<Series> {
    sweeps
        .iter()
        .filter(|rows| !rows.is_empty())
        .map(|rows| Series {
            name: rows[0].metric.to_string(),
            points: rows.iter().map(|r| (r.total(), r.relative_rms)).collect(),
        })
        .collect()
}

/// A metric's parameter with four significant digits: the split-sphere parameters are ~0.1-1, the Hessian tolerances
/// ~1e-6-1e-3 (a fixed number of decimals printed those as 0.0000 / 0.0001).
fn parameter(p: f64) -> String {
    if p != 0.0 && p.abs() < 0.01 {
        format!("{p:.3e}")
    } else {
        format!("{p:.4}")
    }
}

/// The markdown table of tuned rows.
fn table(s: &mut String, rows: &[Row]) {
    let _ = writeln!(
        s,
        "| metric | parameter | records | CPU time (s) | ray casting (s) | raddiff (s) | cache (s) | RMS error | relative RMS error | min radius | 5% radius | median radius | worst 1% share |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2} | {:.2} | {:.3} | {:.3} | {:.5} | {:.4} | {} | {} | {} | {} |",
            r.metric,
            parameter(r.parameter),
            r.records,
            r.total(),
            r.trace_seconds,
            r.raddiff_seconds,
            r.cache_seconds,
            r.rms,
            r.relative_rms,
            cell(r.radii.map(|d| d.min)),
            cell(r.radii.map(|d| d.p5)),
            cell(r.radii.map(|d| d.median)),
            cell(r.worst_share)
        );
    }
}
