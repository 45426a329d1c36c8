//! The report: records, time and RMS error against the reference per metric (markdown and CSV),
//! and the series of the error-against-time plot.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use glam::DVec3;

use crate::caching::{rms_error, Baseline, GatherStore, Run};
use crate::cli::Options;
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
                baseline.summary(),
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
        if !self.overhead.is_empty() {
            let _ = writeln!(s, "{}", self.overhead);
        }
        if !self.media.is_empty() {
            let _ = writeln!(s, "### Media caches\n\n{}\n", self.media_settings);
            table(&mut s, &self.media);
            let _ = writeln!(
                s,
                "\nErrors are over the luminance of the cached term integrated along every camera ray \
                 (all pixels cross the medium), against the same integral of the reference.\n"
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
            "scene,metric,tuned,parameter,records,cpu_seconds,trace_seconds,raddiff_seconds,cache_seconds,rms,relative_rms,uncovered_pixels"
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
                "{},{},{},{},{},{},{},{},{},{},{},{}",
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
                r.uncovered
            )?;
        }
        Ok(())
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
        "| metric | parameter | records | CPU time (s) | ray casting (s) | raddiff (s) | cache (s) | RMS error | relative RMS error |\n|---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2} | {:.2} | {:.3} | {:.3} | {:.5} | {:.4} |",
            r.metric,
            parameter(r.parameter),
            r.records,
            r.total(),
            r.trace_seconds,
            r.raddiff_seconds,
            r.cache_seconds,
            r.rms,
            r.relative_rms
        );
    }
}
